//! `cargo xtask validate-shaders`: naga validation of every WGSL entry file in every
//! value of its key type (`tiledlight_gpu::variants`: exactly the variants the passes can
//! build, not every combination of flags), the Rust/WGSL bindings check of every variant
//! (see [`crate::bindings`]) and the Rust/WGSL struct layout check. Prints each entry
//! file's count of validated variants.
//!
//! Reads `shaders/` from disk (not the table embedded in tiledlight-gpu, which is only as
//! fresh as the last build), preprocesses with `tiledlight_gpu::shader`, and reports
//! every error at its original file and line.

use std::collections::BTreeMap;
use std::fs;
use std::path::Path;

use anyhow::{bail, Context as _, Result};
use naga::valid::{Capabilities, ModuleInfo, ValidationFlags, Validator};
use naga::{Module, Span};
use tiledlight_cull::layout::StructLayout;
use tiledlight_gpu::shader::{self, ShaderSource};

use crate::bindings::{compare_bindings, declarations, named_defines};

/// More defines than this in one entry file is surely a mistake in the declaration.
const MAX_VARIANTS: usize = 16;
/// More key values than this in one entry file is too many to validate (and a sign the
/// file holds kernels that should be files of their own).
const MAX_KEY_VALUES: usize = 1024;

/// wgpu features whose shader capabilities the renderer's device has. Shaders are
/// validated with exactly the naga capabilities wgpu enables for them, so a shader that
/// validates here also loads on the device. `tiledlight_gpu::context` requests only
/// `TIMESTAMP_QUERY`, which adds no shader capability, and where the adapter has them
/// `PRIMITIVE_INDEX` (the visibility buffer's raster) and `SHADER_INT64` with
/// `SHADER_INT64_ATOMIC_MIN_MAX` (its compute rasteriser); keep both in step when the
/// renderer starts requesting e.g. `SUBGROUP` or `IMMEDIATES` (lavapipe has both).
pub const FEATURES: wgpu::Features = wgpu::Features::TIMESTAMP_QUERY
    .union(wgpu::Features::PRIMITIVE_INDEX)
    .union(wgpu::Features::SHADER_INT64)
    .union(wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX);

/// The naga capabilities wgpu gives a device with [`FEATURES`] on an adapter with full
/// downlevel support (lavapipe has it).
pub fn capabilities() -> Capabilities {
    wgpu_naga_bridge::features_to_naga_capabilities(FEATURES, wgpu::DownlevelFlags::all())
}

/// Reads shader files (paths relative to `shaders/`) from a directory on disk.
type Reader<'a> = &'a dyn Fn(&str) -> Option<String>;

/// More variants than this are listed as "and N more" in a binding mismatch.
const LISTED_VARIANTS: usize = 8;

