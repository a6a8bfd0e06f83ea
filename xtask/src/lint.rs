//! `cargo xtask lint`: formatting and clippy over the whole workspace, both run even
//! when the first fails so one pass shows every problem.

use std::path::Path;

use anyhow::{bail, Result};

use crate::process::{cargo, run_status};

/// Runs `cargo fmt --all --check` and `cargo clippy --workspace --all-targets -D warnings`.
pub fn lint(root: &Path) -> Result<()> {
    let fmt = run_status(cargo(root).args(["fmt", "--all", "--check"]))?;
    let clippy = run_status(cargo(root).args(["clippy", "--workspace", "--all-targets", "--", "-D", "warnings"]))?;
    match (fmt, clippy) {
        (true, true) => Ok(()),
        (false, true) => bail!("formatting differs from rustfmt: run `cargo fmt --all`"),
        (true, false) => bail!("clippy found problems"),
        (false, false) => bail!("formatting differs from rustfmt (run `cargo fmt --all`) and clippy found problems"),
    }
}
