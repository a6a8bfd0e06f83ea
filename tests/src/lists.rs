//! GPU per-tile light lists against the CPU reference culler (`tiledlight_cull::cull_tiles`),
//! list for list, as sets: the one comparison every GPU culling test uses (Forward+'s culling
//! pass, Tiled Deferred's debug lists, with and without MSAA, and the GPU property test).
//!
//! Tolerance: CPU and GPU evaluate the same f32 formulas, but WGSL lets the GPU fuse
//! multiply-adds and divide within 2.5 ulp, so a light whose sphere touches a plane within
//! float error may be decided differently. Such a light is accepted only if the CPU culler
//! with radii grown by [`INFLATE`] x (radius + distance) lists it (or the one shrunk by as
//! much does not): the decision was within float error of the boundary. Any other
//! difference fails, and borderline decisions must stay under 0.1% of the pairs
//! ([`assert_lists_match`] per frame; the property test over all its cases).

use std::collections::BTreeSet;

use tiledlight_cull::light::PackedLights;
use tiledlight_cull::{cull_tiles, Camera, CullConfig, TileLists};
use tiledlight_gpu::light_cull::GpuTileLists;

/// How far the CPU culler grows and shrinks every radius, as a fraction of
/// `radius + |centre|`, to find decisions within float error of the boundary.
pub const INFLATE: f32 = 1e-5;

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
    let cull = |inflate: f32| {
        cull_tiles(
            frame.depth,
            frame.width,
            frame.height,
            frame.camera,
            frame.lights,
            &CullConfig { inflate, ..*config },
        )
        .map_err(|e| format!("{label}: CPU culler refused the frame: {e}"))
    };
    let cpu = cull(0.0)?;
    let grown = cull(INFLATE)?;
    let shrunk = cull(-INFLATE)?;
    let fail = |msg: String| Err(format!("{label}: {msg}"));
    if gpu.counts.len() != cpu.lists.len() || gpu.lists.len() != cpu.lists.len() {
        return fail(format!(
            "{} GPU counts and {} GPU lists, {} CPU lists",
            gpu.counts.len(),
            gpu.lists.len(),
            cpu.lists.len()
        ));
    }
    let cap = config.capacity as usize;
    let (mut pairs, mut borderline, mut nonempty_lists) = (0, 0, 0);
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
        if count > cap {
            // Overflow: which `cap` lights the GPU kept depends on thread timing; they must
            // all be real members and the count must be the true one.
            if gpu_set.len() != cap {
                return fail(format!("overflowing list {i} stores {} indices, not the capacity {cap}", gpu_set.len()));
            }
            if !gpu_set.is_subset(&hi) {
                return fail(format!("overflowing list {i} stored a light the CPU never lists"));
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
    let cpu_overflow = cpu.overflowing_lists() as u32;
    if gpu.overflowing.abs_diff(cpu_overflow) as usize > borderline {
        return fail(format!("overflow {} vs CPU {cpu_overflow}", gpu.overflowing));
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
    assert!(
        c.borderline * 1000 <= c.pairs.max(1),
        "{label}: {} borderline decisions of {} pairs",
        c.borderline,
        c.pairs
    );
    eprintln!(
        "{label}: {} pairs in {} lists, {} borderline, {} overflowing",
        c.pairs, c.nonempty_lists, c.borderline, gpu.overflowing
    );
    c
}
