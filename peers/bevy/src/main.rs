//! bevy-peer: renders a glTF file written by `tiledlight export` with Bevy's own glTF
//! loader, its forward renderer (clustered lights, GPU clustering where the adapter has
//! compute) or its deferred one (`--deferred`), headless into an image, and prints GPU
//! times as JSON: per pass (Bevy's `RenderDiagnosticsPlugin`, timestamp queries), the
//! whole frame from its first command to its last (bevy-peer's own two timestamps, which
//! also hold the passes Bevy leaves untimed, e.g. the deferred lighting pass), the CPU time
//! of Bevy's prepare phase (where its per-frame uploads are built and queued), the GPU time
//! of one copy of its cluster index list's bytes (the upload's copy, timed apart once), and
//! the CPU frame time; medians with min and max over `--frames` frames after `--warmup`. Writes
//! the JSON and the last frame as PNG into `--out`.
//!
//! What it changes from Bevy's defaults, and why (all printed in the JSON's `notes`):
//! - the glTF camera hands over to a camera of bevy-peer's at its transform and projection,
//!   rendering into an image (no window) at `--width` x `--height` (the glTF camera itself,
//!   re-targeted, rendered nothing);
//! - light colours: Bevy 0.19's glTF loader reads `KHR_lights_punctual` colours as sRGB
//!   (`Color::srgb_from_array`), the specification says linear: the colour is
//!   re-read as linear so Bevy gets tiledlight's colour;
//! - spot lights: the loader sets a spot's source radius to its range (a soft-light size
//!   of metres); it is reset to 0 like point lights (punctual, as in tiledlight);
//! - exposure and ambient light come from the camera node's `extras.tiledlight`
//!   (tiledlight's fixed exposure; `--exposure` overrides it) so both renderers map the
//!   same radiance to the same pixel value before tonemapping;
//! - intensity needs no change: the loader turns candela into lumens (x 4 pi) and the
//!   renderer back into candela (/ 4 pi); Bevy's range falloff is tiledlight's window
//!   `saturate(1 - (d/r)^4)^2 / max(d^2, 1e-4)`;
//! - pipeline-statistics queries are off (`WgpuSettings::disabled_features`): Bevy's
//!   diagnostics would otherwise run one around every pass, which tiledlight does not.
//! What stays Bevy's default unless a flag says otherwise: 4x MSAA (`--msaa`), the
//! TonyMcMapface tonemapper (`--tonemapping aces` for ACES fitted), no depth prepass
//! (`--depth-prepass`), forward rendering (`--deferred`), and the cluster grid
//! (`ClusterConfig::default()`: 4,096 clusters in 24 Z slices, the first to 5 m, the last
//! to the farthest light's range, resized when the index count passes 16,384); the grid
//! flags are `--clusters TOTAL`, `--cluster-px P`, `--z-slices S`, `--first-slice-depth M`,
//! `--far-z max|M`, `--max-indices N`, `--fixed-clusters`.
//!
//! Usage: bevy-peer --gltf FILE --width W --height H --frames N --warmup M --out DIR
//!        [--exposure E] [--msaa 1|2|4|8] [--tonemapping default|aces|none]
//!        [--depth-prepass] [--deferred] [--name NAME] [--max-frames F] [grid flags]

// The report's json! literal has more fields than the default limit expands.
#![recursion_limit = "256"]

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use bevy::app::{AppExit, ScheduleRunnerPlugin};
use bevy::camera::{Exposure, RenderTarget};
use bevy::core_pipeline::prepass::{DeferredPrepass, DepthPrepass};
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::diagnostic::DiagnosticsStore;
use bevy::gltf::GltfExtras;
use bevy::image::TextureFormatPixelInfo;
use bevy::light::cluster::{ClusterConfig, ClusterFarZMode, ClusterZConfig, Clusters, GlobalClusterSettings};
use bevy::pbr::{DefaultOpaqueRendererMethod, ViewClusterBindings};
use bevy::prelude::*;
use bevy::render::diagnostic::RenderDiagnosticsPlugin;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::{
    Buffer, BufferDescriptor, BufferUsages, CommandEncoderDescriptor, MapMode, PollType, TexelCopyBufferInfo,
    TexelCopyBufferLayout, TextureFormat, TextureUsages,
};
use bevy::render::renderer::{
    RenderAdapterInfo, RenderContext, RenderDevice, RenderGraph, RenderGraphSystems, RenderQueue,
};
use bevy::render::settings::{RenderCreation, WgpuFeatures, WgpuSettings};
use bevy::render::view::Msaa;
use bevy::render::{Extract, Render, RenderApp, RenderPlugin, RenderSystems};
use bevy::window::ExitCondition;
use crossbeam_channel::{Receiver, Sender};
use serde_json::{Value, json};

/// Frames after the measured ones during which late timestamp read-backs are still taken.
const READBACK_LAG: u32 = 8;

