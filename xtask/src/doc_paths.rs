//! The repository paths the docs name exist: every backticked token of `DOCS` that starts
//! with a top-level folder of the workspace (`crates/`, `shaders/`, `tests/`, `docs/`,
//! `scripts/`, `xtask/`, `assets/`, `.ci/`) must name a file or folder, after cutting a
//! `:line`, a `::item` or a parenthesis off; `{a,b}` expands to each, and `*` in the last
//! component matches by prefix and suffix. Tokens with `<...>` are patterns of names, not
//! paths. Checked by this module's unit test (run by `cargo xtask test`), so a moved or
//! renamed file breaks the build of the docs that name it. Depends on std only.

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

#[cfg(test)]
mod tests {
    use super::*;

    fn root() -> &'static Path {
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
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

    /// The negative test: a renamed file, one alternative of a brace group and a glob that
    /// matches nothing are all reported; a line number, an item path, a parenthesis and a
    /// pattern with `<...>` are not paths to check.
    #[test]
    fn a_missing_path_is_reported() {
        let text = "see `crates/gpu/src/plan.rs:12`, `crates/gpu/src/{plan,nope}.rs`, `shaders/traced*.wgsl`, \
                    `shaders/zzz*.wgsl`, `crates/gpu/src/gone.rs`, `tiledlight_gpu::plan`, \
                    `crates/lab/src/tune.rs::Candidate`, `docs/results/<gpu>-<commit>/` and `a b/c`";
        let found: Vec<String> = paths(text).into_iter().map(|(t, _)| t).collect();
        assert_eq!(found.len(), 6, "{found:?}");
        assert_eq!(
            missing(root(), text),
            ["crates/gpu/src/{plan,nope}.rs", "shaders/zzz*.wgsl", "crates/gpu/src/gone.rs"]
        );
    }
}
