//! The measurement lab's statistics, GPU path against CPU reference, on 320x180 frames of
//! the courtyard: the false-positive rate and wasted evaluations per pixel of the lists the
//! GPU culled (read back) equal those of the CPU reference culler's lists, and the lab's
//! statistics of the GPU's per-tile counts (`tiledlight_setup::culling_stats`, what
//! `render`, `sweep` and `accuracy` report) give the CPU's mean and maximum lights per
//! tile; the energy lost to the cutoff (image against the no-cutoff brute force) is
//! positive and shrinks as the threshold falls, and Forward+ loses exactly what brute
//! force with the cutoff loses.

use tiledlight_cull::reference::{list_quality, stats, tile_ranges};
use tiledlight_cull::{cull_tiles, TileLists};
use tiledlight_frame::{Diagnostics as _, FrameRenderer, FrameSettings, Method};
use tiledlight_gpu::culling::CullOptions;
use tiledlight_gpu::light_buffers::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::GpuContext;
use tiledlight_metrics::HdrError;
use tiledlight_scene::{random_lights, LightOptions, Scene};
use tiledlight_setup::culling_stats;
use tiledlight_tests::{gpu, scenes};

const W: u32 = 320;
const H: u32 = 180;

fn lights(scene: &Scene, n: u32, threshold: f32) -> Vec<tiledlight_cull::Light> {
    random_lights(&scene.bounds, &LightOptions { num_point: n, seed: 7, threshold, ..Default::default() }).unwrap()
}

fn renderer(
    ctx: &GpuContext,
    scene: &SceneGpu,
    lights: &LightBuffers,
    method: Method,
    cull: CullOptions,
) -> FrameRenderer {
    FrameRenderer::new(ctx, scene, lights, W, H, FrameSettings { method, cull, ..Default::default() }).unwrap()
}

#[test]
fn gpu_lists_give_the_cpu_false_positive_rate_and_wasted_evaluations() {
    let ctx = gpu();
    let scene = scenes::courtyard();
    let camera = scenes::courtyard_camera(&scene, W, H);
    let scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let lights = LightBuffers::new(&ctx.device, &lights(&scene, 256, 0.1)).unwrap();
    let mut timer = GpuTimer::new(ctx).unwrap();
    for options in [
        CullOptions { capacity: 256, ..Default::default() },
        CullOptions { capacity: 256, aabb: true, ..Default::default() },
        CullOptions { capacity: 256, half_z: true, tile_size: 8, ..Default::default() },
    ] {
        let mut r = renderer(ctx, &scene_gpu, &lights, Method::ForwardPlus, options);
        r.render_once(ctx, &mut timer, &scene_gpu, &camera).unwrap();
        let depth = r.read_depth(ctx).unwrap();
        let gpu_lists = r.read_lists(ctx).unwrap();
        assert_eq!(gpu_lists.overflowing, 0, "the test needs complete lists");
        let config = options.to_config(false);
        let cpu = cull_tiles(&depth, W, H, &camera, &lights.packed, &config).unwrap();
        let grid = cpu.grid;
        let from_gpu = TileLists {
            grid,
            config,
            lists: gpu_lists
                .lists
                .iter()
                .map(|l| {
                    let mut l = l.clone();
                    l.sort_unstable();
                    l
                })
                .collect(),
            ranges: tile_ranges(&depth, &grid, &camera).unwrap(),
            cluster: None,
        };
        let q_gpu = list_quality(&depth, &camera, &lights.packed, &from_gpu);
        let q_cpu = list_quality(&depth, &camera, &lights.packed, &cpu);
        eprintln!("{options:?}: GPU {q_gpu:?}\n  CPU {q_cpu:?}");
        assert!(q_cpu.pixels > (W * H / 2) as u64, "the frame must be mostly geometry");
        assert!(q_cpu.evaluated_per_pixel > 1.0, "lights must reach the frame");
        assert!(q_cpu.false_positive_rate > 0.0 && q_cpu.wasted_per_pixel > 0.0, "plane tests leave false positives");
        // The lists agree up to decisions within float error of a tile boundary
        // (cull_gpu_vs_cpu.rs); none has shown up on this frame, and the statistics must
        // agree to that precision.
        let pairs: usize = cpu.lists.iter().map(Vec::len).sum();
        let tol = 2.0 / pairs as f64;
        assert!((q_gpu.false_positive_rate - q_cpu.false_positive_rate).abs() <= tol, "false-positive rate");
        assert!((q_gpu.wasted_per_pixel - q_cpu.wasted_per_pixel).abs() <= 2.0 * W as f64 / q_cpu.pixels as f64);
        assert!((q_gpu.evaluated_per_pixel - q_cpu.evaluated_per_pixel).abs() <= 2.0 * W as f64 / q_cpu.pixels as f64);
        // The lab's statistics of the GPU's counts give the CPU's mean and maximum per list.
        let s = stats(&cpu);
        let lab = culling_stats(ctx, &r, &options).unwrap().expect("Forward+ has tile lists");
        let geometry = cpu.ranges.iter().filter(|r| r.is_some()).count();
        assert_eq!(lab.tiles_with_geometry, geometry, "tiles with geometry");
        let n = (geometry * options.lists_per_tile() as usize) as f64;
        assert!((lab.mean_per_list - s.mean_per_list).abs() <= 2.0 / n, "mean lights per list");
        assert_eq!(lab.max_per_list, s.max_per_list);
        assert_eq!(lab.max_per_list, gpu_lists.counts.iter().copied().max().unwrap());
        assert_eq!(lab.overflowing, 0);
    }
}

#[test]
fn energy_lost_to_the_cutoff_shrinks_with_the_threshold() {
    let ctx = gpu();
    let scene = scenes::courtyard();
    let camera = scenes::courtyard_camera(&scene, W, H);
    let scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, &scene).unwrap();
    let mut timer = GpuTimer::new(ctx).unwrap();
    let mut render = |lights: &LightBuffers, method: Method| {
        let mut r = renderer(ctx, &scene_gpu, lights, method, CullOptions { capacity: 128, ..Default::default() });
        r.render_once(ctx, &mut timer, &scene_gpu, &camera).unwrap();
        r.read_hdr(ctx).unwrap()
    };
    let reference = render(
        &LightBuffers::new(&ctx.device, &lights(&scene, 128, 0.1)).unwrap(),
        Method::BruteForce { cutoff: false },
    );
    let mut last = f64::INFINITY;
    for threshold in [0.4, 0.1, 0.01] {
        let lb = LightBuffers::new(&ctx.device, &lights(&scene, 128, threshold)).unwrap();
        let tiled = HdrError::of(&reference, &render(&lb, Method::ForwardPlus));
        let brute = HdrError::of(&reference, &render(&lb, Method::BruteForce { cutoff: true }));
        eprintln!("threshold {threshold}: Forward+ {tiled:?}, brute force with cutoff {brute:?}");
        assert!(tiled.energy_lost > 0.0 && tiled.energy_lost < 1.0, "{tiled:?}");
        assert!(tiled.energy_lost < last, "threshold {threshold}: energy lost did not shrink");
        // Culling is conservative: all the loss is the cutoff's.
        assert!((tiled.energy_lost - brute.energy_lost).abs() < 1e-4, "{tiled:?} vs {brute:?}");
        last = tiled.energy_lost;
    }
}
