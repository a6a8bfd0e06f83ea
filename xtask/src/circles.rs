//! `cargo xtask circles` (also run by `validate-shaders` and `test`): the import graphs of
//! the workspace must have no circles.
//!
//! - **Rust**: per crate root (every member's `src/lib.rs`, `src/main.rs`, `src/bin/*.rs`,
//!   `tests/*.rs`, `examples/*.rs`, `benches/*.rs`, `build.rs`), the module tree is followed
//!   through `mod name;` declarations (`#[path]` honoured), and every path naming an item
//!   of the same crate (`use` declarations and paths in code starting with `crate::`,
//!   `super::`, `self::`, a child module or a name a `use` bound) is resolved to the file
//!   that defines it. Re-exports are followed (`crate::Camera` re-exported by `lib.rs` from
//!   `camera.rs` is an edge to `camera.rs`, not to `lib.rs`), so a facade's `pub use` of
//!   its children is an edge down and a child naming the facade's own items is an edge up.
//!   A `mod` declaration is no edge. Nodes are files: an inline module belongs to its file.
//!   Code under `#[cfg(test)]` (a `mod`, `use`, `fn` or `impl`) is left out: unit tests may
//!   reach into any module of their crate (a registry test calling the crate root's list of
//!   every pass), which is no dependency of the crate itself.
//! - **WGSL**: every `#include "path"` line of a file under `shaders/` (inside `#ifdef`s or
//!   not) is an edge from that file to `shaders/path`.
//!
//! A circle is a strongly connected component of more than one file (files that reach each
//! other through imports); it is what the issue counts ("`reference.rs` <-> `cluster.rs`
//! and `assign.rs`" is one). The check prints each graph's size and circles and fails on
//! any. It reads the sources as text (comments and literals blanked, then tokens), no Rust
//! parser: a path built by a macro is not seen.
//!
//! Depends only on std and anyhow.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _, Result};

/// Checks the Rust module graph of every workspace crate and the WGSL include graph of
/// `shaders/`, printing the circles; an error when there is any.
pub fn check(root: &Path) -> Result<()> {
    let report = workspace_report(root)?;
    for line in &report.lines {
        println!("{line}");
    }
    let n = report.circles.len();
    println!("circles: {n} (Rust crates and WGSL includes)");
    if n > 0 {
        for c in &report.circles {
            eprintln!("circle: {}", c.join(" <-> "));
        }
        for d in &report.details {
            eprintln!("  import in a circle: {d}");
        }
        bail!("{n} import circle(s): see above");
    }
    Ok(())
}

/// What [`check`] found: one summary line per graph, and every circle (file names).
pub struct Report {
    /// `rust <crate root>: N files, E edges, C circles`, then the WGSL line.
    pub lines: Vec<String>,
    /// Every circle, its files sorted, prefixed with the crate or `shaders/`.
    pub circles: Vec<Vec<String>>,
    /// The imports inside each circle (`a -> b`), to say where to cut it.
    pub details: Vec<String>,
}

/// The graphs of the workspace at `root`.
pub fn workspace_report(root: &Path) -> Result<Report> {
    let mut lines = Vec::new();
    let mut circles = Vec::new();
    let mut details = Vec::new();
    for member in workspace_members(root)? {
        let package = root.join(&member);
        for crate_root in crate_roots(&package) {
            let graph = rust_graph(&package, &crate_root)?;
            let rel = crate_root.strip_prefix(root).unwrap_or(&crate_root).display().to_string();
            let found = graph.circles();
            lines.push(format!(
                "rust {rel}: {} files, {} edges, {} circles",
                graph.nodes.len(),
                graph.edge_count(),
                found.len()
            ));
            details.extend(graph.circle_edges(&found).into_iter().map(|e| format!("{member}: {e}")));
            circles.extend(found.into_iter().map(|c| c.into_iter().map(|f| format!("{member}/{f}")).collect()));
        }
    }
    let shaders = root.join("shaders");
    let graph = wgsl_graph(&shaders)?;
    let found = graph.circles();
    lines.push(format!(
        "wgsl shaders/: {} files, {} edges, {} circles",
        graph.nodes.len(),
        graph.edge_count(),
        found.len()
    ));
    details.extend(graph.circle_edges(&found).into_iter().map(|e| format!("shaders/: {e}")));
    circles.extend(found.into_iter().map(|c| c.into_iter().map(|f| format!("shaders/{f}")).collect()));
    Ok(Report { lines, circles, details })
}

/// A directed graph of named files.
#[derive(Default, Debug)]
pub struct Graph {
    /// File names (relative to the crate's directory, or to `shaders/`).
    pub nodes: Vec<String>,
    /// Edges by node index (no self-edges).
    pub edges: BTreeMap<usize, BTreeSet<usize>>,
}

