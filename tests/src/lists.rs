//! GPU per-tile light lists against the CPU reference culler (`tiledlight_cull::cull_tiles`),
//! list for list, as sets: the one comparison every GPU culling test uses (Forward+'s culling
//! pass, Tiled Deferred's debug lists, with and without MSAA, and the GPU property test).
//!
//! Tolerance: CPU and GPU evaluate the same f32 formulas, but WGSL lets the GPU fuse
//! multiply-adds and divide within 2.5 ulp, so a light whose volume touches a tile within
//! float error may be decided differently. Such a light is accepted only if the CPU culler
//! run on every light grown by its float error lists it (or the one run on every light
//! shrunk by as much does not): the decision was within float error of the boundary. Any
//! other difference fails, and borderline decisions must stay under 0.1% of the pairs
//! ([`assert_lists_match`] per frame; the property test over all its cases).
//!
//! A light's float error ([`light_error`]) has three parts: [`INFLATE`] x (radius + view
//! distance), the tile planes' and tests' relative error; for orthographic cameras an ulp
//! budget of the depth range (`depth_error`); and [`WORLD_ULPS`] ulps of its
//! world coordinates and of the eye's, the world-to-view transform's rounding, which both
//! sides do from world coordinates (the GPU with fused multiply-adds): far from the origin
//! that is the larger one (1.5e-5 m at 170 m, where the GPU property test found a 0.5
//! degree spot 4.7 cm from a 0.17 mm tile decided differently, 1.4e-6 m from the boundary).
//! Growing a light moves its sphere's surface out by the error and, for a spot, its apex
//! back along the axis by error / sin(half-angle), which moves the cone's surface out by
//! the error everywhere (shrinking does the opposite).
//!
//! The comparison can fail: `tests/tests/negative.rs` feeds it GPU lists lacking one pair
//! of the frame's dimmest light, and lists with one wrong index, for tiles gathered and
//! scattered, half-z, 2.5D and clusters, and requires it to name the pair.

use std::collections::BTreeSet;

use glam::Vec3;
use tiledlight_cull::bounds::to_view;
use tiledlight_cull::light::PackedLights;
use tiledlight_cull::{cull_clusters, cull_tiles, Camera, ClusterConfig, CullConfig, TileLists};
use tiledlight_gpu::culling::GpuTileLists;

/// The relative part of a light's float error, as a fraction of `radius + |view centre|`.
pub const INFLATE: f32 = 1e-5;

/// The world-to-view part of a light's float error, in ulps (f32 epsilon) of
/// `|world position| + |eye|`: the bound `crates/cull/tests/common` uses for the same
/// transform's rounding (`near_spot_sphere_surface`: measured at most 1.54 there).
pub const WORLD_ULPS: f32 = 4.0;

/// How far light `i` of `lights` may be misplaced by float error, seen through `camera`
/// (metres; see the module docs).
pub fn light_error(camera: &Camera, lights: &PackedLights, i: usize) -> f32 {
    let c = Vec3::from(lights.cull[i].center);
    let view_centre = to_view(&camera.view(), c);
    let world = c.length().max(Vec3::from(lights.shading[i].position).length());
    INFLATE * (lights.cull[i].radius + view_centre.length())
        + WORLD_ULPS * f32::EPSILON * (world + camera.eye().length())
        + depth_error(camera)
}

/// The tile depth range's float error (metres): an orthographic depth is linear in view
/// distance, `near + (1 - d) (far - near)`, and the GPU's fused multiply-add rounds that
/// once where the CPU rounds twice, so a tile's near or far bound differs by up to an ulp
/// of `far - near` (measured on the H200 by the GPU property test: an orthographic camera
/// with far 9.1e5 m put a tile's bound centimetres from the CPU's, and a light touching
/// that bound was listed by the GPU alone). [`WORLD_ULPS`] of it, as for the transform.
/// Perspective depth gives the distance as `near / d`, a relative error of a few ulps,
/// inside [`INFLATE`].
fn depth_error(camera: &Camera) -> f32 {
    match camera.projection() {
        tiledlight_cull::Projection::Orthographic { near, far, .. } => WORLD_ULPS * f32::EPSILON * (far - near),
        tiledlight_cull::Projection::Perspective { .. } => 0.0,
    }
}

