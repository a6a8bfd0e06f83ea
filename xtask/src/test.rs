//! `cargo xtask test`: the one command CI and developers run.
//!
//! 1. Picks the adapter GPU tests use (`WGPU_ADAPTER_NAME`, default `llvmpipe`, i.e.
//!    lavapipe on Vulkan) and checks with wgpu that such an adapter exists. A missing
//!    adapter fails the run: GPU tests are never skipped.
//! 2. Runs `validate-shaders`, `circles`, the scripts' Python tests (`PYTHON_TESTS`, with
//!    `python3 -m unittest`), `cargo doc --no-deps --workspace` with rustdoc warnings
//!    denied, and the examples (`EXAMPLES`).
//! 3. Runs every workspace test: `cargo nextest run` when installed (GPU tests one at a
//!    time through the `gpu` test group of `.config/nextest.toml`) plus the doc tests,
//!    else `cargo test` with the GPU test package run separately on one thread.
//!
//! Every step runs even when an earlier one fails (except a missing adapter), so one
//! run reports everything.

use std::env;
use std::path::Path;
use std::process::{Command, Stdio};

use anyhow::{bail, Context as _, Result};

use crate::process::{cargo, describe, run_status};
use crate::{circles, shaders};

/// The package holding the GPU integration tests (directory `tests/`).
const GPU_TEST_PACKAGE: &str = "tiledlight-tests";

/// (package, example) of every example `cargo xtask test` runs.
const EXAMPLES: [(&str, &str); 8] = [
    ("tiledlight-cull", "cull_a_floor"),
    ("tiledlight-gpu", "light_grid"),
    ("tiledlight-lab", "lights_by_tile"),
    ("tiledlight-scene", "courtyard"),
    ("tiledlight-metrics", "compare_images"),
    ("tiledlight-gltf-writer", "triangle"),
    ("tiledlight-frame", "one_frame"),
    ("tiledlight-setup", "render_png"),
];

/// The scripts' unit tests (standard library only), run from the repository root with
/// `python3 -m unittest`: the floor model of `scripts/perf-summary.py`.
const PYTHON_TESTS: [&str; 1] = ["scripts/test_perf_summary.py"];

/// lavapipe's adapter name starts with this (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)").
const DEFAULT_ADAPTER: &str = "llvmpipe";

/// The Debian packages that provide lavapipe and the Vulkan loader.
const VULKAN_PACKAGES: [&str; 2] = ["mesa-vulkan-drivers", "libvulkan1"];

/// Which adapter the GPU tests must use, and the environment that tells them.
#[derive(Debug, PartialEq, Eq)]
pub(crate) struct AdapterChoice {
    /// Case-insensitive substring of the adapter name, as `WGPU_ADAPTER_NAME` means it.
    name: String,
    /// `WGPU_BACKEND` value (comma list), when one applies.
    backend: Option<String>,
    /// Variables to set for the child processes (only those not already set).
    pub(crate) env: Vec<(&'static str, String)>,
}

impl AdapterChoice {
    /// From `WGPU_ADAPTER_NAME` and `WGPU_BACKEND` (`get` reads the environment). Without
    /// an adapter name, lavapipe on Vulkan.
    pub(crate) fn new(get: impl Fn(&str) -> Option<String>) -> Self {
        let get = |key: &str| get(key).filter(|v| !v.trim().is_empty());
        let mut env = Vec::new();
        let name = get("WGPU_ADAPTER_NAME").unwrap_or_else(|| {
            env.push(("WGPU_ADAPTER_NAME", DEFAULT_ADAPTER.to_owned()));
            DEFAULT_ADAPTER.to_owned()
        });
        let mut backend = get("WGPU_BACKEND");
        // lavapipe is a Vulkan driver; Mesa's llvmpipe also shows up as a GL adapter
        // with the same name, which the tests must not pick instead.
        if backend.is_none() && name == DEFAULT_ADAPTER {
            env.push(("WGPU_BACKEND", "vulkan".to_owned()));
            backend = Some("vulkan".to_owned());
        }
        AdapterChoice { name, backend, env }
    }

    fn backends(&self) -> wgpu::Backends {
        self.backend.as_deref().map_or(wgpu::Backends::all(), wgpu::Backends::from_comma_list)
    }