impl Graph {
    /// The index of `name`, added when new.
    pub fn node(&mut self, name: &str) -> usize {
        match self.nodes.iter().position(|n| n == name) {
            Some(i) => i,
            None => {
                self.nodes.push(name.to_owned());
                self.nodes.len() - 1
            }
        }
    }

    /// Adds the edge `from -> to` (a self-edge is no circle and is dropped).
    pub fn edge(&mut self, from: usize, to: usize) {
        if from != to {
            self.edges.entry(from).or_default().insert(to);
        }
    }

    /// The edges `a -> b` with both ends in the same one of `circles`.
    pub fn circle_edges(&self, circles: &[Vec<String>]) -> Vec<String> {
        let mut out = Vec::new();
        for c in circles {
            for (a, bs) in &self.edges {
                for b in bs {
                    if c.contains(&self.nodes[*a]) && c.contains(&self.nodes[*b]) {
                        out.push(format!("{} -> {}", self.nodes[*a], self.nodes[*b]));
                    }
                }
            }
        }
        out
    }

    fn edge_count(&self) -> usize {
        self.edges.values().map(BTreeSet::len).sum()
    }

    /// The strongly connected components of more than one node (Tarjan), each sorted by
    /// name, in name order.
    pub fn circles(&self) -> Vec<Vec<String>> {
        struct Tarjan<'g> {
            g: &'g Graph,
            index: Vec<Option<usize>>,
            low: Vec<usize>,
            on_stack: Vec<bool>,
            stack: Vec<usize>,
            next: usize,
            out: Vec<Vec<String>>,
        }
        impl Tarjan<'_> {
            fn visit(&mut self, v: usize) {
                self.index[v] = Some(self.next);
                self.low[v] = self.next;
                self.next += 1;
                self.stack.push(v);
                self.on_stack[v] = true;
                for &w in self.g.edges.get(&v).into_iter().flatten() {
                    match self.index[w] {
                        None => {
                            self.visit(w);
                            self.low[v] = self.low[v].min(self.low[w]);
                        }
                        Some(i) if self.on_stack[w] => self.low[v] = self.low[v].min(i),
                        Some(_) => {}
                    }
                }
                if Some(self.low[v]) == self.index[v] {
                    let mut scc = Vec::new();
                    while let Some(w) = self.stack.pop() {
                        self.on_stack[w] = false;
                        scc.push(self.g.nodes[w].clone());
                        if w == v {
                            break;
                        }
                    }
                    if scc.len() > 1 {
                        scc.sort();
                        self.out.push(scc);
                    }
                }
            }
        }
        let n = self.nodes.len();
        let mut t = Tarjan {
            g: self,
            index: vec![None; n],
            low: vec![0; n],
            on_stack: vec![false; n],
            stack: Vec::new(),
            next: 0,
            out: Vec::new(),
        };
        for v in 0..n {
            if t.index[v].is_none() {
                t.visit(v);
            }
        }
        t.out.sort();
        t.out
    }
}

// ---- WGSL ----

/// The `#include` graph of every `.wgsl` file under `shaders`.
pub fn wgsl_graph(shaders: &Path) -> Result<Graph> {
    let mut graph = Graph::default();
    let mut files = Vec::new();
    collect_files(shaders, "wgsl", &mut files)?;
    files.sort();
    for file in files {
        let name = rel_name(shaders, &file);
        let from = graph.node(&name);
        let text = fs::read_to_string(&file).with_context(|| format!("cannot read {}", file.display()))?;
        for line in text.lines() {
            let Some(rest) = line.trim().strip_prefix("#include") else { continue };
            let target = rest.trim().trim_matches('"');
            let to = graph.node(target);
            graph.edge(from, to);
        }
    }
    Ok(graph)
}

fn collect_files(dir: &Path, ext: &str, out: &mut Vec<PathBuf>) -> Result<()> {
    for entry in fs::read_dir(dir).with_context(|| format!("cannot list {}", dir.display()))? {
        let path = entry?.path();
        if path.is_dir() {
            collect_files(&path, ext, out)?;
        } else if path.extension().is_some_and(|e| e == ext) {
            out.push(path);
        }
    }
    Ok(())
}

fn rel_name(base: &Path, file: &Path) -> String {
    file.strip_prefix(base).unwrap_or(file).to_string_lossy().replace('\\', "/")
}

// ---- Rust: the workspace's crates ----

/// The `members` of the workspace's `Cargo.toml` (directories relative to `root`).
fn workspace_members(root: &Path) -> Result<Vec<String>> {
    let toml = fs::read_to_string(root.join("Cargo.toml")).context("cannot read the workspace Cargo.toml")?;
    let start = toml.find("members").context("no workspace members")?;
    let open = start + toml[start..].find('[').context("members is not a list")?;
    let close = open + toml[open..].find(']').context("members is not a list")?;
    Ok(toml[open + 1..close]
        .split(',')
        .map(|m| m.trim().trim_matches('"').to_owned())
        .filter(|m| !m.is_empty())
        .collect())
}