/// `lights` with every light grown (`sign` 1) or shrunk (-1) by its [`light_error`].
pub fn perturbed_lights(camera: &Camera, lights: &PackedLights, sign: f32) -> PackedLights {
    let mut out = lights.clone();
    for i in 0..lights.len() {
        let e = light_error(camera, lights, i);
        out.cull[i].radius = (lights.cull[i].radius + sign * e).max(0.0);
        let mut len = lights.shading[i].radius + sign * e;
        if i >= lights.num_point as usize {
            let spot = lights.spots[i - lights.num_point as usize];
            let shift = e / spot.sin_outer;
            let apex = Vec3::from(lights.shading[i].position) - sign * shift * Vec3::from(spot.direction);
            out.shading[i].position = apex.to_array();
            // The cap stays as far out as the grown (or shrunk) sphere's.
            len += sign * shift;
        }
        out.shading[i].radius = len.max(0.0);
    }
    out
}

/// The frame a GPU pass culled: its depth buffer as read back (`samples` values per pixel,
/// pixel-major, as `CullConfig::samples` says), camera and lights as uploaded.
#[derive(Clone, Copy)]
pub struct CulledFrame<'a> {
    /// Reversed-Z depth, row-major.
    pub depth: &'a [f32],
    /// Screen width in pixels.
    pub width: u32,
    /// Screen height in pixels.
    pub height: u32,
    /// The camera of the frame.
    pub camera: &'a Camera,
    /// The lights as uploaded (`LightBuffers::packed`).
    pub lights: &'a PackedLights,
}

/// What a comparison counted.
#[derive(Clone, Debug)]
pub struct ListComparison {
    /// (list, light) pairs of the CPU lists.
    pub pairs: usize,
    /// Pairs decided differently by the GPU, each within float error of the boundary.
    pub borderline: usize,
    /// Lists with at least one light.
    pub nonempty_lists: usize,
    /// The CPU reference lists (for ground-truth checks on the same frame).
    pub cpu: TileLists,
}

/// Compares `gpu` with the CPU culler run on `frame` with `config` (which must match the
/// GPU pass's options, samples included). Returns the first difference that is not within
/// float error as an error naming `label`, the list and the light; does not check the
/// borderline rate (see [`assert_lists_match`]).
pub fn compare_lists(
    label: &str,
    frame: &CulledFrame<'_>,
    gpu: &GpuTileLists,
    config: &CullConfig,
) -> Result<ListComparison, String> {
    compare_lists_with(label, frame, gpu, config, Twin::Tiles)
}

/// [`compare_lists`] for a clustered grid: the CPU twin is `tiledlight_cull::cull_clusters`
/// with `cluster` (and `config`'s samples).
pub fn compare_cluster_lists(
    label: &str,
    frame: &CulledFrame<'_>,
    gpu: &GpuTileLists,
    config: &CullConfig,
    cluster: &ClusterConfig,
) -> Result<ListComparison, String> {
    compare_lists_with(label, frame, gpu, config, Twin::Clusters(*cluster))
}

/// [`compare_cluster_lists`], with [`assert_lists_match`]'s checks.
pub fn assert_cluster_lists_match(
    label: &str,
    frame: &CulledFrame<'_>,
    gpu: &GpuTileLists,
    config: &CullConfig,
    cluster: &ClusterConfig,
) -> ListComparison {
    let c = compare_cluster_lists(label, frame, gpu, config, cluster).unwrap_or_else(|e| panic!("{e}"));
    check_and_print(label, gpu, c)
}

