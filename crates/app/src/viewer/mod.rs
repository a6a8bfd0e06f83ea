//! `tiledlight view`: the interactive viewer. A winit window with a wgpu surface; each
//! frame the renderer of the chosen method draws into its own targets, the tonemapped
//! image is drawn onto the surface ([`tiledlight_gpu::blit`]) and the egui panel over it ([`ui`]). The
//! GPU context is made for the window's surface; scene, lights and renderer come from the
//! same tiledlight-setup [`Prepared`] as `render` and `bench`, and a change of settings
//! rebuilds only what depends on it ([`settings`], `Prepared::reconfigure`). `--frames N`
//! (with `--script`, `--screenshot`, `--screenshot-ui`) makes a scripted run that exits by
//! itself, for tests and demos.
//!
//! Plain `tiledlight` opens the viewer when a display is available ([`run_default`]), and
//! otherwise runs the headless quickstart, saying why in one line.
//!
//! Frames that drop lights because a light grid is full and cannot grow (a fixed budget,
//! or the device's largest binding; a grid that can grow does so for the next frame) get
//! a red warning at the top of the panel for as long as they last and one `warning:` line
//! on stderr each time it starts; `--strict` makes the viewer exit with an error if any
//! was given. A lost device ends the viewer with the loss named.
//!
//! May depend on every other module of the app.

mod script;
pub mod settings;
pub mod ui;

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use clap::Args;
use tiledlight_cull::bounds::{sphere_vs_frustum, to_view};
use tiledlight_cull::tiles::TileFrustum;
use tiledlight_cull::Camera;
use tiledlight_frame::{FrameRenderer, Renderer};
use tiledlight_gpu::heatmap::HeatmapOf;
use tiledlight_gpu::light_grid::GridStatus;
use tiledlight_gpu::readback::read_texture;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::{ContextOptions, GpuContext};
use tiledlight_setup::settings::blend_mode_description;
use tiledlight_setup::{
    group_digits, shadow_atlas_description, LightAnimator, Prepared, Reload, SceneCpu, SceneSource,
};
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::{Window, WindowId};

use crate::render::write_image;
use crate::scene_setup::SceneArgs;
use script::Action;
use settings::{plan, Settings};
use tiledlight_gpu::blit::{Blit, DisplayImage};
use tiledlight_lab::dropped::{self, Dropped};
use tiledlight_lab::output::{check_png_path, rgb_image, save_png};
use tiledlight_setup::bookmark;
use tiledlight_setup::camera_rig::CameraRig;
use ui::{Command, Info, Stats, UiState};

/// How often the culling statistics (a GPU readback) are refreshed.
const STATS_PERIOD: Duration = Duration::from_millis(500);
/// Where the "save camera" key writes the bookmark.
pub const BOOKMARK_PATH: &str = "out/camera.txt";

