//! Running child processes for the tasks: `cargo` at the workspace root with the toolchain
//! that runs xtask, each command echoed first in a form that can be pasted into a shell.
//! Depends only on std and anyhow (the tasks import it; it imports none of them).

use std::path::Path;
use std::process::Command;

use anyhow::{Context as _, Result};

/// A `cargo` command run at the workspace root, with the cargo that runs xtask.
pub fn cargo(root: &Path) -> Command {
    // `cargo run` sets CARGO to its own binary, so the same toolchain builds the tests.
    let mut cmd = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    cmd.current_dir(root);
    cmd
}

/// Runs `cmd`, echoing it first; Ok(true) when it exits successfully.
pub fn run_status(cmd: &mut Command) -> Result<bool> {
    let shown = describe(cmd);
    println!("xtask: running {shown}");
    let status = cmd.status().with_context(|| format!("cannot start {shown}"))?;
    if !status.success() {
        eprintln!("xtask: {shown} failed ({status})");
    }
    Ok(status.success())
}

/// `cmd` as a shell-like line, for messages.
pub fn describe(cmd: &Command) -> String {
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
