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

/// A running Xvfb, stopped when dropped (also when a test fails).
pub struct Xvfb {
    child: std::process::Child,
    /// Its display, e.g. `:5`.
    pub display: String,
}

impl Xvfb {
    /// Starts Xvfb on a display number it picks itself (`-displayfd`: no race with other
    /// tests or a desktop for a free number) and waits until it accepts connections.
    pub fn start() -> Self {
        let child = Command::new("Xvfb")
            .args(["-displayfd", "1", "-screen", "0", "640x480x24", "-nolisten", "tcp"])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::null())
            .spawn();
        let mut child = match child {
            Ok(c) => c,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                panic!("Xvfb not found: the viewer test needs it (`apt-get install xvfb`; .ci/run installs it)")
            }
            Err(e) => panic!("cannot start Xvfb: {e}"),
        };
        // Xvfb writes the display number once it is ready to accept clients.
        let mut line = String::new();
        let stdout = child.stdout.take().expect("piped stdout");
        let read = std::io::BufRead::read_line(&mut std::io::BufReader::new(stdout), &mut line);
        let n = line.trim();
        if read.is_err() || n.is_empty() || !n.bytes().all(|b| b.is_ascii_digit()) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("Xvfb did not report a display number (read {read:?}, got {line:?})");
        }
        Self { display: format!(":{n}"), child }
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        // SIGTERM lets Xvfb remove its lock file and socket; SIGKILL only if it hangs.
        let _ = Command::new("kill").args(["-TERM", &self.child.id().to_string()]).status();
        let t0 = std::time::Instant::now();
        while t0.elapsed() < std::time::Duration::from_secs(5) {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