/// Flags of `tiledlight view`.
#[derive(Args, Clone, Debug)]
pub struct ViewArgs {
    /// Scene, lights, window size and renderer (as for render and bench).
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Exit after rendering N frames (after the script's actions); without it the viewer
    /// runs until closed.
    #[arg(long, value_name = "N")]
    pub frames: Option<u32>,
    /// Actions applied one per frame through the panel's code, e.g.
    /// "method=deferred;lights=300;heatmap=on;wait=5" (keys: docs/USAGE.md, "Viewer").
    #[arg(long, value_name = "ACTIONS")]
    pub script: Option<String>,
    /// When exiting after --frames: save the lit image (no UI) to this PNG.
    #[arg(long, value_name = "FILE.png")]
    pub screenshot: Option<PathBuf>,
    /// When exiting after --frames: save the window as shown, panel included, to this PNG.
    #[arg(long, value_name = "FILE.png")]
    pub screenshot_ui: Option<PathBuf>,
}

/// Why the viewer did not run.
enum Failure {
    /// No window could be opened (no display, no surface, no adapter for it).
    NoWindow(anyhow::Error),
    /// Anything else (bad flags, a scene that does not load, a GPU error).
    Other(anyhow::Error),
}

/// Runs `tiledlight view`.
pub fn run(args: &ViewArgs) -> Result<()> {
    match run_viewer(args) {
        Ok(()) => Ok(()),
        Err(Failure::NoWindow(e)) => {
            Err(e.context("cannot open the viewer window (is DISPLAY or WAYLAND_DISPLAY set?)"))
        }
        Err(Failure::Other(e)) => Err(e),
    }
}

/// Whether plain `tiledlight` will try the viewer: a display is named (`DISPLAY` or
/// `WAYLAND_DISPLAY`) and `TILEDLIGHT_HEADLESS` is unset.
pub fn display_available() -> bool {
    std::env::var_os("TILEDLIGHT_HEADLESS").is_none()
        && ["DISPLAY", "WAYLAND_DISPLAY"].iter().any(|v| std::env::var_os(v).is_some_and(|s| !s.is_empty()))
}

/// Plain `tiledlight`: the viewer when a display is available, else the headless
/// quickstart, with one line saying why.
pub fn run_default() -> Result<()> {
    let has_display = display_available();
    let headless_line = |why: &str| {
        println!("{why}: rendering headless to out/ (run `tiledlight view` with a display for the viewer)");
    };
    if std::env::var_os("TILEDLIGHT_HEADLESS").is_some() {
        headless_line("TILEDLIGHT_HEADLESS is set");
        return crate::quickstart::run();
    }
    if !has_display {
        headless_line("no display (DISPLAY and WAYLAND_DISPLAY are unset)");
        return crate::quickstart::run();
    }
    let mut scene = SceneArgs::default();
    (scene.settings.0.width, scene.settings.0.height) = (1280, 720);
    let args = ViewArgs { scene, frames: None, script: None, screenshot: None, screenshot_ui: None };
    match run_viewer(&args) {
        Ok(()) => Ok(()),
        Err(Failure::NoWindow(e)) => {
            headless_line(&format!("no window ({})", crate::error_line(&e)));
            crate::quickstart::run()
        }
        Err(Failure::Other(e)) => Err(e),
    }
}

fn run_viewer(args: &ViewArgs) -> Result<(), Failure> {
    let script: VecDeque<Action> = match &args.script {
        Some(s) => script::parse(s).map_err(Failure::Other)?.into(),
        None => VecDeque::new(),
    };
    for (flag, p) in [("--screenshot", &args.screenshot), ("--screenshot-ui", &args.screenshot_ui)] {
        if let Some(p) = p {
            check_png_path(p).map_err(Failure::Other)?;
            tiledlight_lab::output::check_output(flag, p).map_err(Failure::Other)?;
        }
    }
    if args.frames.is_none() && (args.screenshot.is_some() || args.screenshot_ui.is_some()) {
        return Err(Failure::Other(anyhow::anyhow!("--screenshot and --screenshot-ui need --frames N")));
    }
    // Flags and files first: a typo should not cost a window and a device.
    let setup = args.scene.settings().map_err(Failure::Other)?;
    let cpu = SceneCpu::load(&setup).map_err(Failure::Other)?;
    tiledlight_lab::output::print_load_warnings(&cpu.warnings);
    let event_loop = EventLoop::new().map_err(|e| Failure::NoWindow(e.into()))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App { args: args.clone(), script, cpu: Some((setup, cpu)), viewer: None, failure: None };
    event_loop.run_app(&mut app).map_err(|e| Failure::Other(e.into()))?;
    match app.failure {
        Some(f) => Err(f),
        None => {
            let warnings = app.viewer.as_ref().map_or(0, |v| v.warnings);
            dropped::strict(args.scene.rows().strict, warnings).map_err(Failure::Other)
        }
    }
}

/// The winit application: creates the viewer when the event loop starts.
struct App {
    args: ViewArgs,
    script: VecDeque<Action>,
    /// The settings of the flags and the scene loaded from them, until the window opens.
    cpu: Option<(tiledlight_setup::Settings, SceneCpu)>,
    viewer: Option<Viewer>,
    failure: Option<Failure>,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.viewer.is_some() {
            return;
        }
        let Some((setup, cpu)) = self.cpu.take() else { return };
        match Viewer::new(event_loop, &self.args, setup, cpu, std::mem::take(&mut self.script)) {
            Ok(v) => self.viewer = Some(v),
            Err(f) => {
                self.failure = Some(f);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(v) = self.viewer.as_mut() else { return };
        let response = v.egui_state.on_window_event(&v.window, &event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => v.resize(size.width, size.height),
            WindowEvent::RedrawRequested => match v.frame() {
                Ok(true) => event_loop.exit(),
                Ok(false) => {}
                Err(e) => {
                    // After a device loss, whatever failed is a consequence: name the loss.
                    let e = v.prep.device_lost().map_or(e, anyhow::Error::from);
                    self.failure = Some(Failure::Other(e));
                    event_loop.exit();
                }
            },
            _ => {
                if response.repaint {
                    v.window.request_redraw();
                }
            }
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        if let Some(v) = &self.viewer {
            v.window.request_redraw();
        }
    }
}

/// The window, its surface, and everything drawn into it.
struct Viewer {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    prep: Prepared,
    renderer: FrameRenderer,
    blit: Blit,
    display: DisplayImage,
    timer: GpuTimer,
    egui_ctx: egui::Context,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
    egui_free: Vec<egui::TextureId>,
    /// The settings in use, and the copy the panel edits.
    settings: Settings,
    pending: Settings,
    rig: CameraRig,
    home: CameraRig,
    animator: LightAnimator,
    stats: Stats,
    ui: UiState,
    script: VecDeque<Action>,
    wait: u32,
    frames_left: Option<u32>,
    screenshot: Option<PathBuf>,
    screenshot_ui: Option<PathBuf>,
    frames: u64,
    /// Frames a scripted run drew while its script's actions (and waits) were still running;
    /// `--frames N` counts the frames after them.
    script_frames: u64,
    last_frame: Instant,
    last_stats: Option<Instant>,
    minimized: bool,
    /// The latest light-grid headers read back (opaque, blended, VPL).
    grids: (Option<GridStatus>, Option<GridStatus>, Option<GridStatus>),
    /// The frames drop lights now (the panel's warning is up).
    dropping: bool,
    /// `warning:` lines printed (for `--strict`).
    warnings: usize,
}

/// The surface format: a plain (non-sRGB) 8-bit one, which egui expects (it blends in
/// gamma space); the blit writes the lit image through an sRGB view of it, so the image's
/// linear values are encoded exactly as in the PNGs.
fn surface_format(caps: &wgpu::SurfaceCapabilities) -> Result<wgpu::TextureFormat> {
    caps.formats
        .iter()
        .copied()
        .find(|f| !f.is_srgb() && f.add_srgb_suffix() != *f)
        .or_else(|| caps.formats.first().map(|f| f.remove_srgb_suffix()))
        .context("the window surface offers no format")
}

fn present_mode(vsync: bool) -> wgpu::PresentMode {
    if vsync {
        wgpu::PresentMode::AutoVsync
    } else {
        wgpu::PresentMode::AutoNoVsync
    }
}

/// A rig at the prepared scene's starting camera, its orbit target at the scene centre's
/// distance; the near plane is pulled in so flying close to walls does not clip them.
fn home_rig(prep: &Prepared) -> CameraRig {
    let dist = (prep.bounds.center() - prep.camera.eye()).length().max(1e-2);
    let mut rig = CameraRig::from_camera(&prep.camera, dist);
    if prep.settings.camera.is_none() {
        rig.near = rig.near.min(dist * 1e-3).max(1e-4);
    }
    rig
}

impl Viewer {
    fn new(
        event_loop: &ActiveEventLoop,
        args: &ViewArgs,
        mut setup: tiledlight_setup::Settings,
        cpu: SceneCpu,
        script: VecDeque<Action>,
    ) -> Result<Self, Failure> {
        let no_window = |e: anyhow::Error| Failure::NoWindow(e);
        let other = |e: anyhow::Error| Failure::Other(e);
        let attrs = Window::default_attributes()
            .with_title("tiledlight")
            .with_inner_size(winit::dpi::PhysicalSize::new(setup.width, setup.height));
        let window = Arc::new(event_loop.create_window(attrs).map_err(|e| no_window(e.into()))?);
        let display = event_loop.owned_display_handle();
        let w = window.clone();
        let (ctx, surface) =
            GpuContext::for_surface(ContextOptions::default(), Box::new(display), move |i| i.create_surface(w))
                .map_err(|e| no_window(e.into()))?;
        let caps = surface.get_capabilities(&ctx.adapter);
        let format = surface_format(&caps).map_err(no_window)?;
        let size = window.inner_size();
        let (width, height) = (size.width.max(1), size.height.max(1));
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            color_space: wgpu::SurfaceColorSpace::Auto,
            width,
            height,
            present_mode: present_mode(true),
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes.first().copied().unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![format.add_srgb_suffix()],
        };
        surface.configure(&ctx.device, &config);

        (setup.width, setup.height) = (width, height);
        let prep = Prepared::with_context(&setup, cpu, ctx).map_err(other)?;
        let settings = Settings::new(setup);
        let renderer = prep.renderer(false).map_err(other)?;
        let blit = Blit::new(&prep.ctx.device, format.add_srgb_suffix()).map_err(|e| other(e.into()))?;
        let display = blit.display_image(&prep.ctx.device, (width, height));
        let timer = GpuTimer::new(&prep.ctx).map_err(|e| other(e.into()))?;

        let egui_ctx = egui::Context::default();
        let egui_state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(prep.ctx.device.limits().max_texture_dimension_2d as usize),
        );
        let egui_renderer = egui_wgpu::Renderer::new(&prep.ctx.device, format, egui_wgpu::RendererOptions::default());
        let home = home_rig(&prep);
        let animator = LightAnimator::new(&prep.lights.packed, prep.bounds.center());
        let stats = Stats { timestamps: timer.enabled(), ..Stats::default() };
        let scene_path = match &prep.settings.scene {
            SceneSource::Default => String::new(),
            SceneSource::Materials => "materials".to_string(),
            SceneSource::File(path) => path.display().to_string(),
            SceneSource::Peer(p) => p.name().to_string(),
        };
        log::info!("viewer: {} on {}", prep.scene_name, prep.ctx.describe());
        Ok(Self {
            window,
            surface,
            config,
            renderer,
            blit,
            display,
            timer,
            egui_ctx,
            egui_state,
            egui_renderer,
            egui_free: Vec::new(),
            pending: settings.clone(),
            settings,
            rig: home.clone(),
            home,
            animator,
            stats,
            ui: UiState { scene_path, ..UiState::default() },
            script,
            wait: 0,
            frames_left: args.frames,
            screenshot: args.screenshot.clone(),
            screenshot_ui: args.screenshot_ui.clone(),
            frames: 0,
            script_frames: 0,
            last_frame: Instant::now(),
            last_stats: None,
            minimized: false,
            grids: (None, None, None),
            dropping: false,
            warnings: 0,
            prep,
        })
    }