/// Every crate root file of the package in `dir`.
fn crate_roots(dir: &Path) -> Vec<PathBuf> {
    let mut roots: Vec<PathBuf> =
        ["src/lib.rs", "src/main.rs", "build.rs"].iter().map(|f| dir.join(f)).filter(|f| f.is_file()).collect();
    for sub in ["src/bin", "tests", "examples", "benches"] {
        let Ok(entries) = fs::read_dir(dir.join(sub)) else { continue };
        let mut files: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "rs"))
            .collect();
        files.sort();
        roots.extend(files);
    }
    roots
}

/// A token of Rust source with comments and literals removed.
#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    /// `::`
    Path,
    Punct(char),
}

/// Rust source as tokens: comments, string, char and byte literals dropped (numbers are
/// kept as identifiers, lifetimes dropped).
fn tokenize(src: &str) -> Vec<Tok> {
    let c: Vec<char> = src.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        let ch = c[i];
        let next = c.get(i + 1).copied();
        if ch == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && next == Some('*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if ch == '"' {
            i = skip_string(&c, i + 1);
        } else if (ch == 'r' || ch == 'b') && raw_string_start(&c, i).is_some() {
            let (hashes, body) = raw_string_start(&c, i).expect("checked");
            i = body;
            loop {
                if i >= c.len() {
                    break;
                }
                if c[i] == '"' && (0..hashes).all(|k| c.get(i + 1 + k) == Some(&'#')) {
                    i += 1 + hashes;
                    break;
                }
                i += 1;
            }
        } else if ch == 'b' && next == Some('"') {
            i = skip_string(&c, i + 2);
        } else if ch == 'b' && next == Some('\'') {
            i = skip_char(&c, i + 1);
        } else if ch == '\'' {
            // A char literal ('a', '\n', '\u{..}') or a lifetime ('a, 'static).
            if c.get(i + 1) == Some(&'\\') || c.get(i + 2) == Some(&'\'') {
                i = skip_char(&c, i);
            } else {
                i += 1;
                while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                    i += 1;
                }
            }
        } else if ch.is_alphanumeric() || ch == '_' {
            let start = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            let word: String = c[start..i].iter().collect();
            // `r#ident`
            if word == "r" && c.get(i) == Some(&'#') && c.get(i + 1).is_some_and(|x| x.is_alphabetic() || *x == '_') {
                continue;
            }
            out.push(Tok::Ident(word));
        } else if ch == ':' && next == Some(':') {
            out.push(Tok::Path);
            i += 2;
        } else {
            if !ch.is_whitespace() {
                out.push(Tok::Punct(ch));
            }
            i += 1;
        }
    }
    out
}

/// Index after the closing quote of a string whose body starts at `i`.
fn skip_string(c: &[char], mut i: usize) -> usize {
    while i < c.len() {
        match c[i] {
            '\\' => i += 2,
            '"' => return i + 1,
            _ => i += 1,
        }
    }
    i
}

/// Index after a char literal whose opening quote is at `i`.
fn skip_char(c: &[char], mut i: usize) -> usize {
    i += 1;
    while i < c.len() {
        match c[i] {
            '\\' => i += 2,
            '\'' => return i + 1,
            _ => i += 1,
        }
    }
    i
}

/// For `r"`, `r#"`, `br"`, `br#"` at `i`: the number of `#` and the index of the body.
fn raw_string_start(c: &[char], i: usize) -> Option<(usize, usize)> {
    // Not the tail of an identifier (`for"` cannot happen, `bar#` neither, but `var"` could).
    if i > 0 && (c[i - 1].is_alphanumeric() || c[i - 1] == '_') {
        return None;
    }
    let mut j = i;
    if c[j] == 'b' {
        j += 1;
    }
    if c.get(j) != Some(&'r') {
        return None;
    }
    j += 1;
    let mut hashes = 0;
    while c.get(j) == Some(&'#') {
        hashes += 1;
        j += 1;
    }
    (c.get(j) == Some(&'"')).then_some((hashes, j + 1))
}

/// A module of the crate: a file, or an inline `mod name { .. }` inside one.
#[derive(Debug, Default)]
struct Module {
    /// Index of the file defining it.
    file: usize,
    parent: Option<usize>,
    children: BTreeMap<String, usize>,
    /// Items defined at its top level (functions, types, constants, macros...).
    items: BTreeSet<String>,
    /// `use` bindings: name -> path (as written, relative to this module).
    uses: BTreeMap<String, Vec<String>>,
    /// `use path::*` targets.
    globs: Vec<Vec<String>>,
    /// Paths in code (and `use` paths) to resolve: (path, file the mention is in).
    mentions: Vec<Vec<String>>,
}

