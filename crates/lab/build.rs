//! Finds the charts' font (`TILEDLIGHT_CHART_FONT`, embedded by `chart.rs`) and records
//! the git commit the lab is built from (`bench::commit_hash`), so benchmark JSON
//! written on another machine (without the repository) still names it. Empty when git is unavailable.

use std::process::Command;

/// What `git args` prints, trimmed (None when git fails or is missing).
fn git(args: &[&str]) -> Option<String> {
    Command::new("git")
        .args(args)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
}

fn main() {
    // The charts' font: through the crate's `assets/fonts` link (also what the published
    // package holds), or at the workspace root in a checkout without links.
    let manifest = std::path::PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let font = ["assets/fonts/DejaVuSans.ttf", "../../assets/fonts/DejaVuSans.ttf"]
        .iter()
        .map(|p| manifest.join(p))
        .find(|p| p.is_file())
        .unwrap_or_else(|| panic!("no chart font under {}/assets/fonts or ../../assets/fonts", manifest.display()));
    let font = font.canonicalize().expect("the font's path resolves");
    println!("cargo:rerun-if-changed={}", font.display());
    println!("cargo:rustc-env=TILEDLIGHT_CHART_FONT={}", font.display());
    let commit = git(&["rev-parse", "--short=12", "HEAD"]).unwrap_or_default();
    // No "-dirty" mark: cargo reruns this only when HEAD, the branch or the index moves,
    // so a mark would go stale with the next edit. Benchmarks are run from committed trees.
    println!("cargo:rustc-env=TILEDLIGHT_COMMIT={commit}");
    // Watch the files a commit changes, found through git itself: in a worktree HEAD and
    // the index live in the worktree's own git dir, the branch refs in the common one, and
    // HEAD's file names the branch rather than the commit, so watching it alone (as
    // `../../.git/HEAD` did) missed every commit on the same branch.
    let (Some(dir), Some(common)) =
        (git(&["rev-parse", "--absolute-git-dir"]), git(&["rev-parse", "--path-format=absolute", "--git-common-dir"]))
    else {
        return;
    };
    println!("cargo:rerun-if-changed={dir}/HEAD");
    println!("cargo:rerun-if-changed={dir}/index");
    println!("cargo:rerun-if-changed={common}/packed-refs");
    if let Some(branch) = git(&["symbolic-ref", "-q", "HEAD"]) {
        println!("cargo:rerun-if-changed={common}/{branch}");
    }
}