    /// A new window size: the surface is reconfigured now, the renderer at the next frame.
    fn resize(&mut self, width: u32, height: u32) {
        self.minimized = width == 0 || height == 0;
        if self.minimized {
            return;
        }
        self.config.width = width;
        self.config.height = height;
        self.surface.configure(&self.prep.ctx.device, &self.config);
        self.pending.setup.width = width;
        self.pending.setup.height = height;
    }

    /// Shows an error in the panel and on stderr; the viewer goes on.
    fn report(&mut self, e: &anyhow::Error) {
        let line = crate::error_line(e);
        eprintln!("error: {line}");
        self.ui.error = Some(line);
    }

    /// Applies `new` (the panel's or the script's edit), rebuilding what it must. On error
    /// the previous settings stay in use (and the panel shows them again).
    fn apply(&mut self, new: Settings) {
        if let Err(e) = self.try_apply(&new) {
            self.report(&e);
            let old = self.settings.clone();
            // The failed attempt may have replaced the scene or the lights before the
            // renderer failed: go back from what `prep` holds now to the old settings.
            self.settings = Settings { setup: self.prep.requested().clone(), ..old.clone() };
            if let Err(e) = self.try_apply(&old) {
                self.report(&e);
                self.settings = old;
            }
        }
        self.pending = self.settings.clone();
    }

