//! Helpers of the command-line integration tests: run the built binary (one GPU run at a
//! time), scratch directories, and the one-error-line check of failing runs.

// Each test binary uses its own subset of these.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Mutex;

/// lavapipe spreads each draw over every core: run the GPU tests of this binary one at a
/// time (nextest runs each test in its own process anyway).
static GPU: Mutex<()> = Mutex::new(());

/// Runs the binary with `args`.
pub fn tiledlight(args: &[&str]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_tiledlight"));
    cmd.args(args);
    // Mesa's WSI complains on stderr without it; the complaint is noise to these tests.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        cmd.env("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    cmd.output().expect("run the tiledlight binary")
}

/// Holds the one-GPU-run-at-a-time lock (for a GPU run expected to fail, through
/// [`fails`]).
pub fn gpu_lock() -> std::sync::MutexGuard<'static, ()> {
    GPU.lock().unwrap_or_else(|e| e.into_inner())
}

/// Runs the binary, one GPU run at a time; panics with its output unless it succeeds.
pub fn gpu_run(args: &[&str]) -> Output {
    let _guard = gpu_lock();
    let out = tiledlight(args);
    assert!(
        out.status.success(),
        "tiledlight {args:?} failed ({:?}):\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// A fresh directory under the target dir for one test's outputs.
pub fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Its standard output as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Runs a failing command; returns its single stderr line.
pub fn fails(args: &[&str]) -> String {
    let out = tiledlight(args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "tiledlight {args:?} succeeded:\n{}", stdout(&out));
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "tiledlight {args:?}: expected one error line, got:\n{err}");
    assert!(lines[0].starts_with("error: "), "{err}");
    lines[0].to_string()
}
