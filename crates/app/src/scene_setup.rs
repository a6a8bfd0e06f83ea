//! The flags `render` and `bench` share, and what they build from them: the scene (the
//! procedural courtyard or a glTF file), its lights, the camera, the GPU context, the
//! scene and light buffers, and a renderer. Every flag is checked here, before any file
//! or GPU work, so bad input gives one clear error line instead of a panic deep inside
//! wgpu. Also the small output helpers both commands use (PNG writing, GPU error capture).
//!
//! May depend on every tiledlight library crate; the subcommand modules depend on it.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use crate::bookmark;
use anyhow::{bail, ensure, Context, Result};
use clap::{Args, ValueEnum};
use glam::Vec3;
use tiledlight_cull::light::try_pack_lights;
use tiledlight_cull::reference::{DEFAULT_CAPACITY, MAX_CAPACITY};
use tiledlight_cull::tiles::MAX_SCREEN_SIDE;
use tiledlight_cull::{Camera, LightKind};
use tiledlight_deferred::shading::workgroup_bytes_besides_lists;
use tiledlight_deferred::{DeferredRenderer, DeferredSettings, EdgeTest};
use tiledlight_forward::{ForwardRenderer, ForwardSettings, Method};
use tiledlight_gpu::light_cull::{CullOptions, CULL_WORKGROUP_BYTES};
use tiledlight_gpu::lights_gpu::LightBuffers;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::targets::Renderer;
use tiledlight_gpu::{ContextOptions, GpuContext};
use tiledlight_scene::{
    default_scene, load_gltf, random_lights, Aabb, CameraDesc, DefaultSceneOptions, GridDensity, Light, LightOptions,
    Scene, DEFAULT_INTENSITY_RANGE, DEFAULT_LIGHT_THRESHOLD, MAX_GRID_OBJECTS, MAX_LIGHTS,
};

/// Random point lights of the default scene when `--lights` is not given.
pub const DEFAULT_POINT_LIGHTS: u64 = 1024;

/// Vertical field of view of the camera that frames a scene without its own camera.
const FRAMING_FOV_Y_DEG: f32 = 60.0;

/// Which renderer draws the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Depth pre-pass, tiled light culling, forward shading of each tile's list.
    ForwardPlus,
    /// Every light for every pixel, with the radius cutoff (the reference for culling).
    BruteForce,
    /// Every light for every pixel, plain inverse-square (the reference for the cutoff).
    BruteForceNoCutoff,
    /// G-buffer pass, then one compute pass that culls each tile's lights and shades it.
    Deferred,
}

impl MethodArg {
    /// The forward renderer's method (None for Tiled Deferred).
    pub fn method(self) -> Option<Method> {
        match self {
            MethodArg::ForwardPlus => Some(Method::ForwardPlus),
            MethodArg::BruteForce => Some(Method::BruteForce { cutoff: true }),
            MethodArg::BruteForceNoCutoff => Some(Method::BruteForce { cutoff: false }),
            MethodArg::Deferred => None,
        }
    }

    /// The flag value, for reports and JSON.
    pub fn name(self) -> &'static str {
        match self {
            MethodArg::ForwardPlus => "forward-plus",
            MethodArg::BruteForce => "brute-force",
            MethodArg::BruteForceNoCutoff => "brute-force-no-cutoff",
            MethodArg::Deferred => "deferred",
        }
    }

    /// True for the methods that cull lights per tile.
    pub fn is_tiled(self) -> bool {
        matches!(self, MethodArg::ForwardPlus | MethodArg::Deferred)
    }
}

/// Tessellation of the default scene's grid objects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DensityArg {
    /// 484 triangles per object.
    Low,
    /// 1764 triangles per object.
    Medium,
    /// 3600 triangles per object.
    High,
}

impl From<DensityArg> for GridDensity {
    fn from(d: DensityArg) -> Self {
        match d {
            DensityArg::Low => GridDensity::Low,
            DensityArg::Medium => GridDensity::Medium,
            DensityArg::High => GridDensity::High,
        }
    }
}