/// Which CPU culler is the twin.
enum Twin<'a> {
    /// `cull_tiles`.
    Tiles,
    /// `cull_tiles_blended` with this blended depth buffer (as drawn).
    Blended(&'a [f32]),
    /// `cull_clusters`.
    Clusters(ClusterConfig),
}

/// [`compare_lists`] for the lists of blended geometry: the CPU twin is
/// `cull_tiles_blended` of `frame`'s opaque depth and the GPU's `blended` depth buffer
/// (read back as drawn, not depth-tested: see `depth_tested_blended`).
pub fn compare_blended_lists(
    label: &str,
    frame: &CulledFrame<'_>,
    blended: &[f32],
    gpu: &GpuTileLists,
    config: &CullConfig,
) -> Result<ListComparison, String> {
    compare_lists_with(label, frame, gpu, config, Twin::Blended(blended))
}

fn compare_lists_with(
    label: &str,
    frame: &CulledFrame<'_>,
    gpu: &GpuTileLists,
    config: &CullConfig,
    twin: Twin<'_>,
) -> Result<ListComparison, String> {
    let tested = match twin {
        Twin::Blended(b) => Some(tiledlight_cull::volumes::depth_tested_blended(frame.depth, b)),
        _ => None,
    };
    let cull = |lights: &PackedLights| {
        let config = CullConfig { inflate: 0.0, ..*config };
        let (depth, w, h, cam) = (frame.depth, frame.width, frame.height, frame.camera);
        match (&tested, &twin) {
            (Some(b), _) => tiledlight_cull::cull_tiles_blended(depth, b, w, h, cam, lights, &config),
            (None, Twin::Clusters(c)) => cull_clusters(depth, w, h, cam, lights, c, config.samples, 0.0),
            (None, _) => cull_tiles(depth, w, h, cam, lights, &config),
        }
        .map_err(|e| format!("{label}: CPU culler refused the frame: {e}"))
    };
    let cpu = cull(frame.lights)?;
    let grown = cull(&perturbed_lights(frame.camera, frame.lights, 1.0))?;
    let shrunk = cull(&perturbed_lights(frame.camera, frame.lights, -1.0))?;
    let fail = |msg: String| Err(format!("{label}: {msg}"));
    if gpu.counts.len() != cpu.lists.len() || gpu.lists.len() != cpu.lists.len() {
        return fail(format!(
            "{} GPU counts and {} GPU lists, {} CPU lists",
            gpu.counts.len(),
            gpu.lists.len(),
            cpu.lists.len()
        ));
    }
    let (mut pairs, mut borderline, mut nonempty_lists, mut truncated) = (0, 0, 0, 0u32);
    for (i, cpu_list) in cpu.lists.iter().enumerate() {
        let gpu_set: BTreeSet<u32> = gpu.lists[i].iter().copied().collect();
        if gpu_set.len() != gpu.lists[i].len() {
            return fail(format!("list {i} has duplicates: {:?}", gpu.lists[i]));
        }
        let count = gpu.counts[i] as usize;
        let cpu_set: BTreeSet<u32> = cpu_list.iter().copied().collect();
        let hi: BTreeSet<u32> = grown.lists[i].iter().copied().collect();
        let lo: BTreeSet<u32> = shrunk.lists[i].iter().copied().collect();
        pairs += cpu_set.len();
        nonempty_lists += usize::from(!cpu_set.is_empty());
        if gpu_set.len() < count {
            // The light grid was full: which lights the list kept depends on the order
            // lists were allocated in; they must all be real members and the count must
            // be the true one.
            truncated += 1;
            if !gpu_set.is_subset(&hi) {
                return fail(format!("truncated list {i} stored a light the CPU never lists"));
            }
            if count.abs_diff(cpu_set.len()) > hi.len() - lo.len() {
                return fail(format!("list {i} count {count} vs CPU {}", cpu_set.len()));
            }
            continue;
        }
        if count != gpu_set.len() {
            return fail(format!("list {i} count {count} vs {} stored", gpu_set.len()));
        }
        for l in gpu_set.symmetric_difference(&cpu_set) {
            let gpu_has = gpu_set.contains(l);
            let within_float_error = if gpu_has { hi.contains(l) } else { !lo.contains(l) };
            if !within_float_error {
                return fail(format!(
                    "list {i}: light {l} {} by the GPU only, and not within float error of the boundary \
                     (GPU {gpu_set:?}, CPU {cpu_set:?})",
                    if gpu_has { "listed" } else { "dropped" }
                ));
            }
            borderline += 1;
        }
    }
    // The header's tally of lists that lost lights is the lists found short here.
    if gpu.overflowing != truncated {
        return fail(format!("the grid header counts {} truncated lists, the lists show {truncated}", gpu.overflowing));
    }
    let counted: u64 = gpu.counts.iter().map(|&c| u64::from(c)).sum();
    if counted != u64::from(gpu.pairs) {
        return fail(format!("the grid header counts {} pairs, the lists {counted}", gpu.pairs));
    }
    Ok(ListComparison { pairs, borderline, nonempty_lists, cpu })
}