/// Validates every entry file and variant under `root/shaders`, compares each variant's
/// bindings with its pass's Rust declaration, then checks the struct layouts.
pub fn validate_shaders(root: &Path) -> Result<()> {
    let dir = root.join("shaders");
    let files = scan(&dir)?;
    let read = |path: &str| fs::read_to_string(dir.join(path)).ok();
    let mut failures = 0usize;
    let mut variants_checked = 0usize;
    let entries: Vec<&String> = files.iter().filter(|f| shader::is_entry(f)).collect();

    let passes = declarations();
    let mut binding_variants = 0usize;
    let mut bindings_compared = 0usize;
    for (i, pass) in passes.iter().enumerate() {
        if !entries.iter().any(|e| *e == pass.entry) {
            eprintln!("error: {}: bindings declared for shaders/{}, which is no entry file", pass.source, pass.entry);
            failures += 1;
        }
        if passes[..i].iter().any(|p| p.entry == pass.entry) {
            eprintln!("error: {}: a second binding declaration for shaders/{}", pass.source, pass.entry);
            failures += 1;
        }
    }

    let spaces = tiledlight_gpu::variants::key_spaces();
    for (entry, _) in &spaces {
        if !entries.iter().any(|e| e == entry) {
            eprintln!("error: tiledlight_gpu::variants: a key type names shaders/{entry}, which is no entry file");
            failures += 1;
        }
    }
    // Every define some entry file declares (a binding condition must name one of them).
    let mut all_declared: Vec<String> = Vec::new();
    for &entry in &entries {
        let text = read(entry).with_context(|| format!("cannot read shaders/{entry}"))?;
        all_declared.extend(shader::variants_in(&text));
    }
    let mut counts: Vec<(String, usize)> = Vec::new();

    for &entry in &entries {
        let text = read(entry).with_context(|| format!("cannot read shaders/{entry}"))?;
        let variants = shader::variants_in(&text);
        if variants.len() > MAX_VARIANTS {
            eprintln!("error: shaders/{entry}: {} variants declared, at most {MAX_VARIANTS}", variants.len());
            failures += 1;
            continue;
        }
        let pass = passes.iter().find(|p| p.entry == entry.as_str());
        if let Some(pass) = pass {
            for define in named_defines(pass) {
                if !all_declared.iter().any(|v| v == define) {
                    eprintln!(
                        "error: {}: a binding of shaders/{entry} depends on {define}, which no entry file declares \
                         in its `// variants:`",
                        pass.source
                    );
                    failures += 1;
                }
            }
        }
        let tested = tested_defines(&read, entry);
        for v in &variants {
            if !tested.contains(v) {
                eprintln!(
                    "error: shaders/{entry}: declares {v}, which neither it nor its includes test (#ifdef/#ifndef)"
                );
                failures += 1;
            }
        }
        let values: Vec<Vec<&str>> = match spaces.iter().find(|(e, _)| e == entry) {
            Some((_, v)) => v.clone(),
            None if variants.is_empty() => vec![Vec::new()],
            None => {
                eprintln!(
                    "error: shaders/{entry}: declares variants but no key type of tiledlight_gpu::variants lists its values"
                );
                failures += 1;
                continue;
            }
        };
        for v in &variants {
            if !values.iter().any(|d| d.contains(&v.as_str())) {
                eprintln!("error: shaders/{entry}: declares {v}, which no value of its key sets");
                failures += 1;
            }
        }
        if values.len() > MAX_KEY_VALUES {
            eprintln!(
                "error: shaders/{entry}: {} key values to validate, at most {MAX_KEY_VALUES} (split the file's kernels)",
                values.len()
            );
            failures += 1;
            continue;
        }
        counts.push((entry.clone(), values.len()));
        // The same error usually shows in many variants: report it once, with them all.
        let mut problems: Vec<(Problem, Vec<String>)> = Vec::new();
        let mut mismatches: Vec<(String, Vec<String>)> = Vec::new();
        for defines in &values {
            variants_checked += 1;
            let variant = format!("[{}]", defines.join(" "));
            let compiled = shader::check_declared(entry, &text, defines)
                .map_err(Problem::from)
                .and_then(|()| compile(&read, entry, defines));
            match compiled {
                Err(p) => match problems.iter_mut().find(|(q, _)| *q == p) {
                    Some((_, in_variants)) => in_variants.push(variant),
                    None => problems.push((p, vec![variant])),
                },
                Ok((module, info)) => {
                    let Some(pass) = pass else { continue };
                    binding_variants += 1;
                    bindings_compared += pass.resolve(defines).len();
                    for m in compare_bindings(pass, defines, &module, &info) {
                        match mismatches.iter_mut().find(|(n, _)| *n == m) {
                            Some((_, in_variants)) => in_variants.push(variant.clone()),
                            None => mismatches.push((m, vec![variant.clone()])),
                        }
                    }
                }
            }
        }
        for (mismatch, in_variants) in mismatches {
            let variants = if in_variants.len() == values.len() && in_variants.len() > 1 {
                format!("all {} variants", in_variants.len())
            } else if in_variants.len() > LISTED_VARIANTS {
                format!(
                    "{} and {} more variants",
                    in_variants[..LISTED_VARIANTS].join(" "),
                    in_variants.len() - LISTED_VARIANTS
                )
            } else {
                in_variants.join(" ")
            };
            let pass = pass.expect("mismatches come from a declaration");
            eprintln!("error: bindings of {} vs shaders/{entry} {variants}: {mismatch}", pass.source);
            failures += 1;
        }
        for (problem, in_variants) in problems {
            let context = if in_variants.len() == values.len() && in_variants.len() > 1 {
                format!("shaders/{entry}, all {} variants", in_variants.len())
            } else if in_variants.len() > LISTED_VARIANTS {
                format!(
                    "shaders/{entry} {} and {} more variants",
                    in_variants[..LISTED_VARIANTS].join(" "),
                    in_variants.len() - LISTED_VARIANTS
                )
            } else {
                format!("shaders/{entry} {}", in_variants.join(" "))
            };
            eprintln!("{}", problem.render(&context));
            failures += 1;
        }
    }

    let sources = layout_sources();
    let mut modules: BTreeMap<&str, Option<Module>> = BTreeMap::new();
    let mut layouts_checked = 0usize;
    for (crate_dir, layouts) in &sources {
        for layout in layouts {
            layouts_checked += 1;
            // Parse each declaring file once; a file that fails is reported once.
            let module = modules.entry(layout.wgsl_file).or_insert_with(|| {
                parse_for_layout(&read, layout.wgsl_file)
                    .map_err(|p| {
                        let context = format!("shaders/{}, for the struct layout check", layout.wgsl_file);
                        eprintln!("{}", p.render(&context));
                    })
                    .ok()
            });
            let Some(module) = module else {
                failures += 1;
                continue;
            };
            for mismatch in compare_layout(crate_dir, layout, module) {
                eprintln!("error: {mismatch}");
                failures += 1;
            }
        }
    }

    if failures > 0 {
        bail!("shader validation failed: {failures} problem(s), see above");
    }
    for (entry, n) in &counts {
        println!("xtask: shaders/{entry}: {n} variant(s)");
    }
    println!(
        "xtask: validated {variants_checked} variant(s) (key values) of {} WGSL entry file(s); {layouts_checked} Rust/WGSL struct layout(s) match",
        entries.len()
    );
    let undeclared: Vec<&str> =
        entries.iter().map(|e| e.as_str()).filter(|e| !passes.iter().any(|p| p.entry == *e)).collect();
    println!(
        "xtask: {} Rust binding declaration(s) match naga in {binding_variants} variant(s) ({bindings_compared} binding(s) compared){}",
        passes.len(),
        if undeclared.is_empty() { String::new() } else { format!("; no declaration: {}", undeclared.join(", ")) }
    );
    Ok(())
}