/// The module graph of one crate.
struct Crate {
    modules: Vec<Module>,
    files: Vec<String>,
    /// `#[macro_export]` macros: name -> defining module (they live at the crate root).
    exported_macros: BTreeMap<String, usize>,
}

/// The file import graph of the crate whose root file is `root_file`, in the package at
/// `package` (file names are relative to it).
pub fn rust_graph(package: &Path, root_file: &Path) -> Result<Graph> {
    let mut krate = Crate { modules: Vec::new(), files: Vec::new(), exported_macros: BTreeMap::new() };
    load_file(&mut krate, root_file, package, None, None, true)?;
    let mut graph = Graph::default();
    // A file loaded twice (`#[path]` to a shared file) is one node.
    let nodes: Vec<usize> = krate.files.iter().map(|f| graph.node(f)).collect();
    for m in 0..krate.modules.len() {
        for path in &krate.modules[m].mentions {
            if let Some(target) = resolve(&krate, m, path, 0) {
                graph.edge(nodes[krate.modules[m].file], nodes[krate.modules[target.module()].file]);
            }
        }
    }
    Ok(graph)
}

/// `path` with `.` and `dir/..` removed (no file system access).
fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir if out.file_name().is_some() => {
                out.pop();
            }
            c => out.push(c),
        }
    }
    out
}

/// Where a path leads: a module itself, or an item defined in a module.
#[derive(Clone, Copy, Debug)]
enum Target {
    Module(usize),
    Item(usize),
}

impl Target {
    fn module(self) -> usize {
        match self {
            Target::Module(m) | Target::Item(m) => m,
        }
    }
}

/// Reads `file` as module `name` of `parent` (None: the crate root) and its `mod`
/// children. `mod_dir`: whether its children live in its own directory (root, `mod.rs`)
/// or in a directory named after it.
fn load_file(
    krate: &mut Crate,
    file: &Path,
    base: &Path,
    parent: Option<(usize, String)>,
    dir_override: Option<PathBuf>,
    mod_dir: bool,
) -> Result<usize> {
    let src = fs::read_to_string(file).with_context(|| format!("cannot read {}", file.display()))?;
    let file_index = krate.files.len();
    krate.files.push(rel_name(base, file));
    let module = krate.modules.len();
    krate.modules.push(Module { file: file_index, parent: parent.as_ref().map(|p| p.0), ..Module::default() });
    if let Some((p, name)) = parent {
        krate.modules[p].children.insert(name, module);
    }
    // Children of this file's top module go in its directory (root or mod.rs) or in the
    // directory named after it.
    let dir = dir_override.unwrap_or_else(|| {
        let parent_dir = file.parent().unwrap_or(Path::new("")).to_path_buf();
        if mod_dir {
            parent_dir
        } else {
            parent_dir.join(file.file_stem().unwrap_or_default())
        }
    });
    let path_attrs = path_attributes(&src);
    let toks = tokenize(&src);
    parse_tokens(krate, &toks, module, &dir, base, file, &path_attrs)?;
    Ok(module)
}

/// The `#[path = "..."]` attributes of `src`, in order, each with the name of the `mod`
/// it applies to.
fn path_attributes(src: &str) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut rest = src;
    while let Some(at) = rest.find("#[path") {
        rest = &rest[at + 6..];
        let Some(q0) = rest.find('"') else { break };
        let Some(q1) = rest[q0 + 1..].find('"') else { break };
        let path = rest[q0 + 1..q0 + 1 + q1].to_owned();
        let after = &rest[q0 + 1 + q1..];
        if let Some(m) = after.find("mod ") {
            let name: String =
                after[m + 4..].trim_start().chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            out.insert(name, path);
        }
    }
    out
}

/// One scope of braces while walking a file's tokens.
enum Scope {
    /// An inline module (its index).
    Module(usize),
    /// Any other block (fn body, impl, struct, expression).
    Block,
    /// Code compiled only for unit tests (`#[cfg(test)]`): not part of the crate's graph.
    Test,
}

/// Whether `toks[i..]` starts with `# [ cfg ( test ) ]`.
fn is_cfg_test(toks: &[Tok], i: usize) -> bool {
    let want = [
        Tok::Punct('#'),
        Tok::Punct('['),
        Tok::Ident("cfg".into()),
        Tok::Punct('('),
        Tok::Ident("test".into()),
        Tok::Punct(')'),
        Tok::Punct(']'),
    ];
    toks.len() >= i + want.len() && toks[i..i + want.len()] == want
}

fn ident(t: Option<&Tok>) -> Option<&str> {
    match t {
        Some(Tok::Ident(s)) => Some(s),
        _ => None,
    }
}