#[derive(Clone, Debug, Resource)]
struct Args {
    gltf: PathBuf,
    width: u32,
    height: u32,
    frames: u32,
    warmup: u32,
    out: PathBuf,
    exposure: Option<f32>,
    msaa: u32,
    tonemapping: String,
    depth_prepass: bool,
    name: String,
    /// Give up (exit 1) when the scene has not loaded and rendered after this many frames.
    max_frames: u32,
    /// Initial capacities of Bevy's GPU clustering lists (Z slices, light indices); Bevy's
    /// own (1,024 and 65,536) when not given. Bevy grows a list after reading an overflow
    /// back, with "a few incorrect frames" (lights missing) meanwhile, so a run logs when
    /// its measured frames start and end and `scripts/peer-bench.sh` checks that no resize
    /// fell between them. Not sized generously by default: Bevy uploads a zeroed index
    /// list of its full capacity from the CPU every frame (16M entries cost 117 ms a frame).
    z_slice_capacity: Option<u32>,
    index_capacity: Option<u32>,
    /// Bevy's `ClusterConfig::FixedZ` total (24 Z slices, square clusters); Bevy's 4,096
    /// when not given. More clusters are smaller ones: shorter lists for small lights.
    clusters: Option<u32>,
    /// Turn off Bevy's dynamic resizing of the cluster grid. With it on (Bevy's default),
    /// Bevy shrinks the grid in X and Y whenever last frame's (cluster, light) index count
    /// passed `view_cluster_bindings_max_indices` (16,384, a uniform-buffer-era limit that
    /// also holds with GPU clustering): at 100,000 lights a request for 65,536 clusters
    /// became 12x7x24 (160 px clusters).
    fixed_clusters: bool,
    /// Bevy's `ClusterConfig::XYZ` with clusters of about this many pixels (the grid is
    /// ceil(width / px) x ceil(height / px) x `--z-slices`); overrides `--clusters`.
    cluster_px: Option<u32>,
    /// Z slices of the grid (Bevy's default 24).
    z_slices: Option<u32>,
    /// Far end of the first Z slice, metres (Bevy's default 5).
    first_slice_depth: Option<f32>,
    /// The far end of the last slice: Bevy's default `MaxClusterableObjectRange` (None) or
    /// a constant depth in metres.
    far_z: Option<f32>,
    /// `GlobalClusterSettings::view_cluster_bindings_max_indices`: the (cluster, light)
    /// index count past which dynamic resizing coarsens the grid (Bevy: 16,384).
    max_indices: Option<u32>,
    /// Bevy's deferred renderer (`DefaultOpaqueRendererMethod::deferred()`, the camera
    /// with `DeferredPrepass` and `DepthPrepass`) instead of its forward one.
    deferred: bool,
}

fn usage() -> ! {
    eprintln!(
        "usage: bevy-peer --gltf FILE --width W --height H --frames N --warmup M --out DIR \
         [--exposure E] [--msaa 1|2|4|8] [--tonemapping default|aces|none] [--depth-prepass] \
         [--name NAME] [--max-frames F] [--z-slice-capacity N] [--index-capacity N] [--clusters TOTAL] \
         [--cluster-px P] [--z-slices S] [--first-slice-depth M] [--far-z max|M] [--max-indices N] \
         [--fixed-clusters] [--deferred]"
    );
    std::process::exit(2)
}

/// A finite number above zero, or exit 1 naming the flag.
fn positive(flag: &str, v: &str) -> f32 {
    match v.parse::<f32>() {
        Ok(x) if x.is_finite() && x > 0.0 => x,
        _ => fail(&format!("{flag} {v}: must be a positive number")),
    }
}

fn fail(msg: &str) -> ! {
    eprintln!("error: {msg}");
    std::process::exit(1)
}

fn parse_args() -> Args {
    let mut a = Args {
        gltf: PathBuf::new(),
        width: 1920,
        height: 1080,
        frames: 100,
        warmup: 20,
        out: PathBuf::from("bevy-out"),
        exposure: None,
        msaa: 4,
        tonemapping: "default".into(),
        depth_prepass: false,
        name: "bevy".into(),
        max_frames: 2000,
        z_slice_capacity: None,
        index_capacity: None,
        clusters: None,
        fixed_clusters: false,
        cluster_px: None,
        z_slices: None,
        first_slice_depth: None,
        far_z: None,
        max_indices: None,
        deferred: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        if flag == "--depth-prepass" {
            a.depth_prepass = true;
            continue;
        }
        if flag == "--fixed-clusters" {
            a.fixed_clusters = true;
            continue;
        }
        if flag == "--deferred" {
            a.deferred = true;
            continue;
        }
        if flag == "--help" || flag == "-h" {
            usage();
        }
        let Some(v) = it.next() else { usage() };
        let num = |v: &str| v.parse::<u32>().unwrap_or_else(|_| fail(&format!("{flag} {v}: not a whole number")));
        match flag.as_str() {
            "--gltf" => a.gltf = PathBuf::from(v),
            "--width" => a.width = num(&v),
            "--height" => a.height = num(&v),
            "--frames" => a.frames = num(&v),
            "--warmup" => a.warmup = num(&v),
            "--out" => a.out = PathBuf::from(v),
            "--exposure" => a.exposure = Some(positive(&flag, &v)),
            "--msaa" => a.msaa = num(&v),
            "--tonemapping" => a.tonemapping = v,
            "--name" => a.name = v,
            "--max-frames" => a.max_frames = num(&v),
            "--z-slice-capacity" => a.z_slice_capacity = Some(num(&v)),
            "--index-capacity" => a.index_capacity = Some(num(&v)),
            "--clusters" => a.clusters = Some(num(&v)),
            "--cluster-px" => a.cluster_px = Some(num(&v)),
            "--z-slices" => a.z_slices = Some(num(&v)),
            "--first-slice-depth" => a.first_slice_depth = Some(positive(&flag, &v)),
            "--far-z" => a.far_z = if v == "max" { None } else { Some(positive(&flag, &v)) },
            "--max-indices" => a.max_indices = Some(num(&v)),
            _ => usage(),
        }
    }
    if a.gltf.as_os_str().is_empty() {
        usage();
    }
    if !a.gltf.is_file() {
        fail(&format!("--gltf {}: no such file", a.gltf.display()));
    }
    if a.width == 0 || a.height == 0 || a.width > 8192 || a.height > 8192 {
        fail(&format!("--width {} --height {}: each must be 1 to 8192", a.width, a.height));
    }
    if a.frames == 0 {
        fail("--frames 0: at least one frame must be measured");
    }
    if ![1, 2, 4, 8].contains(&a.msaa) {
        fail(&format!("--msaa {}: must be 1, 2, 4 or 8", a.msaa));
    }
    if !["default", "aces", "none"].contains(&a.tonemapping.as_str()) {
        fail(&format!("--tonemapping {}: must be default, aces or none", a.tonemapping));
    }
    if a.deferred && a.msaa != 1 {
        fail("--deferred: Bevy's deferred renderer has no MSAA; give --msaa 1");
    }
    if a.cluster_px == Some(0) || a.z_slices == Some(0) {
        fail("--cluster-px and --z-slices must be at least 1");
    }
    if a.max_indices == Some(0) {
        fail("--max-indices 0: must be at least 1");
    }
    a.gltf = a.gltf.canonicalize().unwrap_or_else(|e| fail(&format!("--gltf {}: {e}", a.gltf.display())));
    a
}

