//! The bindings check of `cargo xtask validate-shaders`: every pass's Rust declaration of
//! its bind group layouts (`tiledlight_gpu::bindings::PassBindings`), filtered by a
//! variant's defines, against naga's reflection of that variant's global variables.
//!
//! Compared per `@group`/`@binding`, both ways: the kind (uniform, storage and its access
//! mode, sampled texture with its sample kind, dimension and multisampling, storage
//! texture with its format, access and dimension, sampler or comparison sampler), and
//! that every stage whose entry point uses the binding is in the Rust visibility. naga
//! keeps unused globals, so every declared global counts, used or not. Not comparable
//! with naga and so not checked: a float texture's filterability, dynamic offsets and
//! minimum binding sizes.

use std::collections::BTreeMap;
use std::fmt;

use naga::valid::ModuleInfo;
use naga::Module;
use tiledlight_gpu::bindings::{Cond, PassBindings};

/// Every pass declaration of the workspace.
pub fn declarations() -> Vec<PassBindings> {
    let mut v = tiledlight_gpu::binding_declarations();
    v.extend([
        tiledlight_forward::shading::FORWARD_BINDINGS,
        tiledlight_forward::shading::FORWARD_CLUSTERED_BINDINGS,
        tiledlight_forward::shading::BRUTE_FORCE_BINDINGS,
        tiledlight_deferred::gbuffer::GBUFFER_BINDINGS,
        tiledlight_deferred::shading::DEFERRED_BINDINGS,
        tiledlight_deferred::shading::DEFERRED_MSAA_BINDINGS,
        tiledlight_deferred::shading::DEFERRED_ASSIGNED_BINDINGS,
        tiledlight_visibility::shading::VISIBILITY_BINDINGS,
        tiledlight_visibility::shading::VISIBILITY_MSAA_BINDINGS,
        tiledlight_visibility::shading::TRACED_BINDINGS,
        tiledlight_visibility::shading::TRACED_MSAA_BINDINGS,
        tiledlight_visibility::shading::STOCHASTIC_BINDINGS,
        tiledlight_visibility::denoise::DENOISE_BINDINGS,
        tiledlight_visibility::compute_raster::COMPUTE_RASTER_BINDINGS,
        tiledlight_visibility::compute_raster::LARGE_BINDINGS,
        tiledlight_visibility::raster::DEPTH_COPY_BINDINGS,
    ]);
    v.extend(tiledlight_vpl::binding_declarations());
    v
}

/// Every define a condition of `pass` names (to check some entry file declares it: a
/// condition on a define no file declares is a misspelling, never checked present). A
/// group shared by several entry files (the lights group) may name a define one of them
/// never sets: there the condition never holds, as naga's reflection confirms.
pub fn named_defines(pass: &PassBindings) -> Vec<&'static str> {
    fn walk(c: &Cond, out: &mut Vec<&'static str>) {
        match c {
            Cond::Always | Cond::Never => {}
            Cond::Defined(d) | Cond::NotDefined(d) => {
                if !out.contains(&d.name()) {
                    out.push(d.name())
                }
            }
            Cond::All(cs) | Cond::Any(cs) => cs.iter().for_each(|c| walk(c, out)),
        }
    }
    let mut out = Vec::new();
    for g in pass.groups {
        walk(&g.when, &mut out);
        for b in g.bindings {
            walk(&b.when, &mut out);
            if let tiledlight_gpu::bindings::BindingKind::Texture { multisampled, .. } = &b.kind {
                walk(multisampled, &mut out);
            }
        }
    }
    out
}

/// The kind of a binding as both sides can state it, shown in WGSL syntax.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Shape {
    Uniform,
    Storage {
        read_only: bool,
    },
    Texture {
        sample: Sample,
        dimension: wgpu::TextureViewDimension,
        multisampled: bool,
    },
    StorageTexture {
        format: wgpu::TextureFormat,
        access: wgpu::StorageTextureAccess,
        dimension: wgpu::TextureViewDimension,
    },
    Sampler {
        comparison: bool,
    },
    /// Something this check does not model (binding arrays, acceleration structures, ...).
    Other(String),
}

/// A sampled texture's sample kind (filterability is not part of the WGSL type).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Sample {
    Float,
    Depth,
    Sint,
    Uint,
}

fn dimension_suffix(d: wgpu::TextureViewDimension) -> &'static str {
    use wgpu::TextureViewDimension as D;
    match d {
        D::D1 => "1d",
        D::D2 => "2d",
        D::D2Array => "2d_array",
        D::Cube => "cube",
        D::CubeArray => "cube_array",
        D::D3 => "3d",
    }
}

