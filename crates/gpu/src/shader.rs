//! WGSL sources: the table of every file under `shaders/` (embedded by `build.rs`, so
//! binaries run from anywhere) and a small line-based preprocessor.
//!
//! Directives, each on a line of its own (WGSL never uses `#`, so any line whose first
//! non-blank character is `#` is one; a trailing `// comment` is allowed):
//!
//! - `#include "common/brdf.wgsl"`: path relative to `shaders/`. Each file is included
//!   at most once per load (later includes of it are dropped, like `#pragma once`);
//!   including a file that is still being processed (a cycle) is an error.
//! - `#ifdef NAME`, `#ifndef NAME`, `#else`, `#endif`: nestable conditionals on the
//!   defines passed to [`preprocess`]. They must balance within each file.
//!
//! An entry file declares the defines it reacts to with a line `// variants: A B`;
//! [`preprocess`] refuses any other define ([`ShaderError::UndeclaredDefine`]: a misspelled
//! define, or a flag the file never tests). Which combinations exist is not the file's
//! business: each entry's key type in [`crate::variants`] lists exactly the buildable
//! variants, and `cargo xtask validate-shaders` validates every one of them.
//!
//! Output line `n` always comes from exactly one source line: directives and lines of
//! inactive branches become empty lines, and an `#include` line becomes an empty line
//! followed by the included text. [`ShaderSource::locate`] maps naga's error lines back
//! to file and line.
//!
//! Pure Rust (std and thiserror): no wgpu here, so xtask and tests can use it without a
//! device; turning a [`ShaderSource`] into a `wgpu::ShaderModule` happens elsewhere.

use std::collections::HashSet;

include!(concat!(env!("OUT_DIR"), "/shaders_generated.rs"));

/// Files under this directory of `shaders/` are include-only; every other file is an
/// entry file.
const COMMON_DIR: &str = "common/";

/// A preprocessing error, naming the file (relative to `shaders/`) and 1-based line.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ShaderError {
    /// The entry file does not exist.
    #[error("shader file not found: shaders/{file}")]
    NotFound {
        /// The requested entry file.
        file: String,
    },
    /// An `#include` names a file that does not exist.
    #[error("shaders/{file}:{line}: #include \"{include}\": no such shader file")]
    IncludeNotFound {
        /// File containing the `#include`.
        file: String,
        /// Line of the `#include`.
        line: usize,
        /// The path it names.
        include: String,
    },
    /// An `#include` names a file that is being processed (directly or indirectly
    /// includes itself).
    #[error("shaders/{file}:{line}: #include cycle: {}", chain.join(" -> "))]
    IncludeCycle {
        /// File containing the `#include` that closes the cycle.
        file: String,
        /// Line of that `#include`.
        line: usize,
        /// The files of the cycle, first and last the same.
        chain: Vec<String>,
    },
    /// A `#` line that is not one of the known directives.
    #[error(
        "shaders/{file}:{line}: unknown directive `{directive}` \
         (expected #include, #ifdef, #ifndef, #else or #endif)"
    )]
    UnknownDirective {
        /// File containing the line.
        file: String,
        /// Line number.
        line: usize,
        /// The directive as written.
        directive: String,
    },
    /// A known directive with wrong arguments, or a second `#else`.
    #[error("shaders/{file}:{line}: {message}")]
    BadDirective {
        /// File containing the line.
        file: String,
        /// Line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// `#else` or `#endif` with no open `#ifdef`/`#ifndef` in the same file.
    #[error("shaders/{file}:{line}: #{directive} without a matching #ifdef or #ifndef")]
    Unmatched {
        /// File containing the line.
        file: String,
        /// Line number.
        line: usize,
        /// `else` or `endif`.
        directive: &'static str,
    },
    /// A define the entry file does not declare in its `// variants:` lines (misspelled,
    /// or a flag the file never tests).
    #[error("shaders/{file}: define {define} is not one of its `// variants:` ({})", declared.join(" "))]
    UndeclaredDefine {
        /// The entry file.
        file: String,
        /// The define passed.
        define: String,
        /// The defines the file declares.
        declared: Vec<String>,
    },
    /// An `#ifdef`/`#ifndef` not closed by `#endif` before the end of its file.
    #[error("shaders/{file}:{line}: #ifdef/#ifndef is not closed by #endif before the end of the file")]
    Unterminated {
        /// File containing the conditional.
        file: String,
        /// Line of the unclosed `#ifdef`/`#ifndef`.
        line: usize,
    },
}