/// Scene, lights, screen and renderer flags shared by `render` and `bench`.
///
/// Numbers are parsed wide (u64 light counts) and range-checked in [`SceneArgs::validate`],
/// so an absurd value gets a message naming the flag and its limit.
#[derive(Args, Clone, Debug, PartialEq)]
pub struct SceneArgs {
    /// `default` (the procedural courtyard) or a glTF file (.gltf or .glb).
    #[arg(long, default_value = "default", value_name = "default|FILE")]
    pub scene: String,
    /// Random point lights [default: 1024 for the default scene; for a glTF file, random
    /// lights are added to its own lights only when this or --spot-lights is given].
    #[arg(long, value_name = "N")]
    pub lights: Option<u64>,
    /// Random spot lights [default: 0].
    #[arg(long, value_name = "N")]
    pub spot_lights: Option<u64>,
    /// Seed of the random lights (the same seed gives the same lights).
    #[arg(long, default_value_t = 1, value_name = "S")]
    pub seed: u64,
    /// Intensity threshold that sets each light's radius: r = sqrt(intensity / T).
    #[arg(long, default_value_t = DEFAULT_LIGHT_THRESHOLD, value_name = "T")]
    pub threshold: f32,
    /// Grid objects (instanced spheres) added to the default scene, 0 to 280.
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub grid_objects: u32,
    /// Tessellation of the grid objects.
    #[arg(long, value_enum, default_value_t = DensityArg::Medium)]
    pub density: DensityArg,
    /// Image width in pixels.
    #[arg(long, default_value_t = 1920, value_name = "W")]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 1080, value_name = "H")]
    pub height: u32,
    /// Renderer.
    #[arg(long, value_enum, default_value_t = MethodArg::ForwardPlus)]
    pub method: MethodArg,
    /// Tile side in pixels: 8, 16 or 32.
    #[arg(long, default_value_t = 16, value_name = "8|16|32")]
    pub tile_size: u32,
    /// Light indices stored per tile list (more are counted as overflow), 1 to 2048.
    /// Default: the light count, up to what the GPU's workgroup memory holds (2048), so
    /// lists overflow only when a tile really sees more lights than that.
    #[arg(long, value_name = "N")]
    pub capacity: Option<u32>,
    /// Also test light spheres against each tile's view-space AABB.
    #[arg(long)]
    pub aabb: bool,
    /// Two lists per tile, split at the middle of its depth range.
    #[arg(long)]
    pub half_z: bool,
    /// Also test spot cones against each tile (needs spot lights to matter).
    #[arg(long)]
    pub spot_cone: bool,
    /// One-level culling: every tile tests every light (the default first culls per
    /// 64x64-pixel cell, and tiles test only their cell's lights).
    #[arg(long)]
    pub flat_cull: bool,
    /// Tiled Deferred's G-buffer render targets, 2 to 5: the extra ones are written white
    /// and read back (the sample's bandwidth stress knob; the image does not change).
    #[arg(long, default_value_t = 2, value_name = "2..5")]
    pub gbuffer_rts: u32,
    /// MSAA samples per pixel: 1 (off), 2, 4 or 8 (2 and 8 where the GPU has them). Forward+
    /// and brute force use hardware MSAA; Tiled Deferred shades edge pixels per sample.
    #[arg(long, default_value_t = 1, value_name = "1|2|4|8")]
    pub msaa: u32,
    /// Tiled Deferred's MSAA edge test: a sample farther than this fraction of the view
    /// distance from sample 0's tangent plane makes the pixel an edge.
    #[arg(long, default_value_t = EdgeTest::default().distance, value_name = "F")]
    pub edge_distance: f32,
    /// Tiled Deferred's MSAA edge test: a sample normal turned more than this many degrees
    /// from sample 0's makes the pixel an edge.
    #[arg(long, default_value_t = EdgeTest::default().normal_deg, value_name = "DEG")]
    pub edge_normal_deg: f32,
    /// Exposure before tonemapping.
    #[arg(long, default_value_t = 1.0, value_name = "E")]
    pub exposure: f32,
    /// Camera bookmark to render from (a small text file; the viewer writes them with its
    /// "save camera" button): eye, target, up, field of view, near and far plane.
    #[arg(long, value_name = "FILE")]
    pub camera: Option<PathBuf>,
}

impl Default for SceneArgs {
    /// The defaults clap gives (the default scene, 1024 lights, 1920x1080, Forward+).
    fn default() -> Self {
        Self {
            scene: "default".into(),
            lights: None,
            spot_lights: None,
            seed: 1,
            threshold: DEFAULT_LIGHT_THRESHOLD,
            grid_objects: 0,
            density: DensityArg::Medium,
            width: 1920,
            height: 1080,
            method: MethodArg::ForwardPlus,
            tile_size: 16,
            capacity: None,
            aabb: false,
            half_z: false,
            spot_cone: false,
            flat_cull: false,
            gbuffer_rts: 2,
            msaa: 1,
            edge_distance: EdgeTest::default().distance,
            edge_normal_deg: EdgeTest::default().normal_deg,
            exposure: 1.0,
            camera: None,
        }
    }
}

/// Where the scene comes from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SceneSource {
    /// The procedural courtyard.
    Default,
    /// A glTF file.
    File(PathBuf),
}

impl SceneArgs {
    /// Where `--scene` points.
    pub fn source(&self) -> SceneSource {
        if self.scene.eq_ignore_ascii_case("default") {
            SceneSource::Default
        } else {
            SceneSource::File(PathBuf::from(&self.scene))
        }
    }