    /// The heat map a renderer for `s` is built with: the blended lists only when the scene
    /// now loaded has blended geometry, the VPL lists only with VPLs (the choice is kept for
    /// a scene or settings that have them).
    fn heatmap_of(&self, s: &Settings) -> Option<HeatmapOf> {
        s.effective_heatmap().then(|| s.shown_heatmap(self.prep.has_blended_geometry()))
    }

    fn try_apply(&mut self, new: &Settings) -> Result<()> {
        let mut new = new.clone();
        // A new scene starts from its own camera, not the bookmark of the first one.
        if new.setup.scene != self.settings.setup.scene {
            new.setup.camera = None;
        }
        let p = plan(&self.settings, &new);
        if p.is_empty() {
            self.settings = new;
            return Ok(());
        }
        // Scene, lights and camera as the plan says (nothing changes when it fails).
        let rebuilt = self.prep.reconfigure(&new.setup)?;
        if rebuilt.reload == Reload::Scene {
            tiledlight_lab::output::print_load_warnings(&self.prep.scene_warnings);
        }
        if rebuilt.reload == Reload::Scene || new.setup.camera != self.settings.setup.camera {
            self.home = home_rig(&self.prep);
            self.rig = self.home.clone();
        }
        if rebuilt.reload != Reload::Nothing {
            self.animator = LightAnimator::new(&self.prep.lights.packed, self.prep.bounds.center());
        }
        let renderer_rebuilt = p.renderer || rebuilt.renderer;
        if renderer_rebuilt {
            // The old renderer stays in use until the new one is built, so a renderer
            // the GPU refuses leaves a working viewer behind.
            let size = (new.setup.width, new.setup.height);
            let built = self.prep.renderer_with_heatmap(self.heatmap_of(&new));
            self.renderer = built?;
            self.display = self.blit.display_image(&self.prep.ctx.device, size);
            self.stats.culling = None;
            self.last_stats = None;
        } else {
            // The same renderer: its exposure and heat map are switched in place.
            if p.setup.exposure {
                self.renderer.set_exposure(&self.prep.ctx.queue, new.setup.exposure)?;
            }
            if let Some(h) = self.renderer.heatmap() {
                h.set_enabled(new.effective_heatmap());
                // Only lists the pass has: no error to handle.
                let of = new.shown_heatmap(h.has_blended());
                h.set_of(if h.has(of) { of } else { HeatmapOf::Opaque })?;
            }
        }
        if renderer_rebuilt || rebuilt.reload != Reload::Nothing {
            // The shadows follow the lights as they are on the GPU now: a new renderer drew
            // them for the lights as uploaded, not as the animation left them, and light
            // data rewritten in place (seed, threshold) is news to the renderer in use.
            self.renderer.lights_moved(&self.prep.ctx.queue, self.animator.current())?;
        }
        if p.surface {
            self.config.present_mode = present_mode(new.vsync);
            self.surface.configure(&self.prep.ctx.device, &self.config);
        }
        self.settings = new;
        Ok(())
    }

