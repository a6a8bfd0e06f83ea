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

/// Removes the build outputs of this workspace's crates (named `tiledlight*`) under
/// `target`, so the dry run builds them from today's packages, not from a previous
/// run's package of the same version (measured: a new module of tiledlight-gpu was "not
/// found" by tiledlight-deferred's verification until they were removed).
fn forget_packaged_builds(target: &Path) -> Result<()> {
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
