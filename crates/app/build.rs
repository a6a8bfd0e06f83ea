//! Records the git commit the binary is built from, so benchmark JSON written on another
//! machine (without the repository) still names it. Empty when git is unavailable.

fn main() {
    let commit = std::process::Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    // No "-dirty" mark: cargo reruns this only when HEAD or the index moves, so a mark
    // would go stale with the next edit. Benchmarks are run from committed trees.
    println!("cargo:rustc-env=TILEDLIGHT_COMMIT={commit}");
    println!("cargo:rerun-if-changed=../../.git/HEAD");
    println!("cargo:rerun-if-changed=../../.git/index");
}