    /// Runs the next script action, if its turn has come.
    fn script_step(&mut self) {
        if self.wait > 0 {
            self.wait -= 1;
            return;
        }
        let Some(action) = self.script.pop_front() else { return };
        match action {
            Action::Wait(n) => self.wait = n,
            Action::Camera(mode) => self.rig.mode = mode,
            Action::Window(w, h) => {
                // Some window systems resize at once (returning the size), others later
                // with a Resized event; both end in `resize`.
                if let Some(size) = self.window.request_inner_size(winit::dpi::PhysicalSize::new(w, h)) {
                    self.resize(size.width, size.height);
                }
            }
            Action::Set { key, value } => {
                let mut s = self.pending.clone();
                match script::set(&mut s, &key, &value) {
                    Ok(()) => self.apply(s),
                    Err(e) => self.report(&e),
                }
            }
        }
    }

    fn run_command(&mut self, c: Command) -> bool {
        match c {
            Command::ResetCamera => self.rig = self.home.clone(),
            Command::SaveCamera => match bookmark::save(Path::new(BOOKMARK_PATH), &self.rig.desc()) {
                Ok(()) => self.ui.notice = Some(format!("wrote {BOOKMARK_PATH} (use with --camera)")),
                Err(e) => self.report(&e),
            },
            Command::Screenshot => {
                let path = (1..).map(|n| PathBuf::from(format!("out/screenshot-{n}.png"))).find(|p| !p.exists());
                if let Some(path) = path {
                    match write_image(&self.prep, &self.renderer, self.settings.effective_heatmap(), &path) {
                        Ok(_) => self.ui.notice = Some(format!("wrote {}", path.display())),
                        Err(e) => self.report(&e),
                    }
                }
            }
            Command::Quit => return true,
        }
        false
    }

    /// Lights whose bounding sphere meets the view frustum (CPU, from the uploaded data).
    fn visible_lights(&self, camera: &Camera) -> usize {
        let dp = camera.depth_params();
        let f = TileFrustum::from_parts(&camera.proj(), &dp, (-1.0, 1.0, -1.0, 1.0), dp.near, dp.far);
        let view = camera.view();
        let lights = if self.settings.animate { self.animator.current() } else { &self.prep.lights.packed };
        lights.cull.iter().filter(|l| sphere_vs_frustum(&f, to_view(&view, l.center.into()), l.radius)).count()
    }