fn parse_tokens(
    krate: &mut Crate,
    toks: &[Tok],
    file_module: usize,
    dir: &Path,
    base: &Path,
    file: &Path,
    path_attrs: &BTreeMap<String, String>,
) -> Result<()> {
    let mut scopes: Vec<Scope> = Vec::new();
    let current = |scopes: &[Scope]| {
        scopes
            .iter()
            .rev()
            .find_map(|s| match s {
                Scope::Module(m) => Some(*m),
                Scope::Block | Scope::Test => None,
            })
            .unwrap_or(file_module)
    };
    // Top level of a module (not inside a block): where items are declared.
    let at_module_level = |scopes: &[Scope]| matches!(scopes.last(), None | Some(Scope::Module(_)));
    let mut macro_export = false;
    // After `#[cfg(test)]`: the next item is test-only (a `mod`, `use`, `fn` or `impl`).
    let mut test_item = false;
    let mut i = 0;
    while i < toks.len() {
        let here = current(&scopes);
        if scopes.iter().any(|s| matches!(s, Scope::Test)) {
            match &toks[i] {
                Tok::Punct('{') => scopes.push(Scope::Block),
                Tok::Punct('}') => {
                    scopes.pop();
                }
                _ => {}
            }
            i += 1;
            continue;
        }
        if is_cfg_test(toks, i) {
            test_item = true;
            i += 7;
            continue;
        }
        if test_item && toks[i] == Tok::Punct('#') && toks.get(i + 1) == Some(&Tok::Punct('[')) {
            // Another attribute of the same item (`#[path = ".."]`).
            i = toks[i..].iter().position(|t| *t == Tok::Punct(']')).map_or(toks.len(), |p| i + p + 1);
            continue;
        }
        if test_item {
            match ident(toks.get(i)) {
                Some("use") => {
                    test_item = false;
                    i = toks[i..].iter().position(|t| *t == Tok::Punct(';')).map_or(toks.len(), |p| i + p + 1);
                    continue;
                }
                Some("mod" | "fn" | "impl") => {
                    test_item = false;
                    // Up to the item's `;` (a `mod x;` not loaded) or into its block.
                    let end = toks[i..]
                        .iter()
                        .position(|t| matches!(t, Tok::Punct(';') | Tok::Punct('{')))
                        .map_or(toks.len(), |p| i + p);
                    if toks.get(end) == Some(&Tok::Punct('{')) {
                        scopes.push(Scope::Test);
                    }
                    i = end + 1;
                    continue;
                }
                Some("pub" | "crate" | "async" | "unsafe" | "const") | None => {}
                Some(_) => test_item = false,
            }
        }
        match &toks[i] {
            Tok::Punct('{') => {
                scopes.push(Scope::Block);
                i += 1;
            }
            Tok::Punct('}') => {
                scopes.pop();
                i += 1;
            }
            Tok::Punct('#') => {
                // `#[macro_export]` before a `macro_rules!`.
                if ident(toks.get(i + 2)) == Some("macro_export") {
                    macro_export = true;
                }
                i += 1;
            }
            Tok::Ident(kw) if kw == "use" => {
                let end = toks[i..].iter().position(|t| *t == Tok::Punct(';')).map_or(toks.len(), |p| i + p);
                let mut entries = Vec::new();
                use_tree(&toks[i + 1..end], &[], &mut entries);
                for (path, binding) in entries {
                    if path.first().is_some_and(|s| s.is_empty()) {
                        continue; // `::std::...`: another crate.
                    }
                    let m = &mut krate.modules[here];
                    match binding {
                        UseBinding::Name(name) if name != "_" => {
                            m.uses.insert(name, path.clone());
                        }
                        UseBinding::Name(_) => {}
                        UseBinding::Glob => m.globs.push(path.clone()),
                    }
                    m.mentions.push(path);
                }
                i = end + 1;
            }
            Tok::Ident(kw) if kw == "mod" && at_module_level(&scopes) => {
                let Some(name) = ident(toks.get(i + 1)).map(str::to_owned) else {
                    i += 1;
                    continue;
                };
                match toks.get(i + 2) {
                    Some(Tok::Punct(';')) => {
                        let (child_file, child_dir, mod_dir) = match path_attrs.get(&name) {
                            Some(p) => (normalize(&file.parent().unwrap_or(Path::new("")).join(p)), None, true),
                            None => {
                                let flat = dir.join(format!("{name}.rs"));
                                let nested = dir.join(&name).join("mod.rs");
                                if flat.is_file() {
                                    (flat, None, false)
                                } else if nested.is_file() {
                                    (nested, None, true)
                                } else {
                                    bail!("{}: mod {name}; has no file", file.display());
                                }
                            }
                        };
                        let parent = Some((here, name.clone()));
                        load_file(krate, &child_file, base, parent, child_dir, mod_dir)?;
                        i += 3;
                    }
                    Some(Tok::Punct('{')) => {
                        let m = krate.modules.len();
                        let file_index = krate.modules[file_module].file;
                        krate.modules.push(Module { file: file_index, parent: Some(here), ..Module::default() });
                        krate.modules[here].children.insert(name, m);
                        scopes.push(Scope::Module(m));
                        i += 3;
                    }
                    _ => i += 1,
                }
            }
            Tok::Ident(kw)
                if at_module_level(&scopes)
                    && matches!(
                        kw.as_str(),
                        "fn" | "struct" | "enum" | "union" | "trait" | "type" | "const" | "static" | "macro_rules"
                    ) =>
            {
                // `macro_rules! name`, `const fn name`, `static mut NAME`, `unsafe fn`...
                let mut j = i + 1;
                while matches!(toks.get(j), Some(Tok::Punct('!')))
                    || matches!(ident(toks.get(j)), Some("mut" | "fn" | "unsafe" | "extern"))
                {
                    j += 1;
                }
                if let Some(name) = ident(toks.get(j)) {
                    krate.modules[here].items.insert(name.to_owned());
                    if kw == "macro_rules" && macro_export {
                        krate.exported_macros.insert(name.to_owned(), here);
                    }
                }
                if kw == "macro_rules" {
                    macro_export = false;
                }
                i = j + 1;
            }
            Tok::Ident(first) => {
                // A path in code: `a::b::c` not preceded by `::`, `.` or `$` (a macro's `$crate`).
                let prev = i.checked_sub(1).map(|p| &toks[p]);
                let continues = matches!(prev, Some(Tok::Path | Tok::Punct('.') | Tok::Punct('$')));
                if !continues && toks.get(i + 1) == Some(&Tok::Path) {
                    let mut path = vec![first.clone()];
                    let mut j = i + 1;
                    while toks.get(j) == Some(&Tok::Path) {
                        match ident(toks.get(j + 1)) {
                            Some(s) => {
                                path.push(s.to_owned());
                                j += 2;
                            }
                            None => break,
                        }
                    }
                    krate.modules[here].mentions.push(path);
                    i = j;
                } else {
                    i += 1;
                }
            }
            _ => i += 1,
        }
    }
    Ok(())
}

