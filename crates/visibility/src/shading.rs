//! The visibility buffer's material-and-lights pass (`shaders/visibility.wgsl`, with MSAA
//! `shaders/visibility_msaa.wgsl`; body `shaders/common/assigned_shade.wgsl` over
//! `shaders/common/visibility_surface.wgsl`):
//!
//! 1. The light grid is written before it by the lights' culling pass, the same pass and
//!    contract as Forward+'s (`tiledlight_gpu::culling::LightCulling`: every layout, test
//!    and assignment), culled against the visibility buffer's depth.
//! 2. One workgroup per tile of the light grid (16x16 threads); each thread reads its pixels' IDs, fetches the
//!    triangle's three vertices from the scene's index and vertex buffers, transforms them
//!    as the raster pass did, and computes perspective-correct barycentrics with their
//!    one-pixel steps (`shaders/common/visibility.wgsl`, CPU twin
//!    `tiledlight_cull::visibility`).
//! 3. The material is evaluated as every raster pass evaluates it (`material_at` in
//!    `shaders/common/scene.wgsl`), textures sampled with explicit gradients taken at the
//!    2x2 quad's first pixel (the hardware's coarse derivatives, measured equal).
//! 4. The pixel's list is looked up in the grid (its tile's, half's or cluster's) and lit
//!    with the shared BRDF, shadows and the VPLs' own grid, into the HDR storage image.
//!    With the row `stage-lights` and tile lists (one list a workgroup) the workgroup
//!    first copies its list's first 256 lights (indices and shading records) into
//!    workgroup memory, and its pixels read them from there.
//! 5. With MSAA a pixel whose samples share one ID is shaded once at its centre; any two
//!    IDs make it an edge pixel, shaded per sample and resolved by Tiled Deferred's resolve
//!    ([`EdgeSamples`]).
//!
//! One dispatch shades every material: a textured scene's textures are all in the texture
//! arrays of one bind group (group 2, `tiledlight_gpu::texture_arrays`), a material's slots
//! per-pixel data, so the pass costs the same at 2 materials as at 500 (issue 46).
//!
//! The traced reference ([`ShadeLights::Traced`], `shaders/traced.wgsl`,
//! `shaders/traced_msaa.wgsl`, body `shaders/common/traced_shade.wgsl`) is the same pass
//! with another light loop: no light grid; every light, no cutoff, each light's share
//! multiplied by a shadow ray through the scene's BVH (`tiledlight_gpu::bvh`). A frame costs
//! seconds: with progress it is dispatched in bands of tile rows (each at most
//! [`TRACED_BAND_PAIRS`] pixel-light pairs, at least [`TRACED_BAND_WORKGROUPS`] workgroups),
//! which [`VisibilityShading::record_traced`] submits one by one; timed, one dispatch. Depends on tiledlight-gpu (with the MSAA edge machinery it shares with Tiled Deferred, `tiledlight_gpu::edge_samples`).

use tiledlight_cull::TileGrid;
use tiledlight_gpu::bindings::{create_layout, Binding, Cond, PassBindings, PassGroup};
use tiledlight_gpu::bvh::GpuBvh;
use tiledlight_gpu::culling::{LightCulling, DEPTH_BINDING};
use tiledlight_gpu::define::Define;
use tiledlight_gpu::edge_samples::{light_entries, EdgeSamples, EdgeTest};
use tiledlight_gpu::handles::{Depth, Hdr};
use tiledlight_gpu::light_grid::{compute_bindings, LightGrid};
use tiledlight_gpu::lights_group::LightingInputs;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::readback::read_buffer;
use tiledlight_gpu::recording::Recording;
use tiledlight_gpu::scene_gpu::{SceneGpu, TEXTURE_BINDINGS};
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::tonemap::HDR_FORMAT;
use tiledlight_gpu::util::view_entry;
use tiledlight_gpu::util::{buffer_entry, buffer_init, buffer_zeroed, compute_pipeline, keyed_module};
use tiledlight_gpu::variants::{
    GridLookup, MaterialKey, ShaderKey, Shadowing, StochasticKey, TracedKey, VisibilityKey,
};
use tiledlight_gpu::view::Views;
use tiledlight_gpu::GpuError;

use crate::raster::VisibilityRaster;

const CS: wgpu::ShaderStages = wgpu::ShaderStages::COMPUTE;

/// Stride of the traced bands' uniforms: wgpu's dynamic-offset alignment.
const BAND_STRIDE: u64 = 256;

/// Size of one band's uniform (`TracedBand`: its first row, and the stochastic method's
/// frame parameters).
const BAND_SIZE: u64 = 32;

/// Pixel-light pairs (samples counted as pixels with MSAA) one band of the traced
/// reference covers at most (unless that is fewer than [`TRACED_BAND_WORKGROUPS`]): 2^28,
/// about 0.1 s on the H200, so progress comes often.
pub const TRACED_BAND_PAIRS: u64 = 1 << 28;

/// Lights one dispatch of the traced reference shades on an adapter whose driver caps a
/// shader's loops (a CPU adapter: llvmpipe stops them after 65,535 iterations in all, per
/// group of lanes): the light loop is split into dispatches of this many lights, each
/// adding to a per-pixel sum. On the Figure 9 scene 256 lights a dispatch ran whole and
/// 1,024 did not (a light costs its traversal's steps, up to about 250 there): 64 leaves a
/// margin of 4, and a frame cut short anyway is refused by name
/// ([`VisibilityShading::check_traced_complete`]). GPUs shade every light in one dispatch.
pub const CPU_TRACED_CHUNK_LIGHTS: u32 = 64;

/// Workgroups a band of the traced reference has at least (bands are only for progress:
/// a timed frame is one dispatch): 2,048, several waves on a 132-SM GPU.
pub const TRACED_BAND_WORKGROUPS: u64 = 2048;