fn main() {
    let args = parse_args();
    std::fs::create_dir_all(&args.out).unwrap_or_else(|e| fail(&format!("--out {}: {e}", args.out.display())));
    let asset_dir = args.gltf.parent().expect("a canonical file path has a parent").to_path_buf();
    let wgpu = WgpuSettings {
        // The timestamp features the render diagnostics and the frame timer need (Vulkan
        // has them; Bevy also asks for every adapter feature by default).
        features: WgpuFeatures::TIMESTAMP_QUERY | WgpuFeatures::TIMESTAMP_QUERY_INSIDE_ENCODERS,
        // Bevy's render diagnostics also run a pipeline-statistics query around every
        // pass when the adapter has them; tiledlight runs none, so neither does the peer.
        disabled_features: Some(WgpuFeatures::PIPELINE_STATISTICS_QUERY),
        ..default()
    };
    let (tx, rx) = crossbeam_channel::unbounded();
    let (timer_tx, timer_rx) = crossbeam_channel::unbounded();
    let mut app = App::new();
    if args.deferred {
        // Every StandardMaterial (the glTF's, `OpaqueRendererMethod::Auto`) goes deferred.
        app.insert_resource(DefaultOpaqueRendererMethod::deferred());
    }
    app.insert_resource(args.clone())
        .insert_resource(ClearColor(Color::BLACK))
        .insert_resource(Run::default())
        .insert_resource(MainWorldReceiver(rx))
        .insert_resource(TimerReceiver(timer_rx))
        .add_plugins(
            DefaultPlugins
                .set(WindowPlugin { primary_window: None, exit_condition: ExitCondition::DontExit, ..default() })
                .set(AssetPlugin { file_path: asset_dir.to_string_lossy().into_owned(), ..default() })
                .set(RenderPlugin {
                    render_creation: RenderCreation::Automatic(Box::new(wgpu)),
                    // Pipelines compile when first needed, inside the warm-up, not
                    // asynchronously while frames without the meshes are being timed.
                    synchronous_pipeline_compilation: true,
                    ..default()
                }),
        )
        .add_plugins(ScheduleRunnerPlugin::run_loop(Duration::ZERO))
        .add_plugins(RenderDiagnosticsPlugin)
        .add_plugins(ImageCopyPlugin { sender: tx })
        .add_plugins(FrameTimerPlugin { sender: timer_tx })
        .add_systems(Startup, setup)
        // The diagnostics store takes a frame's spans in PreUpdate (when they came back).
        .add_systems(Update, (adopt_camera, fix_point_lights, fix_spot_lights, collect_gpu_times, collect_timers))
        .add_systems(PostUpdate, drive)
        .run();
}

/// What the run has seen so far.
#[derive(Default, Resource)]
struct Run {
    target: Handle<Image>,
    copier_enabled: Arc<AtomicBool>,
    camera_ready: bool,
    frame: u32,
    /// Frame at which the scene was ready (camera found, lights spawned).
    ready_at: Option<u32>,
    exposure: Option<f32>,
    exposure_source: String,
    ambient: Option<[f32; 3]>,
    points: usize,
    spots: usize,
    last_seen: Option<bevy::platform::time::Instant>,
    collecting: bool,
    /// Per frame (one diagnostics batch): (span path, GPU ms).
    gpu_frames: Vec<Vec<(String, f64)>>,
    cpu_ms: Vec<f64>,
    last_update: Option<Instant>,
    png_requested: bool,
    /// The camera's cluster grid as Bevy last sized it: (tile size px, dimensions).
    clusters: Option<([u32; 2], [u32; 3])>,
    /// Per measured frame: GPU ms from the first to the last command of the frame's
    /// command buffers (bevy-peer's own timestamps, [`FrameTimerPlugin`]).
    frame_gpu_ms: Vec<f64>,
    /// Per measured frame: CPU ms of the render world's prepare phase, where Bevy builds and
    /// writes its per-frame buffers (lights, cluster lists, mesh data).
    prepare_cpu_ms: Vec<f64>,
    /// Per measured frame: bytes of the cluster index list Bevy uploaded.
    index_list_bytes: Vec<f64>,
    /// The upload copy's calibration: (bytes, GPU ms).
    upload_copy: Option<(u64, f64)>,
}

#[derive(Resource, Deref)]
struct MainWorldReceiver(Receiver<Vec<u8>>);

#[derive(Resource, Deref)]
struct RenderWorldSender(Sender<Vec<u8>>);

fn setup(
    mut commands: Commands,
    args: Res<Args>,
    mut run: ResMut<Run>,
    mut images: ResMut<Assets<Image>>,
    assets: Res<AssetServer>,
    device: Res<RenderDevice>,
    clusters: Option<ResMut<GlobalClusterSettings>>,
) {
    let clusters = clusters.map(|c| c.into_inner());
    let clusters = match (clusters, args.max_indices) {
        (Some(c), Some(n)) => {
            c.view_cluster_bindings_max_indices = n as usize;
            Some(c)
        }
        (c, _) => c,
    };
    if let Some(gpu) = clusters.and_then(|c| c.gpu_clustering.as_mut()) {
        if let Some(z) = args.z_slice_capacity {
            gpu.initial_z_slice_list_capacity = z as usize;
        }
        if let Some(i) = args.index_capacity {
            gpu.initial_index_list_capacity = i as usize;
        }
    }
    let mut target = Image::new_target_texture(args.width, args.height, TextureFormat::Rgba8UnormSrgb, None);
    target.texture_descriptor.usage |= TextureUsages::COPY_SRC;
    run.target = images.add(target);
    let copier = ImageCopier::new(run.target.clone(), args.width, args.height, &device);
    run.copier_enabled = copier.enabled.clone();
    commands.spawn(copier);
    let file = args.gltf.file_name().expect("a file").to_string_lossy().into_owned();
    commands.spawn(WorldAssetRoot(assets.load(GltfAssetLabel::Scene(0).from_asset(file))));
}

