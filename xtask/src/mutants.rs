//! `cargo xtask mutants`: the project's own list of realistic bugs, each applied to a
//! scratch copy of the workspace and run against the tests that must catch it.
//!
//! 1. Reads every `xtask/mutants/*.toml` (one file per family; `[[mutant]]` entries with
//!    `name`, `file`, `find`, `replace`, `test` as `PACKAGE::BINARY` — an integration
//!    test file's name, `lib` for a library's unit tests or `bin` for a binary's — an optional `filter` and `why`) and
//!    checks the list: names unique, every file present, every `find` occurring exactly
//!    once in its file (so a mutation never lands somewhere unintended, and a refactor that
//!    removes the text turns the list red instead of silently testing nothing).
//! 2. Selects mutants: all, `--only NAME,...`, or `--changed REV` (those whose file differs
//!    from git revision `REV`: what a developer runs before stopping).
//! 3. Copies the working tree (tracked and untracked files git does not ignore) to
//!    `target/mutants/tree`, built into its own `target/mutants/target` so the developer's
//!    build is untouched and later runs are incremental.
//! 4. Runs each selected mutant's tests once unmutated (a test that already fails catches
//!    nothing), then per mutant: applies it, builds the test binary (a mutant that does not
//!    compile is *unviable*: fix its entry), runs the tests, restores the file. The tests
//!    failing is *caught*; passing is *survived*: a missing test.
//! 5. Prints one line per mutant and a summary, writes it to `target/mutants/results.txt`,
//!    and exits non-zero when any mutant survived or was unviable.
//!
//! Not part of `cargo xtask test`: each mutant rebuilds and reruns tests (minutes each on
//! two cores). GPU tests use the adapter `cargo xtask test` would (lavapipe by default).
//! Depends on the workspace's git checkout, cargo-nextest (else `cargo test`) and toml.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, Context as _, Result};
use serde::Deserialize;

use crate::process::{cargo, describe};
use crate::test::{default_proptest_seed, AdapterChoice};

/// Where the mutant lists live, relative to the workspace root.
pub const MUTANTS_DIR: &str = "xtask/mutants";

/// One realistic bug and the tests that must catch it.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Mutant {
    /// Unique across every list.
    pub name: String,
    /// The file it changes, relative to the workspace root.
    pub file: String,
    /// Text occurring exactly once in `file`.
    pub find: String,
    /// What `find` becomes.
    pub replace: String,
    /// `PACKAGE::BINARY`: an integration test file's name, `lib` for a library's unit tests, `bin` for a binary's.
    pub test: String,
    /// A test-name substring selecting tests of the binary (all when absent).
    #[serde(default)]
    pub filter: Option<String>,
    /// The bug this stands for, and which test catches it.
    #[serde(default)]
    pub why: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ListFile {
    // A list may hold only comments (candidates not yet verified).
    #[serde(default)]
    mutant: Vec<Mutant>,
}

impl Mutant {
    /// (package, binary) of `test`.
    pub fn target(&self) -> Result<(&str, &str)> {
        match self.test.split_once("::") {
            Some((p, b)) if !p.is_empty() && !b.is_empty() && !b.contains("::") => Ok((p, b)),
            _ => bail!("mutant `{}`: test `{}` is not PACKAGE::BINARY", self.name, self.test),
        }
    }

    /// `text` with this mutation applied; an error unless `find` occurs exactly once, or
    /// when the mutation changes nothing.
    pub fn apply(&self, text: &str) -> Result<String> {
        if self.find == self.replace {
            bail!("mutant `{}`: `replace` equals `find`: it changes nothing", self.name);
        }
        match text.matches(&self.find).count() {
            1 => Ok(text.replacen(&self.find, &self.replace, 1)),
            0 => bail!("mutant `{}`: its `find` text no longer occurs in {}", self.name, self.file),
            n => bail!("mutant `{}`: its `find` text occurs {n} times in {} (make it unique)", self.name, self.file),
        }
    }
}