    /// Random (point, spot) lights asked for, with the per-scene defaults applied.
    pub fn random_light_counts(&self) -> (u64, u64) {
        match self.source() {
            SceneSource::Default => (self.lights.unwrap_or(DEFAULT_POINT_LIGHTS), self.spot_lights.unwrap_or(0)),
            SceneSource::File(_) => (self.lights.unwrap_or(0), self.spot_lights.unwrap_or(0)),
        }
    }

    /// Checks every flag's range; the error names the flag, its value and the limit.
    pub fn validate(&self) -> Result<()> {
        let side = 1..=MAX_SCREEN_SIDE;
        ensure!(side.contains(&self.width), "--width {}: must be between 1 and {MAX_SCREEN_SIDE} pixels", self.width);
        ensure!((2..=5).contains(&self.gbuffer_rts), "--gbuffer-rts {}: must be between 2 and 5", self.gbuffer_rts);
        ensure!(
            side.contains(&self.height),
            "--height {}: must be between 1 and {MAX_SCREEN_SIDE} pixels",
            self.height
        );
        ensure!([8, 16, 32].contains(&self.tile_size), "--tile-size {}: must be 8, 16 or 32", self.tile_size);
        ensure!([1, 2, 4, 8].contains(&self.msaa), "--msaa {}: must be 1, 2, 4 or 8", self.msaa);
        ensure!(
            self.edge_distance.is_finite() && self.edge_distance >= 0.0,
            "--edge-distance {}: must be a number >= 0",
            self.edge_distance
        );
        ensure!(
            (0.0..=180.0).contains(&self.edge_normal_deg),
            "--edge-normal-deg {}: must be between 0 and 180 degrees",
            self.edge_normal_deg
        );
        ensure!(
            self.capacity.is_none_or(|c| (1..=MAX_CAPACITY).contains(&c)),
            "--capacity {}: must be between 1 and {MAX_CAPACITY} lights per tile list",
            self.capacity.unwrap_or_default()
        );
        for (flag, n) in [("--lights", self.lights), ("--spot-lights", self.spot_lights)] {
            if let Some(n) = n {
                ensure!(n <= MAX_LIGHTS, "{flag} {n}: at most {MAX_LIGHTS} lights are supported");
            }
        }
        let (points, spots) = self.random_light_counts();
        ensure!(
            points + spots <= MAX_LIGHTS,
            "--lights {points} plus --spot-lights {spots}: at most {MAX_LIGHTS} lights in total are supported"
        );
        ensure!(
            self.threshold.is_finite() && self.threshold > 0.0,
            "--threshold {}: must be a positive number",
            self.threshold
        );
        ensure!(
            self.exposure.is_finite() && self.exposure > 0.0,
            "--exposure {}: must be a positive number",
            self.exposure
        );
        ensure!(
            self.grid_objects <= MAX_GRID_OBJECTS,
            "--grid-objects {}: must be between 0 and {MAX_GRID_OBJECTS}",
            self.grid_objects
        );
        if let SceneSource::File(path) = self.source() {
            let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
            ensure!(
                matches!(ext.as_deref(), Some("gltf" | "glb")),
                "--scene {}: expected 'default' or a .gltf/.glb file",
                path.display()
            );
            ensure!(
                self.grid_objects == 0,
                "--grid-objects {}: grid objects exist only in the default scene",
                self.grid_objects
            );
        }
        if self.method.is_tiled() {
            let lists = u64::from(self.width.div_ceil(self.tile_size))
                * u64::from(self.height.div_ceil(self.tile_size))
                * if self.half_z { 2 } else { 1 };
            // The GPU checks its own binding limit; this only stops requests no GPU binds
            // (u32 offsets) before minutes of scene loading.
            let bytes = lists * u64::from(self.capacity.unwrap_or(MAX_CAPACITY)) * 4;
            ensure!(
                bytes <= u64::from(u32::MAX),
                "--capacity {} at {}x{} with {} px tiles needs {bytes} bytes of tile lists: lower the capacity or raise the tile size",
                self.capacity.unwrap_or(MAX_CAPACITY),
                self.width,
                self.height,
                self.tile_size
            );
        }
        Ok(())
    }

    /// The per-list capacity: `--capacity`, or the one `Prepared::new` chose for the
    /// scene's light count.
    pub fn capacity(&self) -> u32 {
        self.capacity.unwrap_or(DEFAULT_CAPACITY)
    }

    /// The culling options of these flags.
    pub fn cull_options(&self) -> CullOptions {
        CullOptions {
            tile_size: self.tile_size,
            capacity: self.capacity(),
            aabb: self.aabb,
            half_z: self.half_z,
            spot_cone: self.spot_cone,
            coarse: !self.flat_cull,
            samples: self.msaa,
            grid_pairs: None,
        }
    }