/// Group 1 of the visibility kernels: depth (0), bounding spheres (1), the lighting uniform
/// (2), the IDs (3, multisampled with `MSAA`), shading lights (6), the HDR output (9); spots
/// (7) with `SPOT_LIGHTS`; with `MSAA` the sample texture (12), edge list (13) and resolve
/// arguments (14); with `SHADOWS` the atlas (15), its sampler (16) and faces (17); with
/// `VPLS` the VPLs (19), their uniform (20), grid (21) and indices (22) (the numbers of
/// Tiled Deferred's group); then the scene: instances (24), materials (25), indices (26),
/// positions (27), normals (28), uvs (29), tangents (30) with `NORMAL_MAP`, second uvs (31)
/// with `UV1`. The traced reference (`TRACED`) has no VPL grid (21, 22) but the VPL
/// counter (23), and the BVH's nodes (33), triangles (34), with `TRACE_MASKS` its masks
/// (35-37), its band (38, dynamic offset) and ray count (39); the stochastic method
/// (`STOCHASTIC`, with `TRACED`) adds its history (40).
pub const VISIBILITY_GROUP: &[Binding] = &[
    DEPTH_BINDING,
    Binding::storage(1, CS),
    Binding::uniform(2, CS),
    Binding::texture(3, CS, wgpu::TextureSampleType::Uint).multisampled_when(Cond::Defined(Define::Msaa)),
    Binding::storage(6, CS),
    Binding::storage_texture(9, CS, HDR_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
    Binding::storage(7, CS).when(Cond::Defined(Define::SpotLights)),
    Binding::storage_texture(12, CS, HDR_FORMAT, wgpu::StorageTextureAccess::WriteOnly)
        .when(Cond::Defined(Define::Msaa)),
    Binding::storage_rw(13, CS).when(Cond::Defined(Define::Msaa)),
    Binding::storage_rw(14, CS).when(Cond::Defined(Define::Msaa)),
    Binding::depth_array(15, CS).when(Cond::Defined(Define::Shadows)),
    Binding::sampler(16, CS, wgpu::SamplerBindingType::Comparison).when(Cond::Defined(Define::Shadows)),
    Binding::storage(17, CS).when(Cond::Defined(Define::Shadows)),
    Binding::storage(19, CS).when(Cond::Defined(Define::Vpls)),
    Binding::uniform(20, CS).when(Cond::Defined(Define::Vpls)),
    Binding::storage(21, CS).when(Cond::All(&[Cond::Defined(Define::Vpls), Cond::NotDefined(Define::Traced)])),
    Binding::storage(22, CS).when(Cond::All(&[Cond::Defined(Define::Vpls), Cond::NotDefined(Define::Traced)])),
    Binding::storage(23, CS).when(Cond::All(&[Cond::Defined(Define::Vpls), Cond::Defined(Define::Traced)])),
    Binding::storage(24, CS),
    Binding::storage(25, CS),
    Binding::storage(26, CS),
    Binding::storage(27, CS),
    Binding::storage(28, CS),
    Binding::storage(29, CS),
    Binding::storage(30, CS).when(Cond::Defined(Define::NormalMap)),
    Binding::storage(31, CS).when(Cond::Defined(Define::Uv1)),
    TRACE[0],
    TRACE[1],
    TRACE[2],
    TRACE[3],
    TRACE[4],
    Binding::uniform(38, CS).dynamic_offset(BAND_SIZE).when(Cond::Defined(Define::Traced)),
    Binding::storage_rw(39, CS).when(Cond::Defined(Define::Traced)),
    // The stochastic method's history, or the traced reference's per-pixel sum of the
    // lights its earlier dispatches shaded ([`CPU_TRACED_CHUNK_LIGHTS`]; one sample a pixel).
    Binding::storage_rw(40, CS).when(Cond::Any(&[
        Cond::Defined(Define::Stochastic),
        Cond::All(&[Cond::Defined(Define::Traced), Cond::NotDefined(Define::Msaa)]),
    ])),
    Binding::storage_rw(41, CS).when(Cond::Defined(Define::Denoise)),
    Binding::storage_rw(42, CS).when(Cond::Defined(Define::Reuse)),
    Binding::storage_rw(43, CS).when(Cond::Defined(Define::Reuse)),
    Binding::storage(44, CS).when(Cond::Defined(Define::Stochastic)),
];

/// The lights as the light tree sees them (`tiledlight_cull::light_tree::TreeLight`): the
/// shading records' position, the luminance of their radiance, their radius.
fn tree_lights(packed: &tiledlight_cull::light::PackedLights) -> Vec<tiledlight_cull::light_tree::TreeLight> {
    let luminance = tiledlight_cull::stochastic::luminance;
    packed.shading.iter().map(|s| (s.position.into(), luminance(s.radiance.into()), s.radius)).collect()
}

/// Bytes of the temporal history's header (`ReuseHistory::view` in
/// `shaders/common/stochastic_shade.wgsl`: the previous frame's view) before its records.
const HISTORY_HEADER: u64 = std::mem::size_of::<tiledlight_gpu::view::ViewUniforms>() as u64;

/// The traced reference's hierarchy (33-37), only with `TRACED`.
const TRACE: [Binding; 5] = {
    let t = tiledlight_gpu::bvh::trace_bindings(33);
    let traced = Cond::Defined(Define::Traced);
    [t[0].when(traced), t[1].when(traced), t[2], t[3], t[4]]
};

/// The bindings of the visibility kernel (`shaders/visibility.wgsl`): the view (0),
/// [`VISIBILITY_GROUP`] (1), the material textures (2) with `TEXTURES`, and the light grid
/// with its tile ranges (3; the ranges are read only with `HALF_Z`).
pub const VISIBILITY_BINDINGS: PassBindings = PassBindings {
    entry: "visibility.wgsl",
    source: file!(),
    groups: &[
        PassGroup::new(0, tiledlight_gpu::view::BINDINGS),
        PassGroup::new(1, VISIBILITY_GROUP),
        PassGroup::new(2, TEXTURE_BINDINGS).when(Cond::Defined(Define::Textures)),
        PassGroup::new(3, &compute_bindings(Cond::Always)),
    ],
};

/// [`VISIBILITY_BINDINGS`] for the MSAA kernel (`shaders/visibility_msaa.wgsl`).
pub const VISIBILITY_MSAA_BINDINGS: PassBindings =
    PassBindings { entry: "visibility_msaa.wgsl", ..VISIBILITY_BINDINGS };

/// The bindings of the traced reference (`shaders/traced.wgsl`): the view (0),
/// [`VISIBILITY_GROUP`] (1) and the material textures (2) with `TEXTURES`; no light grid.
pub const TRACED_BINDINGS: PassBindings = PassBindings {
    entry: "traced.wgsl",
    source: file!(),
    groups: &[
        PassGroup::new(0, tiledlight_gpu::view::BINDINGS),
        PassGroup::new(1, VISIBILITY_GROUP),
        PassGroup::new(2, TEXTURE_BINDINGS).when(Cond::Defined(Define::Textures)),
    ],
};

/// [`TRACED_BINDINGS`] for the MSAA kernel (`shaders/traced_msaa.wgsl`).
pub const TRACED_MSAA_BINDINGS: PassBindings = PassBindings { entry: "traced_msaa.wgsl", ..TRACED_BINDINGS };

/// The bindings of the stochastic method's kernel (`shaders/stochastic.wgsl`): the traced
/// reference's, and the light grid with its tile ranges (3; the ranges read only with
/// `HALF_Z`), whose lists are its near candidates' source.
pub const STOCHASTIC_BINDINGS: PassBindings = PassBindings { entry: "stochastic.wgsl", ..VISIBILITY_BINDINGS };

/// Where each pixel's lights come from.
#[derive(Clone, Copy)]
pub enum ShadeLights<'a> {
    /// Its list in the light grid `culling` writes (the visibility buffer).
    Lists(&'a LightCulling),
    /// Every light, each with a shadow ray through the scene's hierarchy (the traced
    /// reference); `cutoff`: with the windowed falloff (else plain inverse-square).
    Traced {
        /// The scene's hierarchy.
        bvh: &'a GpuBvh,
        /// Keep the radius cutoff.
        cutoff: bool,
    },
    /// The stochastic method: every light a candidate, one kept a pixel by its unshadowed
    /// contribution and shadowed by a ray through the scene's hierarchy, the frames
    /// accumulated ([`crate::stochastic`]); no cutoff.
    Stochastic {
        /// The scene's hierarchy.
        bvh: &'a GpuBvh,
        /// The light grid's culling: each pixel's list is its near candidates' source.
        culling: &'a LightCulling,
    },
}

impl<'a> ShadeLights<'a> {
    /// The hierarchy its rays go through (None for the light grid's lists).
    fn bvh(self) -> Option<&'a GpuBvh> {
        match self {
            ShadeLights::Lists(_) => None,
            ShadeLights::Traced { bvh, .. } | ShadeLights::Stochastic { bvh, .. } => Some(bvh),
        }
    }
}