/// Parses the lists in `dir` (every `*.toml`, in name order) and checks names, files,
/// targets and that each mutation applies exactly once to the files under `root`.
pub fn load(root: &Path, dir: &Path) -> Result<Vec<Mutant>> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    paths.sort();
    let mut all = Vec::new();
    let mut seen = BTreeMap::new();
    for path in &paths {
        let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let list: ListFile = toml::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
        for m in list.mutant {
            if let Some(other) = seen.insert(m.name.clone(), path.clone()) {
                bail!("mutant `{}` is named twice ({} and {})", m.name, other.display(), path.display());
            }
            m.target()?;
            let file = root.join(&m.file);
            let source = std::fs::read_to_string(&file)
                .with_context(|| format!("mutant `{}` ({}): reading {}", m.name, path.display(), file.display()))?;
            m.apply(&source).with_context(|| format!("in {}", path.display()))?;
            all.push(m);
        }
    }
    if all.is_empty() {
        bail!("no mutants in {}", dir.display());
    }
    Ok(all)
}

/// What became of one mutant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Its tests failed: the bug is caught.
    Caught,
    /// Its tests passed: a missing test.
    Survived,
    /// It did not compile: the entry needs fixing.
    Unviable,
    /// Its tests ran past the time limit (counted as caught: a hang is a failure CI sees).
    Timeout,
}

impl Outcome {
    fn label(self) -> &'static str {
        match self {
            Outcome::Caught => "caught",
            Outcome::Survived => "SURVIVED",
            Outcome::Unviable => "UNVIABLE",
            Outcome::Timeout => "caught (timeout)",
        }
    }
    /// Whether the run counts as a failure of the list.
    pub fn is_failure(self) -> bool {
        matches!(self, Outcome::Survived | Outcome::Unviable)
    }
}

/// Options of `cargo xtask mutants`.
#[derive(Debug, Default, PartialEq)]
pub struct Options {
    /// Only these mutants (by name).
    pub only: Vec<String>,
    /// Only mutants whose file differs from this git revision.
    pub changed: Option<String>,
    /// Check the list and print it; run nothing.
    pub list: bool,
    /// Per-mutant time limit for its tests.
    pub timeout: Duration,
}

/// Parses `cargo xtask mutants` arguments.
pub fn parse_args(args: &[String]) -> Result<Options> {
    let mut o = Options { timeout: Duration::from_secs(900), ..Default::default() };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |flag: &str| it.next().cloned().with_context(|| format!("{flag} needs a value"));
        match a.as_str() {
            "--list" => o.list = true,
            "--only" => o.only.extend(value("--only")?.split(',').map(str::to_owned)),
            "--changed" => o.changed = Some(value("--changed")?),
            "--timeout" => {
                let v = value("--timeout")?;
                let secs: u64 = v.parse().with_context(|| format!("--timeout takes seconds, got `{v}`"))?;
                o.timeout = Duration::from_secs(secs);
            }
            other => bail!("unknown argument `{other}` (mutants takes --list, --only A,B, --changed REV, --timeout S)"),
        }
    }
    Ok(o)
}

/// The mutants `o` selects from `all`; `changed_files` are the files differing from
/// `--changed`'s revision.
pub fn select<'a>(all: &'a [Mutant], o: &Options, changed_files: &BTreeSet<String>) -> Result<Vec<&'a Mutant>> {
    for name in &o.only {
        if !all.iter().any(|m| &m.name == name) {
            bail!("no mutant named `{name}`");
        }
    }
    Ok(all
        .iter()
        .filter(|m| o.only.is_empty() || o.only.contains(&m.name))
        .filter(|m| o.changed.is_none() || changed_files.contains(&m.file))
        .collect())
}