    fn matches(&self, adapter_name: &str) -> bool {
        adapter_name.to_lowercase().contains(&self.name.to_lowercase())
    }
}

/// Where the workspace's shared proptest configuration lives (see its module doc).
const PROPTEST_SEED_FILE: &str = "crates/cull/tests/common/seed.rs";

/// `DEFAULT_SEED` of [`PROPTEST_SEED_FILE`]: the seed every property test uses when
/// `PROPTEST_RNG_SEED` is unset.
pub(crate) fn default_proptest_seed(root: &Path) -> Result<u64> {
    let path = root.join(PROPTEST_SEED_FILE);
    let text = std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    parse_default_seed(&text).with_context(|| format!("no `pub const DEFAULT_SEED: u64 = N;` in {}", path.display()))
}

fn parse_default_seed(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.trim_start().starts_with("pub const DEFAULT_SEED: u64 ="))?;
    let value = line.split('=').nth(1)?.trim().trim_end_matches(';').replace('_', "");
    value.parse().ok()
}

/// Runs the whole test suite; `extra` goes to `cargo nextest run` / `cargo test`.
pub fn test(root: &Path, extra: &[String]) -> Result<()> {
    let choice = AdapterChoice::new(|k| env::var(k).ok());
    let set_by_xtask = |key: &str| choice.env.iter().any(|(k, _)| *k == key);
    println!(
        "xtask: GPU tests use WGPU_ADAPTER_NAME={}{} and WGPU_BACKEND={}{}",
        choice.name,
        if set_by_xtask("WGPU_ADAPTER_NAME") { " (default, lavapipe)" } else { " (from the environment)" },
        choice.backend.as_deref().unwrap_or("<all>"),
        if set_by_xtask("WGPU_BACKEND") { " (default)" } else { "" },
    );
    ensure_adapter(&choice)?;

    let mut failed: Vec<&str> = Vec::new();
    if let Err(e) = shaders::validate_shaders(root) {
        eprintln!("error: {e:#}");
        failed.push("validate-shaders");
    }
    if let Err(e) = circles::check(root) {
        eprintln!("error: {e:#}");
        failed.push("circles");
    }
    // The script that turns bench's JSON into docs/PERFORMANCE.md's table and floors.
    let mut cmd = Command::new("python3");
    cmd.current_dir(root).args(["-m", "unittest"]).args(PYTHON_TESTS);
    match run_status(&mut cmd) {
        Ok(true) => {}
        Ok(false) => failed.push("python tests"),
        Err(e) => {
            eprintln!("error: {e:#} (python3 is needed for the scripts' tests)");
            failed.push("python tests");
        }
    }
    // The API docs build without a warning (a broken intra-doc link, stray HTML in a doc
    // comment): the crates are meant to be read and reused.
    println!("xtask: running cargo doc --no-deps --workspace (rustdoc warnings denied)");
    let mut cmd = cargo(root);
    cmd.args(["doc", "--no-deps", "--workspace"]).env("RUSTDOCFLAGS", "-D warnings");
    if !run_status(&mut cmd)? {
        failed.push("cargo doc");
    }
    // The examples a user would copy build and run (each asserts what it shows).
    for (package, example) in EXAMPLES {
        println!("xtask: running example {example} of {package}");
        let mut cmd = cargo(root);
        cmd.args(["run", "--quiet", "--package", package, "--example", example]);
        if !run_status(&mut cmd)? {
            failed.push("examples");
        }
    }

    // Property tests draw random cases; CI runs the same ones every time (a new random
    // failure would turn an unrelated submission red). The seed is the one the tests
    // themselves fall back to (`DEFAULT_SEED` of the shared proptest configuration), so
    // plain `cargo test` draws the same cases. Set PROPTEST_RNG_SEED to explore.
    let proptest_seed = match env::var("PROPTEST_RNG_SEED") {
        Ok(s) => s,
        Err(_) => default_proptest_seed(root)?.to_string(),
    };
    println!("xtask: property tests use PROPTEST_RNG_SEED={proptest_seed}");
    let with_env = |mut cmd: Command| {
        for (k, v) in &choice.env {
            cmd.env(k, v);
        }
        cmd.env("PROPTEST_RNG_SEED", &proptest_seed);
        cmd
    };
    if nextest_available(root) {
        // nextest does not run doc tests. They run first so that nextest's summary of the
        // whole suite ("N tests run: N passed") is the last thing printed, not a doc-test
        // run of zero tests that a reader of the closing line would take for no tests.
        let mut cmd = with_env(cargo(root));
        cmd.args(["test", "--workspace", "--doc", "--no-fail-fast"]);
        if !run_status(&mut cmd)? {
            failed.push("doc tests");
        }
        // The `gpu` test group in .config/nextest.toml serializes the GPU package.
        let mut cmd = with_env(cargo(root));
        cmd.args(["nextest", "run", "--workspace", "--no-fail-fast"]).args(extra);
        if !run_status(&mut cmd)? {
            failed.push("cargo nextest run");
        }
    } else {
        println!("xtask: cargo-nextest not found, using cargo test (`cargo install cargo-nextest` for faster runs)");
        let (cargo_args, test_args) = split_test_args(extra);
        let mut cmd = with_env(cargo(root));
        cmd.args(["test", "--workspace", "--exclude", GPU_TEST_PACKAGE, "--no-fail-fast"]).args(cargo_args);
        if !test_args.is_empty() {
            cmd.arg("--").args(test_args);
        }
        if !run_status(&mut cmd)? {
            failed.push("cargo test (CPU packages)");
        }
        let mut cmd = with_env(cargo(root));
        cmd.args(["test", "--package", GPU_TEST_PACKAGE, "--no-fail-fast"])
            .args(cargo_args)
            .args(["--", "--test-threads=1"])
            .args(test_args);
        if !run_status(&mut cmd)? {
            failed.push("cargo test (GPU package)");
        }
    }

    if !failed.is_empty() {
        bail!("failed: {}", failed.join(", "));
    }
    println!("xtask: all tests passed");
    Ok(())
}