/// [`compare_lists`], panicking on a difference or when borderline decisions exceed 0.1%
/// of the pairs; prints the counts.
pub fn assert_lists_match(
    label: &str,
    frame: &CulledFrame<'_>,
    gpu: &GpuTileLists,
    config: &CullConfig,
) -> ListComparison {
    let c = compare_lists(label, frame, gpu, config).unwrap_or_else(|e| panic!("{e}"));
    check_and_print(label, gpu, c)
}

/// [`compare_blended_lists`], with [`assert_lists_match`]'s checks.
pub fn assert_blended_lists_match(
    label: &str,
    frame: &CulledFrame<'_>,
    blended: &[f32],
    gpu: &GpuTileLists,
    config: &CullConfig,
) -> ListComparison {
    let c = compare_blended_lists(label, frame, blended, gpu, config).unwrap_or_else(|e| panic!("{e}"));
    check_and_print(label, gpu, c)
}

fn check_and_print(label: &str, gpu: &GpuTileLists, c: ListComparison) -> ListComparison {
    assert!(
        c.borderline * 1000 <= c.pairs.max(1),
        "{label}: {} borderline decisions of {} pairs",
        c.borderline,
        c.pairs
    );
    eprintln!(
        "{label}: {} pairs in {} lists, {} borderline, {} truncated (grid full), {} spilled past the workgroup list",
        c.pairs, c.nonempty_lists, c.borderline, gpu.overflowing, gpu.status.header.spilled_lists
    );
    c
}

/// What [`compare_blended_lists_independent`] counted.
#[derive(Clone, Debug)]
pub struct BoundedComparison {
    /// (list, light) pairs of the CPU lists from the exact raster.
    pub pairs: usize,
    /// Lists with a light the GPU must hold (the lower bound's non-empty lists).
    pub certain_lists: usize,
    /// Pairs the bounds leave open (in the upper bound, not the lower): silhouettes within
    /// the raster's reach, or lights within float error.
    pub open_pairs: usize,
    /// GPU pairs that differ from the exact raster's lists (each inside the bounds).
    pub off_exact: usize,
}