/// What a `use` entry binds.
#[derive(Debug, PartialEq)]
enum UseBinding {
    Name(String),
    Glob,
}

/// Expands a `use` tree (the tokens between `use` and `;`) into full paths, each with what
/// it binds. A leading `::` gives an empty first segment. `pub`/`pub(crate)` are skipped.
fn use_tree(toks: &[Tok], prefix: &[String], out: &mut Vec<(Vec<String>, UseBinding)>) {
    // Split at top-level commas.
    let mut depth = 0;
    let mut start = 0;
    let mut parts = Vec::new();
    for (k, t) in toks.iter().enumerate() {
        match t {
            Tok::Punct('{') => depth += 1,
            Tok::Punct('}') => depth -= 1,
            Tok::Punct(',') if depth == 0 => {
                parts.push(&toks[start..k]);
                start = k + 1;
            }
            _ => {}
        }
    }
    parts.push(&toks[start..]);
    for part in parts {
        let mut path = prefix.to_vec();
        let mut k = 0;
        if k < part.len() && part[k] == Tok::Path {
            path.push(String::new());
            k += 1;
        }
        let mut binding = None;
        while k < part.len() {
            match &part[k] {
                Tok::Ident(s) if s == "as" => {
                    binding = ident(part.get(k + 1)).map(|b| UseBinding::Name(b.to_owned()));
                    k += 2;
                }
                Tok::Ident(s) => {
                    path.push(s.clone());
                    k += 1;
                }
                Tok::Path => k += 1,
                Tok::Punct('*') => {
                    binding = Some(UseBinding::Glob);
                    k += 1;
                }
                Tok::Punct('{') => {
                    let close = part.iter().rposition(|t| *t == Tok::Punct('}')).unwrap_or(part.len());
                    use_tree(&part[k + 1..close], &path, out);
                    path.clear();
                    break;
                }
                _ => k += 1,
            }
        }
        if path.is_empty() || path.len() == prefix.len() && binding.is_none() {
            continue;
        }
        let binding = match binding {
            Some(b) => b,
            None if path.last().is_some_and(|s| s == "self") => {
                path.pop();
                match path.last() {
                    Some(n) => UseBinding::Name(n.clone()),
                    None => continue,
                }
            }
            None => UseBinding::Name(path.last().cloned().unwrap_or_default()),
        };
        out.push((path, binding));
    }
}