    /// Workgroup memory the method's culling kernel needs besides its lists (bytes).
    pub fn reserved_workgroup_bytes(&self) -> u32 {
        match self.method {
            MethodArg::Deferred => workgroup_bytes_besides_lists(self.tile_size, self.msaa),
            _ => CULL_WORKGROUP_BYTES,
        }
    }

    /// The forward renderer's settings of these flags (`heatmap` only for the tiled method).
    pub fn settings(&self, heatmap: bool) -> ForwardSettings {
        ForwardSettings {
            method: self.method.method().unwrap_or(Method::ForwardPlus),
            cull: self.cull_options(),
            exposure: self.exposure,
            heatmap,
            msaa: self.msaa,
            ..ForwardSettings::default()
        }
    }

    /// The Tiled Deferred renderer's settings of these flags.
    pub fn deferred_settings(&self, heatmap: bool) -> DeferredSettings {
        DeferredSettings {
            cull: self.cull_options(),
            gbuffer_rts: self.gbuffer_rts,
            exposure: self.exposure,
            heatmap,
            msaa: self.msaa,
            edge: EdgeTest { distance: self.edge_distance, normal_deg: self.edge_normal_deg },
            ..DeferredSettings::default()
        }
    }

    /// One line of the culling options, e.g. "16 px tiles, capacity 512, tests: planes+aabb".
    pub fn culling_description(&self) -> String {
        let mut tests = String::from("planes");
        if self.aabb {
            tests.push_str("+aabb");
        }
        if self.spot_cone {
            tests.push_str("+spot-cone");
        }
        if self.half_z {
            tests.push_str(", half-z (2 lists per tile)");
        }
        let levels = if self.flat_cull { "one level" } else { "two levels (64 px cells, then tiles)" };
        format!("{} px tiles, capacity {}, {levels}, tests: {tests}", self.tile_size, self.capacity())
    }
}

/// The lights of a run, counted.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LightSummary {
    /// Point lights in total.
    pub point: usize,
    /// Spot lights in total.
    pub spot: usize,
    /// Lights that came from the glTF file (KHR_lights_punctual).
    pub from_file: usize,
    /// Random lights generated.
    pub random: usize,
}

impl LightSummary {
    fn of(lights: &[Light], from_file: usize) -> Self {
        let spot = lights.iter().filter(|l| matches!(l.kind, LightKind::Spot { .. })).count();
        Self { point: lights.len() - spot, spot, from_file, random: lights.len() - from_file }
    }
}

/// Everything a run needs before a renderer exists: the GPU, the uploaded scene and
/// lights, the camera, and what to print about them.
pub struct Prepared {
    /// The flags it was built from.
    pub args: SceneArgs,
    /// Device, queue and adapter.
    pub ctx: GpuContext,
    /// The scene's name.
    pub scene_name: String,
    /// Instances drawn.
    pub instances: usize,
    /// The scene on the GPU.
    pub scene_gpu: SceneGpu,
    /// The lights on the GPU.
    pub lights: LightBuffers,
    /// Light counts.
    pub light_summary: LightSummary,
    /// The camera (aspect = width / height).
    pub camera: Camera,
    /// Where the camera came from, for the report.
    pub camera_source: String,
    /// The scene's bounds (random lights are placed in them).
    pub bounds: Aabb,
    /// The lights the scene file brought along (before the random ones).
    pub file_lights: Vec<Light>,
    /// The scene file's own camera, if any (the camera is rebuilt from it on a new aspect).
    scene_camera: Option<CameraDesc>,
    gpu_errors: Arc<Mutex<Vec<String>>>,
}

/// The CPU half of a run, built before any GPU work so that file and flag errors come
/// before the slow device creation: the scene, all its lights and the camera.
pub struct SceneCpu {
    /// The scene.
    pub scene: Scene,
    /// The scene's own lights followed by the random ones.
    pub lights: Vec<Light>,
    /// How many of `lights` came from the scene file.
    pub file_lights: usize,
    /// The camera (aspect = width / height): the bookmark, the scene's, or one framing it.
    pub camera: Camera,
    /// Where the camera came from, for the report.
    pub camera_source: String,
}

impl SceneCpu {
    /// Checks the flags and builds the scene, its lights and the camera.
    pub fn load(args: &SceneArgs) -> Result<Self> {
        args.validate()?;
        let (scene, file_lights) = load_scene(args)?;
        let lights = build_lights(args, &scene.bounds, &scene.lights)?;
        let (camera, camera_source) = choose_camera(args, scene.camera.as_ref(), &scene.bounds)?;
        Ok(Self { scene, lights, file_lights, camera, camera_source })
    }
}

