//! placeholder
use clap::Args;
/// Flags.
#[derive(Args, Clone, Debug)]
pub struct AccuracyArgs {}
/// Runs.
pub fn run(_a: &AccuracyArgs) -> anyhow::Result<()> {
    Ok(())
}