/// The GPU's blended lists against lists culled from a blended depth buffer rasterised
/// independently on the CPU (`tiledlight_cull::blended_depth::raster_depth` of the blended
/// instances' triangles, not the GPU's blended depth), depth-tested against `frame`'s
/// opaque depth as the GPU's kernel does (`depth_tested_blended`).
///
/// The raster gives each sample a least and a most depth (coverage and depth a GPU
/// rasterising within the raster's reach may produce), and the blended culler is monotone
/// in both (more samples or nearer ones only widen a tile's range) and in the lights' size,
/// so every list must hold the CPU list of the least depths with every light shrunk by its
/// float error ([`perturbed_lights`]) and lie within the CPU list of the most depths with
/// every light grown. Any other difference fails, naming the list and light. Truncated
/// lists (a full grid) fail too: this check needs complete lists.
pub fn compare_blended_lists_independent(
    label: &str,
    frame: &CulledFrame<'_>,
    raster: &tiledlight_cull::blended_depth::DepthBounds,
    gpu: &GpuTileLists,
    config: &CullConfig,
) -> Result<BoundedComparison, String> {
    use tiledlight_cull::cull_tiles_blended;
    use tiledlight_cull::volumes::depth_tested_blended;
    let fail = |msg: String| Err(format!("{label}: {msg}"));
    let n = frame.depth.len();
    if raster.exact.len() != n || raster.least.len() != n || raster.most.len() != n {
        return fail(format!("the raster holds {} samples, the opaque depth {n}", raster.exact.len()));
    }
    let config = CullConfig { inflate: 0.0, ..*config };
    let cull = |blended: &[f32], lights: &PackedLights| {
        let tested = depth_tested_blended(frame.depth, blended);
        cull_tiles_blended(frame.depth, &tested, frame.width, frame.height, frame.camera, lights, &config)
            .map_err(|e| format!("{label}: CPU culler refused the frame: {e}"))
    };
    let exact = cull(&raster.exact, frame.lights)?;
    let lower = cull(&raster.least, &perturbed_lights(frame.camera, frame.lights, -1.0))?;
    let upper = cull(&raster.most, &perturbed_lights(frame.camera, frame.lights, 1.0))?;
    if gpu.counts.len() != exact.lists.len() || gpu.lists.len() != exact.lists.len() {
        return fail(format!("{} GPU lists, {} CPU lists", gpu.lists.len(), exact.lists.len()));
    }
    if gpu.overflowing > 0 {
        return fail(format!("{} GPU lists were truncated (grid full): grow the grid first", gpu.overflowing));
    }
    let (mut pairs, mut certain_lists, mut open_pairs, mut off_exact) = (0, 0, 0, 0);
    for (i, exact_list) in exact.lists.iter().enumerate() {
        let gpu_set: BTreeSet<u32> = gpu.lists[i].iter().copied().collect();
        if gpu_set.len() != gpu.lists[i].len() || gpu.counts[i] as usize != gpu_set.len() {
            return fail(format!("list {i}: count {} for {:?}", gpu.counts[i], gpu.lists[i]));
        }
        let lo: BTreeSet<u32> = lower.lists[i].iter().copied().collect();
        let hi: BTreeSet<u32> = upper.lists[i].iter().copied().collect();
        let ex: BTreeSet<u32> = exact_list.iter().copied().collect();
        if let Some(l) = lo.difference(&gpu_set).next() {
            return fail(format!(
                "list {i} lacks light {l}, which reaches the range of blended samples the raster says the \
                 GPU must have drawn there (GPU {gpu_set:?}, at least {lo:?})"
            ));
        }
        if let Some(l) = gpu_set.difference(&hi).next() {
            return fail(format!(
                "list {i} holds light {l}, which reaches no range the GPU's blended samples can have there \
                 (GPU {gpu_set:?}, at most {hi:?})"
            ));
        }
        pairs += ex.len();
        certain_lists += usize::from(!lo.is_empty());
        open_pairs += hi.len() - lo.len();
        off_exact += gpu_set.symmetric_difference(&ex).count();
    }
    let counted: u64 = gpu.counts.iter().map(|&c| u64::from(c)).sum();
    if counted != u64::from(gpu.pairs) {
        return fail(format!("the grid header counts {} pairs, the lists {counted}", gpu.pairs));
    }
    Ok(BoundedComparison { pairs, certain_lists, open_pairs, off_exact })
}
