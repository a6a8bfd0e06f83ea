//! Every `tiledlight` command that README.md and docs/USAGE.md show, run (issue 47: the
//! budget recipe as written gave a useless answer, and nothing noticed).
//!
//! 1. [`doc_commands`] collects the commands: each line of a fenced block that starts with
//!    `tiledlight` or `cargo run` (continuation lines joined, `#` comments dropped), and each
//!    inline code span of the prose that starts with `tiledlight ` (joined across its line
//!    breaks).
//! 2. A command with a placeholder (`[...]`, `<...>`, `...`, `|`, an upper-case word such as
//!    `DIR`) or a bare command name (`tiledlight sweep`) is a synopsis or a reference: its
//!    command must exist and every `--flag` it names must be in that command's `--help`.
//! 3. Every other command must have an entry in [`CHECKS`], which says what its text claims:
//!    files it writes, lines it prints. It runs as written at 64x36 (`--width`/`--height`
//!    added or replaced), in a scratch folder (outputs land there; inputs under the
//!    repository are found), with a few frames where the command measures, and under Xvfb
//!    for the viewer (`--frames 2`). A command in the docs with no entry fails the test:
//!    a new command comes with its check.
//!
//! The tests run on lavapipe in CI (a few minutes together).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{gpu_lock, scratch, Xvfb};

/// A command as the docs show it: where, and its words.
#[derive(Clone, Debug)]
struct DocCommand {
    /// "README.md:82".
    place: String,
    /// The command, whitespace collapsed.
    text: String,
}

/// The commands of `doc` (step 1).
fn doc_commands(name: &str, doc: &str) -> Vec<DocCommand> {
    let mut out = Vec::new();
    let lines: Vec<&str> = doc.lines().collect();
    let (mut in_block, mut prose) = (false, String::new());
    let mut prose_lines: Vec<usize> = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let line = lines[i];
        if line.trim_start().starts_with("```") {
            in_block = !in_block;
            i += 1;
            continue;
        }
        if in_block {
            let start = i;
            let mut text = line.trim().to_string();
            while text.ends_with('\\') && i + 1 < lines.len() {
                text.pop();
                i += 1;
                text.push(' ');
                text.push_str(lines[i].trim());
            }
            let text = text.split(" #").next().unwrap_or_default();
            if text.starts_with("tiledlight ") || text == "tiledlight" || text.starts_with("cargo run") {
                out.push(DocCommand { place: format!("{name}:{}", start + 1), text: collapse(text) });
            }
        } else {
            prose.push_str(line);
            prose.push('\n');
            prose_lines.push(i + 1);
        }
        i += 1;
    }
    // Inline code spans of the prose: between backticks, possibly across a line break.
    let mut rest = prose.as_str();
    let mut offset = 0;
    while let Some(open) = rest.find('`') {
        let after = &rest[open + 1..];
        let Some(close) = after.find('`') else { break };
        let span = &after[..close];
        if span.starts_with("tiledlight ") {
            let line = prose[..offset + open].matches('\n').count();
            let place = format!("{name}:{}", prose_lines.get(line).copied().unwrap_or(0));
            out.push(DocCommand { place, text: collapse(span) });
        }
        offset += open + 1 + close + 1;
        rest = &after[close + 1..];
    }
    out
}

fn collapse(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Whether `c` is a synopsis or a reference to a command (step 2), not a command to run.
fn is_synopsis(c: &str) -> bool {
    let words: Vec<&str> = c.split_whitespace().collect();
    words.len() <= 2 && words[0] == "tiledlight"
        || c.contains('[')
        || c.contains('<')
        || c.contains("...")
        || c.contains('|')
        || words.iter().skip(1).any(|w| w.len() > 1 && w.chars().all(|ch| ch.is_ascii_uppercase() || ch == '.'))
}

/// What a runnable command's text claims (step 3).
struct Check {
    /// The command exactly as the docs show it (whitespace collapsed).
    doc: &'static str,
    /// Flags added to make it small and short (frames, a shorter sweep), with the reason in
    /// the entry's comment.
    extra: &'static [&'static str],
    /// Files (relative to the scratch folder) it must write.
    files: &'static [&'static str],
    /// Texts its standard output must hold.
    prints: &'static [&'static str],
    /// A further check of its standard output.
    also: Option<fn(&str)>,
    /// What the scratch folder must hold first (the input the text says to fetch).
    setup: Option<fn(&Path)>,
}