impl fmt::Display for Shape {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Shape::Uniform => f.write_str("var<uniform>"),
            Shape::Storage { read_only: true } => f.write_str("var<storage, read>"),
            Shape::Storage { read_only: false } => f.write_str("var<storage, read_write>"),
            Shape::Texture { sample, dimension, multisampled } => {
                let ms = if *multisampled { "multisampled_" } else { "" };
                let dim = dimension_suffix(*dimension);
                match sample {
                    Sample::Depth => write!(f, "texture_depth_{ms}{dim}"),
                    Sample::Float => write!(f, "texture_{ms}{dim}<f32>"),
                    Sample::Sint => write!(f, "texture_{ms}{dim}<i32>"),
                    Sample::Uint => write!(f, "texture_{ms}{dim}<u32>"),
                }
            }
            Shape::StorageTexture { format, access, dimension } => {
                let access = match access {
                    wgpu::StorageTextureAccess::WriteOnly => "write",
                    wgpu::StorageTextureAccess::ReadOnly => "read",
                    wgpu::StorageTextureAccess::ReadWrite => "read_write",
                    wgpu::StorageTextureAccess::Atomic => "atomic",
                };
                let format = format!("{format:?}").to_lowercase();
                write!(f, "texture_storage_{}<{format}, {access}>", dimension_suffix(*dimension))
            }
            Shape::Sampler { comparison: false } => f.write_str("sampler"),
            Shape::Sampler { comparison: true } => f.write_str("sampler_comparison"),
            Shape::Other(s) => f.write_str(s),
        }
    }
}

/// The shape of a layout entry's binding type.
fn rust_shape(ty: &wgpu::BindingType) -> Shape {
    match *ty {
        wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, .. } => Shape::Uniform,
        wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Storage { read_only }, .. } => {
            Shape::Storage { read_only }
        }
        wgpu::BindingType::Texture { sample_type, view_dimension, multisampled } => Shape::Texture {
            sample: match sample_type {
                wgpu::TextureSampleType::Float { .. } => Sample::Float,
                wgpu::TextureSampleType::Depth => Sample::Depth,
                wgpu::TextureSampleType::Sint => Sample::Sint,
                wgpu::TextureSampleType::Uint => Sample::Uint,
            },
            dimension: view_dimension,
            multisampled,
        },
        wgpu::BindingType::StorageTexture { access, format, view_dimension } => {
            Shape::StorageTexture { format, access, dimension: view_dimension }
        }
        wgpu::BindingType::Sampler(ty) => Shape::Sampler { comparison: ty == wgpu::SamplerBindingType::Comparison },
        ref other => Shape::Other(format!("{other:?}")),
    }
}

/// The shape of a WGSL global variable with a binding.
fn wgsl_shape(module: &Module, var: &naga::GlobalVariable) -> Shape {
    use naga::{AddressSpace, ImageClass, ImageDimension, ScalarKind, StorageAccess, TypeInner};
    match var.space {
        AddressSpace::Uniform => return Shape::Uniform,
        AddressSpace::Storage { access } => {
            return Shape::Storage { read_only: !access.contains(StorageAccess::STORE) }
        }
        AddressSpace::Handle => {}
        other => return Shape::Other(format!("var<{other:?}>")),
    }
    let dimension = |dim: ImageDimension, arrayed: bool| {
        use wgpu::TextureViewDimension as D;
        match (dim, arrayed) {
            (ImageDimension::D1, _) => D::D1,
            (ImageDimension::D2, false) => D::D2,
            (ImageDimension::D2, true) => D::D2Array,
            (ImageDimension::D3, _) => D::D3,
            (ImageDimension::Cube, false) => D::Cube,
            (ImageDimension::Cube, true) => D::CubeArray,
        }
    };
    match &module.types[var.ty].inner {
        TypeInner::Image { dim, arrayed, class } => {
            let dimension = dimension(*dim, *arrayed);
            match *class {
                ImageClass::Sampled { kind, multi } => Shape::Texture {
                    sample: match kind {
                        ScalarKind::Sint => Sample::Sint,
                        ScalarKind::Uint => Sample::Uint,
                        _ => Sample::Float,
                    },
                    dimension,
                    multisampled: multi,
                },
                ImageClass::Depth { multi } => Shape::Texture { sample: Sample::Depth, dimension, multisampled: multi },
                ImageClass::Storage { format, access } => Shape::StorageTexture {
                    format: wgpu_naga_bridge::map_storage_format_from_naga(format),
                    access: if access.contains(StorageAccess::ATOMIC) {
                        wgpu::StorageTextureAccess::Atomic
                    } else if access.contains(StorageAccess::LOAD | StorageAccess::STORE) {
                        wgpu::StorageTextureAccess::ReadWrite
                    } else if access.contains(StorageAccess::STORE) {
                        wgpu::StorageTextureAccess::WriteOnly
                    } else {
                        wgpu::StorageTextureAccess::ReadOnly
                    },
                    dimension,
                },
                ImageClass::External => Shape::Other("texture_external".into()),
            }
        }
        TypeInner::Sampler { comparison } => Shape::Sampler { comparison: *comparison },
        other => Shape::Other(format!("{other:?}")),
    }
}