/// Splits `cargo test` arguments at the first `--`: (for cargo, for the test binaries).
fn split_test_args(extra: &[String]) -> (&[String], &[String]) {
    match extra.iter().position(|a| a == "--") {
        Some(i) => (&extra[..i], &extra[i + 1..]),
        None => (extra, &[]),
    }
}

fn nextest_available(root: &Path) -> bool {
    cargo(root)
        .args(["nextest", "--version"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// One adapter wgpu found.
#[derive(Clone, Debug)]
struct FoundAdapter {
    name: String,
    backend: wgpu::Backend,
    features: wgpu::Features,
}

/// Every adapter wgpu finds on `backends`.
fn enumerate_adapters(backends: wgpu::Backends) -> Vec<FoundAdapter> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    pollster::block_on(instance.enumerate_adapters(backends))
        .iter()
        .map(|a| {
            let info = a.get_info();
            FoundAdapter { name: info.name, backend: info.backend, features: a.features() }
        })
        .collect()
}

/// Fails unless an adapter matching `choice` exists. On a Debian CI machine run as root
/// (`CI` set), installs lavapipe first when it is missing.
fn ensure_adapter(choice: &AdapterChoice) -> Result<()> {
    let mut adapters = enumerate_adapters(choice.backends());
    let found = |adapters: &[FoundAdapter]| adapters.iter().find(|a| choice.matches(&a.name)).cloned();
    let system = System::detect();
    if found(&adapters).is_none() && choice.name == DEFAULT_ADAPTER && system.can_auto_install() {
        println!("xtask: no lavapipe adapter on this CI machine: installing {}", VULKAN_PACKAGES.join(" "));
        install_lavapipe()?;
        adapters = enumerate_adapters(choice.backends());
    }
    if let Some(a) = found(&adapters) {
        println!("xtask: GPU tests run on adapter \"{}\" ({:?})", a.name, a.backend);
        let lacking = shaders::FEATURES - a.features;
        if !lacking.is_empty() {
            // validate-shaders accepts shaders that use these; the device cannot run them.
            println!("xtask: warning: the adapter lacks {lacking:?}, which validate-shaders allows");
        }
        return Ok(());
    }

    let listed = if adapters.is_empty() {
        "none".to_owned()
    } else {
        adapters.iter().map(|a| format!("\"{}\" ({:?})", a.name, a.backend)).collect::<Vec<_>>().join(", ")
    };
    let what = format!(
        "looked for an adapter whose name contains \"{}\" on backend(s) {}; found: {listed}; {}",
        choice.name,
        choice.backend.as_deref().unwrap_or("all"),
        icd_summary()
    );
    if choice.name != DEFAULT_ADAPTER {
        bail!(
            "no matching GPU adapter: unset WGPU_ADAPTER_NAME to test on lavapipe, \
             or set it to part of a name found ({what})"
        );
    }
    match system.install_command() {
        Some(cmd) => bail!("no Vulkan adapter found: run `{cmd}` ({what})"),
        None => bail!(
            "no Vulkan adapter found: install Mesa's lavapipe Vulkan driver and the Vulkan loader \
             (Debian/Ubuntu: `apt-get install -y mesa-vulkan-drivers libvulkan1`) ({what})"
        ),
    }
}

/// What the machine allows for installing lavapipe.
struct System {
    debian: bool,
    root: bool,
    ci: bool,
}

impl System {
    fn detect() -> Self {
        let root =
            Command::new("id").arg("-u").output().is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
        System {
            debian: Path::new("/etc/debian_version").exists(),
            root,
            ci: env::var_os("CI").is_some_and(|v| !v.is_empty()),
        }
    }

    fn can_auto_install(&self) -> bool {
        self.debian && self.root && self.ci
    }

    /// The exact command that installs lavapipe here, when known.
    fn install_command(&self) -> Option<String> {
        self.debian.then(|| {
            format!(
                "{}apt-get install -y --no-install-recommends {}",
                if self.root { "" } else { "sudo " },
                VULKAN_PACKAGES.join(" ")
            )
        })
    }
}

fn install_lavapipe() -> Result<()> {
    for args in [vec!["update"], [&["install", "-y", "--no-install-recommends"][..], &VULKAN_PACKAGES[..]].concat()] {
        let mut cmd = Command::new("apt-get");
        cmd.args(&args).env("DEBIAN_FRONTEND", "noninteractive");
        let shown = describe(&cmd);
        let ok = cmd.status().with_context(|| format!("cannot start {shown}"))?.success();
        if !ok {
            bail!("{shown} failed while installing lavapipe");
        }
    }
    Ok(())
}

/// Where the Vulkan loader looks for drivers, for the no-adapter message.
fn icd_summary() -> String {
    for var in ["VK_DRIVER_FILES", "VK_ICD_FILENAMES"] {
        if let Some(v) = env::var_os(var).filter(|v| !v.is_empty()) {
            return format!("{var}={}", v.to_string_lossy());
        }
    }
    let dirs = ["/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d"];
    let icds: Vec<String> = dirs
        .iter()
        .filter_map(|d| std::fs::read_dir(d).ok())
        .flatten()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".json"))
        .collect();
    let loader = [
        "/usr/lib/x86_64-linux-gnu/libvulkan.so.1",
        "/usr/lib/aarch64-linux-gnu/libvulkan.so.1",
        "/usr/lib/libvulkan.so.1",
        "/usr/lib64/libvulkan.so.1",
    ]
    .iter()
    .any(|p| Path::new(p).exists());
    format!(
        "Vulkan ICDs in {}: {}; lavapipe ICD (lvp_icd*.json) {}; Vulkan loader libvulkan.so.1 {}",
        dirs.join(", "),
        if icds.is_empty() { "none".to_owned() } else { icds.join(" ") },
        if icds.iter().any(|n| n.starts_with("lvp_icd")) { "present" } else { "missing" },
        if loader { "present" } else { "not found in the usual places" }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_proptest_seed_is_read_from_the_shared_configuration() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        assert_eq!(default_proptest_seed(&root).unwrap(), 20_261_122);
        assert_eq!(parse_default_seed("x\n    pub const DEFAULT_SEED: u64 = 7_0;\n"), Some(70));
        assert_eq!(parse_default_seed("pub const OTHER: u64 = 1;"), None);
        assert_eq!(parse_default_seed("pub const DEFAULT_SEED: u64 = seven;"), None);
    }

    fn choice(vars: &[(&str, &str)]) -> AdapterChoice {
        AdapterChoice::new(|k| vars.iter().find(|(n, _)| *n == k).map(|(_, v)| v.to_string()))
    }

    #[test]
    fn default_adapter_is_lavapipe_on_vulkan() {
        let c = choice(&[]);
        assert_eq!(c.name, "llvmpipe");
        assert_eq!(c.backends(), wgpu::Backends::VULKAN);
        assert_eq!(c.env, [("WGPU_ADAPTER_NAME", "llvmpipe".into()), ("WGPU_BACKEND", "vulkan".into())]);
        assert!(c.matches("llvmpipe (LLVM 15.0.6, 256 bits)"));
        assert!(!c.matches("NVIDIA H100"));
        // Empty counts as unset.
        assert_eq!(choice(&[("WGPU_ADAPTER_NAME", " ")]).name, "llvmpipe");
    }

    #[test]
    fn environment_wins_and_is_not_overridden() {
        let c = choice(&[("WGPU_ADAPTER_NAME", "NVIDIA")]);
        assert!(c.env.is_empty());
        assert_eq!(c.backends(), wgpu::Backends::all());
        assert!(c.matches("nvidia h100 80gb"));
        let c = choice(&[("WGPU_BACKEND", "gl")]);
        assert_eq!(c.env, [("WGPU_ADAPTER_NAME", "llvmpipe".into())]);
        assert_eq!(c.backends(), wgpu::Backends::GL);
    }

    #[test]
    fn test_args_split_at_double_dash() {
        let args: Vec<String> = ["-p", "x", "--", "--nocapture"].iter().map(|s| s.to_string()).collect();
        assert_eq!(split_test_args(&args), (&args[..2], &args[3..]));
        assert_eq!(split_test_args(&args[..2]), (&args[..2], &[][..]));
    }
}
