//! Project tasks, run as `cargo xtask <task>` (alias in `.cargo/config.toml`):
//!
//! - `validate-shaders`: preprocess every entry WGSL file of `shaders/` in every value of
//!   its variant key (`tiledlight_gpu::variants`), parse and validate it with naga, compare each variant's bindings with
//!   its pass's Rust declaration (`tiledlight_gpu::bindings`), and check that the Rust
//!   structs shared with WGSL have the same size and field offsets as their WGSL twins.
//! - `test [ARGS...]`: check that a Vulkan adapter (lavapipe by default) exists, run
//!   `validate-shaders`, then every workspace test with GPU tests one at a time; `ARGS`
//!   go to `cargo nextest run` (or `cargo test` when nextest is missing).
//! - `lint`: `cargo fmt --check` and `cargo clippy -D warnings` over the workspace.
//!
//! Depends on the workspace's own crates (for the shader preprocessor, the bindings
//! declarations and the Rust struct layouts), naga (validation) and wgpu (the adapter probe).

mod bindings;
mod lint;
mod shaders;
mod test;

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use anyhow::{bail, Context as _, Result};

const USAGE: &str = "\
usage: cargo xtask <task>

tasks:
  validate-shaders   validate every WGSL entry file and variant with naga, check Rust/WGSL bindings and struct layouts
  test [ARGS...]     check for a Vulkan adapter, validate shaders, run all tests (ARGS go to cargo nextest run / cargo test)
  lint               cargo fmt --check and cargo clippy -D warnings over the workspace";

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
            shaders::validate_shaders(&root)
        }
        "test" => test::test(&root, rest),
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

/// A `cargo` command run at the workspace root, with the cargo that runs xtask.
fn cargo(root: &Path) -> Command {
    // `cargo run` sets CARGO to its own binary, so the same toolchain builds the tests.
    let mut cmd = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    cmd.current_dir(root);
    cmd
}

/// Runs `cmd`, echoing it first; Ok(true) when it exits successfully.
fn run_status(cmd: &mut Command) -> Result<bool> {
    let shown = describe(cmd);
    println!("xtask: running {shown}");
    let status = cmd.status().with_context(|| format!("cannot start {shown}"))?;
    if !status.success() {
        eprintln!("xtask: {shown} failed ({status})");
    }
    Ok(status.success())
}

/// `cmd` as a shell-like line, for messages.
fn describe(cmd: &Command) -> String {
    let program = Path::new(cmd.get_program()).file_name().unwrap_or(cmd.get_program()).to_string_lossy().into_owned();
    std::iter::once(program).chain(cmd.get_args().map(|a| quote(&a.to_string_lossy()))).collect::<Vec<_>>().join(" ")
}

/// `arg` quoted for a shell when it needs to be, so echoed commands can be pasted.
fn quote(arg: &str) -> String {
    let plain = !arg.is_empty() && arg.chars().all(|c| c.is_ascii_alphanumeric() || "-_=./:,+@%".contains(c));
    if plain {
        arg.to_owned()
    } else {
        format!("'{}'", arg.replace('\'', r"'\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_are_echoed_pasteably() {
        let mut cmd = Command::new("/usr/bin/cargo");
        cmd.args(["nextest", "run", "-E", "package(x)", "it's"]);
        assert_eq!(describe(&cmd), r"cargo nextest run -E 'package(x)' 'it'\''s'");
    }
}