/// `VERTEX | FRAGMENT`, or `none`.
fn stages(s: wgpu::ShaderStages) -> String {
    let names: Vec<&str> = s.iter_names().map(|(n, _)| n).collect();
    if names.is_empty() {
        "none".into()
    } else {
        names.join(" | ")
    }
}

/// Compares `pass`'s declaration, filtered by `defines`, with the bindings of `module`
/// (that variant of `pass.entry`, validated into `info`); one line per mismatch, each
/// naming the group, the binding and both sides.
pub fn compare_bindings(pass: &PassBindings, defines: &[&str], module: &Module, info: &ModuleInfo) -> Vec<String> {
    let mut out = Vec::new();
    let mut rust: BTreeMap<(u32, u32), wgpu::BindGroupLayoutEntry> = BTreeMap::new();
    for (group, entry) in pass.resolve(defines) {
        if rust.insert((group, entry.binding), entry).is_some() {
            out.push(format!("@group({group}) @binding({}): declared twice in Rust", entry.binding));
        }
    }
    let mut wgsl: BTreeMap<(u32, u32), (String, Shape, wgpu::ShaderStages)> = BTreeMap::new();
    for (handle, var) in module.global_variables.iter() {
        let Some(rb) = &var.binding else { continue };
        // Stages whose entry points use it (through any function they call).
        let mut used = wgpu::ShaderStages::NONE;
        for (i, ep) in module.entry_points.iter().enumerate() {
            if !info.get_entry_point(i)[handle].is_empty() {
                used |= wgpu_naga_bridge::map_naga_stage(ep.stage);
            }
        }
        let name = var.name.clone().unwrap_or_default();
        wgsl.insert((rb.group, rb.binding), (name, wgsl_shape(module, var), used));
    }
    let keys: std::collections::BTreeSet<(u32, u32)> = rust.keys().chain(wgsl.keys()).copied().collect();
    for (group, binding) in keys {
        let at = format!("@group({group}) @binding({binding})");
        match (rust.get(&(group, binding)), wgsl.get(&(group, binding))) {
            (Some(r), None) => out.push(format!("{at}: {} in Rust, not declared in the WGSL", rust_shape(&r.ty))),
            (None, Some((name, w, _))) => out.push(format!("{at}: not declared in Rust, {name}: {w} in the WGSL")),
            (Some(r), Some((name, w, used))) => {
                let r_shape = rust_shape(&r.ty);
                if r_shape != *w {
                    out.push(format!("{at}: {r_shape} in Rust, {name}: {w} in the WGSL"));
                }
                if !r.visibility.contains(*used) {
                    out.push(format!(
                        "{at}: visible to {} in Rust, but {name} is used by {} in the WGSL",
                        stages(r.visibility),
                        stages(*used)
                    ));
                }
            }
            (None, None) => unreachable!(),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use naga::valid::{ValidationFlags, Validator};
    use tiledlight_gpu::bindings::{Binding, PassGroup};
    use tiledlight_gpu::define::Define;

    const FS: wgpu::ShaderStages = wgpu::ShaderStages::FRAGMENT;
    const CS: wgpu::ShaderStages = wgpu::ShaderStages::COMPUTE;

    fn check(pass: &PassBindings, defines: &[&str], wgsl: &str) -> Vec<String> {
        let module = naga::front::wgsl::parse_str(wgsl).unwrap();
        let info = Validator::new(ValidationFlags::all(), crate::shaders::capabilities()).validate(&module).unwrap();
        compare_bindings(pass, defines, &module, &info)
    }

    const WGSL: &str = "
@group(0) @binding(0) var<storage, read> lights: array<u32>;
@group(0) @binding(1) var<storage, read_write> grid: array<u32>;
@group(0) @binding(2) var depth: texture_depth_multisampled_2d;
@group(0) @binding(3) var out_image: texture_storage_2d<rgba16float, write>;
@group(1) @binding(0) var<uniform> params: vec4<f32>;
@group(1) @binding(1) var image_sampler: sampler;
@compute @workgroup_size(1) fn main() {
    grid[0] = lights[0] + u32(textureLoad(depth, vec2<i32>(0), 0));
    textureStore(out_image, vec2<i32>(0), params);
}
";

    const GOOD: PassBindings = PassBindings {
        entry: "test.wgsl",
        source: "test.rs",
        groups: &[
            PassGroup::new(
                0,
                &[
                    Binding::storage(0, CS),
                    Binding::storage_rw(1, CS),
                    Binding::texture(2, CS, wgpu::TextureSampleType::Depth)
                        .multisampled_when(Cond::Defined(Define::Msaa)),
                    Binding::storage_texture(
                        3,
                        CS,
                        wgpu::TextureFormat::Rgba16Float,
                        wgpu::StorageTextureAccess::WriteOnly,
                    ),
                ],
            ),
            PassGroup::new(1, &[Binding::uniform(0, CS), Binding::sampler(1, FS, wgpu::SamplerBindingType::Filtering)]),
        ],
    };

    #[test]
    fn matching_declaration_has_no_mismatch() {
        assert_eq!(check(&GOOD, &["MSAA"], WGSL), Vec::<String>::new());
    }

    #[test]
    fn a_define_changing_the_rust_side_is_a_mismatch() {
        // Without MSAA the declaration says single-sampled; this WGSL is multisampled.
        assert_eq!(
            check(&GOOD, &[], WGSL),
            ["@group(0) @binding(2): texture_depth_2d in Rust, depth: texture_depth_multisampled_2d in the WGSL"]
        );
    }

    #[test]
    fn wrong_access_missing_and_extra_bindings_are_reported_both_ways() {
        const BAD: PassBindings = PassBindings {
            entry: "test.wgsl",
            source: "test.rs",
            groups: &[
                PassGroup::new(
                    0,
                    &[
                        // read_write in the WGSL.
                        Binding::storage(1, CS),
                        // binding 0 left out; binding 5 only in Rust.
                        Binding::storage(5, CS),
                        Binding::texture(2, CS, wgpu::TextureSampleType::Depth).multisampled_when(Cond::Always),
                        // a different format and access.
                        Binding::storage_texture(
                            3,
                            CS,
                            wgpu::TextureFormat::Rgba8Unorm,
                            wgpu::StorageTextureAccess::ReadWrite,
                        ),
                    ],
                ),
                PassGroup::new(
                    1,
                    &[
                        // used by the compute stage, visible to the fragment stage only.
                        Binding::uniform(0, FS),
                        Binding::sampler(1, FS, wgpu::SamplerBindingType::Comparison),
                    ],
                ),
            ],
        };
        assert_eq!(
            check(&BAD, &[], WGSL),
            [
                "@group(0) @binding(0): not declared in Rust, lights: var<storage, read> in the WGSL",
                "@group(0) @binding(1): var<storage, read> in Rust, grid: var<storage, read_write> in the WGSL",
                "@group(0) @binding(3): texture_storage_2d<rgba8unorm, read_write> in Rust, \
                 out_image: texture_storage_2d<rgba16float, write> in the WGSL",
                "@group(0) @binding(5): var<storage, read> in Rust, not declared in the WGSL",
                "@group(1) @binding(0): visible to FRAGMENT in Rust, but params is used by COMPUTE in the WGSL",
                "@group(1) @binding(1): sampler_comparison in Rust, image_sampler: sampler in the WGSL",
            ]
        );
    }

    #[test]
    fn conditions_filter_bindings_and_groups() {
        const PASS: PassBindings = PassBindings {
            entry: "test.wgsl",
            source: "test.rs",
            groups: &[
                PassGroup::new(0, &[Binding::storage(0, CS).when(Cond::NotDefined(Define::Shadows))]),
                PassGroup::new(1, &[Binding::uniform(0, CS)]).when(Cond::Defined(Define::Msaa)),
            ],
        };
        let wgsl = "@group(0) @binding(0) var<storage, read> lights: array<u32>;\n\
                    @compute @workgroup_size(1) fn main() { _ = lights[0]; }";
        assert_eq!(check(&PASS, &[], wgsl), Vec::<String>::new());
        assert_eq!(
            check(&PASS, &["SHADOWS", "MSAA"], wgsl),
            [
                "@group(0) @binding(0): not declared in Rust, lights: var<storage, read> in the WGSL",
                "@group(1) @binding(0): var<uniform> in Rust, not declared in the WGSL",
            ]
        );
        assert_eq!(named_defines(&PASS), ["SHADOWS", "MSAA"]);
    }

    #[test]
    fn a_binding_declared_twice_is_reported() {
        const PASS: PassBindings = PassBindings {
            entry: "test.wgsl",
            source: "test.rs",
            groups: &[PassGroup::new(
                0,
                &[Binding::storage(0, CS), Binding::storage(0, CS).when(Cond::Defined(Define::HalfZ))],
            )],
        };
        let wgsl = "@group(0) @binding(0) var<storage, read> lights: array<u32>;";
        assert_eq!(check(&PASS, &[], wgsl), Vec::<String>::new());
        assert_eq!(check(&PASS, &["HALF_Z"], wgsl), ["@group(0) @binding(0): declared twice in Rust"]);
    }

    #[test]
    fn every_declaration_names_its_own_source() {
        for d in declarations() {
            assert!(d.source.ends_with(".rs") && d.entry.ends_with(".wgsl"), "{d:?}");
        }
    }
}