/// Preprocessed WGSL with a map from each output line to its source file and line.
#[derive(Clone, Debug)]
pub struct ShaderSource {
    /// The WGSL text to hand to naga or wgpu. Every line ends with `\n`.
    pub text: String,
    /// Files that contributed to `text`, relative to `shaders/`; the entry comes first.
    files: Vec<String>,
    /// For output line `i + 1`: (index into `files`, 1-based source line).
    line_map: Vec<(u32, u32)>,
}

impl ShaderSource {
    /// The entry file this source was made from, relative to `shaders/`.
    pub fn entry(&self) -> &str {
        &self.files[0]
    }

    /// Every file that went into the text (the entry first, then includes in the order
    /// they were first included), relative to `shaders/`.
    pub fn files(&self) -> &[String] {
        &self.files
    }

    /// Number of lines of `text`.
    pub fn line_count(&self) -> usize {
        self.line_map.len()
    }

    /// Source file (relative to `shaders/`) and 1-based line of 1-based output line
    /// `output_line`, as naga's `SourceLocation::line_number` reports it. Lines past the
    /// end (naga points at the end of input for a missing `}`) map to the last line;
    /// line 0 maps to the first.
    pub fn locate(&self, output_line: usize) -> (String, usize) {
        let Some(last) = self.line_map.len().checked_sub(1) else {
            return (self.files[0].clone(), output_line);
        };
        let (file, line) = self.line_map[output_line.saturating_sub(1).min(last)];
        (self.files[file as usize].clone(), line as usize)
    }
}

/// The embedded contents of `path` (relative to `shaders/`), if that file exists.
pub fn embedded(path: &str) -> Option<&'static str> {
    SHADER_FILES.binary_search_by(|(p, _)| (*p).cmp(path)).ok().map(|i| SHADER_FILES[i].1)
}

/// Every embedded entry file (every file not under `common/`), sorted.
pub fn entry_files() -> Vec<&'static str> {
    SHADER_FILES.iter().map(|(p, _)| *p).filter(|p| is_entry(p)).collect()
}

/// True when `path` (relative to `shaders/`) is an entry file, not an include-only one.
pub fn is_entry(path: &str) -> bool {
    !path.starts_with(COMMON_DIR)
}

/// The defines that embedded entry file `entry` declares with `// variants: ...`
/// (empty when it declares none or does not exist).
pub fn variants(entry: &str) -> Vec<String> {
    embedded(entry).map(variants_in).unwrap_or_default()
}

/// The defines declared by `// variants: A B` lines of `source` (all such lines, in
/// order, without duplicates). Only the file's own lines count, not its includes.
pub fn variants_in(source: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for line in source.lines() {
        let Some(rest) = line.trim_start().strip_prefix("//") else {
            continue;
        };
        let Some(names) = rest.trim_start().strip_prefix("variants:") else {
            continue;
        };
        for name in names.split_whitespace() {
            if !out.iter().any(|n| n == name) {
                out.push(name.to_owned());
            }
        }
    }
    out
}

/// Checks that every define of `defines` is declared by a `// variants:` line of entry
/// file `entry`, whose text is `text`.
pub fn check_declared(entry: &str, text: &str, defines: &[&str]) -> Result<(), ShaderError> {
    let declared = variants_in(text);
    match defines.iter().find(|d| !declared.iter().any(|v| v == *d)) {
        Some(d) => Err(ShaderError::UndeclaredDefine { file: entry.to_owned(), define: d.to_string(), declared }),
        None => Ok(()),
    }
}

