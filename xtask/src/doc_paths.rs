//! The repository paths the docs name exist: every backticked token of `DOCS` that starts
//! with a top-level folder of the workspace (`crates/`, `shaders/`, `tests/`, `docs/`,
//! `scripts/`, `xtask/`, `assets/`, `.ci/`) must name a file or folder, after cutting a
//! `:line`, a `::item` or a parenthesis off; `{a,b}` expands to each, and `*` in the last
//! component matches by prefix and suffix. Tokens with `<...>` are patterns of names, not
//! paths. Checked by this module's unit test (run by `cargo xtask test`), so a moved or
//! renamed file breaks the build of the docs that name it. Every library crate's README
//! names a `cargo run -p ... --example ...` whose example exists. Depends on std only.

use std::path::Path;

/// The docs whose paths are checked (ARCHITECTURE.md's recipes name the files a change
/// touches; the others lead a user to files).
pub const DOCS: [&str; 5] =
    ["docs/ARCHITECTURE.md", "README.md", "docs/USAGE.md", "tests/README.md", "docs/RELIABILITY.md"];

const ROOTS: [&str; 8] = ["crates/", "shaders/", "tests/", "docs/", "scripts/", "xtask/", "assets/", ".ci/"];

/// The paths of `text` (see the module doc), each with its candidates after expansion.
pub fn paths(text: &str) -> Vec<(String, Vec<String>)> {
    let mut out = Vec::new();
    for (i, part) in text.split('`').enumerate() {
        // Odd parts are inside backticks.
        if i % 2 == 0 || part.contains(char::is_whitespace) || part.contains('<') {
            continue;
        }
        if !ROOTS.iter().any(|r| part.starts_with(r)) {
            continue;
        }
        let path = part.split("::").next().unwrap_or(part);
        let path = path.split([':', '(', ';']).next().unwrap_or(path).trim_end_matches('.');
        out.push((part.to_string(), expand(path)));
    }
    out
}

/// `a/{b,c}.rs` -> `a/b.rs`, `a/c.rs` (one brace group).
fn expand(path: &str) -> Vec<String> {
    match (path.find('{'), path.find('}')) {
        (Some(a), Some(b)) if a < b => {
            path[a + 1..b].split(',').map(|alt| format!("{}{alt}{}", &path[..a], &path[b + 1..])).collect()
        }
        _ => vec![path.to_string()],
    }
}

/// Whether `path` (relative to `root`; `*` in its last component) names something.
fn exists(root: &Path, path: &str) -> bool {
    let Some((dir, name)) = path.rsplit_once('/').filter(|(_, n)| n.contains('*')) else {
        return root.join(path).exists();
    };
    let (prefix, suffix) = name.split_once('*').unwrap_or((name, ""));
    std::fs::read_dir(root.join(dir)).is_ok_and(|entries| {
        entries.filter_map(Result::ok).any(|e| {
            let n = e.file_name().to_string_lossy().into_owned();
            n.starts_with(prefix) && n.ends_with(suffix)
        })
    })
}

/// The tokens of `text` naming a path under `root` that does not exist.
pub fn missing(root: &Path, text: &str) -> Vec<String> {
    paths(text).into_iter().filter(|(_, c)| !c.iter().all(|p| exists(root, p))).map(|(t, _)| t).collect()
}

/// The `cargo run ... -p PACKAGE --example NAME` commands of `text` whose example file
/// (`crates/*/examples/NAME.rs` of the package named) does not exist under `root`.
/// The differences between a markdown text's contents list (the `- [Title](#anchor)`
/// lines under `## Contents`) and its `## ` sections after it: each section listed once, in
/// order, with GitHub's anchor.
pub fn contents_mismatch(text: &str) -> Vec<String> {
    let anchor = |h: &str| {
        h.to_lowercase()
            .chars()
            .filter(|c| c.is_ascii_alphanumeric() || *c == ' ' || *c == '-')
            .collect::<String>()
            .replace(' ', "-")
    };
    let Some(start) = text.find("## Contents\n") else {
        return vec!["no `## Contents` section".into()];
    };
    let body = &text[start + "## Contents\n".len()..];
    let listed: Vec<String> =
        body.lines().skip_while(|l| l.is_empty()).take_while(|l| l.starts_with("- [")).map(str::to_string).collect();
    let sections: Vec<String> =
        body.lines().filter_map(|l| l.strip_prefix("## ")).map(|h| format!("- [{h}](#{})", anchor(h))).collect();
    let mut bad: Vec<String> =
        sections.iter().filter(|s| !listed.contains(s)).map(|s| format!("not listed: {s}")).collect();
    bad.extend(listed.iter().filter(|l| !sections.contains(l)).map(|l| format!("no such section: {l}")));
    if bad.is_empty() && listed != sections {
        bad.push("listed out of order".into());
    }
    bad
}