/// The camera bevy-peer renders with (placed where the glTF's camera is).
#[derive(Component)]
struct PeerCamera;

/// The glTF's camera: render into the image, with tiledlight's exposure and ambient light.
fn adopt_camera(
    mut commands: Commands,
    args: Res<Args>,
    mut run: ResMut<Run>,
    mut cameras: Query<
        (Option<&GltfExtras>, &Projection, &Transform, &mut Camera),
        (Added<Camera3d>, Without<PeerCamera>),
    >,
    mut ambient: ResMut<GlobalAmbientLight>,
) {
    for (extras, projection, transform, mut camera) in &mut cameras {
        if run.camera_ready {
            eprintln!("warning: the glTF has more than one camera: the first one renders");
            continue;
        }
        let extras: Value = extras.and_then(|e| serde_json::from_str(&e.value).ok()).unwrap_or(Value::Null);
        let t = &extras["tiledlight"];
        let file_exposure = t["exposure"].as_f64().map(|e| e as f32);
        (run.exposure, run.exposure_source) = match (args.exposure, file_exposure) {
            (Some(e), _) => (Some(e), "--exposure".into()),
            (None, Some(e)) => (Some(e), "the file's extras.tiledlight.exposure".into()),
            (None, None) => (None, "Bevy's default (the file has no fixed exposure)".into()),
        };
        // The glTF camera (a root node of the scene, so its transform is its world
        // transform) hands over to a camera of our own that renders into the image, as in
        // Bevy's headless_renderer example: the scene's camera, re-targeted where it
        // stands, rendered nothing.
        camera.is_active = false;
        let mut e = commands.spawn((
            Camera3d::default(),
            projection.clone(),
            *transform,
            RenderTarget::Image(run.target.clone().into()),
            Msaa::from_samples(args.msaa),
            PeerCamera,
        ));
        if let Some(x) = run.exposure {
            // Bevy multiplies radiance by 2^-ev100 / 1.2: pick ev100 so that this is x.
            e.insert(Exposure { ev100: (1.0 / (1.2 * x)).log2() });
        }
        match args.tonemapping.as_str() {
            "aces" => {
                e.insert(Tonemapping::AcesFitted);
            }
            "none" => {
                e.insert(Tonemapping::None);
            }
            _ => {}
        }
        if args.depth_prepass || args.deferred {
            e.insert(DepthPrepass);
        }
        if args.deferred {
            e.insert(DeferredPrepass);
        }
        e.insert(cluster_config(&args));
        if let Some(a) = t["ambient"].as_array() {
            let c: Vec<f32> = a.iter().filter_map(|v| v.as_f64()).map(|v| v as f32).collect();
            if c.len() == 3 {
                let m = c[0].max(c[1]).max(c[2]);
                if m > 0.0 {
                    // Bevy's ambient radiance is colour x brightness (cd/m^2).
                    ambient.color = Color::linear_rgb(c[0] / m, c[1] / m, c[2] / m);
                    ambient.brightness = m;
                } else {
                    ambient.brightness = 0.0;
                }
                run.ambient = Some([c[0], c[1], c[2]]);
            }
        }
        run.camera_ready = true;
    }
}

/// The camera's cluster grid: Bevy's default (`FixedZ`, 4,096 clusters, 24 slices, first
/// slice to 5 m, far end at the farthest light's range, resizing on) changed only where a
/// flag says so.
fn cluster_config(args: &Args) -> ClusterConfig {
    let ClusterConfig::FixedZ { total, z_slices, z_config, dynamic_resizing } = ClusterConfig::default() else {
        unreachable!("Bevy's default cluster configuration is FixedZ")
    };
    let z_slices = args.z_slices.unwrap_or(z_slices);
    let z_config = ClusterZConfig {
        first_slice_depth: args.first_slice_depth.unwrap_or(z_config.first_slice_depth),
        far_z_mode: args.far_z.map_or(z_config.far_z_mode, ClusterFarZMode::Constant),
    };
    let dynamic_resizing = dynamic_resizing && !args.fixed_clusters;
    match args.cluster_px {
        Some(px) => ClusterConfig::XYZ {
            dimensions: UVec3::new(args.width.div_ceil(px), args.height.div_ceil(px), z_slices),
            z_config,
            dynamic_resizing,
        },
        None => ClusterConfig::FixedZ { total: args.clusters.unwrap_or(total), z_slices, z_config, dynamic_resizing },
    }
}

/// Bevy's glTF loader stored the (linear) light colour as sRGB: read the same numbers as
/// linear.
fn relinearise(c: &mut Color) {
    let s = c.to_srgba();
    *c = Color::linear_rgba(s.red, s.green, s.blue, s.alpha);
}

fn fix_point_lights(mut run: ResMut<Run>, mut lights: Query<&mut PointLight, Added<PointLight>>) {
    for mut l in &mut lights {
        relinearise(&mut l.color);
        l.radius = 0.0;
        run.points += 1;
    }
}

fn fix_spot_lights(mut run: ResMut<Run>, mut lights: Query<&mut SpotLight, Added<SpotLight>>) {
    for mut l in &mut lights {
        relinearise(&mut l.color);
        l.radius = 0.0;
        run.spots += 1;
    }
}

/// Every new batch of render diagnostics (one frame's spans) while measuring.
fn collect_gpu_times(store: Res<DiagnosticsStore>, mut run: ResMut<Run>) {
    let mut batch = Vec::new();
    let mut newest = run.last_seen;
    for d in store.iter() {
        let path = d.path().as_str();
        if !path.starts_with("render/") || !path.ends_with("/elapsed_gpu") {
            continue;
        }
        let Some(m) = d.measurement() else { continue };
        if run.last_seen.is_some_and(|t| m.time <= t) {
            continue;
        }
        newest = Some(newest.map_or(m.time, |t| t.max(m.time)));
        let name = path.trim_start_matches("render/").trim_end_matches("/elapsed_gpu").to_string();
        batch.push((name, m.value));
    }
    run.last_seen = newest;
    if run.collecting && !batch.is_empty() {
        run.gpu_frames.push(batch);
    }
}

