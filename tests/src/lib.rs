//! GPU integration-test harness for tiledlight, run on lavapipe in CI.
//!
//! [`gpu`] shares one device per test process, on the adapter named by `WGPU_ADAPTER_NAME` (failing, never
//! skipping, when none exists); [`scenes`] builds small test scenes, cameras and lights;
//! [`compare`] holds the comparisons with the brute-force reference as functions (their
//! tolerances stated once); [`subpixel`] measures what one step of the rasteriser's
//! sub-pixel grid does to a textured reference; [`lists`] compares GPU per-tile light lists with the CPU
//! reference culler; [`kernels`] runs a WGSL function over test cases for its twin test;
//! [`images`] compares images with nv-flip (mean and percentile thresholds) and writes
//! `-actual.png` / `-difference.png` next to the test output on failure. Depends on every
//! tiledlight crate; nothing depends on it.

pub mod compare;
pub mod gbuffer;
pub mod images;
pub mod kernels;
pub mod lists;
pub mod scenes;
pub mod subpixel;
pub mod textured;

use tiledlight_gpu::{ContextOptions, GpuContext};

/// The test process's one device, created on first use and shared by every test of the
/// process (`cargo test` runs a file's tests as threads of one process; nextest runs each
/// in its own). One device per case exhausted the H200's driver: after a few dozen
/// devices, instance creation found no adapter at all. Panics with the reason when no
/// adapter exists: a GPU test must fail, not pass silently, on a machine without Vulkan
/// (install mesa-vulkan-drivers).
pub fn gpu() -> &'static GpuContext {
    static CONTEXT: std::sync::OnceLock<GpuContext> = std::sync::OnceLock::new();
    CONTEXT.get_or_init(|| match GpuContext::headless(ContextOptions::default()) {
        Ok(ctx) => {
            eprintln!("adapter: {}", ctx.describe());
            ctx
        }
        Err(e) => panic!("GPU tests need an adapter: {e}"),
    })
}

/// Directory for failure artefacts (`target/test-output`).
pub fn output_dir() -> std::path::PathBuf {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/test-output");
    std::fs::create_dir_all(&dir).expect("create target/test-output");
    dir
}

/// Whether `ctx` runs on lavapipe (Mesa's CPU Vulkan, what CI has). Some expectations are
/// per adapter, as in wgpu's own test suite: lavapipe runs a workgroup's threads in order
/// and filters textures its own way, so results that a parallel GPU may legitimately
/// vary (the order of atomically appended lights, texture-filter precision) are exact or
/// tighter there. Each test that asks says why.
pub fn is_lavapipe(ctx: &GpuContext) -> bool {
    ctx.info.name.to_lowercase().contains("llvmpipe")
}

/// The sample counts (of 1, 2, 4, 8) both methods' targets can multisample on `ctx`
/// (`targets::check_msaa` over the depth, HDR and Tiled Deferred G-buffer formats), each
/// count of 2, 4 and 8 it lacks printed (never skipped silently). lavapipe: 1x and 4x.
pub fn adapter_sample_counts(ctx: &GpuContext) -> Vec<u32> {
    use tiledlight_deferred::gbuffer::SURFACE_FORMAT;
    use tiledlight_gpu::depth_prepass::DEPTH_FORMAT;
    use tiledlight_gpu::tonemap::HDR_FORMAT;
    let formats = [DEPTH_FORMAT, HDR_FORMAT, SURFACE_FORMAT];
    let counts: Vec<u32> =
        [1, 2, 4, 8].into_iter().filter(|&n| tiledlight_gpu::targets::check_msaa(ctx, n, &formats).is_ok()).collect();
    for n in [2, 4, 8] {
        if !counts.contains(&n) {
            eprintln!("MSAA {n}x: the adapter ({}) lacks it: not rendered here", ctx.info.name);
        }
    }
    counts
}

/// The error message of `r`, which must be an error (bad-input tests assert what it names).
pub fn err_text<T>(r: Result<T, impl std::fmt::Display>) -> String {
    match r {
        Ok(_) => panic!("expected an error"),
        Err(e) => e.to_string(),
    }
}

/// The visibility buffer's rasters a test draws at `msaa` samples, named explicitly (the
/// default, `Raster::Auto`, picks one per adapter: a test of both must not depend on it):
/// the hardware's at every count, the compute raster at one sample (it draws one; the
/// adapter must have its 64-bit atomics, or the test fails naming them).
pub fn visibility_rasters(msaa: u32) -> Vec<tiledlight_gpu::features::Raster> {
    use tiledlight_gpu::features::Raster;
    if msaa == 1 {
        vec![Raster::Hardware, Raster::Compute]
    } else {
        vec![Raster::Hardware]
    }
}