/// Every Rust struct shared with WGSL, grouped by the crate that defines it (named by
/// its directory, for messages).
fn layout_sources() -> Vec<(&'static str, Vec<StructLayout>)> {
    let mut cull = tiledlight_cull::light::layouts();
    cull.extend(tiledlight_cull::vpl::layouts());
    vec![("crates/cull", cull), ("crates/gpu", tiledlight_gpu::layouts())]
}

/// Every `*.wgsl` file under `dir`, relative to it with `/` separators, sorted.
fn scan(dir: &Path) -> Result<Vec<String>> {
    fn walk(dir: &Path, prefix: &str, out: &mut Vec<String>) -> Result<()> {
        for entry in fs::read_dir(dir).with_context(|| format!("cannot read {}", dir.display()))? {
            let entry = entry.with_context(|| format!("cannot read {}", dir.display()))?;
            let path = entry.path();
            let name = entry.file_name();
            let name = name.to_str().with_context(|| format!("shader path is not UTF-8: {}", path.display()))?;
            if path.is_dir() {
                walk(&path, &format!("{prefix}{name}/"), out)?;
            } else if name.ends_with(".wgsl") {
                out.push(format!("{prefix}{name}"));
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, "", &mut out)?;
    out.sort();
    Ok(out)
}

/// Every define an `#ifdef`/`#ifndef` of `entry` or of any file it includes (in any
/// branch) tests.
fn tested_defines(read: Reader<'_>, entry: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut seen: Vec<String> = Vec::new();
    let mut todo = vec![entry.to_owned()];
    while let Some(file) = todo.pop() {
        if seen.contains(&file) {
            continue;
        }
        seen.push(file.clone());
        let Some(text) = read(&file) else { continue };
        for line in text.lines() {
            let line = line.trim();
            let mut words = line.split_whitespace();
            match words.next() {
                Some("#ifdef" | "#ifndef") => {
                    if let Some(name) = words.next() {
                        if !out.iter().any(|o| o == name) {
                            out.push(name.to_owned());
                        }
                    }
                }
                Some("#include") => {
                    if let Some(path) = words.next() {
                        todo.push(path.trim_matches('"').to_owned());
                    }
                }
                _ => {}
            }
        }
    }
    out
}

/// One error, at its original file:line, without saying which entry and variant it
/// came from (the caller groups equal problems of several variants).
#[derive(Debug, PartialEq, Eq)]
struct Problem {
    /// `location: message`.
    head: String,
    /// Further lines (labelled spans with their source line, notes), each starting `\n`.
    details: String,
}

impl Problem {
    fn render(&self, context: &str) -> String {
        format!("error: {} (in {context}){}", self.head, self.details)
    }
}

impl From<shader::ShaderError> for Problem {
    fn from(e: shader::ShaderError) -> Self {
        Problem { head: e.to_string(), details: String::new() }
    }
}

/// Preprocesses, parses and validates one variant of `entry`.
fn compile(read: Reader<'_>, entry: &str, defines: &[&str]) -> Result<(Module, ModuleInfo), Problem> {
    let source = shader::preprocess_with(read, entry, defines)?;
    let module = parse(&source)?;
    let info = Validator::new(ValidationFlags::all(), capabilities()).validate(&module).map_err(|e| {
        // naga's errors nest their causes; the chain is the useful message.
        let mut message = e.to_string();
        let mut cause = std::error::Error::source(&e);
        while let Some(c) = cause {
            message.push_str(&format!(": {c}"));
            cause = c.source();
        }
        let labels: Vec<(Span, String)> = e.spans().cloned().collect();
        problem(&source, &message, &labels, &[])
    })?;
    Ok((module, info))
}

/// Parses preprocessed WGSL with naga.
fn parse(source: &ShaderSource) -> Result<Module, Problem> {
    naga::front::wgsl::parse_str(&source.text).map_err(|e| {
        let labels: Vec<(Span, String)> = e.labels().map(|(s, l)| (s, l.to_owned())).collect();
        let notes: Vec<String> = e.notes().map(|n| format!("note: {n}")).collect();
        problem(source, e.message(), &labels, &notes)
    })
}

/// A naga error with each labelled span at its original file:line:column and the source
/// line under it.
fn problem(source: &ShaderSource, message: &str, labels: &[(Span, String)], notes: &[String]) -> Problem {
    let defined: Vec<&(Span, String)> = labels.iter().filter(|(s, _)| s.is_defined()).collect();
    let position = |span: Span| {
        let loc = span.location(&source.text);
        let (file, line) = source.locate(loc.line_number as usize);
        let text = source.text.lines().nth(loc.line_number as usize - 1).unwrap_or("");
        (format!("shaders/{file}:{line}:{}", loc.line_position), text.trim_end().to_owned())
    };
    let head = match defined.first() {
        Some((span, _)) => format!("{}: {message}", position(*span).0),
        None => message.to_owned(),
    };
    let mut details = String::new();
    for (span, label) in defined {
        let (at, text) = position(*span);
        details.push_str(&format!("\n  --> {at}: {label}\n   | {text}"));
    }
    for note in notes {
        details.push_str(&format!("\n  {note}"));
    }
    Problem { head, details }
}

/// Preprocesses (no defines) and parses the file that declares a shared struct. Include
/// files are parsed on their own, so they must `#include` what they use. Not validated:
/// only the layout matters, and entry files are validated already.
fn parse_for_layout(read: Reader<'_>, file: &str) -> Result<Module, Problem> {
    parse(&shader::preprocess_with(read, file, &[])?)
}

/// Compares a Rust struct's layout with naga's layout of the WGSL struct it mirrors;
/// one line per mismatch. WGSL members whose names start with `_` are padding, like the
/// Rust fields left out of `layout.fields`.
pub fn compare_layout(crate_dir: &str, layout: &StructLayout, module: &Module) -> Vec<String> {
    let prefix = format!("{} ({crate_dir}) vs {} (shaders/{})", layout.rust_name, layout.wgsl_name, layout.wgsl_file);
    let found = module.types.iter().find(|(_, ty)| ty.name.as_deref() == Some(layout.wgsl_name));
    let Some((_, ty)) = found else {
        return vec![format!("{prefix}: no type {} in the WGSL", layout.wgsl_name)];
    };
    let naga::TypeInner::Struct { members, span } = &ty.inner else {
        return vec![format!("{prefix}: {} is not a struct in the WGSL", layout.wgsl_name)];
    };
    let mut out = Vec::new();
    if *span as usize != layout.size {
        out.push(format!("{prefix}: size {} in Rust, {span} in WGSL", layout.size));
    }
    for field in &layout.fields {
        match members.iter().find(|m| m.name.as_deref() == Some(field.name)) {
            None => out.push(format!(
                "{prefix}: field {} (offset {} in Rust) has no WGSL member of that name",
                field.name, field.offset
            )),
            Some(m) if m.offset as usize != field.offset => out.push(format!(
                "{prefix}: field {} at offset {} in Rust, {} in WGSL",
                field.name, field.offset, m.offset
            )),
            Some(_) => {}
        }
    }
    for m in members {
        let name = m.name.as_deref().unwrap_or("");
        if !name.starts_with('_') && !layout.fields.iter().any(|f| f.name == name) {
            out.push(format!(
                "{prefix}: WGSL member {name} (offset {}) has no Rust field of that name \
                 (padding must start with `_` on both sides)",
                m.offset
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;
    use tiledlight_cull::layout::FieldLayout;

    fn cull_light(size: usize, radius_offset: usize) -> StructLayout {
        StructLayout {
            rust_name: "GpuCullLight",
            wgsl_name: "CullLight",
            wgsl_file: "common/lights.wgsl",
            size,
            fields: vec![
                FieldLayout { name: "center", offset: 0 },
                FieldLayout { name: "radius", offset: radius_offset },
            ],
        }
    }

    fn module(wgsl: &str) -> Module {
        naga::front::wgsl::parse_str(wgsl).unwrap()
    }

    #[test]
    fn matching_layout_has_no_mismatch() {
        let m = module("struct CullLight { center: vec3<f32>, radius: f32, _pad: vec4<f32> }");
        assert_eq!(compare_layout("crates/cull", &cull_light(32, 12), &m), Vec::<String>::new());
    }

    #[test]
    fn mismatching_layout_is_reported_per_field() {
        // An extra member pushes radius to 16 and the size to 32.
        let m = module("struct CullLight { center: vec3<f32>, extra: f32, radius: f32 }");
        assert_eq!(
            compare_layout("crates/cull", &cull_light(16, 12), &m),
            [
                "GpuCullLight (crates/cull) vs CullLight (shaders/common/lights.wgsl): size 16 in Rust, 32 in WGSL",
                "GpuCullLight (crates/cull) vs CullLight (shaders/common/lights.wgsl): field radius at offset 12 in Rust, 16 in WGSL",
                "GpuCullLight (crates/cull) vs CullLight (shaders/common/lights.wgsl): WGSL member extra (offset 12) \
                 has no Rust field of that name (padding must start with `_` on both sides)",
            ]
        );
    }

    #[test]
    fn missing_struct_or_member_is_reported() {
        let m = module("struct Other { a: f32 }");
        let got = compare_layout("crates/cull", &cull_light(16, 12), &m);
        assert_eq!(
            got,
            ["GpuCullLight (crates/cull) vs CullLight (shaders/common/lights.wgsl): no type CullLight in the WGSL"]
        );
        let m = module("struct CullLight { center: vec3<f32>, r: f32 }");
        let got = compare_layout("crates/cull", &cull_light(16, 12), &m);
        assert_eq!(got.len(), 2, "{got:?}");
        assert!(got[0].ends_with("field radius (offset 12 in Rust) has no WGSL member of that name"), "{got:?}");
    }

    #[test]
    fn real_cull_layouts_are_well_formed() {
        // The check itself needs shaders/; here only that the Rust side lists fields.
        for l in tiledlight_cull::light::layouts() {
            assert!(!l.fields.is_empty() && l.size > 0, "{l:?}");
        }
    }

    fn files(list: &[(&str, &str)]) -> HashMap<String, String> {
        list.iter().map(|(p, t)| (p.to_string(), t.to_string())).collect()
    }

    #[test]
    fn errors_point_at_the_original_file_and_line() {
        let map = files(&[
            ("e.wgsl", "// variants: X\n#include \"common/a.wgsl\"\n#ifdef X\nfn g() -> f32 { return f(); }\n#endif\n"),
            ("common/a.wgsl", "// helper\n\nfn f() -> f32 { return 1.0 }\n"),
        ]);
        let read = |p: &str| map.get(p).cloned();
        let err = compile(&read, "e.wgsl", &[]).unwrap_err().render("ctx");
        assert!(err.starts_with("error: shaders/common/a.wgsl:3:"), "{err}");
        assert!(err.contains("(in ctx)"), "{err}");
        assert!(err.contains("fn f() -> f32 { return 1.0 }"), "{err}");
    }

    #[test]
    fn validation_errors_are_mapped_too() {
        let map = files(&[(
            "e.wgsl",
            "// variants: X\n#ifdef X\nfn g() -> f32 { return 1.0; }\n#else\nfn g() -> f32 { return 1u; }\n#endif\n",
        )]);
        let read = |p: &str| map.get(p).cloned();
        assert!(compile(&read, "e.wgsl", &["X"]).is_ok());
        let err = compile(&read, "e.wgsl", &[]).unwrap_err().render("ctx");
        assert!(err.starts_with("error: shaders/e.wgsl:5:"), "{err}");
    }

    #[test]
    fn preprocessor_errors_are_reported() {
        let map = files(&[("e.wgsl", "#ifdef X\n")]);
        let read = |p: &str| map.get(p).cloned();
        let err = compile(&read, "e.wgsl", &["X"]).unwrap_err().render("shaders/e.wgsl [X]");
        assert_eq!(
            err,
            "error: shaders/e.wgsl:1: #ifdef/#ifndef is not closed by #endif before the end of the file (in shaders/e.wgsl [X])"
        );
    }

    #[test]
    fn real_declarations_match_their_shaders_and_fail_on_another_variant() {
        let read = |p: &str| shader::embedded(p).map(str::to_owned);
        let forward = tiledlight_forward::shading::FORWARD_BINDINGS;
        let (module, info) = compile(&read, forward.entry, &["HALF_Z"]).unwrap();
        assert_eq!(compare_bindings(&forward, &["HALF_Z"], &module, &info), Vec::<String>::new());
        // The declaration filtered for brute force against the tiled half-z variant.
        assert_eq!(
            compare_bindings(&forward, &["BRUTE_FORCE"], &module, &info),
            [
                "@group(3) @binding(2): not declared in Rust, light_grid: var<storage, read> in the WGSL",
                "@group(3) @binding(3): not declared in Rust, light_indices: var<storage, read> in the WGSL",
                "@group(3) @binding(4): not declared in Rust, tile_ranges: var<storage, read> in the WGSL",
            ]
        );
        let deferred = tiledlight_deferred::shading::DEFERRED_MSAA_BINDINGS;
        let (module, info) = compile(&read, deferred.entry, &["MSAA"]).unwrap();
        assert_eq!(compare_bindings(&deferred, &["MSAA"], &module, &info), Vec::<String>::new());
        let got = compare_bindings(&deferred, &[], &module, &info);
        assert!(
            got.contains(
                &"@group(1) @binding(0): texture_2d<f32> in Rust, depth_texture: texture_multisampled_2d<f32> in the WGSL"
                    .to_string()
            ),
            "{got:?}"
        );
        assert!(
            got.contains(
                &"@group(1) @binding(13): not declared in Rust, edge_list: var<storage, read_write> in the WGSL"
                    .to_string()
            ),
            "{got:?}"
        );
    }

    #[test]
    fn capabilities_are_those_of_a_full_downlevel_device_without_extras() {
        let caps = capabilities();
        assert!(caps.contains(Capabilities::CUBE_ARRAY_TEXTURES | Capabilities::MULTISAMPLED_SHADING));
        assert!(!caps.intersects(Capabilities::SUBGROUP | Capabilities::RAY_QUERY | Capabilities::FLOAT64));
    }
}