/// `out/peer` as the docs' unpacking loop leaves it: the H200 peer run's results
/// (`docs/results/h200-d717d47-peer/json`).
fn unpacked_peer_results(dir: &Path) {
    let from = repo().join("docs/results/h200-d717d47-peer/json");
    let to = dir.join("out/peer");
    std::fs::create_dir_all(&to).unwrap();
    for e in std::fs::read_dir(&from).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

/// The budget recipe (USAGE): its rows must differ (at the default threshold every row
/// read FLIP 0.78, the cutoff's error swamping the shadows) and it names the cheapest
/// setting within each FLIP level.
fn budget_rows_differ(out: &str) {
    let flips: Vec<&str> = out.lines().filter_map(|l| l.split("FLIP mean ").nth(1)?.split(' ').next()).collect();
    assert!(flips.len() >= 8, "one row a setting: {out}");
    let first = flips[0];
    assert!(flips.iter().any(|f| *f != first), "every row has FLIP {first}: the recipe measures nothing: {out}");
}

const SMALL: [&str; 4] = ["--width", "64", "--height", "36"];

/// Every runnable command of the docs and its claims.
const CHECKS: &[Check] = &[
    // README, the first screen.
    Check {
        doc: "cargo run --release",
        extra: &[],
        files: &["out/render.png", "out/heatmap.png"],
        prints: &["benchmark:", "method:     forward-plus"],
        also: None,
        setup: None,
    },
    Check {
        doc: "tiledlight render --method forward-plus",
        extra: &[],
        files: &["out/render.png"],
        prints: &["method:     forward-plus ("],
        also: None,
        setup: None,
    },
    Check {
        doc: "tiledlight render --method deferred",
        extra: &[],
        files: &["out/render.png"],
        prints: &["method:     deferred ("],
        also: None,
        setup: None,
    },
    Check {
        doc: "tiledlight render --method visibility",
        extra: &[],
        files: &["out/render.png"],
        prints: &["method:     visibility ("],
        also: None,
        setup: None,
    },
    Check {
        doc: "tiledlight render --method brute-force",
        extra: &[],
        files: &["out/render.png"],
        prints: &["method:     brute-force ("],
        also: None,
        setup: None,
    },
    // "The crossover (Figure 9)": a CSV and its chart, the crossover or its absence said.
    // Two light counts of the preset's ten and two frames a point keep it short.
    Check {
        doc: "tiledlight sweep --preset figure9",
        extra: &["--axis", "lights=32,256", "--frames", "2", "--warmup", "0"],
        files: &["out/figure9.csv", "out/figure9.png"],
        prints: &["crossover"],
        also: None,
        setup: None,
    },
    // USAGE: the demos.
    Check {
        doc: "tiledlight render --demo shadows",
        extra: &[],
        files: &["out/render.png"],
        prints: &["shadow"],
        also: None,
        setup: None,
    },
    // The stochastic method's converged image: 64 frames of a still view (small, few lights:
    // 64 frames of the courtyard at its full size take minutes on lavapipe).
    Check {
        doc: "tiledlight view --method stochastic --frames 64 --screenshot out.png",
        extra: &["--width", "160", "--height", "90", "--lights", "64"],
        files: &["out.png"],
        prints: &["viewer error: none"],
        also: None,
        setup: None,
    },
    Check {
        doc: "tiledlight render --demo vpl --vpl --out vpl.png",
        extra: &[],
        files: &["vpl.png"],
        prints: &["cull_vpls"],
        also: None,
        setup: None,
    },
    Check {
        doc: "tiledlight render --demo heatmap --grid 2.5d",
        extra: &[],
        files: &["out/heatmap.png"],
        prints: &["2.5D"],
        also: None,
        setup: None,
    },
    Check {
        doc: "tiledlight view --demo glass",
        extra: &[],
        files: &[],
        prints: &["viewer error: none"],
        also: None,
        setup: None,
    },
    // A normal-mapped glTF from the repository.
    Check {
        doc: "tiledlight render --scene assets/normal-mapped/studs.gltf --lights 10 --width 640 --height 360 --out \
              docs/images/normal-mapped-studs.png",
        extra: &[],
        files: &["docs/images/normal-mapped-studs.png"],
        prints: &["studs.gltf"],
        also: None,
        setup: None,
    },
    // A million lights, assigned light-centrically (seconds, where the gather took minutes).
    Check {
        doc: "tiledlight render --light-preset million --method deferred --assign scatter --out out/million.png",
        extra: &[],
        files: &["out/million.png"],
        prints: &["1000000 point", "0 dropped"],
        also: None,
        setup: None,
    },
    Check {
        doc: "tiledlight export --lights 1000 --exposure 0.5 --out out/court-1000.gltf",
        extra: &[],
        files: &["out/court-1000.gltf", "out/court-1000.bin"],
        prints: &[],
        also: None,
        setup: None,
    },
    Check {
        doc: "tiledlight export --scene bevy-many-lights --out out/bevy-many-lights.gltf",
        extra: &[],
        files: &["out/bevy-many-lights.gltf", "out/bevy-many-lights.bin"],
        prints: &[],
        also: None,
        setup: None,
    },
    // The viewer's picture (`--frames 6` already makes it a scripted run).
    Check {
        doc: "tiledlight view --width 768 --height 432 --lights 2048 --spot-lights 64 --frames 6 --screenshot-ui \
              docs/images/viewer.png",
        extra: &[],
        files: &["docs/images/viewer.png"],
        prints: &["viewer error: none"],
        also: None,
        setup: None,
    },
    // The budget recipe, three frames of each setting.
    Check {
        doc: "tiledlight accuracy --reference traced --budget --threshold 0.0015 --axis \
              shadow-point-lights=16,0,64,128 --axis casters-by=brightness,contribution",
        extra: &["--frames", "1", "--warmup", "0"],
        files: &["out/accuracy.csv"],
        prints: &["cheapest"],
        also: Some(budget_rows_differ),
        setup: None,
    },
    // The peer report over unpacked results.
    Check {
        doc: "tiledlight peer-report out/peer",
        extra: &[],
        files: &["out/peer/peer-report.md", "out/peer/peer-frame-time.png"],
        prints: &["wrote out/peer/peer-report.md"],
        also: None,
        setup: Some(unpacked_peer_results),
    },
    // The material count, as a sweep (two frames a point).
    Check {
        doc: "tiledlight sweep --scene materials --axis materials=2..512",
        extra: &["--frames", "2", "--warmup", "0"],
        files: &["out/sweep.csv", "out/sweep.png"],
        prints: &["materials"],
        also: None,
        setup: None,
    },
];

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn all_commands() -> Vec<DocCommand> {
    let mut all = Vec::new();
    for file in ["README.md", "docs/USAGE.md"] {
        let text = std::fs::read_to_string(repo().join(file)).unwrap();
        all.extend(doc_commands(file, &text));
    }
    all
}

/// The words of `c` made small (64x36) and run from a scratch folder: a `--scene` file of
/// the repository becomes an absolute path (outputs stay relative: they land in the
/// scratch folder, never over the repository's own images).
fn small_args(c: &Check, words: &[&str]) -> Vec<String> {
    let mut args: Vec<String> = Vec::new();
    let mut i = 0;
    while i < words.len() {
        let w = words[i];
        if (w == "--width" || w == "--height") && i + 1 < words.len() {
            i += 2;
            continue;
        }
        let in_repo = repo().join(w);
        if i > 0 && words[i - 1] == "--scene" && in_repo.is_file() {
            args.push(in_repo.to_string_lossy().into_owned());
        } else {
            args.push(w.to_string());
        }
        i += 1;
    }
    args.extend(SMALL.iter().map(|s| s.to_string()));
    args.extend(c.extra.iter().map(|s| s.to_string()));
    args
}

/// Runs `c` (step 3) and checks its claims.
fn run_check(c: &Check, dir: &Path) {
    let words: Vec<&str> = c.doc.split_whitespace().collect();
    let rest: &[&str] = match words[..] {
        ["cargo", "run", "--release"] => &[],
        ["tiledlight", ref rest @ ..] => rest,
        _ => panic!("{}: not a tiledlight command", c.doc),
    };
    let viewer = rest.first() == Some(&"view");
    // The quick start is the 1080p tour and takes no flags; the peer report draws nothing.
    let args = match rest.first() {
        None => Vec::new(),
        Some(&"peer-report") => rest.iter().map(|s| s.to_string()).collect(),
        Some(_) => small_args(c, rest),
    };
    if let Some(setup) = c.setup {
        setup(dir);
    }
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_tiledlight"));
    cmd.args(&args).current_dir(dir).env_remove("WAYLAND_DISPLAY");
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        cmd.env("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    let _x = if viewer {
        let x = Xvfb::start();
        cmd.env("DISPLAY", &x.display);
        if !args.iter().any(|a| a == "--frames") {
            cmd.args(["--frames", "2"]);
        }
        Some(x)
    } else {
        cmd.env_remove("DISPLAY");
        None
    };
    let out = cmd.output().expect("run the tiledlight binary");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{} (run as {args:?}) failed:\n{stdout}\n{stderr}", c.doc);
    for f in c.files {
        assert!(dir.join(f).is_file(), "{}: wrote no {f}:\n{stdout}", c.doc);
    }
    for p in c.prints {
        assert!(stdout.contains(p), "{}: printed no {p:?}:\n{stdout}", c.doc);
    }
    if let Some(also) = c.also {
        also(&stdout);
    }
}

/// Steps 1 and 3: every runnable command of the docs has a check, and every check is a
/// command of the docs (a command removed from the docs takes its check with it).
#[test]
fn every_doc_command_has_a_check() {
    let all = all_commands();
    assert!(all.len() > 20, "the docs show {} commands: the parser lost some", all.len());
    for d in all.iter().filter(|d| !is_synopsis(&d.text)) {
        assert!(
            CHECKS.iter().any(|c| collapse(c.doc) == d.text),
            "{}: `{}` has no check in crates/app/tests/doc_commands.rs (what does its text claim?)",
            d.place,
            d.text
        );
    }
    for c in CHECKS {
        assert!(
            all.iter().any(|d| d.text == collapse(c.doc)),
            "a check of a command the docs no longer show: {}",
            c.doc
        );
    }
}

/// Step 2: every synopsis names a real command, and every flag it names is in that
/// command's `--help`.
#[test]
fn every_doc_synopsis_names_real_flags() {
    let mut checked = 0;
    for d in all_commands().iter().filter(|d| is_synopsis(&d.text)) {
        let words: Vec<&str> = d.text.split_whitespace().collect();
        let sub = words.get(1).copied().filter(|w| !w.starts_with('<') && !w.starts_with('-'));
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_tiledlight"));
        cmd.args(sub.iter()).arg("--help");
        let out = cmd.output().unwrap();
        let help = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{}: `{}`: no such command", d.place, d.text);
        for flag in words.iter().filter_map(|w| {
            let w = w.trim_matches(|c: char| c == '[' || c == ']' || c == '(' || c == ')' || c == '`');
            w.starts_with("--").then(|| w.split(['=', '|', ']']).next().unwrap_or(w))
        }) {
            assert!(help.contains(flag), "{}: `{}` names {flag}, which `{sub:?} --help` lacks", d.place, d.text);
            checked += 1;
        }
    }
    assert!(checked > 20, "only {checked} flags checked");
}

/// The parser itself: a fenced block's continued command, a comment, an inline span across
/// a line break, and a synopsis.
#[test]
fn the_parser_finds_block_inline_and_synopsis_commands() {
    let doc = "Intro `tiledlight render\n--lights 4` and `cargo build`.\n```sh\ntiledlight bench --frames 2 \\\n    \
               --json b.json   # a comment\necho no\n```\nSee `tiledlight sweep [flags]`.\n";
    let found: Vec<String> = doc_commands("X", doc).into_iter().map(|d| d.text).collect();
    assert_eq!(
        found,
        ["tiledlight bench --frames 2 --json b.json", "tiledlight render --lights 4", "tiledlight sweep [flags]"]
    );
    assert!(is_synopsis("tiledlight sweep [flags]") && is_synopsis("tiledlight peer-report DIR"));
    assert!(is_synopsis("tiledlight view") && !is_synopsis("tiledlight render --lights 4"));
}

/// Step 3's runs, one test a command so that a failure names it (and nextest runs them
/// in parallel processes).
fn run_doc_check(doc_prefix: &str) {
    let c = CHECKS
        .iter()
        .find(|c| collapse(c.doc).starts_with(doc_prefix))
        .unwrap_or_else(|| panic!("no check starts with {doc_prefix}"));
    let name: String = doc_prefix.chars().map(|ch| if ch.is_ascii_alphanumeric() { ch } else { '-' }).collect();
    let dir = scratch(&format!("doc-{name}"));
    let _guard = gpu_lock();
    run_check(c, &dir);
}

#[test]
fn doc_quick_start() {
    run_doc_check("cargo run --release");
}

#[test]
fn doc_readme_methods() {
    for m in ["forward-plus", "deferred", "visibility", "brute-force"] {
        run_doc_check(&format!("tiledlight render --method {m}"));
    }
}

#[test]
fn doc_figure9_sweep() {
    run_doc_check("tiledlight sweep --preset figure9");
}

#[test]
fn doc_demos() {
    for d in ["shadows", "vpl", "heatmap"] {
        run_doc_check(&format!("tiledlight render --demo {d}"));
    }
}

#[test]
fn doc_viewer_commands() {
    run_doc_check("tiledlight view --demo glass");
    run_doc_check("tiledlight view --width 768");
}

#[test]
fn doc_normal_mapped_glb_million_and_exports() {
    run_doc_check("tiledlight render --scene assets/normal-mapped/studs.gltf");
    run_doc_check("tiledlight render --light-preset million");
    run_doc_check("tiledlight export --lights 1000");
    run_doc_check("tiledlight export --scene bevy-many-lights");
}

#[test]
fn doc_peer_report() {
    run_doc_check("tiledlight peer-report out/peer");
}

#[test]
fn doc_budget_recipe() {
    run_doc_check("tiledlight accuracy --reference traced --budget");
}

#[test]
fn doc_materials_sweep() {
    run_doc_check("tiledlight sweep --scene materials");
}