/// Preprocesses embedded entry file `entry` (relative to `shaders/`) with `defines` set,
/// each of which the file must declare ([`check_declared`]).
pub fn preprocess(entry: &str, defines: &[&str]) -> Result<ShaderSource, ShaderError> {
    let text = embedded(entry).ok_or_else(|| ShaderError::NotFound { file: entry.to_owned() })?;
    check_declared(entry, text, defines)?;
    preprocess_with(&|path| embedded(path).map(str::to_owned), entry, defines)
}

/// Preprocesses `entry` with `defines` set, reading files through `files` (path
/// relative to `shaders/` to contents, `None` when missing): xtask reads them from disk
/// to check the current files, tests pass literal sources.
pub fn preprocess_with(
    files: &dyn Fn(&str) -> Option<String>,
    entry: &str,
    defines: &[&str],
) -> Result<ShaderSource, ShaderError> {
    let text = files(entry).ok_or_else(|| ShaderError::NotFound { file: entry.to_owned() })?;
    let mut pre = Preprocessor {
        files,
        defines: defines.iter().copied().collect(),
        text: String::with_capacity(text.len()),
        names: Vec::new(),
        line_map: Vec::new(),
        included: HashSet::from([entry.to_owned()]),
        stack: Vec::new(),
    };
    pre.process(entry, &text)?;
    Ok(ShaderSource { text: pre.text, files: pre.names, line_map: pre.line_map })
}

/// State of one [`preprocess_with`] call.
struct Preprocessor<'a> {
    files: &'a dyn Fn(&str) -> Option<String>,
    defines: HashSet<&'a str>,
    text: String,
    names: Vec<String>,
    line_map: Vec<(u32, u32)>,
    /// Files already included in this load (the pragma-once set).
    included: HashSet<String>,
    /// Files being processed, outermost first, for cycle detection.
    stack: Vec<String>,
}

/// One open `#ifdef`/`#ifndef`.
struct Conditional {
    /// Whether the condition held (the `#ifdef` branch is active).
    taken: bool,
    /// Whether `#else` has been seen.
    in_else: bool,
    /// Line of the `#ifdef`/`#ifndef`, for errors.
    line: usize,
}

impl Conditional {
    fn active(&self) -> bool {
        self.taken != self.in_else
    }
}

/// A parsed directive line.
enum Directive<'s> {
    Include(&'s str),
    Ifdef(&'s str),
    Ifndef(&'s str),
    Else,
    Endif,
}

impl Preprocessor<'_> {
    fn emit(&mut self, file: u32, line: usize, text: &str) {
        self.text.push_str(text);
        self.text.push('\n');
        self.line_map.push((file, line as u32));
    }

    fn process(&mut self, path: &str, text: &str) -> Result<(), ShaderError> {
        let file = self.names.len() as u32;
        self.names.push(path.to_owned());
        self.stack.push(path.to_owned());
        let mut conds: Vec<Conditional> = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let active = conds.iter().all(Conditional::active);
            let Some(directive) = parse_directive(raw, path, line)? else {
                self.emit(file, line, if active { raw } else { "" });
                continue;
            };
            self.emit(file, line, "");
            match directive {
                Directive::Include(include) => {
                    if active {
                        self.include(include, path, line)?;
                    }
                }
                Directive::Ifdef(name) => {
                    conds.push(Conditional { taken: self.defines.contains(name), in_else: false, line })
                }
                Directive::Ifndef(name) => {
                    conds.push(Conditional { taken: !self.defines.contains(name), in_else: false, line })
                }
                Directive::Else => {
                    let cond = conds.last_mut().ok_or_else(|| ShaderError::Unmatched {
                        file: path.to_owned(),
                        line,
                        directive: "else",
                    })?;
                    if cond.in_else {
                        return Err(ShaderError::BadDirective {
                            file: path.to_owned(),
                            line,
                            message: format!("second #else for the #ifdef/#ifndef of line {}", cond.line),
                        });
                    }
                    cond.in_else = true;
                }
                Directive::Endif => {
                    conds.pop().ok_or_else(|| ShaderError::Unmatched {
                        file: path.to_owned(),
                        line,
                        directive: "endif",
                    })?;
                }
            }
        }
        if let Some(open) = conds.last() {
            return Err(ShaderError::Unterminated { file: path.to_owned(), line: open.line });
        }
        self.stack.pop();
        Ok(())
    }

    fn include(&mut self, include: &str, from: &str, line: usize) -> Result<(), ShaderError> {
        if let Some(start) = self.stack.iter().position(|f| f == include) {
            let mut chain = self.stack[start..].to_vec();
            chain.push(include.to_owned());
            return Err(ShaderError::IncludeCycle { file: from.to_owned(), line, chain });
        }
        if !self.included.insert(include.to_owned()) {
            return Ok(());
        }
        let text = (self.files)(include).ok_or_else(|| ShaderError::IncludeNotFound {
            file: from.to_owned(),
            line,
            include: include.to_owned(),
        })?;
        self.process(include, &text)
    }
}