/// Runs the task.
pub fn mutants(root: &Path, args: &[String]) -> Result<()> {
    let o = parse_args(args)?;
    let all = load(root, &root.join(MUTANTS_DIR))?;
    let changed_files = match &o.changed {
        Some(rev) => git_lines(root, &["diff", "--name-only", rev])?.into_iter().collect(),
        None => BTreeSet::new(),
    };
    let selected = select(&all, &o, &changed_files)?;
    println!("xtask: {} mutants listed, {} selected", all.len(), selected.len());
    if o.list {
        for m in &selected {
            println!("{:<44} {:<48} {}", m.name, m.file, m.test);
        }
        return Ok(());
    }
    if selected.is_empty() {
        println!("xtask: nothing to run");
        return Ok(());
    }

    let scratch = root.join("target/mutants");
    let tree = scratch.join("tree");
    sync_tree(root, &tree)?;
    let env = test_env(root)?;
    let target_dir = scratch.join("target");

    // Baseline: every selected (binary, filter) passes unmutated.
    let mut baselines: BTreeSet<(String, Option<String>)> = BTreeSet::new();
    for m in &selected {
        let key = (m.test.clone(), m.filter.clone());
        if baselines.insert(key) {
            let run = run_tests(&tree, &target_dir, &env, m, o.timeout)?;
            if run != Outcome::Survived {
                bail!(
                    "the tests of mutant `{}` ({} {}) do not pass unmutated ({}): fix them first",
                    m.name,
                    m.test,
                    m.filter.as_deref().unwrap_or(""),
                    run.label()
                );
            }
        }
    }

    let mut lines = Vec::new();
    let mut failures = 0;
    for (k, m) in selected.iter().enumerate() {
        let path = tree.join(&m.file);
        let original = std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
        std::fs::write(&path, m.apply(&original)?)?;
        let start = Instant::now();
        let outcome = run_tests(&tree, &target_dir, &env, m, o.timeout);
        std::fs::write(&path, &original)?;
        let outcome = outcome?;
        failures += outcome.is_failure() as usize;
        let line = format!(
            "{:<16} {:<44} {:>6.0} s  {} {}",
            outcome.label(),
            m.name,
            start.elapsed().as_secs_f64(),
            m.test,
            m.filter.as_deref().unwrap_or("")
        );
        println!("xtask: mutant {}/{}: {line}", k + 1, selected.len());
        lines.push(line);
    }
    let caught = lines.len() - failures;
    let summary = format!("{caught} caught, {failures} survived or unviable, of {} mutants", lines.len());
    std::fs::write(scratch.join("results.txt"), format!("{}\n{summary}\n", lines.join("\n")))?;
    println!("\n{}\n{summary}", lines.join("\n"));
    if failures > 0 {
        bail!("{failures} mutants survived or did not compile: each surviving one is a missing test");
    }
    Ok(())
}

/// The environment the tests run with: the adapter `cargo xtask test` picks, and its
/// property-test seed.
fn test_env(root: &Path) -> Result<Vec<(String, String)>> {
    let choice = AdapterChoice::new(|k| std::env::var(k).ok());
    let mut env: Vec<(String, String)> = choice.env.iter().map(|(k, v)| (k.to_string(), v.clone())).collect();
    if std::env::var("PROPTEST_RNG_SEED").is_err() {
        env.push(("PROPTEST_RNG_SEED".into(), default_proptest_seed(root)?.to_string()));
    }
    Ok(env)
}