/// The camera of a run at the screen's aspect ratio, and where it came from: the
/// `--camera` bookmark, else the scene's own camera, else one framing the scene's bounds.
fn choose_camera(args: &SceneArgs, scene_camera: Option<&CameraDesc>, bounds: &Aabb) -> Result<(Camera, String)> {
    let aspect = args.width as f32 / args.height as f32;
    Ok(match (&args.camera, scene_camera) {
        (Some(path), _) => {
            let desc = bookmark::load(path)?;
            let cam = camera_from_desc(&desc, aspect)
                .with_context(|| format!("--camera {}: unusable camera", path.display()))?;
            (cam, format!("bookmark {}", path.display()))
        }
        (None, Some(desc)) => (
            camera_from_desc(desc, aspect).context("the scene's camera is unusable")?,
            "the scene's camera".to_string(),
        ),
        (None, None) => (frame_bounds(bounds, aspect)?, "framing the scene bounds".to_string()),
    })
}

/// `args` with the per-list capacity chosen for `lights` lights when `--capacity` is not
/// given (what the device's workgroup memory holds, up to the light count).
fn with_capacity(args: &SceneArgs, lights: u32, limits: &wgpu::Limits) -> SceneArgs {
    let mut args = args.clone();
    if args.capacity.is_none() {
        args.capacity = Some(CullOptions::capacity_for(lights, args.half_z, args.reserved_workgroup_bytes(), limits));
    }
    args
}

impl Prepared {
    /// Checks the flags, builds the scene and lights on the CPU (so file errors come
    /// before the slow device creation), then creates the device and uploads them.
    pub fn new(args: &SceneArgs) -> Result<Self> {
        let cpu = SceneCpu::load(args)?;
        let ctx = GpuContext::headless(ContextOptions::default())
            .context("creating the GPU device (set WGPU_ADAPTER_NAME to pick an adapter)")?;
        Self::with_context(args, cpu, ctx)
    }

    /// Uploads a loaded scene and its lights to an existing device (the viewer's, made for
    /// its window).
    pub fn with_context(args: &SceneArgs, cpu: SceneCpu, ctx: GpuContext) -> Result<Self> {
        // wgpu panics on errors raised outside an error scope; collect them instead so a
        // GPU problem during the frame loop ends the run with an error message.
        let gpu_errors = Arc::new(Mutex::new(Vec::new()));
        let sink = gpu_errors.clone();
        ctx.device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            log::debug!("GPU error: {e}");
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        let (scene_gpu, lights) = upload(&ctx, &cpu)?;
        Ok(Self {
            args: with_capacity(args, lights.len(), &ctx.device.limits()),
            ctx,
            scene_name: cpu.scene.name.clone(),
            instances: cpu.scene.instances.len(),
            scene_gpu,
            lights,
            light_summary: LightSummary::of(&cpu.lights, cpu.file_lights),
            camera: cpu.camera,
            camera_source: cpu.camera_source,
            bounds: cpu.scene.bounds,
            file_lights: cpu.scene.lights,
            scene_camera: cpu.scene.camera,
            gpu_errors,
        })
    }

    /// Replaces the scene and lights by a newly loaded one (the viewer's scene picker).
    /// Nothing changes when the upload fails. Renderers built before must be rebuilt.
    pub fn replace_scene(&mut self, args: &SceneArgs, cpu: SceneCpu) -> Result<()> {
        let (scene_gpu, lights) = upload(&self.ctx, &cpu)?;
        self.args = with_capacity(args, lights.len(), &self.ctx.device.limits());
        self.scene_name = cpu.scene.name.clone();
        self.instances = cpu.scene.instances.len();
        self.scene_gpu = scene_gpu;
        self.lights = lights;
        self.light_summary = LightSummary::of(&cpu.lights, cpu.file_lights);
        self.camera = cpu.camera;
        self.camera_source = cpu.camera_source;
        self.bounds = cpu.scene.bounds;
        self.file_lights = cpu.scene.lights;
        self.scene_camera = cpu.scene.camera;
        Ok(())
    }

    /// Switches to the flags `args` on the same GPU device, rebuilding only what they
    /// change: the scene (`--scene`, `--grid-objects`, `--density`; the threshold of a
    /// glTF file's lights), the lights (their counts, seed and threshold) and the camera
    /// (bookmark, aspect ratio). Renderers built before must be rebuilt
    /// ([`Prepared::renderer`]). Sweeps use it so that a GPU context is created once per
    /// run, not once per point.
    pub fn reconfigure(&mut self, args: &SceneArgs) -> Result<()> {
        args.validate()?;
        let old = &self.args;
        let file = matches!(args.source(), SceneSource::File(_));
        let scene_changed = old.scene != args.scene
            || old.grid_objects != args.grid_objects
            || old.density != args.density
            || (file && old.threshold != args.threshold);
        let lights_changed = old.lights != args.lights
            || old.spot_lights != args.spot_lights
            || old.seed != args.seed
            || old.threshold != args.threshold;
        if scene_changed {
            self.replace_scene(args, SceneCpu::load(args)?)?;
        } else if lights_changed {
            self.replace_lights(args)?;
        }
        (self.camera, self.camera_source) = choose_camera(args, self.scene_camera.as_ref(), &self.bounds)?;
        self.set_renderer_args(args)?;
        self.check_gpu_errors()
    }