/// Parses `raw` as a directive; `Ok(None)` when it is ordinary WGSL.
fn parse_directive<'s>(raw: &'s str, file: &str, line: usize) -> Result<Option<Directive<'s>>, ShaderError> {
    let Some(body) = raw.trim_start().strip_prefix('#') else {
        return Ok(None);
    };
    let bad = |message: String| ShaderError::BadDirective { file: file.to_owned(), line, message };
    let (name, args) = body.split_once(char::is_whitespace).unwrap_or((body, ""));
    let args = args.trim();
    // Whatever follows the arguments must be nothing or a comment.
    let check_rest = |rest: &str, what: &str| {
        let rest = rest.trim();
        if rest.is_empty() || rest.starts_with("//") {
            Ok(())
        } else {
            Err(bad(format!("unexpected `{rest}` after {what}")))
        }
    };
    let ident = |directive: &str| -> Result<&'s str, ShaderError> {
        let end = args.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(args.len());
        let (ident, rest) = args.split_at(end);
        if ident.is_empty() || ident.starts_with(|c: char| c.is_ascii_digit()) {
            return Err(bad(format!("#{directive} needs a define name (letters, digits, `_`)")));
        }
        check_rest(rest, &format!("#{directive} {ident}"))?;
        Ok(ident)
    };
    let directive = match name {
        "include" => {
            let path = args
                .strip_prefix('"')
                .and_then(|a| a.split_once('"'))
                .map(|(path, rest)| check_rest(rest, "the #include path").map(|()| path))
                .ok_or_else(|| bad("#include needs a quoted path: #include \"common/file.wgsl\"".to_owned()))??;
            let clean = !path.is_empty()
                && !path.starts_with('/')
                && !path.contains('\\')
                && path.split('/').all(|c| !c.is_empty() && c != "." && c != "..");
            if !clean {
                return Err(bad(format!(
                    "#include \"{path}\": the path must be relative to shaders/, with `/` and no `.` or `..`"
                )));
            }
            Directive::Include(path)
        }
        "ifdef" => Directive::Ifdef(ident("ifdef")?),
        "ifndef" => Directive::Ifndef(ident("ifndef")?),
        "else" | "endif" => {
            check_rest(args, &format!("#{name}"))?;
            if name == "else" {
                Directive::Else
            } else {
                Directive::Endif
            }
        }
        _ => return Err(ShaderError::UnknownDirective { file: file.to_owned(), line, directive: format!("#{name}") }),
    };
    Ok(Some(directive))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// Preprocesses `entry` from the literal `files`.
    fn run(files: &[(&str, &str)], entry: &str, defines: &[&str]) -> Result<ShaderSource, ShaderError> {
        let map: HashMap<String, String> = files.iter().map(|(p, t)| (p.to_string(), t.to_string())).collect();
        preprocess_with(&|p| map.get(p).cloned(), entry, defines)
    }

    /// The non-empty output lines, trimmed.
    fn lines(src: &ShaderSource) -> Vec<&str> {
        src.text.lines().map(str::trim).filter(|l| !l.is_empty()).collect()
    }

    #[test]
    fn plain_file_is_unchanged() {
        let src = run(&[("a.wgsl", "fn a() {}\n\nfn b() {}")], "a.wgsl", &[]).unwrap();
        assert_eq!(src.text, "fn a() {}\n\nfn b() {}\n");
        assert_eq!(src.entry(), "a.wgsl");
        assert_eq!(src.line_count(), 3);
    }

    #[test]
    fn include_inserts_file_and_maps_lines() {
        let files = [
            ("main.wgsl", "// entry\n#include \"common/x.wgsl\"\nfn main_fn() {}\n"),
            ("common/x.wgsl", "fn x1() {}\nfn x2() {}\n"),
        ];
        let src = run(&files, "main.wgsl", &[]).unwrap();
        assert_eq!(lines(&src), ["// entry", "fn x1() {}", "fn x2() {}", "fn main_fn() {}"]);
        assert_eq!(src.files(), ["main.wgsl", "common/x.wgsl"]);
        let at = |needle: &str| src.text.lines().position(|l| l == needle).unwrap() + 1;
        assert_eq!(src.locate(at("fn x2() {}")), ("common/x.wgsl".into(), 2));
        assert_eq!(src.locate(at("fn main_fn() {}")), ("main.wgsl".into(), 3));
        assert_eq!(src.locate(2), ("main.wgsl".into(), 2), "the #include line itself");
        // Past the end and line 0 are clamped rather than panicking.
        assert_eq!(src.locate(1000), ("main.wgsl".into(), 3));
        assert_eq!(src.locate(0), ("main.wgsl".into(), 1));
    }

    #[test]
    fn every_output_line_maps_to_its_source_line() {
        let files = [
            ("e.wgsl", "a\n#ifdef X\nb\n#else\nc\n#endif\n#include \"common/i.wgsl\"\nd"),
            ("common/i.wgsl", "#ifndef X\ne\n#endif\nf"),
        ];
        for defines in [&[][..], &["X"][..]] {
            let src = run(&files, "e.wgsl", defines).unwrap();
            for (n, out) in src.text.lines().enumerate() {
                let (file, line) = src.locate(n + 1);
                let original = files.iter().find(|(p, _)| *p == file).unwrap().1;
                let original = original.lines().nth(line - 1).unwrap();
                assert!(out.is_empty() || out == original, "{out:?} vs {file}:{line} {original:?}");
            }
        }
    }

    #[test]
    fn include_is_once_only() {
        let files = [
            ("e.wgsl", "#include \"common/a.wgsl\"\n#include \"common/b.wgsl\"\n#include \"common/a.wgsl\"\nmain"),
            ("common/a.wgsl", "#include \"common/c.wgsl\"\na"),
            ("common/b.wgsl", "#include \"common/c.wgsl\"\nb"),
            ("common/c.wgsl", "c"),
        ];
        let src = run(&files, "e.wgsl", &[]).unwrap();
        assert_eq!(lines(&src), ["c", "a", "b", "main"]);
    }

    #[test]
    fn include_cycle_is_an_error() {
        let files = [
            ("e.wgsl", "#include \"common/a.wgsl\""),
            ("common/a.wgsl", "#include \"common/b.wgsl\""),
            ("common/b.wgsl", "\n#include \"common/a.wgsl\""),
        ];
        let err = run(&files, "e.wgsl", &[]).unwrap_err();
        assert_eq!(
            err,
            ShaderError::IncludeCycle {
                file: "common/b.wgsl".into(),
                line: 2,
                chain: vec!["common/a.wgsl".into(), "common/b.wgsl".into(), "common/a.wgsl".into()],
            }
        );
        assert_eq!(
            err.to_string(),
            "shaders/common/b.wgsl:2: #include cycle: common/a.wgsl -> common/b.wgsl -> common/a.wgsl"
        );
        // Including the entry from an include is a cycle too.
        let files = [("e.wgsl", "#include \"common/a.wgsl\""), ("common/a.wgsl", "#include \"e.wgsl\"")];
        assert!(matches!(run(&files, "e.wgsl", &[]), Err(ShaderError::IncludeCycle { .. })));
    }

    #[test]
    fn missing_files_are_errors() {
        assert_eq!(run(&[], "nope.wgsl", &[]).unwrap_err(), ShaderError::NotFound { file: "nope.wgsl".into() });
        let err = run(&[("e.wgsl", "x\n#include \"common/gone.wgsl\"")], "e.wgsl", &[]).unwrap_err();
        assert_eq!(err.to_string(), "shaders/e.wgsl:2: #include \"common/gone.wgsl\": no such shader file");
    }

    #[test]
    fn ifdef_ifndef_else_and_nesting() {
        let text = "\
#ifdef A
a
#ifndef B
a_not_b
#else
a_b
#endif
#else
not_a
#ifdef B
not_a_b
#endif
#endif
  #ifdef C // indented, with a comment
c
#endif
always";
        let files = [("e.wgsl", text)];
        let got = |defines: &[&str]| {
            let src = run(&files, "e.wgsl", defines).unwrap();
            assert_eq!(src.line_count(), text.lines().count());
            lines(&src).join(" ")
        };
        assert_eq!(got(&[]), "not_a always");
        assert_eq!(got(&["A"]), "a a_not_b always");
        assert_eq!(got(&["A", "B"]), "a a_b always");
        assert_eq!(got(&["B"]), "not_a not_a_b always");
        assert_eq!(got(&["C"]), "not_a c always");
    }

    #[test]
    fn includes_in_inactive_branches_are_skipped() {
        let files = [
            ("e.wgsl", "#ifdef X\n#include \"common/x.wgsl\"\n#endif\n#include \"common/y.wgsl\""),
            ("common/x.wgsl", "x"),
            ("common/y.wgsl", "#include \"common/x.wgsl\"\ny"),
        ];
        // Not included while inactive, so the later include still brings it in.
        assert_eq!(lines(&run(&files, "e.wgsl", &[]).unwrap()), ["x", "y"]);
        assert_eq!(lines(&run(&files, "e.wgsl", &["X"]).unwrap()), ["x", "y"]);
        // A missing file in an inactive branch is not read.
        let files = [("e.wgsl", "#ifdef X\n#include \"common/none.wgsl\"\n#endif\nok")];
        assert_eq!(lines(&run(&files, "e.wgsl", &[]).unwrap()), ["ok"]);
    }

    #[test]
    fn directive_errors_name_file_and_line() {
        let err = |text: &str| run(&[("e.wgsl", text)], "e.wgsl", &["X"]).unwrap_err();
        assert_eq!(
            err("a\n#define X 1"),
            ShaderError::UnknownDirective { file: "e.wgsl".into(), line: 2, directive: "#define".into() }
        );
        // Unknown directives are errors in inactive branches too.
        assert!(matches!(err("#ifdef Y\n#if X\n#endif"), ShaderError::UnknownDirective { line: 2, .. }));
        assert_eq!(err("a\n#endif"), ShaderError::Unmatched { file: "e.wgsl".into(), line: 2, directive: "endif" });
        assert!(matches!(err("#else"), ShaderError::Unmatched { line: 1, directive: "else", .. }));
        assert_eq!(err("#ifdef X\n#ifdef Y\n#endif\n"), ShaderError::Unterminated { file: "e.wgsl".into(), line: 1 });
        assert!(matches!(err("#ifdef X\n#else\n#else\n#endif"), ShaderError::BadDirective { line: 3, .. }));
        assert!(matches!(err("#ifdef\n#endif"), ShaderError::BadDirective { line: 1, .. }));
        assert!(matches!(err("#ifdef X Y\n#endif"), ShaderError::BadDirective { line: 1, .. }));
        assert!(matches!(err("#ifdef 1X\n#endif"), ShaderError::BadDirective { line: 1, .. }));
        assert!(matches!(err("#endif junk"), ShaderError::BadDirective { .. }));
        assert!(matches!(err("#include common/a.wgsl"), ShaderError::BadDirective { .. }));
        assert!(matches!(err("#include \"../a.wgsl\""), ShaderError::BadDirective { .. }));
        assert!(matches!(err("#include \"/a.wgsl\""), ShaderError::BadDirective { .. }));
        assert_eq!(
            err("\n\n#foo").to_string(),
            "shaders/e.wgsl:3: unknown directive `#foo` (expected #include, #ifdef, #ifndef, #else or #endif)"
        );
    }

    #[test]
    fn conditionals_must_balance_per_file() {
        let files = [("e.wgsl", "#ifdef X\n#include \"common/i.wgsl\""), ("common/i.wgsl", "#endif")];
        assert_eq!(
            run(&files, "e.wgsl", &["X"]).unwrap_err(),
            ShaderError::Unmatched { file: "common/i.wgsl".into(), line: 1, directive: "endif" }
        );
    }

    #[test]
    fn include_with_trailing_comment_and_crlf() {
        let files = [("e.wgsl", "#include \"common/i.wgsl\" // why\r\nmain\r\n"), ("common/i.wgsl", "inc\r\n")];
        let src = run(&files, "e.wgsl", &[]).unwrap();
        assert_eq!(src.text, "\ninc\nmain\n");
    }

    #[test]
    fn variants_declaration() {
        let text = "// a comment\n//variants: SPOT_LIGHTS ALPHA_MASK\n  // variants: MSAA SPOT_LIGHTS\nfn f() {}";
        assert_eq!(variants_in(text), ["SPOT_LIGHTS", "ALPHA_MASK", "MSAA"]);
        assert!(variants_in("fn f() {} // not variants: X").is_empty());
    }

    #[test]
    fn undeclared_defines_are_refused() {
        // A misspelled define of a real entry file: refused, naming the file and define.
        let e = preprocess("forward.wgsl", &["SPOT_LIGHT"]).unwrap_err();
        assert!(matches!(&e, ShaderError::UndeclaredDefine { define, .. } if define == "SPOT_LIGHT"), "{e}");
        assert!(e.to_string().starts_with("shaders/forward.wgsl: define SPOT_LIGHT is not one of its `// variants:`"));
        // A flag an include tests but this entry never sets (forward.wgsl's lists are not
        // clusters: forward_clustered.wgsl is that kernel).
        assert!(matches!(preprocess("forward.wgsl", &["CLUSTERED"]), Err(ShaderError::UndeclaredDefine { .. })));
        assert!(preprocess("forward_clustered.wgsl", &["CLUSTERED"]).is_ok());
        assert!(preprocess("forward.wgsl", &["SPOT_LIGHTS", "HALF_Z"]).is_ok());
        // An entry without variants takes no define.
        assert!(matches!(preprocess("heatmap.wgsl", &["MSAA"]), Err(ShaderError::UndeclaredDefine { .. })));
        let text = "// variants: A B\nfn f() {}";
        assert!(check_declared("e.wgsl", text, &["B", "A"]).is_ok());
        assert_eq!(
            check_declared("e.wgsl", text, &["A", "C"]).unwrap_err(),
            ShaderError::UndeclaredDefine {
                file: "e.wgsl".into(),
                define: "C".into(),
                declared: vec!["A".into(), "B".into()]
            }
        );
    }

    #[test]
    fn embedded_table_is_sorted_and_entries_exclude_common() {
        assert!(SHADER_FILES.windows(2).all(|w| w[0].0 < w[1].0));
        for (path, text) in SHADER_FILES {
            assert_eq!(embedded(path), Some(*text));
        }
        assert!(entry_files().iter().all(|p| !p.starts_with("common/")));
        assert_eq!(embedded("no/such/file.wgsl"), None);
    }

    #[test]
    fn embedded_entries_preprocess_in_every_key_value() {
        let spaces = crate::variants::key_spaces();
        for entry in entry_files() {
            let values = spaces.iter().find(|(e, _)| *e == entry).map_or(vec![vec![]], |(_, v)| v.clone());
            for defines in values {
                if let Err(e) = preprocess(entry, &defines) {
                    panic!("{entry} with {defines:?}: {e}");
                }
            }
        }
    }
}