/// What [`VisibilityShading::record_traced`] calls after each band: `(encoder, band done
/// (1-based), bands)`.
pub type BandFlush<'a> = dyn FnMut(&mut wgpu::CommandEncoder, u32, u32) + 'a;

/// What a traced frame (the traced reference's or the stochastic method's) cast.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TracedStats {
    /// Shadow rays cast.
    pub rays: u64,
    /// Invocations whose light loop or BVH traversal ended before its end: a driver's
    /// loop limit (llvmpipe's 65,535 iterations a shader) cut them short, and their
    /// pixels are missing light or shadows. 0 on every GPU.
    pub cut: u32,
}

/// The traced reference's bands and ray count.
struct Traced {
    /// One `TracedBand` a band, [`BAND_STRIDE`] apart.
    bands_buffer: wgpu::Buffer,
    /// Tile rows a band.
    rows: u32,
    /// Bands of the frame.
    bands: u32,
    /// Dispatches a band's lights are split into (1 but on a CPU adapter:
    /// [`CPU_TRACED_CHUNK_LIGHTS`]); band `b`'s chunk `c` is entry `c * bands + b`.
    chunks: u32,
    /// The traced reference's per-pixel sum across its chunks (binding 40): the screen's
    /// with several chunks, else one unused vec4 (the binding needs a buffer).
    sum: Option<wgpu::Buffer>,
    /// The frame's rays, a 64-bit count in two words (cleared at the start of each frame).
    stats: wgpu::Buffer,
    /// The stochastic method's per-pixel history (None for the traced reference).
    history: Option<wgpu::Buffer>,
    /// What the stochastic method's shading leaves its denoiser (`--denoise N` > 0): a
    /// pixel's surface, albedo and unlit term.
    guide: Option<wgpu::Buffer>,
    /// The stochastic method's reservoirs between the sampling and the reusing run
    /// (`--reuse N` > 0), or the copy of the history the one run reads (`--temporal N` > 0
    /// alone): one 32-byte record a pixel (`tiledlight_cull::reuse::Record`).
    records: Option<wgpu::Buffer>,
    /// The temporal reuse's history (`--temporal N` > 0): the previous frame's view
    /// ([`HISTORY_HEADER`] bytes), then each pixel's final record.
    history_records: Option<wgpu::Buffer>,
    /// The light tree the far candidates are drawn from (`--far-candidates` > 0 and some
    /// lights; `tiledlight_cull::light_tree`), else one zero node, never read (the binding
    /// needs a buffer of one node at least); None for the traced reference.
    light_tree: Option<wgpu::Buffer>,
    /// The tree's shape, refitted when the lights move (None: the placeholder).
    tree: std::cell::RefCell<Option<tiledlight_cull::light_tree::LightTree>>,
    /// The view of the frame the history holds (None before the first frame).
    previous_view: std::cell::Cell<Option<tiledlight_gpu::view::ViewUniforms>>,
    /// The sampling run (`REUSE_PASS` 0) of the pass with spatial reuse; the pass's
    /// pipeline is then the reusing run.
    sample: Option<wgpu::ComputePipeline>,
    /// The pass's label and timer name: `traced.shade` or `stochastic.shade`.
    label: &'static str,
}