/// The frame timer's and prepare clock's readings (render world) while measuring.
fn collect_timers(receiver: Res<TimerReceiver>, mut run: ResMut<Run>) {
    absorb_timers(&receiver, &mut run);
}

/// Takes every reading that came: per-frame ones while measuring, the upload copy's always.
fn absorb_timers(receiver: &TimerReceiver, run: &mut Run) {
    while let Ok(t) = receiver.try_recv() {
        match t {
            Timing::UploadCopyGpu { bytes, ms } => run.upload_copy = Some((bytes, ms)),
            _ if !run.collecting => {}
            Timing::FrameGpu(ms) => run.frame_gpu_ms.push(ms),
            Timing::PrepareCpu(ms) => run.prepare_cpu_ms.push(ms),
            Timing::IndexListBytes(b) => run.index_list_bytes.push(b as f64),
        }
    }
}

fn drive(
    args: Res<Args>,
    mut run: ResMut<Run>,
    receiver: Res<MainWorldReceiver>,
    lights: Query<(), Or<(With<PointLight>, With<SpotLight>)>>,
    adapter: Option<Res<RenderAdapterInfo>>,
    clusters: Option<Res<GlobalClusterSettings>>,
    grids: Query<&Clusters, With<PeerCamera>>,
    timers: Res<TimerReceiver>,
    mut exit: MessageWriter<AppExit>,
) {
    if let Some(c) = grids.iter().next() {
        run.clusters = Some((c.tile_size.to_array(), c.dimensions.to_array()));
    }
    let now = Instant::now();
    run.frame += 1;
    let frame = run.frame;
    if run.ready_at.is_none() && run.camera_ready && !lights.is_empty() {
        run.ready_at = Some(frame);
    }
    let Some(ready) = run.ready_at else {
        if frame > args.max_frames {
            fail(&format!("{}: the scene did not load within {} frames", args.gltf.display(), args.max_frames));
        }
        return;
    };
    let since = frame - ready;
    if since > args.warmup && since <= args.warmup + args.frames {
        if let Some(last) = run.last_update {
            run.cpu_ms.push((now - last).as_secs_f64() * 1e3);
        }
        if !run.collecting {
            // scripts/peer-bench.sh checks that no clustering resize is logged between these.
            info!("bevy-peer: measuring from frame {frame}");
        }
        run.collecting = true;
    }
    run.last_update = Some(now);
    // Measure until `frames` frames have GPU times (with `wait_for_gpu` every frame's
    // arrive, a frame or two late), or give up after 20 times as many frames and report
    // how many came.
    let measured =
        run.gpu_frames.len() >= args.frames as usize || since > args.warmup + 20 * args.frames + READBACK_LAG;
    if since > args.warmup + args.frames && measured && !run.png_requested {
        run.collecting = false;
        info!("bevy-peer: measured {} frames' GPU times by frame {frame}", run.gpu_frames.len());
        run.copier_enabled.store(true, Ordering::Relaxed);
        run.png_requested = true;
        return;
    }
    if run.png_requested {
        let mut data = Vec::new();
        while let Ok(d) = receiver.try_recv() {
            data = d;
        }
        if data.is_empty() {
            if since > args.warmup + 20 * args.frames + READBACK_LAG + 60 {
                fail("the last frame's image never came back from the GPU");
            }
            return;
        }
        // The upload copy's calibration was sent just before the frame's image.
        absorb_timers(&timers, &mut run);
        let png = args.out.join(format!("{}.png", args.name));
        save_png(&png, args.width, args.height, &unpad(&data, args.width, args.height));
        let json = report(&args, &run, adapter.as_deref(), clusters.as_deref(), lights.iter().count());
        let path = args.out.join(format!("{}.json", args.name));
        std::fs::write(&path, serde_json::to_vec_pretty(&json).expect("JSON"))
            .unwrap_or_else(|e| fail(&format!("writing {}: {e}", path.display())));
        println!("{}", serde_json::to_string_pretty(&json).expect("JSON"));
        println!("wrote {} and {}", path.display(), png.display());
        exit.write(AppExit::Success);
    }
}

fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    Some(if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) })
}