    /// Renders one frame; true when a scripted run is finished.
    fn frame(&mut self) -> Result<bool> {
        let now = Instant::now();
        let dt = (now - self.last_frame).as_secs_f32();
        self.last_frame = now;
        if self.minimized {
            return Ok(false);
        }
        if let Some(lost) = self.prep.device_lost() {
            return Err(lost.into());
        }
        for e in self.prep.take_gpu_errors() {
            self.report(&anyhow::anyhow!("GPU: {e}"));
        }

        // The panel (and keys) edit `pending`; applied below unless a slider is held.
        let raw = self.egui_state.take_egui_input(&self.window);
        let info = Info {
            adapter: &self.prep.ctx.info.name,
            scene: format!(
                "{}: {} triangles, {} instances",
                self.prep.scene_name,
                group_digits(self.prep.scene_gpu.triangles),
                self.prep.instances
            ),
            lights: &self.prep.light_summary,
            memory: self.renderer.memory(),
            capacity: self.prep.settings.capacity(),
            shadow_atlas: self.renderer.outputs().shadow_atlas,
            blended: self.renderer.outputs().blended,
            size: (self.prep.settings.width, self.prep.settings.height),
            stats: &self.stats,
        };
        let (ui, pending, rig) = (&mut self.ui, &mut self.pending, &mut self.rig);
        let mut commands = Vec::new();
        let mut output = self.egui_ctx.run_pass(raw, |ctx| commands = ui::draw(ctx, ui, pending, rig, &info, dt));
        self.egui_state.handle_platform_output(&self.window, std::mem::take(&mut output.platform_output));
        // Texture changes are applied now, even if this frame is not drawn; textures egui
        // no longer uses are freed at the next frame, after this one's paint jobs ran.
        {
            let ctx = &self.prep.ctx;
            for id in self.egui_free.drain(..) {
                self.egui_renderer.free_texture(&id);
            }
            for (id, deltas) in &output.textures_delta.set {
                for delta in deltas {
                    self.egui_renderer.update_texture(&ctx.device, &ctx.queue, *id, delta);
                }
            }
            self.egui_free.extend(output.textures_delta.free.iter().copied());
            output.textures_delta.clear();
        }
        let mut quit = false;
        for c in commands {
            quit |= self.run_command(c);
        }
        if self.pending != self.settings && !self.egui_ctx.egui_is_using_pointer() {
            self.apply(self.pending.clone());
        }
        if self.frames > 0 {
            self.script_step();
        }

        if self.settings.animate {
            let queue = &self.prep.ctx.queue;
            self.animator.advance(queue, &self.prep.lights, dt);
            // The moved casters' shadow faces are drawn again by this frame. Should the
            // renderer not fit the lights (a failed change left them apart), the panel says
            // so once and the viewer goes on with shadows where they were.
            if let Err(e) = self.renderer.lights_moved(queue, self.animator.current()) {
                let e = anyhow::Error::from(e).context("moving the lights' shadows");
                if self.ui.error.as_deref() != Some(crate::error_line(&e).as_str()) {
                    self.report(&e);
                }
            }
        }
        let (w, h) = (self.prep.settings.width, self.prep.settings.height);
        let camera = match self.rig.camera(w as f32 / h as f32) {
            Ok(c) => c,
            Err(e) => {
                self.report(&e.context("camera"));
                self.rig = self.home.clone();
                return Ok(quit);
            }
        };

        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => return Ok(quit),
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.prep.ctx.device, &self.config);
                return Ok(quit);
            }
            other => bail!("cannot draw to the window: {other:?}"),
        };
        let (target, target_srgb) = views(&frame.texture);
        let scripted_end = self.frames_left == Some(0) && self.script.is_empty() && self.wait == 0;
        let capture = if scripted_end { self.screenshot_ui.take() } else { None };

        let ctx = &self.prep.ctx;
        let ppp = egui_winit::pixels_per_point(&self.egui_ctx, &self.window);
        let paint = self.egui_ctx.tessellate(output.shapes, ppp);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [self.config.width, self.config.height],
            pixels_per_point: ppp,
        };
        // A finished frame's light-grid headers, when their copies have arrived: a grid
        // grows for the next frame if that one dropped lights; one that cannot (the VPLs'
        // never does) is warned of.
        // (Never waits: it cannot fail on a read-back.)
        let between = self.renderer.between_frames(ctx, false).unwrap_or_default();
        let (opaque, blended, vpl) = (between.status, between.blended, between.vpl);
        self.grids = (opaque.or(self.grids.0), blended.or(self.grids.1), vpl.or(self.grids.2));
        let dropping = self.lasting_drops();
        self.stats.dropped = dropping;
        if let Some(w) = &self.stats.dropped {
            if !self.dropping {
                dropped::warn(&mut self.warnings, w);
            }
        }
        self.dropping = self.stats.dropped.is_some();
        let mut encoder =
            ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("viewer.frame") });
        self.renderer.record(&ctx.queue, &mut encoder, &self.timer, &self.prep.scene_gpu, &camera);
        let extra = self.egui_renderer.update_buffers(&ctx.device, &ctx.queue, &mut encoder, &paint, &screen);
        let ldr = &self.renderer.outputs().targets.ldr;
        self.blit.record(&mut encoder, Some(&self.timer), ldr, &self.display, &target_srgb);
        let t = self.timer.begin("viewer.ui", &mut encoder);
        draw_ui(&self.egui_renderer, &mut encoder, &target, t.render_writes(), &paint, &screen);
        self.timer.end(&mut encoder, t);
        let captured = capture.map(|path| {
            let tex = ctx.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("viewer.capture"),
                size: wgpu::Extent3d { width: self.config.width, height: self.config.height, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: self.config.format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[self.config.format.add_srgb_suffix()],
            });
            let (view, view_srgb) = views(&tex);
            self.blit.record(&mut encoder, None, ldr, &self.display, &view_srgb);
            draw_ui(&self.egui_renderer, &mut encoder, &view, None, &paint, &screen);
            (path, tex)
        });
        self.timer.resolve(&mut encoder);
        ctx.queue.submit(extra.into_iter().chain([encoder.finish()]));
        self.window.pre_present_notify();
        ctx.queue.present(frame);
        tiledlight_lab::bench::lose_device_for_tests(ctx);
        self.timer.end_frame()?;
        ctx.device.poll(wgpu::PollType::Poll).context("polling the GPU")?;
        while let Some(times) = self.timer.finished_frame() {
            self.stats.passes = times;
        }
        self.stats.push_frame(dt * 1e3);
        self.stats.shadow_faces = self.renderer.outputs().shadow_atlas.map(|a| a.faces_drawn_last_frame());
        self.frames += 1;

        if self.last_stats.is_none_or(|t| t.elapsed() >= STATS_PERIOD) || scripted_end {
            self.last_stats = Some(Instant::now());
            self.stats.visible_lights = self.visible_lights(&camera);
            match self.prep.culling_stats(&self.renderer) {
                Ok(c) => self.stats.culling = c,
                Err(e) => self.report(&e),
            }
            // A frame whose VPLs the cap refused is warned of once while it lasts, as
            // dropped lights are.
            let refused_before = self.stats.vpls.is_some_and(|(_, r)| r > 0);
            match self.renderer.vpl_count(&self.prep.ctx) {
                Ok(v) => {
                    if let (Some(w), false) =
                        (v.and_then(|c| tiledlight_lab::dropped::refused_line("the frame", c)), refused_before)
                    {
                        dropped::warn(&mut self.warnings, &w);
                    }
                    self.stats.vpls = v;
                }
                Err(e) => self.report(&e.into()),
            }
        }

        if let Some((path, tex)) = captured {
            self.save_capture(&path, &tex)?;
        }
        if scripted_end {
            if let Some(path) = self.screenshot.take() {
                write_image(&self.prep, &self.renderer, self.settings.effective_heatmap(), &path)?;
                println!("wrote {}", path.display());
            }
            self.print_state();
            return Ok(true);
        }
        if let Some(n) = self.frames_left.as_mut() {
            if self.script.is_empty() && self.wait == 0 {
                *n = n.saturating_sub(1);
            } else {
                self.script_frames += 1;
            }
        }
        Ok(quit)
    }

    /// The warning about the latest frames' dropped lights, when a grid dropped some and
    /// cannot grow to hold them (a grid that can has grown for the next frame already).
    fn lasting_drops(&self) -> Option<String> {
        let (opaque, blended, vpl) = self.grids;
        let lasting = |s: Option<GridStatus>, capacity: Option<u32>| {
            s.filter(|s| !s.complete() && capacity.is_some_and(|c| s.needed() > c))
        };
        let opaque = lasting(opaque, self.renderer.outputs().light_grid.map(|g| g.capacity()));
        let blended_capacity =
            self.renderer.outputs().blended.and_then(|b| b.culling.as_ref()).map(|c| c.grid.capacity());
        let blended = lasting(blended, blended_capacity);
        // The VPL grid never grows: whatever it dropped lasts.
        let vpl = lasting(vpl, self.renderer.outputs().vpl_light_grid.map(|g| g.capacity()));
        let d = Dropped::of(opaque.as_slice(), blended.as_slice()).with_vpl(vpl.as_slice());
        let max_binding = self.prep.ctx.device.limits().max_storage_buffer_binding_size;
        d.warning("the frame", self.prep.settings.grid_pairs, max_binding)
    }

    /// Writes the window as shown (panel included), read back from `tex`.
    fn save_capture(&self, path: &Path, tex: &wgpu::Texture) -> Result<()> {
        let ctx = &self.prep.ctx;
        let mut px = read_texture(&ctx.device, &ctx.queue, tex, wgpu::TextureAspect::All, 4)?;
        if matches!(tex.format(), wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb) {
            px.chunks_exact_mut(4).for_each(|p| p.swap(0, 2));
        }
        save_png(path, &rgb_image(tex.width(), tex.height(), &px)?)?;
        println!("wrote {} (with the panel)", path.display());
        Ok(())
    }

    /// The end state of a scripted run, for tests: what the panel would show.
    fn print_state(&self) {
        let s = &self.settings;
        let l = &self.prep.light_summary;
        // `--frames N` counts the frames after the script; one more is drawn for the
        // screenshots and this report: say which frames were which.
        println!(
            "viewer frames: {} ({} while the script's actions ran, {} after them, 1 final)",
            self.frames,
            self.script_frames,
            self.frames.saturating_sub(self.script_frames + 1)
        );
        println!("viewer method: {}", s.setup.method.name());
        println!("viewer lights: {} point, {} spot", l.point, l.spot);
        println!("viewer scene: {}", self.prep.scene_name);
        println!("viewer size: {}x{}", self.prep.settings.width, self.prep.settings.height);
        println!("viewer msaa: {}x", self.prep.settings.msaa);
        if let Some(a) = self.renderer.outputs().shadow_atlas {
            let (points, spots) = self.prep.settings.shadow_casters();
            println!(
                "viewer shadows: {points} point + {spots} spot casters, {} faces drawn by the last frame; {}",
                a.faces_drawn_last_frame(),
                shadow_atlas_description(a)
            );
        }
        if let Some(b) = self.renderer.outputs().blended {
            println!("viewer blended: {} instances, {}", b.instance_count(), blend_mode_description(b.mode()));
        }
        if let Some(c) = &self.stats.culling {
            println!("viewer culling: {c}");
        }
        println!("viewer visible lights: {}", self.stats.visible_lights);
        if let Some((kept, refused)) = self.stats.vpls {
            println!("viewer VPLs: {kept} made, {refused} refused");
        }
        match &s.setup.vpl {
            Some(c) => println!(
                "viewer VPL settings: RSM {}, block {}, colour threshold {}, brightness threshold {}, cap {}, {} shading",
                c.rsm_size,
                c.block,
                c.colour_threshold,
                c.brightness_threshold,
                c.cap,
                c.shading.name()
            ),
            None => println!("viewer VPL settings: off"),
        }
        let heat = self.renderer.heatmap().filter(|h| h.enabled()).map_or("off", |h| h.of().name());
        println!("viewer heat map: {heat}");
        println!("viewer dropped: {}", self.stats.dropped.as_deref().unwrap_or("none"));
        println!("viewer error: {}", self.ui.error.as_deref().unwrap_or("none"));
    }
}

/// Plain and sRGB views of a surface (or capture) texture: egui draws through the first,
/// the blit through the second.
fn views(texture: &wgpu::Texture) -> (wgpu::TextureView, wgpu::TextureView) {
    let plain = texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some("viewer.surface"),
        format: Some(texture.format().remove_srgb_suffix()),
        ..Default::default()
    });
    let srgb = texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some("viewer.surface.srgb"),
        format: Some(texture.format().add_srgb_suffix()),
        ..Default::default()
    });
    (plain, srgb)
}

/// Draws egui's paint jobs over `target`.
fn draw_ui(
    renderer: &egui_wgpu::Renderer,
    encoder: &mut wgpu::CommandEncoder,
    target: &wgpu::TextureView,
    timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    paint: &[egui::ClippedPrimitive],
    screen: &egui_wgpu::ScreenDescriptor,
) {
    let mut pass = encoder
        .begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("viewer.ui"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        })
        .forget_lifetime();
    renderer.render(&mut pass, paint, screen);
}
