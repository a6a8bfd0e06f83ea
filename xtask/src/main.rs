//! Project tasks, run as `cargo xtask <task>` (alias in `.cargo/config.toml`):
//!
//! - `validate-shaders`: preprocess every entry WGSL file of `shaders/` in every value of
//!   its variant key (`tiledlight_gpu::variants`), parse and validate it with naga, compare each variant's bindings with
//!   its pass's Rust declaration (`tiledlight_gpu::bindings`), and check that the Rust
//!   structs shared with WGSL have the same size and field offsets as their WGSL twins.
//! - `circles [DIR]`: the module import graph of every crate and the WGSL `#include` graph
//!   of `shaders/` (of this workspace, or the one at `DIR`) must have no circles (also run
//!   by `validate-shaders`).
//! - `test [ARGS...]`: check that a Vulkan adapter (lavapipe by default) exists, run
//!   `validate-shaders`, then every workspace test with GPU tests one at a time; `ARGS`
//!   go to `cargo nextest run` (or `cargo test` when nextest is missing).
//! - `lint`: `cargo fmt --check` and `cargo clippy -D warnings` over the workspace.
//! - The docs' paths (`doc_paths.rs`, a unit test): every repository path the docs name
//!   exists.
//! - `mutants`: apply each realistic bug of `xtask/mutants/*.toml` to a scratch copy and run
//!   the tests named for it; a surviving mutant is a missing test (`mutants.rs`).
//!
//! Depends on the workspace's own crates (for the shader preprocessor, the bindings
//! declarations and the Rust struct layouts), naga (validation) and wgpu (the adapter probe).

mod bindings;
mod circles;
// Only its unit tests use it (`cargo xtask test` runs them with every other test).
#[cfg(test)]
mod doc_paths;
mod lint;
mod mutants;
mod process;
mod shaders;
mod test;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Result};

const USAGE: &str = "\
usage: cargo xtask <task>

tasks:
  validate-shaders   validate every WGSL entry file and variant with naga, check Rust/WGSL bindings and struct layouts, then `circles`
  circles [DIR]      fail on any circle in the module import graphs of the crates or the WGSL #include graph
  test [ARGS...]     check for a Vulkan adapter, validate shaders, run all tests (ARGS go to cargo nextest run / cargo test)
  lint               cargo fmt --check and cargo clippy -D warnings over the workspace
  mutants [--list] [--only A,B] [--changed REV] [--timeout S]
                     apply each mutant of xtask/mutants/*.toml to a scratch copy and run the tests
                     that must catch it; fails on a survivor (not part of `test`: minutes per mutant)";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: &[String]) -> Result<()> {
    let root = workspace_root();
    let Some((task, rest)) = args.split_first() else {
        println!("{USAGE}");
        bail!("no task given");
    };
    match task.as_str() {
        "validate-shaders" => {
            if !rest.is_empty() {
                bail!("validate-shaders takes no arguments, got {rest:?}");
            }
            shaders::validate_shaders(&root)?;
            circles::check(&root)
        }
        "circles" => match rest {
            [] => circles::check(&root),
            [other] => circles::check(Path::new(other)),
            _ => bail!("circles takes at most one argument (a workspace directory), got {rest:?}"),
        },
        "test" => test::test(&root, rest),
        "mutants" => mutants::mutants(&root, rest),
        "lint" => {
            if !rest.is_empty() {
                bail!("lint takes no arguments, got {rest:?}");
            }
            lint::lint(&root)
        }
        "help" | "-h" | "--help" => {
            println!("{USAGE}");
            Ok(())
        }
        other => {
            println!("{USAGE}");
            bail!("unknown task `{other}`");
        }
    }
}

/// The workspace root: xtask lives one directory below it.
fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask is inside the workspace").to_path_buf()
}