/// Builds, then runs, the tests of `m` in `tree`: `Survived` when they pass.
fn run_tests(
    tree: &Path,
    target_dir: &Path,
    env: &[(String, String)],
    m: &Mutant,
    timeout: Duration,
) -> Result<Outcome> {
    let (package, binary) = m.target()?;
    let nextest = cargo(tree).args(["nextest", "--version"]).stdout(Stdio::null()).stderr(Stdio::null()).status();
    let nextest = nextest.is_ok_and(|s| s.success());
    let command = |build_only: bool| {
        let mut cmd = cargo(tree);
        cmd.env("CARGO_TARGET_DIR", target_dir);
        for (k, v) in env {
            cmd.env(k, v);
        }
        cmd.args(if nextest { &["nextest", "run"][..] } else { &["test"][..] });
        cmd.args(["--package", package]);
        // A mutant is caught by any failing test; nextest refuses the flag with --no-run.
        if !build_only {
            cmd.arg("--no-fail-fast");
        }
        if binary == "lib" {
            cmd.arg("--lib");
        } else if binary == "bin" {
            // A binary crate's unit tests (the app's).
            cmd.arg("--bins");
        } else {
            cmd.args(["--test", binary]);
        }
        if build_only {
            cmd.arg("--no-run");
        } else if let Some(f) = &m.filter {
            if nextest {
                cmd.arg(f);
            } else {
                cmd.args(["--", f]);
            }
        }
        cmd
    };
    let mut build = command(true);
    println!("xtask: {}", describe(&build));
    if !build.status().context("starting cargo")?.success() {
        return Ok(Outcome::Unviable);
    }
    let mut run = command(false);
    println!("xtask: {}", describe(&run));
    let mut child = run.spawn().context("starting cargo")?;
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait()? {
            return Ok(if status.success() { Outcome::Survived } else { Outcome::Caught });
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            return Ok(Outcome::Timeout);
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// Makes `tree` a copy of the working tree's files (tracked, and untracked that git does
/// not ignore), rewriting only files whose bytes differ (so cargo's incremental build
/// sees only real changes) and removing files no longer in the tree.
fn sync_tree(root: &Path, tree: &Path) -> Result<()> {
    let files = git_lines(root, &["ls-files", "--cached", "--others", "--exclude-standard"])?;
    let wanted: BTreeSet<&str> = files.iter().map(String::as_str).collect();
    let mut copied = 0;
    for f in &files {
        let from = root.join(f);
        let to = tree.join(f);
        // A tracked link (crates/gpu/shaders, crates/lab/assets/fonts) is linked again: its
        // relative target is in the tree too.
        if std::fs::symlink_metadata(&from).is_ok_and(|m| m.file_type().is_symlink()) {
            let target = std::fs::read_link(&from)?;
            if std::fs::read_link(&to).ok() != Some(target.clone()) {
                let _ = std::fs::remove_file(&to);
                std::fs::create_dir_all(to.parent().expect("a link has a parent"))?;
                link(&target, &to).with_context(|| format!("linking {}", to.display()))?;
                copied += 1;
            }
            continue;
        }
        if !from.is_file() {
            continue; // deleted in the working tree but still in the index
        }
        let bytes = std::fs::read(&from).with_context(|| format!("reading {}", from.display()))?;
        if std::fs::read(&to).ok().as_deref() != Some(&bytes[..]) {
            std::fs::create_dir_all(to.parent().expect("a file has a parent"))?;
            std::fs::write(&to, &bytes)?;
            copied += 1;
        }
    }
    let mut removed = 0;
    if tree.exists() {
        for entry in walk(tree)? {
            let rel = entry.strip_prefix(tree)?.to_string_lossy().replace('\\', "/");
            if !wanted.contains(rel.as_str()) {
                std::fs::remove_file(&entry)?;
                removed += 1;
            }
        }
    }
    println!("xtask: scratch tree {}: {copied} files written, {removed} removed", tree.display());
    Ok(())
}

/// Every file and link under `dir` (links are not followed: a linked folder is one entry).
fn walk(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d)? {
            let e = e?;
            if e.file_type()?.is_dir() {
                stack.push(e.path());
            } else {
                out.push(e.path());
            }
        }
    }
    Ok(out)
}

/// A symbolic link at `at` to `target`.
#[cfg(unix)]
fn link(target: &Path, at: &Path) -> std::io::Result<()> {
    std::os::unix::fs::symlink(target, at)
}

/// A symbolic link at `at` to `target` (a folder's, as the workspace's links are).
#[cfg(windows)]
fn link(target: &Path, at: &Path) -> std::io::Result<()> {
    std::os::windows::fs::symlink_dir(target, at)
}