fn report(
    args: &Args,
    run: &Run,
    adapter: Option<&RenderAdapterInfo>,
    clusters: Option<&GlobalClusterSettings>,
    lights: usize,
) -> Value {
    let frames: Vec<&Vec<(String, f64)>> = run.gpu_frames.iter().take(args.frames as usize).collect();
    let mut names: Vec<String> = Vec::new();
    for f in &frames {
        for (n, _) in f.iter() {
            if !names.contains(n) {
                names.push(n.clone());
            }
        }
    }
    let mut passes = serde_json::Map::new();
    for n in &names {
        let mut v: Vec<f64> = frames.iter().filter_map(|f| f.iter().find(|(m, _)| m == n).map(|p| p.1)).collect();
        let samples = v.len();
        passes.insert(n.clone(), json!({"median_ms": median(&mut v), "frames": samples}));
    }
    // A frame's GPU time: the sum of its top-level spans (nested spans are inside them).
    let totals: Vec<f64> =
        frames.iter().map(|f| f.iter().filter(|(n, _)| !n.contains('/')).map(|p| p.1).sum()).collect();
    let mut cpu = run.cpu_ms.clone();
    let spread = |v: &[f64]| {
        let mut v: Vec<f64> = v.iter().take(args.frames as usize).copied().collect();
        let n = v.len();
        let min = v.iter().copied().fold(f64::INFINITY, f64::min);
        let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        json!({"median_ms": median(&mut v), "min_ms": (n > 0).then_some(min), "max_ms": (n > 0).then_some(max), "frames": n})
    };
    let z = match cluster_config(args) {
        ClusterConfig::FixedZ { z_config, .. } | ClusterConfig::XYZ { z_config, .. } => z_config,
        _ => unreachable!("bevy-peer configures FixedZ or XYZ"),
    };
    // tiledlight's "total GPU": the sum of the passes' medians (top-level spans here).
    let sum_of_medians: f64 =
        passes.iter().filter(|(n, _)| !n.contains('/')).filter_map(|(_, v)| v["median_ms"].as_f64()).sum();
    json!({
        "renderer": "bevy",
        "bevy_version": "0.19.1",
        "name": args.name,
        "adapter": adapter.map(|a| format!("{} ({:?}, {:?}, driver {})", a.name, a.backend, a.device_type, a.driver_info)),
        "gltf": args.gltf.display().to_string(),
        "width": args.width,
        "height": args.height,
        "msaa": args.msaa,
        "tonemapping": if args.tonemapping == "default" { "tony_mc_mapface" } else { args.tonemapping.as_str() },
        "depth_prepass": args.depth_prepass,
        "gpu_clustering": clusters.map(|c| c.gpu_clustering.is_some()),
        "method": if args.deferred { "deferred" } else { "forward" },
        "pipeline_statistics_queries": "disabled (WgpuSettings.disabled_features)",
        "cluster_config": match cluster_config(args) {
            ClusterConfig::XYZ { dimensions, .. } => json!({"mode": "xyz", "cluster_px": args.cluster_px, "requested_dimensions": dimensions.to_array()}),
            ClusterConfig::FixedZ { total, .. } => json!({"mode": "fixed_z", "total": total}),
            _ => Value::Null,
        },
        "cluster_z_slices": args.z_slices.unwrap_or(24),
        "cluster_first_slice_depth_m": z.first_slice_depth,
        "cluster_far_z": match z.far_z_mode {
            ClusterFarZMode::MaxClusterableObjectRange => json!("max_clusterable_object_range"),
            ClusterFarZMode::Constant(m) => json!(m),
        },
        "cluster_config_total": args.clusters.unwrap_or(4096),
        "cluster_dynamic_resizing": !args.fixed_clusters,
        "view_cluster_bindings_max_indices": clusters.map(|c| c.view_cluster_bindings_max_indices),
        "cluster_tile_px": run.clusters.map(|c| c.0),
        "cluster_dimensions": run.clusters.map(|c| c.1),
        "gpu_clustering_initial_capacities": clusters.and_then(|c| c.gpu_clustering).map(|g| json!({
            "z_slice_list": g.initial_z_slice_list_capacity,
            "index_list": g.initial_index_list_capacity,
        })),
        "point_lights": run.points,
        "spot_lights": run.spots,
        "lights_in_world": lights,
        "exposure": run.exposure,
        "exposure_source": run.exposure_source,
        "ambient": run.ambient,
        "warmup_frames": args.warmup,
        "frames": args.frames,
        "gpu_frames_measured": frames.len(),
        "gpu_frame_ms_median": median(&mut totals.clone()),
        "gpu_frame_spans_sum": spread(&totals),
        "frame_gpu_first_to_last": spread(&run.frame_gpu_ms),
        "prepare_cpu": spread(&run.prepare_cpu_ms),
        "cluster_index_list_bytes_median": median(&mut run.index_list_bytes.clone()),
        "upload_copy_gpu": run.upload_copy.map(|(bytes, ms)| json!({"bytes": bytes, "ms": ms})),
        "gpu_sum_of_top_level_pass_medians_ms": sum_of_medians,
        "cpu_frame_ms_median": median(&mut cpu),
        "passes": passes,
        "notes": [
            "gpu_frame_ms_median: the sum of the frame's top-level timed spans (Bevy's RenderDiagnosticsPlugin); untimed work between passes is not in it",
            "cpu_frame_ms_median: wall-clock time between app updates; the render world waits for the GPU after each frame, so it includes the GPU time",
            "frame_gpu_first_to_last: GPU time from a timestamp before the frame's first command to one after its last (bevy-peer's own query set, written in the RenderGraph schedule's Begin set and after its Render set): every pass plus the untimed work and gaps between them",
            "upload_copy_gpu: GPU time of one copy of the cluster index list's bytes (its median size while measured) from a host-visible buffer into a device buffer, timed with two timestamps after the measured frames, median of 5: what the zeroed index list Bevy uploads every frame costs the GPU, outside every other timer",
            "prepare_cpu: CPU time of the render world's Prepare set (RenderSystems::Prepare), where Bevy builds its per-frame buffers and queues their uploads (queue.write_buffer: lights, cluster lists including a zeroed index list of its full capacity, mesh data); the GPU copies of those uploads run at the head of the frame's submission, before the frame timer's first timestamp",
            "the log says when measuring starts and ends ('bevy-peer: measuring from frame', 'bevy-peer: measured'); a clustering resize warning between them means measured frames missed lights",
            "light colours re-read as linear (Bevy 0.19's glTF loader reads them as sRGB); spot source radius set to 0 (the loader sets it to the range)",
            "exposure: Bevy's Exposure with ev100 = log2(1 / (1.2 * exposure)), so radiance x exposure as in tiledlight",
        ],
    })
}

fn save_png(path: &Path, w: u32, h: u32, rgba: &[u8]) {
    let file = std::fs::File::create(path).unwrap_or_else(|e| fail(&format!("writing {}: {e}", path.display())));
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().unwrap_or_else(|e| fail(&format!("writing {}: {e}", path.display())));
    writer.write_image_data(rgba).unwrap_or_else(|e| fail(&format!("writing {}: {e}", path.display())));
}

// ---- The last frame back to the CPU (Bevy's headless_renderer example, one copy only) ----

struct ImageCopyPlugin {
    sender: Sender<Vec<u8>>,
}

impl Plugin for ImageCopyPlugin {
    fn build(&self, app: &mut App) {
        app.sub_app_mut(RenderApp)
            .insert_resource(RenderWorldSender(self.sender.clone()))
            .add_systems(ExtractSchedule, image_copy_extract)
            .add_systems(Render, (wait_for_gpu, receive_image_from_buffer).chain().after(RenderSystems::Render))
            .add_systems(RenderGraph, image_copy_driver);
    }
}

#[derive(Clone, Default, Resource, Deref, DerefMut)]
struct ImageCopiers(Vec<ImageCopier>);

#[derive(Clone, Component)]
struct ImageCopier {
    buffer: Buffer,
    enabled: Arc<AtomicBool>,
    src_image: Handle<Image>,
}

