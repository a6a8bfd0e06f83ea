//! `cargo xtask lint`: formatting, clippy, the library crates' public docs and their
//! packages, over the whole workspace; every check runs even when one before it fails, so
//! one pass shows every problem.
//!
//! 1. `cargo fmt --all --check`.
//! 2. `cargo clippy --workspace --all-targets -D warnings`.
//! 3. `cargo doc` of the library crates (no private items), rustdoc warnings as errors:
//!    broken intra-doc links and bad doc syntax in what a user of the crates reads.
//! 4. `cargo publish --workspace --dry-run`: every library crate packaged and built from
//!    its package (a local overlay stands in for the workspace's unpublished crates), so a
//!    file a crate reads from outside its folder, a missing version or a bad manifest field
//!    fails here, not at publishing. The slowest step (a second build of every crate).

use std::path::Path;

use anyhow::{bail, Result};

use crate::process::{cargo, run_status};

/// The workspace members that are not published (the app, the GPU tests, this tool).
const UNPUBLISHED: [&str; 3] = ["tiledlight", "tiledlight-tests", "xtask"];

/// The dry run's own target directory: its builds of the packaged crates are registry
/// builds, which cargo never rebuilds for the same version, so they are forgotten before
/// each run ([`forget_packaged_builds`]); the dependencies' stay.
const PUBLISH_TARGET: &str = "target/publish-check";

/// Removes what a previous dry run left of this workspace's crates (named `tiledlight*`):
/// their build outputs under `target`, and their sources that cargo unpacked from the
/// run's temporary local registry into `$CARGO_HOME/registry/src/-<hash>/` (cargo never
/// unpacks or rebuilds a registry version again), so the dry run builds today's packages
/// (measured: a new module of tiledlight-gpu was "not found" by the verification of the
/// crates using it until both were removed). crates.io's sources are not touched.
fn forget_packaged_builds(target: &Path) -> Result<()> {
    let cargo_home = std::env::var_os("CARGO_HOME")
        .map(std::path::PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| Path::new(&h).join(".cargo")));
    if let Some(src) = cargo_home.map(|h| h.join("registry/src")) {
        for registry in std::fs::read_dir(&src).into_iter().flatten().filter_map(|e| e.ok()) {
            // Local registries' folders are named "-<hash>"; crates.io's "index.crates.io-<hash>".
            if !registry.file_name().to_string_lossy().starts_with('-') {
                continue;
            }
            for e in std::fs::read_dir(registry.path())?.filter_map(|e| e.ok()) {
                if e.file_name().to_string_lossy().starts_with("tiledlight") {
                    std::fs::remove_dir_all(e.path())?;
                }
            }
        }
    }
    for dir in [".fingerprint", "deps", "build"] {
        let Ok(entries) = std::fs::read_dir(target.join("debug").join(dir)) else { continue };
        for e in entries.filter_map(|e| e.ok()) {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with("tiledlight") || name.starts_with("libtiledlight") {
                let p = e.path();
                if p.is_dir() {
                    std::fs::remove_dir_all(&p)?;
                } else {
                    std::fs::remove_file(&p)?;
                }
            }
        }
    }
    Ok(())
}

/// Runs the four checks of the module doc.
pub fn lint(root: &Path) -> Result<()> {
    let fmt = run_status(cargo(root).args(["fmt", "--all", "--check"]))?;
    let clippy = run_status(cargo(root).args(["clippy", "--workspace", "--all-targets", "--", "-D", "warnings"]))?;
    let mut doc = cargo(root);
    doc.args(["doc", "--workspace", "--no-deps"]).env("RUSTDOCFLAGS", "-D warnings");
    for p in UNPUBLISHED {
        doc.args(["--exclude", p]);
    }
    let doc = run_status(&mut doc)?;
    forget_packaged_builds(&root.join(PUBLISH_TARGET))?;
    let publish = run_status(cargo(root).args([
        "publish",
        "--workspace",
        "--dry-run",
        "--allow-dirty",
        "--target-dir",
        PUBLISH_TARGET,
    ]))?;
    let failed: Vec<&str> = [
        (fmt, "formatting differs from rustfmt (run `cargo fmt --all`)"),
        (clippy, "clippy found problems"),
        (doc, "the library crates' docs have warnings"),
        (publish, "a library crate does not package or build from its package"),
    ]
    .into_iter()
    .filter(|(ok, _)| !ok)
    .map(|(_, what)| what)
    .collect();
    if failed.is_empty() {
        Ok(())
    } else {
        bail!("{}", failed.join("; "))
    }
}