    /// Regenerates the random lights for `args` (counts, seed, threshold) in the current
    /// scene. With the same number of point and spot lights the buffers are rewritten in
    /// place and `false` is returned; otherwise they are reallocated and `true` says that
    /// renderers built before must be rebuilt. Nothing changes on error.
    pub fn replace_lights(&mut self, args: &SceneArgs) -> Result<bool> {
        args.validate()?;
        let lights = build_lights(args, &self.bounds, &self.file_lights)?;
        let summary = LightSummary::of(&lights, self.file_lights.len());
        let same_shape = summary.point == self.light_summary.point && summary.spot == self.light_summary.spot;
        let realloc = if same_shape {
            // Validated like every upload (`LightBuffers::new` does the same).
            let packed = try_pack_lights(&lights).context("uploading the lights")?;
            if !packed.is_empty() {
                let q = &self.ctx.queue;
                q.write_buffer(&self.lights.cull, 0, bytemuck::cast_slice(&packed.cull));
                q.write_buffer(&self.lights.shading, 0, bytemuck::cast_slice(&packed.shading));
                if let Some(spots) = &self.lights.spots {
                    q.write_buffer(spots, 0, bytemuck::cast_slice(&packed.spots));
                }
            }
            self.lights.packed = packed;
            false
        } else {
            self.lights = LightBuffers::new(&self.ctx.device, &lights).context("uploading the lights")?;
            true
        };
        self.args = with_capacity(args, self.lights.len(), &self.ctx.device.limits());
        self.light_summary = summary;
        Ok(realloc)
    }

    /// Sets the renderer flags (method, screen size, culling options...) for the next
    /// [`Prepared::renderer`], keeping the scene and lights; the capacity is chosen for the
    /// current lights when `args` has none. The caller checks that scene and light flags
    /// did not change (those need [`Prepared::replace_scene`] / [`Prepared::replace_lights`]).
    pub fn set_renderer_args(&mut self, args: &SceneArgs) -> Result<()> {
        args.validate()?;
        self.args = with_capacity(args, self.lights.len(), &self.ctx.device.limits());
        Ok(())
    }

    /// Takes the GPU errors raised outside an error scope since the last call (the viewer
    /// shows them and goes on; `check_gpu_errors` ends a headless run instead).
    pub fn take_gpu_errors(&self) -> Vec<String> {
        self.gpu_errors.lock().map(|mut v| std::mem::take(&mut *v)).unwrap_or_default()
    }

    /// Builds a renderer for the flags' method, screen and settings.
    pub fn renderer(&self, heatmap: bool) -> Result<Box<dyn Renderer>> {
        let a = &self.args;
        if heatmap && !a.method.is_tiled() {
            bail!("--heatmap needs a tiled method, forward-plus or deferred ({} has no tiles)", a.method.name());
        }
        let r: Result<Box<dyn Renderer>, _> = match a.method {
            MethodArg::Deferred => DeferredRenderer::new(
                &self.ctx,
                &self.scene_gpu,
                &self.lights,
                a.width,
                a.height,
                a.deferred_settings(heatmap),
            )
            .map(|r| Box::new(r) as Box<dyn Renderer>),
            _ => ForwardRenderer::new(&self.ctx, &self.scene_gpu, &self.lights, a.width, a.height, a.settings(heatmap))
                .map(|r| Box::new(r) as Box<dyn Renderer>),
        };
        let r = r.with_context(|| format!("building the {} renderer at {}x{}", a.method.name(), a.width, a.height))?;
        self.check_gpu_errors()?;
        Ok(r)
    }

    /// Fails with the first GPU error wgpu raised outside an error scope, if any.
    pub fn check_gpu_errors(&self) -> Result<()> {
        let errors = self.gpu_errors.lock().map(|v| v.clone()).unwrap_or_default();
        match errors.first() {
            Some(e) => bail!("GPU error ({} in all): {e}", errors.len()),
            None => Ok(()),
        }
    }