impl ImageCopier {
    fn new(src_image: Handle<Image>, width: u32, height: u32, device: &RenderDevice) -> Self {
        let padded = RenderDevice::align_copy_bytes_per_row(width as usize * 4);
        let buffer = device.create_buffer(&BufferDescriptor {
            label: Some("bevy-peer readback"),
            size: padded as u64 * height as u64,
            usage: BufferUsages::MAP_READ | BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        // Disabled until the measured frames are over: the copy and its wait would be timed.
        Self { buffer, src_image, enabled: Arc::new(AtomicBool::new(false)) }
    }

    fn enabled(&self) -> bool {
        self.enabled.load(Ordering::Relaxed)
    }
}

fn image_copy_extract(mut commands: Commands, copiers: Extract<Query<&ImageCopier>>) {
    commands.insert_resource(ImageCopiers(copiers.iter().cloned().collect()));
}

fn image_copy_driver(
    ctx: RenderContext,
    copiers: Res<ImageCopiers>,
    queue: Res<RenderQueue>,
    images: Res<RenderAssets<bevy::render::texture::GpuImage>>,
) {
    for c in copiers.iter().filter(|c| c.enabled()) {
        let Some(src) = images.get(&c.src_image) else { continue };
        let mut encoder =
            ctx.render_device().create_command_encoder(&CommandEncoderDescriptor { label: Some("bevy-peer copy") });
        let block = src.texture_descriptor.format.block_copy_size(None).expect("a colour format");
        let padded =
            RenderDevice::align_copy_bytes_per_row(src.texture_descriptor.size.width as usize * block as usize);
        encoder.copy_texture_to_buffer(
            src.texture.as_image_copy(),
            TexelCopyBufferInfo {
                buffer: &c.buffer,
                layout: TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded as u32), rows_per_image: None },
            },
            src.texture_descriptor.size,
        );
        queue.submit(std::iter::once(encoder.finish()));
    }
}

/// Waits until the GPU has run the frame just submitted. Headless rendering has no
/// swapchain to hold the CPU back: without this the CPU queued frames up to 25 times
/// faster than the GPU ran them (100,000 lights: 16 ms against 377 ms), the queue grew
/// without bound, and Bevy's diagnostics, which keep only the newest finished frame's
/// times when several finish between two reads, measured one frame in 25. With it every
/// frame's times are read and the CPU frame time includes the GPU's.
fn wait_for_gpu(device: Res<RenderDevice>) {
    device.poll(PollType::wait_indefinitely()).expect("waiting for the frame's GPU work");
}

fn receive_image_from_buffer(copiers: Res<ImageCopiers>, device: Res<RenderDevice>, sender: Res<RenderWorldSender>) {
    for c in copiers.0.iter().filter(|c| c.enabled()) {
        let slice = c.buffer.slice(..);
        let (s, r) = crossbeam_channel::bounded(1);
        slice.map_async(MapMode::Read, move |res| {
            let _ = s.send(res);
        });
        device.poll(PollType::wait_indefinitely()).expect("polling the device for the image read-back");
        match r.recv() {
            Ok(Ok(())) => {}
            _ => fail("mapping the image read-back buffer failed"),
        }
        let data = slice.get_mapped_range().to_vec();
        c.buffer.unmap();
        let _ = sender.send(data);
    }
}

/// Strips the row padding of a read-back (rows aligned to 256 bytes).
fn unpad(data: &[u8], width: u32, height: u32) -> Vec<u8> {
    let row = width as usize * TextureFormat::Rgba8UnormSrgb.pixel_size().unwrap_or(4);
    let padded = RenderDevice::align_copy_bytes_per_row(row);
    data.chunks(padded).take(height as usize).flat_map(|r| &r[..row]).copied().collect()
}

// ---- The frame timer: first to last command of a frame, and the prepare phase's CPU time ----

/// One reading sent from the render world to the main world.
enum Timing {
    FrameGpu(f64),
    PrepareCpu(f64),
    /// Bytes of the view's cluster index list Bevy uploads (zeroed) this frame.
    IndexListBytes(u64),
    /// GPU ms of one copy of the index list's bytes from host-visible memory into a device
    /// buffer (the copy `queue.write_buffer` makes), timed once after the measured frames.
    UploadCopyGpu { bytes: u64, ms: f64 },
}

#[derive(Resource, Deref)]
struct TimerReceiver(Receiver<Timing>);

struct FrameTimerPlugin {
    sender: Sender<Timing>,
}

impl Plugin for FrameTimerPlugin {
    fn build(&self, app: &mut App) {
        app.sub_app_mut(RenderApp)
            .insert_resource(TimerSender(self.sender.clone()))
            .init_resource::<UploadSize>()
            .add_systems(
                Render,
                (
                    (create_frame_timer, prepare_clock_start)
                        .after(RenderSystems::PhaseSort)
                        .before(RenderSystems::Prepare),
                    prepare_clock_stop.after(RenderSystems::Prepare).before(RenderSystems::Render),
                    read_frame_timer.after(wait_for_gpu).before(receive_image_from_buffer),
                    index_list_size.after(RenderSystems::Prepare).before(RenderSystems::Render),
                    time_upload_copy.after(read_frame_timer).before(receive_image_from_buffer),
                ),
            )
            .add_systems(
                RenderGraph,
                (
                    frame_timer_begin.in_set(RenderGraphSystems::Begin),
                    frame_timer_end.after(RenderGraphSystems::Render).before(RenderGraphSystems::Submit),
                ),
            );
    }
}

#[derive(Resource, Deref)]
struct TimerSender(Sender<Timing>);

/// Two timestamps per frame, resolved and copied into a buffer read after the frame.
#[derive(Resource)]
struct FrameTimer {
    queries: wgpu::QuerySet,
    resolved: Buffer,
    readback: Buffer,
    period_ns: f32,
}

#[derive(Resource)]
struct PrepareClock(Instant);