/// Resolves `path`, written in module `from`, to a module or item of the crate (None: it
/// names something outside the crate, a local, or cannot be followed).
fn resolve(krate: &Crate, from: usize, path: &[String], depth: u32) -> Option<Target> {
    if depth > 16 || path.is_empty() {
        return None;
    }
    let (start, rest) = match path[0].as_str() {
        "crate" => (0, &path[1..]),
        "self" => (from, &path[1..]),
        "super" => {
            let mut m = from;
            let mut k = 0;
            while path.get(k).is_some_and(|s| s == "super") {
                m = krate.modules[m].parent?;
                k += 1;
            }
            (m, &path[k..])
        }
        "Self" => return None,
        first => {
            // A child module, or a name bound by a `use` of this module or an enclosing
            // one (inline test modules see their file's imports through `use super::*`).
            if let Some(&child) = krate.modules[from].children.get(first) {
                (child, &path[1..])
            } else if let Some(target) = krate.modules[from].uses.get(first) {
                if target.first().map(String::as_str) == Some(first) && target.len() == 1 {
                    return None;
                }
                let t = resolve(krate, from, target, depth + 1)?;
                return match t {
                    Target::Module(m) => walk(krate, m, &path[1..], depth + 1),
                    item => Some(item),
                };
            } else {
                return None;
            }
        }
    };
    walk(krate, start, rest, depth + 1)
}