    /// The report lines about adapter, scene, lights, screen and method.
    pub fn describe(&self) -> Vec<(String, String)> {
        let a = &self.args;
        let l = &self.light_summary;
        let mut lights = format!("{} point, {} spot", l.point, l.spot);
        match (l.from_file, l.random) {
            (0, _) => lights.push_str(&format!(" (random, seed {}, threshold {})", a.seed, a.threshold)),
            (f, 0) => lights.push_str(&format!(" (all {f} from the glTF file)")),
            (f, r) => lights.push_str(&format!(
                " ({f} from the glTF file + {r} random, seed {}, threshold {})",
                a.seed, a.threshold
            )),
        }
        let grid = tiledlight_cull::TileGrid::new(a.width, a.height, a.tile_size).ok();
        let mut res = format!("{}x{}", a.width, a.height);
        if let Some(g) = grid {
            res.push_str(&format!(
                ", {} px tiles: {}x{} = {} tiles",
                g.tile_size,
                g.tiles_x,
                g.tiles_y,
                g.tile_count()
            ));
        }
        let method = match a.method {
            MethodArg::ForwardPlus => format!("forward-plus ({})", a.culling_description()),
            MethodArg::Deferred => {
                format!("deferred ({}, {} G-buffer targets)", a.culling_description(), a.gbuffer_rts)
            }
            m => format!("{} (every light for every pixel)", m.name()),
        };
        if a.msaa > 1 {
            res.push_str(&format!(", MSAA {}x", a.msaa));
            if a.method == MethodArg::Deferred {
                res.push_str(&format!(
                    " (edge test: {} of the view distance off the tangent plane, or normals {} deg apart)",
                    a.edge_distance, a.edge_normal_deg
                ));
            }
        }
        vec![
            ("adapter".into(), self.ctx.describe()),
            (
                "scene".into(),
                format!(
                    "{}: {} triangles, {} instances, camera: {}",
                    self.scene_name,
                    group_digits(self.scene_gpu.triangles),
                    self.instances,
                    self.camera_source
                ),
            ),
            ("lights".into(), lights),
            ("resolution".into(), res),
            ("method".into(), method),
        ]
    }
}

/// Loads or builds the scene; returns it with the number of lights it brought along.
fn load_scene(args: &SceneArgs) -> Result<(Scene, usize)> {
    match args.source() {
        SceneSource::Default => {
            let opts = DefaultSceneOptions { grid_objects: args.grid_objects, density: args.density.into() };
            let scene = default_scene(&opts).context("building the default scene")?;
            Ok((scene, 0))
        }
        SceneSource::File(path) => {
            let scene = load_gltf(&path, args.threshold).context("loading the scene")?;
            let n = scene.lights.len();
            Ok((scene, n))
        }
    }
}

/// Uploads the scene and its lights.
fn upload(ctx: &GpuContext, cpu: &SceneCpu) -> Result<(SceneGpu, LightBuffers)> {
    let scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, &cpu.scene)
        .with_context(|| format!("uploading scene '{}'", cpu.scene.name))?;
    let lights = LightBuffers::new(&ctx.device, &cpu.lights).context("uploading the lights")?;
    Ok((scene_gpu, lights))
}

/// The scene's own lights followed by the random ones asked for, placed in `bounds`.
fn build_lights(args: &SceneArgs, bounds: &Aabb, scene_lights: &[Light]) -> Result<Vec<Light>> {
    let file_lights = scene_lights.len();
    let (points, spots) = args.random_light_counts();
    let total = file_lights as u64 + points + spots;
    ensure!(
        total <= MAX_LIGHTS,
        "{file_lights} lights from the scene plus {} random: at most {MAX_LIGHTS} lights are supported",
        points + spots
    );
    let mut lights = scene_lights.to_vec();
    if points + spots > 0 {
        let opts = LightOptions {
            // Both fit: validate() capped them at MAX_LIGHTS (2^20).
            num_point: points as u32,
            num_spot: spots as u32,
            seed: args.seed,
            threshold: args.threshold,
            intensity_range: DEFAULT_INTENSITY_RANGE,
        };
        lights.extend(random_lights(bounds, &opts).context("generating random lights")?);
    }
    Ok(lights)
}

/// The scene's suggested camera at the screen's aspect ratio.
pub fn camera_from_desc(d: &CameraDesc, aspect: f32) -> Result<Camera> {
    Ok(Camera::perspective(d.eye, d.target, d.up, d.fov_y, aspect, d.near, d.far)?)
}

/// A camera in front of the scene (+z side, a little above) that sees the whole bounding
/// sphere of `bounds`, with an infinite far plane.
pub fn frame_bounds(bounds: &Aabb, aspect: f32) -> Result<Camera> {
    ensure!(bounds.is_valid(), "the scene has no valid bounds to frame a camera on");
    let center = bounds.center();
    // A flat or point-like scene still needs a distance to stand back.
    let radius = (0.5 * bounds.size().length()).max(1e-3);
    let fov_y = FRAMING_FOV_Y_DEG.to_radians();
    let half_x = ((fov_y * 0.5).tan() * aspect).atan();
    let half = (fov_y * 0.5).min(half_x);
    let dist = radius / half.sin();
    let dir = Vec3::new(0.0, 0.35, 1.0).normalize();
    let eye = center + dir * dist;
    // Every surface is at least dist - radius away; reversed-Z keeps precision with a
    // small near plane, so halve that for margin.
    let near = ((dist - radius) * 0.5).max(dist * 1e-4);
    Ok(Camera::perspective(eye, center, Vec3::Y, fov_y, aspect, near, None)?)
}