fn create_frame_timer(mut commands: Commands, timer: Option<Res<FrameTimer>>, device: Res<RenderDevice>, queue: Res<RenderQueue>) {
    if timer.is_some() {
        return;
    }
    let queries = device.wgpu_device().create_query_set(&wgpu::QuerySetDescriptor {
        label: Some("bevy-peer frame timer"),
        ty: wgpu::QueryType::Timestamp,
        count: 2,
    });
    let buffer = |label, usage| device.create_buffer(&BufferDescriptor { label: Some(label), size: 16, usage, mapped_at_creation: false });
    commands.insert_resource(FrameTimer {
        queries,
        resolved: buffer("bevy-peer frame timer resolve", BufferUsages::QUERY_RESOLVE | BufferUsages::COPY_SRC),
        readback: buffer("bevy-peer frame timer readback", BufferUsages::MAP_READ | BufferUsages::COPY_DST),
        period_ns: queue.get_timestamp_period(),
    });
}

fn prepare_clock_start(mut commands: Commands) {
    commands.insert_resource(PrepareClock(Instant::now()));
}

fn prepare_clock_stop(clock: Option<Res<PrepareClock>>, sender: Res<TimerSender>) {
    if let Some(c) = clock {
        let _ = sender.send(Timing::PrepareCpu(c.0.elapsed().as_secs_f64() * 1e3));
    }
}

/// The frame's first command: runs before every camera's schedule (RenderGraph's Begin).
fn frame_timer_begin(mut ctx: RenderContext, timer: Option<Res<FrameTimer>>) {
    if let Some(t) = timer {
        ctx.command_encoder().write_timestamp(&t.queries, 0);
    }
}

/// The frame's last command: after every camera's schedule, before the submit.
fn frame_timer_end(mut ctx: RenderContext, timer: Option<Res<FrameTimer>>) {
    if let Some(t) = timer {
        let encoder = ctx.command_encoder();
        encoder.write_timestamp(&t.queries, 1);
        encoder.resolve_query_set(&t.queries, 0..2, &t.resolved, 0);
        encoder.copy_buffer_to_buffer(&t.resolved, 0, &t.readback, 0, 16);
    }
}

/// After `wait_for_gpu`: the frame's two timestamps, as milliseconds, to the main world.
fn read_frame_timer(timer: Option<Res<FrameTimer>>, device: Res<RenderDevice>, sender: Res<TimerSender>) {
    let Some(t) = timer else { return };
    if let Some(ms) = read_timestamps(&t, &device) {
        let _ = sender.send(Timing::FrameGpu(ms));
    }
}

/// Waits for the GPU, then reads the timer's two resolved timestamps: their distance in
/// milliseconds (None when they were not both written).
fn read_timestamps(t: &FrameTimer, device: &RenderDevice) -> Option<f64> {
    let slice = t.readback.slice(..);
    let (s, r) = crossbeam_channel::bounded(1);
    slice.map_async(MapMode::Read, move |res| {
        let _ = s.send(res);
    });
    device.poll(PollType::wait_indefinitely()).expect("polling the device for the frame timer");
    if !matches!(r.recv(), Ok(Ok(()))) {
        fail("mapping the frame timer's read-back buffer failed");
    }
    let ticks: Vec<u64> = {
        let data = slice.get_mapped_range();
        data.chunks_exact(8).map(|c| u64::from_le_bytes(c.try_into().expect("8 bytes"))).collect()
    };
    t.readback.unmap();
    // Timestamps not both written read as zeros.
    (ticks[0] != 0 && ticks[1] > ticks[0]).then(|| (ticks[1] - ticks[0]) as f64 * f64::from(t.period_ns) * 1e-6)
}

/// The cluster index list's bytes this frame (the zeroed list Bevy uploads in full).
fn index_list_size(views: Query<&ViewClusterBindings>, sender: Res<TimerSender>, mut last: ResMut<UploadSize>) {
    let bytes: u64 = views.iter().map(|v| v.n_indices() as u64 * 4).sum();
    last.0 = bytes;
    let _ = sender.send(Timing::IndexListBytes(bytes));
}

/// The last frame's index-list bytes, for the copy's calibration.
#[derive(Default, Resource)]
struct UploadSize(u64);

/// Once, when the measured frames are over (the image copy is enabled): the GPU time of
/// copying the index list's bytes from a host-visible buffer into a device buffer, which
/// is the copy `queue.write_buffer` records at the head of every frame's submission.
/// Median of 5 copies, each between two timestamps.
fn time_upload_copy(
    copiers: Res<ImageCopiers>,
    timer: Option<Res<FrameTimer>>,
    size: Res<UploadSize>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    sender: Res<TimerSender>,
    mut done: Local<bool>,
) {
    let Some(t) = timer else { return };
    if *done || !copiers.iter().any(|c| c.enabled()) || size.0 == 0 {
        return;
    }
    *done = true;
    let bytes = size.0.next_multiple_of(4);
    let staging = device.create_buffer(&BufferDescriptor {
        label: Some("bevy-peer upload calibration source"),
        size: bytes,
        usage: BufferUsages::MAP_WRITE | BufferUsages::COPY_SRC,
        mapped_at_creation: true,
    });
    staging.unmap();
    let target = device.create_buffer(&BufferDescriptor {
        label: Some("bevy-peer upload calibration target"),
        size: bytes,
        usage: BufferUsages::COPY_DST | BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let mut times = Vec::new();
    for _ in 0..5 {
        let mut e = device.create_command_encoder(&CommandEncoderDescriptor { label: Some("bevy-peer upload calibration") });
        e.write_timestamp(&t.queries, 0);
        e.copy_buffer_to_buffer(&staging, 0, &target, 0, bytes);
        e.write_timestamp(&t.queries, 1);
        e.resolve_query_set(&t.queries, 0..2, &t.resolved, 0);
        e.copy_buffer_to_buffer(&t.resolved, 0, &t.readback, 0, 16);
        queue.submit(std::iter::once(e.finish()));
        if let Some(ms) = read_timestamps(&t, &device) {
            times.push(ms);
        }
    }
    if !times.is_empty() {
        let _ = sender.send(Timing::UploadCopyGpu { bytes, ms: median(&mut times).expect("not empty") });
    }
}