/// Follows `rest` down from module `m`.
fn walk(krate: &Crate, m: usize, rest: &[String], depth: u32) -> Option<Target> {
    if depth > 16 {
        return None;
    }
    let Some(s) = rest.first() else { return Some(Target::Module(m)) };
    let module = &krate.modules[m];
    if let Some(&child) = module.children.get(s) {
        return walk(krate, child, &rest[1..], depth + 1);
    }
    if m == 0 {
        if let Some(&def) = krate.exported_macros.get(s) {
            return Some(Target::Item(def));
        }
    }
    if module.items.contains(s) {
        return Some(Target::Item(m));
    }
    if let Some(target) = module.uses.get(s) {
        return match resolve(krate, m, target, depth + 1) {
            Some(Target::Module(t)) => walk(krate, t, &rest[1..], depth + 1),
            Some(item) => Some(item),
            // A re-export of another crate's item: no edge beyond this module.
            None => Some(Target::Item(m)),
        };
    }
    for glob in &module.globs {
        if let Some(Target::Module(g)) = resolve(krate, m, glob, depth + 1) {
            let gm = &krate.modules[g];
            if gm.children.contains_key(s) || gm.items.contains(s) || gm.uses.contains_key(s) {
                return walk(krate, g, rest, depth + 1);
            }
        }
    }
    // Defined in a way this reader does not see (a macro): say it is here.
    Some(Target::Item(m))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scratch directory holding `files` (path, text), removed on drop.
    struct Scratch(PathBuf);

    impl Scratch {
        fn new(name: &str, files: &[(&str, &str)]) -> Self {
            let dir = std::env::temp_dir().join(format!("xtask-circles-{name}-{}", std::process::id()));
            let _ = fs::remove_dir_all(&dir);
            for (path, text) in files {
                let p = dir.join(path);
                fs::create_dir_all(p.parent().unwrap()).unwrap();
                fs::write(p, text).unwrap();
            }
            Scratch(dir)
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = fs::remove_dir_all(&self.0);
        }
    }

    #[test]
    fn a_rust_cycle_is_reported() {
        let s = Scratch::new(
            "rust",
            &[
                ("src/lib.rs", "pub mod a;\npub mod b;\npub mod c;\n"),
                ("src/a.rs", "use crate::b::B;\npub struct A;\n"),
                ("src/b.rs", "pub struct B(crate::c::C);\n"),
                ("src/c.rs", "pub struct C;\nfn f() -> super::a::A { todo!() }\n"),
            ],
        );
        let g = rust_graph(&s.0, &s.0.join("src/lib.rs")).unwrap();
        assert_eq!(g.circles(), vec![vec!["src/a.rs".to_owned(), "src/b.rs".into(), "src/c.rs".into()]]);
    }

    #[test]
    fn a_wgsl_cycle_is_reported() {
        let s = Scratch::new(
            "wgsl",
            &[
                ("a.wgsl", "#include \"common/b.wgsl\"\nfn a() {}\n"),
                ("common/b.wgsl", "#ifdef X\n#include \"common/c.wgsl\"\n#endif\n"),
                ("common/c.wgsl", "  #include \"common/b.wgsl\"\n"),
                ("d.wgsl", "#include \"common/c.wgsl\"\n"),
            ],
        );
        let g = wgsl_graph(&s.0).unwrap();
        assert_eq!(g.circles(), vec![vec!["common/b.wgsl".to_owned(), "common/c.wgsl".into()]]);
    }

    /// The shapes the workspace uses that are no circle: a facade re-exporting its
    /// children while they import a sibling through `super::`, a crate root re-exporting
    /// what a module then names through `crate::`, a `#[macro_export]` macro, test
    /// modules importing their parent, comments and strings naming modules.
    #[test]
    fn facades_reexports_and_tests_are_no_circle() {
        let s = Scratch::new(
            "facade",
            &[
                (
                    "src/lib.rs",
                    "pub mod culling;\npub mod camera;\npub mod layout;\npub use camera::Camera;\n\
                     pub use culling::{Options, Tile};\n",
                ),
                (
                    "src/camera.rs",
                    "pub struct Camera;\n#[cfg(test)]\n#[path = \"camera/tests.rs\"]\nmod tests;\n\
                     #[cfg(test)]\nfn helper() { crate::culling::tile::make(); }\n",
                ),
                ("src/camera/tests.rs", "use super::*;\n"),
                (
                    "src/layout.rs",
                    "#[macro_export]\nmacro_rules! layout { () => { $crate::layout::x() } }\npub fn x() {}\n",
                ),
                (
                    "src/culling/mod.rs",
                    "//! Uses crate::camera in a comment.\nmod options;\npub mod tile;\npub use options::Options;\n\
                     pub use tile::Tile;\nfn f() { let s = \"crate::camera::Camera\"; tile::make(); }\n",
                ),
                ("src/culling/options.rs", "pub struct Options(crate::Camera);\nfn g() { crate::layout!(); }\n"),
                (
                    "src/culling/tile.rs",
                    "use super::options::Options;\npub struct Tile;\npub fn make() {}\n\
                     #[cfg(test)]\nmod tests {\n    use super::*;\n    use crate::culling::Tile as T;\n}\n",
                ),
            ],
        );
        let g = rust_graph(&s.0, &s.0.join("src/lib.rs")).unwrap();
        assert_eq!(g.circles(), Vec::<Vec<String>>::new(), "{g:?}");
        let edge = |a: &str, b: &str| {
            let (a, b) = (g.nodes.iter().position(|n| n == a).unwrap(), g.nodes.iter().position(|n| n == b).unwrap());
            g.edges.get(&a).is_some_and(|e| e.contains(&b))
        };
        // Through the root's re-export to the defining file, not to lib.rs.
        assert!(edge("src/culling/options.rs", "src/camera.rs"));
        assert!(!edge("src/culling/options.rs", "src/lib.rs"));
        assert!(edge("src/culling/options.rs", "src/layout.rs"));
        assert!(edge("src/culling/tile.rs", "src/culling/options.rs"));
        assert!(edge("src/culling/mod.rs", "src/culling/tile.rs"));
        assert!(!edge("src/camera.rs", "src/culling/tile.rs"));
        // Unit tests are no part of the graph.
        assert!(!g.nodes.iter().any(|n| n == "src/camera/tests.rs"), "{:?}", g.nodes);
        // The comment and the string are no edge.
        assert!(!edge("src/culling/mod.rs", "src/camera.rs"));
    }

    /// A child naming an item its facade defines, while the facade uses the child, is a
    /// circle (what the culling folder avoids by keeping its options in their own file).
    #[test]
    fn a_child_using_its_facade_is_a_circle() {
        let s = Scratch::new(
            "child",
            &[
                ("src/main.rs", "mod culling;\nfn main() {}\n"),
                ("src/culling/mod.rs", "mod tile;\npub struct Options;\npub use tile::Tile;\n"),
                ("src/culling/tile.rs", "pub struct Tile(super::Options);\n"),
            ],
        );
        let g = rust_graph(&s.0, &s.0.join("src/main.rs")).unwrap();
        assert_eq!(g.circles(), vec![vec!["src/culling/mod.rs".to_owned(), "src/culling/tile.rs".into()]]);
    }

    #[test]
    fn use_trees_expand() {
        let toks = tokenize("pub(crate) use crate::a::{b::{self, C as D}, e::*, F};");
        let end = toks.iter().position(|t| *t == Tok::Punct(';')).unwrap();
        let start = toks.iter().position(|t| *t == Tok::Ident("use".into())).unwrap();
        let mut out = Vec::new();
        use_tree(&toks[start + 1..end], &[], &mut out);
        let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        assert_eq!(
            out,
            vec![
                (s(&["crate", "a", "b"]), UseBinding::Name("b".into())),
                (s(&["crate", "a", "b", "C"]), UseBinding::Name("D".into())),
                (s(&["crate", "a", "e"]), UseBinding::Glob),
                (s(&["crate", "a", "F"]), UseBinding::Name("F".into())),
            ]
        );
    }

    /// The workspace itself: no circle (the check `validate-shaders` runs, as a test too).
    #[test]
    fn the_workspace_has_no_circles() {
        let root = crate::workspace_root();
        let report = workspace_report(&root).unwrap();
        assert!(report.lines.len() > 10, "{:?}", report.lines);
        assert_eq!(report.circles, Vec::<Vec<String>>::new());
    }
}