/// The material-and-lights pass.
pub struct VisibilityShading {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    /// Group 2 for untextured scenes (an empty group).
    empty_group: Option<wgpu::BindGroup>,
    msaa: Option<EdgeSamples>,
    tiles: (u32, u32),
    /// The screen in pixels.
    screen: (u32, u32),
    /// The traced reference's bands (None for the light grid's pass).
    traced: Option<Traced>,
    /// The pipeline constants the pass was built with ([`Self::constants`]).
    constants: Vec<(String, f64)>,
}

/// The list lookup that reads what `culling` writes.
fn lookup(culling: &LightCulling) -> GridLookup {
    if culling.options.clusters.is_some() {
        GridLookup::Clustered
    } else if culling.options.half_z {
        GridLookup::HalfZ
    } else {
        GridLookup::Tile
    }
}

impl VisibilityShading {
    /// Builds the pass over `raster`'s IDs and `depth`, writing `hdr`, with the lights of
    /// `shade` (a grid built over the same depth, or every light traced).
    pub fn new(
        inputs: &LightingInputs<'_>,
        (depth, raster): (Depth<'_>, &VisibilityRaster),
        hdr: Hdr<'_>,
        scene: &SceneGpu,
        (shade, grid, edge): (ShadeLights<'_>, TileGrid, EdgeTest),
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
        let LightingInputs { device, views, lights, lighting, features, atlas, vpls } = *inputs;
        let (depth, hdr) = (depth.view, hdr.view);
        let traced = shade.bvh().is_some();
        let stochastic = matches!(shade, ShadeLights::Stochastic { .. });
        if stochastic && features.msaa > 1 {
            return Err(GpuError::Config(format!(
                "the stochastic method shades one sample a pixel: MSAA ({}x) is not supported, use --msaa 1",
                features.msaa
            )));
        }
        if stochastic && features.vpl {
            return Err(GpuError::Config(
                "the stochastic method does not sample VPLs yet: render it without --vpl (the traced reference adds \
                 them unshadowed)"
                    .into(),
            ));
        }
        // The grid's pass reads the VPLs' grid; the traced one every VPL.
        if features.vpl != vpls.is_some_and(|v| v.lists.is_some() != traced) {
            return Err(GpuError::Config(
                "the VPL buffers (with their light grid unless traced) must be given exactly when the features have \
                 VPLs"
                    .into(),
            ));
        }
        if features.shadows.is_some() != atlas.is_some() {
            return Err(GpuError::Config("the shadow atlas must exist exactly when the features have shadows".into()));
        }
        edge.validate()?;
        let samples = features.msaa;
        let textures = scene.textures.as_ref().filter(|_| features.textures);
        let materials = MaterialKey::of(&features.materials);
        let (key, bindings, tile): (Box<dyn ShaderKey>, PassBindings, u32) = match shade {
            ShadeLights::Lists(culling) => (
                Box::new(VisibilityKey {
                    lookup: lookup(culling),
                    spots: features.spot_lights,
                    shadowing: Shadowing::of(features.shadows.is_some(), features.vpl)
                        .ok_or_else(|| GpuError::Config("VPLs need shadow casters".into()))?,
                    msaa: samples > 1,
                    materials,
                }),
                VISIBILITY_BINDINGS,
                culling.options.tile_size,
            ),
            ShadeLights::Traced { bvh, cutoff } => (
                Box::new(TracedKey {
                    cutoff,
                    spots: features.spot_lights,
                    vpls: features.vpl,
                    msaa: samples > 1,
                    masks: bvh.masks.is_some(),
                    materials,
                }),
                TRACED_BINDINGS,
                16,
            ),
            ShadeLights::Stochastic { bvh, culling } => (
                Box::new(StochasticKey {
                    lookup: lookup(culling),
                    spots: features.spot_lights,
                    masks: bvh.masks.is_some(),
                    materials,
                    denoise: features.knobs.denoise > 0,
                    reuse: features.knobs.reuse > 0 || features.knobs.temporal > 0,
                }),
                STOCHASTIC_BINDINGS,
                16,
            ),
        };
        let defines = key.defines();
        // Storage buffers in the one compute stage: every option on reads 21.
        let storage = bindings
            .resolve(&defines)
            .into_iter()
            .filter(|(_, e)| {
                matches!(e.ty, wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Storage { .. }, .. })
            })
            .count() as u32;
        let limit = device.limits().max_storage_buffers_per_shader_stage;
        if storage > limit {
            return Err(GpuError::Limit {
                what: "the visibility buffer's material-and-lights pass".into(),
                name: "max_storage_buffers_per_shader_stage",
                limit: limit.into(),
                asked: format!("{storage} storage buffers in one compute stage"),
            });
        }
        let mut bind = vec![
            view_entry(0, depth),
            wgpu::BindGroupEntry { binding: 1, resource: lights.cull.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: lighting.as_entire_binding() },
            view_entry(3, &raster.ids_view),
            wgpu::BindGroupEntry { binding: 6, resource: lights.shading.as_entire_binding() },
            view_entry(9, hdr),
            wgpu::BindGroupEntry { binding: 24, resource: scene.instances.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 25, resource: scene.materials.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 26, resource: scene.indices.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 27, resource: scene.positions.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 28, resource: scene.normals.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 29, resource: scene.uvs.as_entire_binding() },
        ];
        if features.materials.normal_map {
            let t = scene.tangents.as_ref().ok_or_else(|| GpuError::Config("normal maps need tangents".into()))?;
            bind.push(wgpu::BindGroupEntry { binding: 30, resource: t.as_entire_binding() });
        }
        if features.materials.uv1 {
            let u = scene.uvs1.as_ref().ok_or_else(|| GpuError::Config("UV1 needs the second uv set".into()))?;
            bind.push(wgpu::BindGroupEntry { binding: 31, resource: u.as_entire_binding() });
        }
        // The traced kernel reads no shadow map (its atlas, with VPLs, serves their RSM).
        bind.extend(light_entries(lights, features, atlas.filter(|_| !traced), vpls));
        let mut traced_state = match shade.bvh() {
            None => None,
            Some(bvh) => {
                bind.extend(bvh.entries(33));
                if let Some(v) = vpls {
                    bind.push(buffer_entry(23, &v.count));
                }
                // Bands of tile rows, each at most TRACED_BAND_PAIRS pixel-light pairs.
                let rows_total = grid.height.div_ceil(tile);
                let pairs_per_row =
                    (u64::from(grid.width) * u64::from(tile) * u64::from(samples) * lights.packed.len().max(1) as u64)
                        .max(1);
                // At least TRACED_BAND_WORKGROUPS workgroups a band: fewer leave a large
                // GPU idle (one row of tiles at 16,384 lights ran 4x slower a ray).
                let min_rows = TRACED_BAND_WORKGROUPS.div_ceil(u64::from(grid.width.div_ceil(tile).max(1)));
                let rows =
                    (TRACED_BAND_PAIRS / pairs_per_row).max(min_rows).clamp(1, u64::from(rows_total.max(1))) as u32;
                // The stochastic method's frame is one band (milliseconds, no progress).
                let rows = if stochastic { rows_total.max(1) } else { rows };
                let bands = rows_total.max(1).div_ceil(rows);
                // A CPU adapter's loop limit: the light loop in chunks (one sample a pixel).
                let n_lights = lights.packed.len() as u32;
                let cpu = tiledlight_gpu::error::has_cpu_loop_limit(device);
                let chunk = if cpu && !stochastic && samples == 1 { CPU_TRACED_CHUNK_LIGHTS } else { u32::MAX };
                let chunks = n_lights.div_ceil(chunk).max(1);
                let mut data = vec![0u8; (bands * chunks) as usize * BAND_STRIDE as usize];
                for c in 0..chunks {
                    let (light_first, light_end) =
                        if chunks == 1 { (0, u32::MAX) } else { (c * chunk, ((c + 1) * chunk).min(n_lights)) };
                    for b in 0..bands {
                        let at = ((c * bands + b) as u64 * BAND_STRIDE) as usize;
                        data[at..at + 4].copy_from_slice(&(b * rows).to_le_bytes());
                        // TracedBand's light_first and light_end (words 6 and 7).
                        data[at + 24..at + 28].copy_from_slice(&light_first.to_le_bytes());
                        data[at + 28..at + 32].copy_from_slice(&light_end.to_le_bytes());
                    }
                }
                let sum = (!stochastic && samples == 1).then(|| {
                    let bytes = if chunks > 1 { u64::from(grid.width) * u64::from(grid.height) * 16 } else { 16 };
                    if chunks > 1 {
                        memory.add("traced.sum", bytes);
                    }
                    buffer_zeroed(device, "traced.sum", bytes.max(16), wgpu::BufferUsages::STORAGE)
                });
                // The stochastic method writes its frame's parameters into its band.
                let usage = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
                let bands_buffer = buffer_init(device, "traced.bands", &data, usage);
                let stats = buffer_zeroed(
                    device,
                    "traced.stats",
                    12,
                    wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                );
                memory.add("traced.bands", bands_buffer.size());
                let history = stochastic.then(|| {
                    let bytes = u64::from(grid.width) * u64::from(grid.height) * 16;
                    memory.add("stochastic.history", bytes);
                    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
                    buffer_zeroed(device, "stochastic.history", bytes.max(16), usage)
                });
                let guide = (stochastic && features.knobs.denoise > 0).then(|| {
                    let bytes = u64::from(grid.width) * u64::from(grid.height) * crate::denoise::GUIDE_BYTES_PER_PIXEL;
                    memory.add("stochastic.denoise.guide", bytes);
                    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
                    buffer_zeroed(device, "stochastic.denoise.guide", bytes, usage)
                });
                let record_bytes = u64::from(grid.width) * u64::from(grid.height) * 32;
                let records = (stochastic && (features.knobs.reuse > 0 || features.knobs.temporal > 0)).then(|| {
                    memory.add("stochastic.reuse.records", record_bytes);
                    let usage =
                        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
                    // At least the history's header: the buffer stands in for the history
                    // (binding 43) when there is none.
                    buffer_zeroed(device, "stochastic.reuse.records", record_bytes.max(HISTORY_HEADER + 32), usage)
                });
                let history_records = (stochastic && features.knobs.temporal > 0).then(|| {
                    let bytes = HISTORY_HEADER + record_bytes;
                    memory.add("stochastic.temporal.history", bytes);
                    let usage =
                        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
                    buffer_zeroed(device, "stochastic.temporal.history", bytes, usage)
                });
                let tree = (stochastic
                    && features.knobs.light_tree
                    && features.knobs.far_candidates > 0
                    && !lights.packed.is_empty())
                .then(|| tiledlight_cull::light_tree::LightTree::from_points(&tree_lights(&lights.packed)));
                let light_tree = stochastic.then(|| match &tree {
                    Some(t) => {
                        let bytes: &[u8] = bytemuck::cast_slice(&t.nodes);
                        memory.add("stochastic.light_tree", bytes.len() as u64);
                        let usage =
                            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC;
                        buffer_init(device, "stochastic.light_tree", bytes, usage)
                    }
                    None => {
                        let node = std::mem::size_of::<tiledlight_cull::light_tree::Node>() as u64;
                        buffer_zeroed(device, "stochastic.light_tree.unused", node, wgpu::BufferUsages::STORAGE)
                    }
                });
                let tree = std::cell::RefCell::new(tree);
                let label = if stochastic { "stochastic.shade" } else { "traced.shade" };
                let previous_view = std::cell::Cell::new(None);
                Some(Traced {
                    bands_buffer,
                    rows,
                    bands,
                    chunks,
                    sum,
                    stats,
                    history,
                    guide,
                    records,
                    history_records,
                    light_tree,
                    tree,
                    previous_view,
                    sample: None,
                    label,
                })
            }
        };
        if let Some(t) = &traced_state {
            bind.push(wgpu::BindGroupEntry {
                binding: 38,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &t.bands_buffer,
                    offset: 0,
                    size: wgpu::BufferSize::new(BAND_SIZE),
                }),
            });
            bind.push(buffer_entry(39, &t.stats));
            if let Some(s) = &t.sum {
                bind.push(buffer_entry(40, s));
            }
            if let Some(h) = &t.history {
                bind.push(buffer_entry(40, h));
                if let Some(tree) = &t.light_tree {
                    bind.push(buffer_entry(44, tree));
                }
            }
            if let Some(g) = &t.guide {
                bind.push(buffer_entry(41, g));
            }
            if let Some(r) = &t.records {
                bind.push(buffer_entry(42, r));
                // Without temporal reuse the records stand in for the history (never read).
                bind.push(buffer_entry(43, t.history_records.as_ref().unwrap_or(r)));
            }
        }
        let msaa =
            (samples > 1).then(|| EdgeSamples::new(device, "visibility", &grid, samples, hdr, memory)).transpose()?;
        if let Some(m) = &msaa {
            bind.extend(m.entries());
        }
        let layout = create_layout(device, "visibility.layout", VISIBILITY_GROUP, &defines);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("visibility.bind_group"),
            layout: &layout,
            entries: &bind,
        });
        let empty_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("visibility.no_textures.layout"),
            entries: &[],
        });
        let empty_group = textures.is_none().then(|| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("visibility.no_textures"),
                layout: &empty_layout,
                entries: &[],
            })
        });
        let texture_layout = textures.map_or(&empty_layout, |t| &t.layout);
        let module = keyed_module(device, key.as_ref())?;
        let mut constants = vec![
            ("TILE_SIZE", tile as f64),
            ("WG", tile.min(16) as f64),
            ("TRIANGLE_BITS", raster.layout.triangle_bits as f64),
        ];
        if samples > 1 {
            constants.push(("SAMPLES", samples as f64));
            constants.extend(EdgeSamples::constants(samples, edge, tile));
            constants.push(("SURFACE_EDGES", f64::from(u8::from(features.knobs.surface_edges))));
        }
        let pipeline = match shade {
            ShadeLights::Lists(culling) => {
                constants.extend(features.light_constants());
                // One list a workgroup only with tile lists (the workgroup's tile is the grid's).
                if features.knobs.stage_lights && lookup(culling) == GridLookup::Tile {
                    constants.push(("STAGE_LIGHTS", 1.0));
                }
                compute_pipeline(
                    device,
                    "visibility.shade",
                    &[&views.layout, &layout, texture_layout, culling.grid.layout()],
                    &module,
                    &constants,
                )
            }
            ShadeLights::Traced { bvh, .. } | ShadeLights::Stochastic { bvh, .. } => {
                constants.extend([
                    ("TRACE_EPS", f64::from(tiledlight_cull::trace::SURFACE_EPS)),
                    ("TRACE_POSITION_EPS", f64::from(tiledlight_cull::trace::POSITION_EPS)),
                    ("TRACE_SCALE", f64::from(bvh.scale)),
                ]);
                if stochastic {
                    constants.push(("DEMOD_FLOOR", f64::from(tiledlight_cull::denoise::DEMOD_FLOOR)));
                    let from_tree = traced_state.as_ref().is_some_and(|t| t.tree.borrow().is_some());
                    constants.push(("FAR_FROM_TREE", f64::from(u32::from(from_tree))));
                    constants.push(("RAYS", f64::from(features.knobs.rays)));
                }
                let label = if stochastic { "stochastic.shade" } else { "traced.shade" };
                let mut layouts = vec![&views.layout, &layout, texture_layout];
                if let ShadeLights::Stochastic { culling, .. } = shade {
                    layouts.push(culling.grid.layout());
                }
                if let Some(t) = traced_state.as_mut().filter(|t| t.records.is_some()) {
                    use tiledlight_cull::reuse;
                    constants.extend([
                        ("REUSE_NEIGHBOURS", f64::from(features.knobs.reuse)),
                        ("REUSE_RADIUS", f64::from(reuse::RADIUS)),
                        ("REUSE_NORMAL_COS", f64::from(reuse::NORMAL_COS)),
                        ("REUSE_DISTANCE_SHARE", f64::from(reuse::DISTANCE_SHARE)),
                        ("REUSE_DRAW_BASE", f64::from(reuse::DRAW_BASE)),
                        ("TEMPORAL_CAP", f64::from(features.knobs.temporal)),
                    ]);
                    if features.knobs.reuse > 0 {
                        let mut sampling = constants.clone();
                        sampling.push(("REUSE_PASS", 0.0));
                        t.sample = Some(compute_pipeline(device, "stochastic.sample", &layouts, &module, &sampling));
                        constants.push(("REUSE_PASS", 1.0));
                    } else {
                        // Temporal reuse alone: one run samples, reuses and shades.
                        constants.push(("REUSE_PASS", 2.0));
                    }
                }
                compute_pipeline(device, label, &layouts, &module, &constants)
            }
        };
        let tiles = (grid.width.div_ceil(tile), grid.height.div_ceil(tile));
        let constants = constants.iter().map(|&(k, v)| (k.to_string(), v)).collect();
        let screen = (grid.width, grid.height);
        Ok(Self { constants, pipeline, bind_group, empty_group, msaa, tiles, screen, traced: traced_state })
    }

    /// The pipeline constants the shading pipeline was built with (tests: a setting that
    /// must not change the image, the early-outs' ablation, took effect).
    pub fn constants(&self) -> &[(String, f64)] {
        &self.constants
    }

    /// Records the pass (one dispatch per material of a textured scene) with the lists of
    /// `light_grid` (the culling pass's, recorded before).
    pub fn record(&self, r: &mut Recording<'_>, light_grid: &LightGrid) {
        let (encoder, timer, (views, view), scene) = (&mut *r.encoder, r.timer, r.view, r.scene);
        if let Some(m) = &self.msaa {
            m.record_clear(encoder);
        }
        let t = timer.begin("visibility.shade", encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("visibility.shade"),
                timestamp_writes: t.compute_writes(),
            });
            pass.set_bind_group(3, light_grid.bind_group(), &[]);
            self.dispatch(&mut pass, (views, view), scene, None);
        }
        timer.end(encoder, t);
    }

    /// Records the traced reference's pass, band after band. With `flush`, each band is
    /// its own compute pass (untimed) followed by `flush(encoder, band, bands)`, which may
    /// submit what the encoder holds and report progress; without, one timed dispatch
    /// covers the frame.
    pub fn record_traced(&self, r: &mut Recording<'_>, flush: Option<&mut BandFlush<'_>>) {
        self.record_rays(r, None, flush);
    }

    /// Records the stochastic method's pass with the lists of `light_grid` (the culling
    /// pass's, recorded before): one timed dispatch.
    pub fn record_stochastic(&self, r: &mut Recording<'_>, light_grid: &LightGrid) {
        self.record_rays(r, Some(light_grid), None);
    }

    /// [`Self::record_traced`], with the light grid the stochastic kernel reads.
    fn record_rays(&self, r: &mut Recording<'_>, light_grid: Option<&LightGrid>, flush: Option<&mut BandFlush<'_>>) {
        let (encoder, timer, (views, view), scene) = (&mut *r.encoder, r.timer, r.view, r.scene);
        let Some(traced) = &self.traced else { return };
        if let Some(m) = &self.msaa {
            m.record_clear(encoder);
        }
        encoder.clear_buffer(&traced.stats, 0, None);
        // Temporal reuse in one run: it reads the history from a copy, as it overwrites it.
        if let (None, Some(history), Some(records)) = (&traced.sample, &traced.history_records, &traced.records) {
            encoder.copy_buffer_to_buffer(history, HISTORY_HEADER, records, 0, history.size() - HISTORY_HEADER);
        }
        match flush {
            None => {
                // With spatial reuse the sampling run first, timed on its own: it leaves
                // the records the pass reads.
                if let Some(sample) = &traced.sample {
                    let t = timer.begin("stochastic.sample", encoder);
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("stochastic.sample"),
                        timestamp_writes: t.compute_writes(),
                    });
                    if let Some(g) = light_grid {
                        pass.set_bind_group(3, g.bind_group(), &[]);
                    }
                    self.dispatch_with(sample, &mut pass, (views, view), scene, Some((0, self.tiles.1)));
                    drop(pass);
                    timer.end(encoder, t);
                }
                let t = timer.begin(traced.label, encoder);
                {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some(traced.label),
                        timestamp_writes: t.compute_writes(),
                    });
                    if let Some(g) = light_grid {
                        pass.set_bind_group(3, g.bind_group(), &[]);
                    }
                    // Timed: the whole frame in one dispatch (band 0 starts at row 0), so
                    // no band waits for the previous one's tail; a dispatch a chunk of
                    // lights on a CPU adapter.
                    for c in 0..traced.chunks {
                        self.dispatch(&mut pass, (views, view), scene, Some((c * traced.bands, self.tiles.1)));
                    }
                }
                timer.end(encoder, t);
            }
            Some(flush) => {
                for band in 0..traced.bands {
                    {
                        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                            label: Some(traced.label),
                            timestamp_writes: None,
                        });
                        let rows = traced.rows.min(self.tiles.1.saturating_sub(band * traced.rows));
                        for c in 0..traced.chunks {
                            self.dispatch(&mut pass, (views, view), scene, Some((c * traced.bands + band, rows)));
                        }
                    }
                    flush(encoder, band + 1, traced.bands);
                }
            }
        }
    }

    /// The dispatches of one pass (or, traced, of `band`: its index and its rows of tiles):
    /// one per material class.
    fn dispatch(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        (views, view): (&Views, u32),
        scene: &SceneGpu,
        band: Option<(u32, u32)>,
    ) {
        self.dispatch_with(&self.pipeline, pass, (views, view), scene, band);
    }

    /// [`Self::dispatch`] with `pipeline` (the stochastic method's sampling run).
    fn dispatch_with(
        &self,
        pipeline: &wgpu::ComputePipeline,
        pass: &mut wgpu::ComputePass<'_>,
        (views, view): (&Views, u32),
        scene: &SceneGpu,
        band: Option<(u32, u32)>,
    ) {
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, views.bind_group(), &views.offsets(view));
        let rows = band.map_or(self.tiles.1, |(_, rows)| rows);
        let band_offset = band.map(|(b, _)| (u64::from(b) * BAND_STRIDE) as u32);
        let offsets: Vec<u32> = band_offset.into_iter().collect();
        pass.set_bind_group(1, &self.bind_group, &offsets);
        match (&self.empty_group, &scene.textures) {
            (Some(empty), _) => pass.set_bind_group(2, empty, &[]),
            (None, Some(t)) => pass.set_bind_group(2, &t.bind_group, &[]),
            (None, None) => unreachable!("a textured pass without the scene's textures"),
        }
        if rows > 0 {
            pass.dispatch_workgroups(self.tiles.0, rows, 1);
        }
    }

    /// Rays the last traced frame cast (stalls the GPU); None for the light grid's pass.
    pub fn read_traced_rays(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Option<u64>, GpuError> {
        Ok(self.read_traced_stats(device, queue)?.map(|s| s.rays))
    }

    /// What the last traced frame cast and whether the driver let it finish (stalls the
    /// GPU); None for the light grid's pass.
    pub fn read_traced_stats(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Option<TracedStats>, GpuError> {
        let Some(t) = &self.traced else { return Ok(None) };
        let words: Vec<u32> = read_buffer(device, queue, &t.stats)?;
        Ok(Some(TracedStats { rays: u64::from(words[0]) | u64::from(words[1]) << 32, cut: words[2] }))
    }

    /// An error naming the problem when the last traced frame's loops were cut short by
    /// the driver ([`TracedStats::cut`]); Ok for the light grid's pass and complete frames.
    pub fn check_traced_complete(&self, ctx: &tiledlight_gpu::GpuContext) -> Result<(), GpuError> {
        match self.read_traced_stats(&ctx.device, &ctx.queue)? {
            Some(s) if s.cut > 0 => Err(GpuError::Unsupported {
                adapter: ctx.info.name.clone(),
                what: format!(
                    "this traced frame: it cut {} invocations' loops short, so their pixels miss light or shadows \
                     (llvmpipe stops a shader's loops after 65,535 iterations in all, and a pixel's lights times \
                     their BVH traversals passed that); fewer lights or a smaller scene renders whole there, any \
                     GPU renders it",
                    s.cut
                ),
            }),
            _ => Ok(()),
        }
    }

    /// Writes the stochastic method's next frame (its seed, candidates, history length and
    /// whether a previous frame came) into its one band, and with temporal reuse the view
    /// the history was seen through, before the frame, seen through `view`, is recorded;
    /// nothing for the other passes.
    pub fn write_stochastic_frame(
        &self,
        queue: &wgpu::Queue,
        p: crate::stochastic::FrameParams,
        view: &tiledlight_gpu::view::ViewUniforms,
    ) {
        let Some(t) = self.traced.as_ref().filter(|t| t.history.is_some()) else { return };
        let previous = t.previous_view.replace(Some(*view)).filter(|_| p.previous);
        if let (Some(h), Some(v)) = (&t.history_records, &previous) {
            queue.write_buffer(h, 0, bytemuck::bytes_of(v));
        }
        let words = [p.frame, p.candidates, p.accumulated, p.far_candidates, u32::from(previous.is_some())];
        queue.write_buffer(&t.bands_buffer, 4, bytemuck::cast_slice(&words));
    }

    /// Refits the stochastic method's light tree to `lights` (moved or changed, the same
    /// count) and uploads it; nothing without a tree.
    pub fn refit_light_tree(&self, queue: &wgpu::Queue, lights: &tiledlight_cull::light::PackedLights) {
        let Some(t) = &self.traced else { return };
        let mut tree = t.tree.borrow_mut();
        if let Some(tree) = tree.as_mut().filter(|tree| tree.nodes.len() + 1 == 2 * lights.len()) {
            tree.refit(&tree_lights(lights));
            if let Some(buffer) = &t.light_tree {
                queue.write_buffer(buffer, 0, bytemuck::cast_slice(&tree.nodes));
            }
        }
    }

    /// The stochastic method's history (`[f32; 4]` a pixel: the mean light, the mean
    /// squared luminance over the albedo) and, with the denoiser, its guide (three planes of
    /// a `[f32; 4]` a pixel: surface, albedo, unlit); None for the other passes.
    pub fn stochastic_buffers(&self) -> Option<(&wgpu::Buffer, Option<&wgpu::Buffer>)> {
        let t = self.traced.as_ref()?;
        Some((t.history.as_ref()?, t.guide.as_ref()))
    }

    /// The stochastic method's reservoir records (`--reuse N` or `--temporal N` > 0: 32
    /// bytes a pixel, `tiledlight_cull::reuse::Record::pack`); None without reuse.
    pub fn stochastic_records(&self) -> Option<&wgpu::Buffer> {
        self.traced.as_ref()?.records.as_ref()
    }

    /// The temporal reuse's history (`--temporal N` > 0): the previous frame's view
    /// (`ViewUniforms`, [`Self::HISTORY_HEADER`] bytes), then each pixel's final record as
    /// [`Self::stochastic_records`] holds them; None without temporal reuse.
    pub fn stochastic_history_records(&self) -> Option<&wgpu::Buffer> {
        self.traced.as_ref()?.history_records.as_ref()
    }

    /// The stochastic method's light tree (`tiledlight_cull::light_tree::Node`s, the root
    /// first; one zero node without `--light-tree`); None for the other passes.
    pub fn stochastic_light_tree(&self) -> Option<&wgpu::Buffer> {
        self.traced.as_ref()?.light_tree.as_ref()
    }

    /// Bytes before the history's records ([`Self::stochastic_history_records`]).
    pub const HISTORY_HEADER: u64 = HISTORY_HEADER;

    /// The screen the pass shades, in pixels.
    pub fn screen(&self) -> (u32, u32) {
        self.screen
    }

    /// Bands a traced frame is cast in (None for the light grid's pass).
    pub fn traced_bands(&self) -> Option<u32> {
        self.traced.as_ref().map(|t| t.bands)
    }

    /// Records the MSAA resolve of the edge pixels (nothing without MSAA).
    pub fn record_resolve(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer) {
        if let Some(m) = &self.msaa {
            m.record_resolve(encoder, timer);
        }
    }

    /// Pixels of the last frame queued for per-sample shading (MSAA only; stalls the GPU).
    pub fn read_edge_pixels(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Option<u32>, GpuError> {
        self.msaa.as_ref().map(|m| m.read_edge_pixels(device, queue)).transpose()
    }

    /// The last frame's edge pixels (MSAA only; stalls the GPU), in no particular order.
    pub fn read_edge_list(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Vec<(u32, u32)>, GpuError> {
        self.msaa.as_ref().map_or(Ok(Vec::new()), |m| m.read_edge_list(device, queue))
    }
}