/// An RGB image from tightly packed RGBA8 pixels.
pub fn rgb_image(width: u32, height: u32, rgba: &[u8]) -> Result<image::RgbImage> {
    ensure!(
        rgba.len() == width as usize * height as usize * 4,
        "image readback has {} bytes, expected {width}x{height}x4",
        rgba.len()
    );
    let rgb: Vec<u8> = rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
    image::RgbImage::from_raw(width, height, rgb).context("building the output image")
}

/// Saves `img` as PNG at `path` (which must end in .png), creating its directory.
pub fn save_png(path: &Path, img: &image::RgbImage) -> Result<()> {
    check_png_path(path)?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating directory {}", dir.display()))?;
    }
    img.save_with_format(path, image::ImageFormat::Png).with_context(|| format!("writing {}", path.display()))
}

/// Output paths must be PNG files: checked before rendering so a typo costs no time.
pub fn check_png_path(path: &Path) -> Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    ensure!(ext.as_deref() == Some("png"), "--out {}: only .png output is supported", path.display());
    Ok(())
}

/// 1234567 -> "1,234,567".
pub fn group_digits(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args() -> SceneArgs {
        SceneArgs { width: 64, height: 36, ..SceneArgs::default() }
    }

    fn err(a: SceneArgs) -> String {
        format!("{:#}", a.validate().unwrap_err())
    }

    #[test]
    fn defaults_are_valid() {
        SceneArgs::default().validate().unwrap();
        assert_eq!(SceneArgs::default().random_light_counts(), (1024, 0));
    }

    #[test]
    fn bad_flags_name_the_flag() {
        assert!(err(SceneArgs { width: 0, ..args() }).contains("--width 0"));
        assert!(err(SceneArgs { height: 20000, ..args() }).contains("--height 20000"));
        assert!(err(SceneArgs { tile_size: 7, ..args() }).contains("--tile-size 7"));
        assert!(err(SceneArgs { capacity: Some(0), ..args() }).contains("--capacity 0"));
        assert!(err(SceneArgs { lights: Some(99_999_999), ..args() }).contains("--lights 99999999"));
        let both = SceneArgs { lights: Some(MAX_LIGHTS), spot_lights: Some(1), ..args() };
        assert!(err(both).contains("in total"));
        assert!(err(SceneArgs { threshold: f32::NAN, ..args() }).contains("--threshold"));
        assert!(err(SceneArgs { threshold: 0.0, ..args() }).contains("--threshold"));
        assert!(err(SceneArgs { exposure: -1.0, ..args() }).contains("--exposure"));
        assert!(err(SceneArgs { grid_objects: 281, ..args() }).contains("--grid-objects 281"));
        assert!(err(SceneArgs { scene: "x.obj".into(), ..args() }).contains("--scene x.obj"));
        let grid_on_file = SceneArgs { scene: "x.glb".into(), grid_objects: 3, ..args() };
        assert!(err(grid_on_file).contains("default scene"));
    }

    #[test]
    fn gltf_gets_random_lights_only_when_asked() {
        let a = SceneArgs { scene: "a.gltf".into(), ..args() };
        assert_eq!(a.random_light_counts(), (0, 0));
        let a = SceneArgs { scene: "a.gltf".into(), spot_lights: Some(5), ..args() };
        assert_eq!(a.random_light_counts(), (0, 5));
    }

    #[test]
    fn framing_sees_the_whole_box() {
        let b = Aabb::new(Vec3::new(-10.0, 0.0, -3.0), Vec3::new(10.0, 5.0, 3.0));
        let cam = frame_bounds(&b, 16.0 / 9.0).unwrap();
        for i in 0..8 {
            let p = Vec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            );
            let c = cam.view_proj() * p.extend(1.0);
            let ndc = c.truncate() / c.w;
            assert!(c.w > 0.0 && ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0, "corner {p} at {ndc}");
            assert!(ndc.z > 0.0 && ndc.z <= 1.0, "corner {p} depth {}", ndc.z);
        }
        assert!(frame_bounds(&Aabb::empty(), 1.0).is_err());
    }

    #[test]
    fn digits_are_grouped() {
        assert_eq!(group_digits(0), "0");
        assert_eq!(group_digits(999), "999");
        assert_eq!(group_digits(1000), "1,000");
        assert_eq!(group_digits(1234567), "1,234,567");
    }
}