fn git_lines(root: &Path, args: &[&str]) -> Result<Vec<String>> {
    let out = Command::new("git").current_dir(root).args(args).output().context("running git")?;
    if !out.status.success() {
        bail!("git {} failed: {}", args.join(" "), String::from_utf8_lossy(&out.stderr).trim());
    }
    Ok(String::from_utf8(out.stdout)?.lines().map(str::to_owned).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mutant(find: &str, replace: &str) -> Mutant {
        Mutant {
            name: "m".into(),
            file: "f.rs".into(),
            find: find.into(),
            replace: replace.into(),
            test: "pkg::bin".into(),
            filter: None,
            why: String::new(),
        }
    }

    #[test]
    fn a_mutation_applies_exactly_once_or_not_at_all() {
        assert_eq!(mutant("a < b", "a <= b").apply("if a < b { x }").unwrap(), "if a <= b { x }");
        // Absent, repeated or a no-op: errors naming the problem.
        assert!(mutant("a > b", "a >= b").apply("if a < b {}").unwrap_err().to_string().contains("no longer occurs"));
        assert!(mutant("x", "y").apply("x + x").unwrap_err().to_string().contains("occurs 2 times"));
        assert!(mutant("x", "x").apply("x").unwrap_err().to_string().contains("changes nothing"));
    }

    #[test]
    fn targets_are_package_and_binary() {
        let mut m = mutant("a", "b");
        assert_eq!(m.target().unwrap(), ("pkg", "bin"));
        for bad in ["pkg", "::bin", "pkg::", "a::b::c"] {
            m.test = bad.into();
            assert!(m.target().is_err(), "{bad}");
        }
    }

    #[test]
    fn arguments_select_mutants() {
        let o = parse_args(&["--only".into(), "a,c".into(), "--timeout".into(), "60".into()]).unwrap();
        assert_eq!(o.only, ["a", "c"]);
        assert_eq!(o.timeout, Duration::from_secs(60));
        assert!(parse_args(&["--bogus".into()]).is_err());
        assert!(parse_args(&["--changed".into()]).is_err());
        let mut a = mutant("x", "y");
        a.name = "a".into();
        a.file = "one.rs".into();
        let mut c = a.clone();
        c.name = "c".into();
        c.file = "two.rs".into();
        let all = vec![a, c];
        let names = |v: Vec<&Mutant>| v.iter().map(|m| m.name.clone()).collect::<Vec<_>>();
        assert_eq!(names(select(&all, &o, &BTreeSet::new()).unwrap()), ["a", "c"]);
        let changed = Options { changed: Some("HEAD".into()), ..Default::default() };
        let files: BTreeSet<String> = ["two.rs".to_owned()].into();
        assert_eq!(names(select(&all, &changed, &files).unwrap()), ["c"]);
        let unknown = Options { only: vec!["zz".into()], ..Default::default() };
        assert!(select(&all, &unknown, &BTreeSet::new()).is_err());
    }

    /// The checked-in lists parse, name unique mutants, and every one applies exactly once
    /// to today's sources (a refactor that removes a mutant's text fails here, in CI).
    #[test]
    fn the_checked_in_lists_apply_to_todays_sources() {
        let root = crate::workspace_root();
        let all = load(&root, &root.join(MUTANTS_DIR)).unwrap();
        assert!(all.len() >= 30, "the list has {} mutants; the project keeps at least 30", all.len());
        let families: BTreeSet<&str> = all.iter().map(|m| m.file.split('/').nth(1).unwrap_or("")).collect();
        assert!(families.len() >= 5, "mutants must span the crates and shader families: {families:?}");
    }

    #[test]
    fn a_list_with_a_duplicate_or_stale_entry_is_refused() {
        let dir = std::env::temp_dir().join(format!("tiledlight-mutants-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("src.rs"), "fn f() { a < b }").unwrap();
        let entry = |name: &str, find: &str| {
            format!(
                "[[mutant]]\nname = \"{name}\"\nfile = \"src.rs\"\nfind = \"{find}\"\nreplace = \"a <= b\"\ntest = \"p::b\"\n"
            )
        };
        std::fs::write(dir.join("l.toml"), entry("one", "a < b")).unwrap();
        assert_eq!(load(&dir, &dir).unwrap().len(), 1);
        std::fs::write(dir.join("m.toml"), entry("one", "a < b")).unwrap();
        assert!(load(&dir, &dir).unwrap_err().to_string().contains("named twice"));
        std::fs::write(dir.join("m.toml"), entry("two", "a > b")).unwrap();
        assert!(format!("{:#}", load(&dir, &dir).unwrap_err()).contains("no longer occurs"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