pub fn missing_examples(root: &Path, text: &str) -> Vec<String> {
    let mut bad = Vec::new();
    for line in text.lines().filter(|l| l.contains("cargo run") && l.contains("--example")) {
        let words: Vec<&str> = line.split_whitespace().collect();
        let after = |flag: &str| words.iter().position(|w| *w == flag).and_then(|i| words.get(i + 1)).copied();
        let (Some(package), Some(example)) = (after("-p"), after("--example")) else {
            bad.push(line.trim().to_string());
            continue;
        };
        let dir = package.strip_prefix("tiledlight-").unwrap_or(package);
        if !root.join(format!("crates/{dir}/examples/{example}.rs")).exists() {
            bad.push(line.trim().to_string());
        }
    }
    bad
}

#[cfg(test)]
mod tests {
    use super::*;

    fn root() -> &'static Path {
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
    }

    /// docs/USAGE.md opens with a contents list of its sections (issue 47); a list that
    /// misses, invents or reorders a section is reported.
    #[test]
    fn usage_has_a_true_contents_list() {
        let usage = std::fs::read_to_string(root().join("docs/USAGE.md")).unwrap();
        assert_eq!(contents_mismatch(&usage), Vec::<String>::new());
        let text = "## Contents\n\n- [B](#b)\n- [A b](#a-b)\n\n## A b\n\n## B\n";
        assert_eq!(contents_mismatch(text), ["listed out of order"]);
        let text = "## Contents\n\n- [A](#a)\n- [C](#c)\n\n## A\n\n## B\n";
        assert_eq!(contents_mismatch(text), ["not listed: - [B](#b)", "no such section: - [C](#c)"]);
        assert_eq!(contents_mismatch("## A\n"), ["no `## Contents` section"]);
    }

    #[test]
    fn every_path_the_docs_name_exists() {
        let mut bad = Vec::new();
        for doc in DOCS {
            let text = std::fs::read_to_string(root().join(doc)).unwrap_or_else(|e| panic!("{doc}: {e}"));
            let n = paths(&text).len();
            assert!(doc != "docs/ARCHITECTURE.md" || n > 100, "{doc}: only {n} paths found: the scan is broken");
            bad.extend(missing(root(), &text).into_iter().map(|t| format!("{doc}: `{t}`")));
        }
        assert!(bad.is_empty(), "paths named in the docs that do not exist:\n{}", bad.join("\n"));
    }

    /// Every library crate has a README (its package's `readme`) whose runnable example
    /// exists.
    #[test]
    fn every_library_crate_has_a_readme_with_a_runnable_example() {
        let mut bad = Vec::new();
        for entry in std::fs::read_dir(root().join("crates")).unwrap() {
            let dir = entry.unwrap().path();
            if dir.file_name().is_some_and(|n| n == "app") {
                continue;
            }
            let Ok(text) = std::fs::read_to_string(dir.join("README.md")) else {
                bad.push(format!("{}: no README.md", dir.display()));
                continue;
            };
            if !text.contains("--example") {
                bad.push(format!("{}: README.md runs no example", dir.display()));
            }
            bad.extend(missing_examples(root(), &text).into_iter().map(|l| format!("{}: `{l}`", dir.display())));
        }
        assert!(bad.is_empty(), "{}", bad.join("\n"));
    }

    /// An example command naming a file that does not exist is reported.
    #[test]
    fn a_missing_example_is_reported() {
        let text = "cargo run -p tiledlight-cull --example cull_a_floor\ncargo run -p tiledlight-cull --example gone\n";
        assert_eq!(missing_examples(root(), text), ["cargo run -p tiledlight-cull --example gone"]);
    }

    /// The negative test: a renamed file, one alternative of a brace group and a glob that
    /// matches nothing are all reported; a line number, an item path, a parenthesis and a
    /// pattern with `<...>` are not paths to check.
    #[test]
    fn a_missing_path_is_reported() {
        let text = "see `crates/frame/src/plan.rs:12`, `crates/frame/src/{plan,nope}.rs`, `shaders/traced*.wgsl`, \
                    `shaders/zzz*.wgsl`, `crates/gpu/src/gone.rs`, `tiledlight_gpu::plan`, \
                    `crates/lab/src/tune.rs::Candidate`, `docs/results/<gpu>-<commit>/` and `a b/c`";
        let found: Vec<String> = paths(text).into_iter().map(|(t, _)| t).collect();
        assert_eq!(found.len(), 6, "{found:?}");
        assert_eq!(
            missing(root(), text),
            ["crates/frame/src/{plan,nope}.rs", "shaders/zzz*.wgsl", "crates/gpu/src/gone.rs"]
        );
    }
}
