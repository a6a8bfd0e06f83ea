//! The viewer's egui panel, help overlay and input: the controls of TiledLighting11's
//! sample (method, light counts, threshold, tile size, half-z, grid objects, G-buffer
//! targets, MSAA, heat map with legend, shadow-casting point and spot lights with the
//! shadow tile size, filter and format, transparent grid objects and the blend mode,
//! virtual point lights: on/off, RSM size, block, thresholds, cap, shading model),
//! scene and camera controls, and the statistics (per-pass GPU times with a rolling
//! graph, frame time, visible lights, lights per tile, lists that lost lights to a full
//! light grid, shadow faces drawn and the shadow atlas, blended instances, GPU memory). Widgets edit a copy of the settings; the viewer applies
//! it ([`super::settings::plan`] decides what to rebuild). Keys and mouse steer the camera
//! when egui does not want them. Depends on egui, tiledlight-setup (settings, statistics)
//! and the viewer's other modules.

use std::collections::VecDeque;

use egui::{Color32, RichText};
use tiledlight_gpu::blended::BlendedPath;
use tiledlight_gpu::heatmap::{heatmap_palette, heatmap_t, HeatmapOf, HEATMAP_OVERFLOW};
use tiledlight_gpu::knobs::{Control, Kind, Knob, Knobs, Needs, KNOBS};
use tiledlight_gpu::memory::{format_bytes, MemoryReport};
use tiledlight_gpu::shadow_atlas::ShadowAtlas;
use tiledlight_gpu::timer::PassTime;

use super::settings::{Settings, VplControl, METHODS, MSAA_CHOICES, VPL_BLOCKS, VPL_RSM_SIZES};
use tiledlight_cull::vpl::VplShading;
use tiledlight_lab::legend::label_values;
use tiledlight_scene::GridDensity;
use tiledlight_setup::camera_rig::{CameraRig, Mode, Motion};
use tiledlight_setup::stats::atlas_layout_description;
use tiledlight_setup::{CasterChoice, CullingStats, LightSummary, Method, SceneSource};

use tiledlight_setup::GridLayout;

/// The most shadow-casting lights of each kind the panel's sliders offer (TiledLighting11
/// has a few; every point caster is six atlas tiles).
pub const MAX_PANEL_CASTERS: usize = 128;

/// Key bindings, as the help overlay (F1) and docs/USAGE.md list them.
pub const KEYS: [(&str, &str); 15] = [
    ("W A S D", "fly forward / left / back / right"),
    ("Q / E", "fly down / up"),
    ("Shift", "move 5x faster"),
    ("drag (left or right button)", "look around (fly) / turn around the target (orbit)"),
    ("wheel", "flight speed (fly) / distance to the target (orbit)"),
    ("Tab", "switch between fly and orbit"),
    ("R", "reset the camera"),
    ("C", "save the camera bookmark (out/camera.txt)"),
    ("M", "next method"),
    ("H", "heat map on / off"),
    ("Space", "light animation on / off"),
    ("P or F12", "screenshot of the lit image, no UI (out/screenshot-N.png)"),
    ("U", "hide / show the panel"),
    ("F1", "this help"),
    ("Esc", "quit"),
];

/// Frames kept for the rolling graph.
pub const HISTORY: usize = 240;

/// Something the panel or a key asks the viewer to do.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Command {
    /// Back to the scene's starting camera.
    ResetCamera,
    /// Write the camera bookmark.
    SaveCamera,
    /// Save the lit image.
    Screenshot,
    /// Close the viewer.
    Quit,
}

/// Measurements shown in the panel.
#[derive(Clone, Debug, Default)]
pub struct Stats {
    /// Pass times of the last finished frame.
    pub passes: Vec<PassTime>,
    /// Per frame: CPU frame time and summed GPU time, milliseconds.
    pub history: VecDeque<(f32, f32)>,
    /// Culling statistics, refreshed a few times a second (tiled methods).
    pub culling: Option<CullingStats>,
    /// Lights whose bounding sphere meets the view frustum.
    pub visible_lights: usize,
    /// Whether the device has timestamp queries.
    pub timestamps: bool,
    /// Shadow faces the last frame drew (None without shadow casters).
    pub shadow_faces: Option<u32>,
    /// The warning about lights the latest frames dropped (a light grid full and unable to
    /// grow), shown in red at the top of the panel; None while frames are complete.
    pub dropped: Option<String>,
    /// VPLs the last frame read back made and those the cap refused (None without VPLs),
    /// refreshed with the culling statistics.
    pub vpls: Option<(u32, u32)>,
}

impl Stats {
    /// Records a frame's CPU time (and the latest GPU total).
    pub fn push_frame(&mut self, frame_ms: f32) {
        let gpu: f64 = self.passes.iter().map(|p| p.ms).sum();
        if self.history.len() == HISTORY {
            self.history.pop_front();
        }
        self.history.push_back((frame_ms, gpu as f32));
    }

    /// Mean CPU frame time over the history.
    pub fn mean_frame_ms(&self) -> f32 {
        if self.history.is_empty() {
            return 0.0;
        }
        self.history.iter().map(|h| h.0).sum::<f32>() / self.history.len() as f32
    }
}

/// What the panel shows about the current state.
pub struct Info<'a> {
    /// Adapter line.
    pub adapter: &'a str,
    /// Scene line.
    pub scene: String,
    /// Light counts of the scene in use.
    pub lights: &'a LightSummary,
    /// GPU memory of the renderer, scene and lights.
    pub memory: &'a MemoryReport,
    /// The list capacity in use (heat-map legend).
    pub capacity: u32,
    /// The renderer's shadow atlas, when lights cast shadows.
    pub shadow_atlas: Option<&'a ShadowAtlas>,
    /// The renderer's blended path, when the scene has blended geometry.
    pub blended: Option<&'a BlendedPath>,
    /// Render size in pixels.
    pub size: (u32, u32),
    /// Measurements.
    pub stats: &'a Stats,
}

/// Panel state that is not a setting.
#[derive(Clone, Debug, Default)]
pub struct UiState {
    /// Show the key list.
    pub show_help: bool,
    /// Hide the panel.
    pub hide_panel: bool,
    /// The last error, shown in red until dismissed.
    pub error: Option<String>,
    /// The last notice (file written...).
    pub notice: Option<String>,
    /// The glTF path being typed.
    pub scene_path: String,
}

fn rgb(c: [f32; 3]) -> Color32 {
    egui::Rgba::from_rgb(c[0], c[1], c[2]).into()
}

/// Draws the panel (and help) and handles keys and mouse. Returns the commands asked for.
pub fn draw(
    ctx: &egui::Context,
    st: &mut UiState,
    s: &mut Settings,
    rig: &mut CameraRig,
    info: &Info<'_>,
    dt: f32,
) -> Vec<Command> {
    let mut commands = Vec::new();
    input(ctx, st, s, rig, dt, &mut commands);
    if st.show_help {
        egui::Window::new("Keys (F1)").collapsible(false).anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0]).show(
            ctx,
            |ui| {
                egui::Grid::new("keys").striped(true).show(ui, |ui| {
                    for (k, what) in KEYS {
                        ui.label(RichText::new(k).strong());
                        ui.label(what);
                        ui.end_row();
                    }
                });
            },
        );
    }
    if st.hide_panel {
        return commands;
    }
    egui::Window::new("tiledlight").default_pos([8.0, 8.0]).default_width(290.0).resizable(true).vscroll(true).show(
        ctx,
        |ui| {
            if let Some(e) = st.error.clone() {
                ui.horizontal_wrapped(|ui| {
                    ui.colored_label(Color32::from_rgb(255, 90, 90), format!("error: {e}"));
                    if ui.small_button("dismiss").clicked() {
                        st.error = None;
                    }
                });
            }
            if let Some(n) = &st.notice {
                ui.label(RichText::new(n).weak());
            }
            if let Some(d) = &info.stats.dropped {
                ui.colored_label(Color32::from_rgb(255, 60, 60), RichText::new(format!("warning: {d}")).strong());
            }
            // The panel's order (issue 47): at 1280x720 the method, the lights and the main
            // dials are what a user comes to change, so they come first under a one-line
            // frame summary; the statistics (a screen of numbers) follow, collapsed.
            ui.label(summary_line(info));
            controls(ui, st, s, info);
            stats_section(ui, info);
            camera_section(ui, rig, &mut commands);
            ui.horizontal(|ui| {
                if ui.button("Screenshot (P)").clicked() {
                    commands.push(Command::Screenshot);
                }
                if ui.button("Keys (F1)").clicked() {
                    st.show_help = !st.show_help;
                }
            });
        },
    );
    commands
}

fn input(
    ctx: &egui::Context,
    st: &mut UiState,
    s: &mut Settings,
    rig: &mut CameraRig,
    dt: f32,
    commands: &mut Vec<Command>,
) {
    use egui::Key;
    if !ctx.egui_wants_keyboard_input() {
        ctx.input(|i| {
            let down = |k| if i.key_down(k) { 1.0 } else { 0.0 };
            let motion = Motion {
                right: down(Key::D) - down(Key::A),
                up: down(Key::E) - down(Key::Q),
                forward: down(Key::W) - down(Key::S),
                boost: if i.modifiers.shift { 5.0 } else { 1.0 },
            };
            if rig.mode == Mode::Fly {
                rig.step(motion, dt);
            }
            let pressed = |k| i.key_pressed(k);
            if pressed(Key::F1) {
                st.show_help = !st.show_help;
            }
            if pressed(Key::Tab) {
                rig.mode = if rig.mode == Mode::Fly { Mode::Orbit } else { Mode::Fly };
            }
            if pressed(Key::R) {
                commands.push(Command::ResetCamera);
            }
            if pressed(Key::C) {
                commands.push(Command::SaveCamera);
            }
            if pressed(Key::P) || pressed(Key::F12) {
                commands.push(Command::Screenshot);
            }
            if pressed(Key::U) {
                st.hide_panel = !st.hide_panel;
            }
            if pressed(Key::Escape) {
                commands.push(Command::Quit);
            }
            if pressed(Key::H) {
                s.heatmap = !s.heatmap;
            }
            if pressed(Key::Space) {
                s.animate = !s.animate;
            }
            if pressed(Key::M) {
                let i = METHODS.iter().position(|m| *m == s.setup.method).unwrap_or(0);
                s.setup.method = METHODS[(i + 1) % METHODS.len()];
            }
        });
    }
    if !ctx.egui_wants_pointer_input() {
        ctx.input(|i| {
            if i.pointer.primary_down() || i.pointer.secondary_down() {
                let d = i.pointer.delta();
                rig.turn(d.x, d.y);
            }
            let scroll = i.smooth_scroll_delta.y;
            if scroll != 0.0 {
                // About 50 points a wheel notch (egui-winit's line height); touchpads less.
                rig.wheel(scroll / 50.0);
            }
        });
    }
}

/// The panel's first line: size, frame time and rate, the GPU total when timed, and the
/// visible lights (the statistics section below has the rest).
fn summary_line(info: &Info<'_>) -> String {
    let st = info.stats;
    let frame = st.mean_frame_ms();
    let fps = if frame > 0.0 { 1000.0 / frame } else { 0.0 };
    let gpu = if st.timestamps && !st.passes.is_empty() {
        let total: f64 = st.passes.iter().map(|p| p.ms).sum();
        format!(", GPU {total:.2} ms")
    } else {
        String::new()
    };
    format!(
        "{}x{}  frame {frame:.2} ms ({fps:.1} fps){gpu}, {} lights visible",
        info.size.0, info.size.1, st.visible_lights
    )
}

fn stats_section(ui: &mut egui::Ui, info: &Info<'_>) {
    let st = info.stats;
    egui::CollapsingHeader::new("Statistics").default_open(false).show(ui, |ui| {
        if st.timestamps {
            egui::Grid::new("passes").num_columns(2).show(ui, |ui| {
                for p in &st.passes {
                    ui.label(&p.label);
                    ui.label(format!("{:.3} ms", p.ms));
                    ui.end_row();
                }
                let total: f64 = st.passes.iter().map(|p| p.ms).sum();
                ui.label(RichText::new("GPU total").strong());
                // A frame that dropped lights did less than the whole frame's work.
                match st.dropped {
                    Some(_) => ui.colored_label(
                        Color32::from_rgb(255, 60, 60),
                        RichText::new(format!("{total:.3} ms * (incomplete frame)")).strong(),
                    ),
                    None => ui.label(RichText::new(format!("{total:.3} ms")).strong()),
                };
                ui.end_row();
            });
        } else {
            ui.label("GPU pass times: the adapter has no timestamp queries");
        }
        graph(ui, st);
        let l = info.lights;
        ui.label(format!("lights: {} point, {} spot; {} visible", l.point, l.spot, st.visible_lights));
        match &st.culling {
            Some(c) => {
                let per = if c.lists_per_tile == 1 { "tile" } else { "half-z list" };
                ui.label(format!("lights per {per}: mean {:.1}, max {}", c.mean_per_list, c.max_per_list));
                let colour =
                    if c.overflowing > 0 { Color32::from_rgb(255, 120, 255) } else { ui.visuals().text_color() };
                ui.colored_label(
                    colour,
                    format!("lists that lost lights (grid full): {} ({} lights)", c.overflowing, c.dropped),
                );
                ui.label(format!("lists past the workgroup list ({}): {}", c.capacity, c.spilled));
            }
            None => {
                ui.label("no tiles (brute force)");
            }
        }
        if let Some(a) = info.shadow_atlas {
            let faces = st.shadow_faces.unwrap_or_default();
            ui.label(format!("shadow faces drawn last frame: {faces} of {}", a.layout.faces()));
            ui.label(format!("shadow atlas: {}", format_bytes(a.memory.total())))
                .on_hover_text(atlas_layout_description(&a.layout, &a.options));
        }
        if let Some((kept, refused)) = st.vpls {
            ui.label(format!("VPLs: {kept}"));
            if refused > 0 {
                ui.colored_label(
                    Color32::from_rgb(255, 60, 60),
                    format!("{refused} VPLs refused by the cap (--vpl-cap)"),
                );
            }
        }
        if let Some(b) = info.blended {
            ui.label(format!(
                "blended: {} instances ({}), {}",
                b.instance_count(),
                b.mode().name(),
                format_bytes(b.memory.total())
            ));
        }
        egui::CollapsingHeader::new(format!("GPU memory: {}", format_bytes(info.memory.total()))).show(ui, |ui| {
            egui::Grid::new("memory").num_columns(2).show(ui, |ui| {
                for (c, b) in &info.memory.entries {
                    ui.label(c);
                    ui.label(format_bytes(*b));
                    ui.end_row();
                }
            });
        });
        ui.label(RichText::new(info.adapter).weak().small());
        ui.label(RichText::new(&info.scene).weak().small());
    });
}

/// The rolling graph: CPU frame time (white) and GPU time (green), scaled to the largest.
fn graph(ui: &mut egui::Ui, st: &Stats) {
    let (rect, _) = ui.allocate_exact_size(egui::vec2(ui.available_width().min(260.0), 48.0), egui::Sense::hover());
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 2.0, Color32::from_black_alpha(120));
    let max = st.history.iter().map(|h| h.0.max(h.1)).fold(1e-3f32, f32::max);
    let point = |i: usize, v: f32| {
        egui::pos2(
            rect.left() + rect.width() * i as f32 / (HISTORY - 1) as f32,
            rect.bottom() - rect.height() * (v / max).clamp(0.0, 1.0),
        )
    };
    for (series, colour) in [(0usize, Color32::WHITE), (1, Color32::from_rgb(80, 220, 120))] {
        let pts: Vec<egui::Pos2> =
            st.history.iter().enumerate().map(|(i, h)| point(i, if series == 0 { h.0 } else { h.1 })).collect();
        painter.add(egui::Shape::line(pts, egui::Stroke::new(1.0, colour)));
    }
    painter.text(
        rect.left_top() + egui::vec2(3.0, 2.0),
        egui::Align2::LEFT_TOP,
        format!("{max:.1} ms  frame / GPU"),
        egui::FontId::monospace(9.0),
        Color32::LIGHT_GRAY,
    );
}

fn controls(ui: &mut egui::Ui, st: &mut UiState, s: &mut Settings, info: &Info<'_>) {
    let tiled = s.setup.method.is_tiled();
    egui::CollapsingHeader::new("Method and lights").default_open(true).show(ui, |ui| {
        egui::ComboBox::from_label("method").selected_text(s.setup.method.label()).show_ui(ui, |ui| {
            for m in METHODS {
                ui.selectable_value(&mut s.setup.method, m, m.label());
            }
        });
        let (mut points, mut spots) = s.setup.random_light_counts();
        ui.add(egui::Slider::new(&mut points, 0..=65_536).logarithmic(true).text("point lights"));
        ui.add(egui::Slider::new(&mut spots, 0..=65_536).logarithmic(true).text("spot lights"));
        if (points, spots) != s.setup.random_light_counts() {
            (s.setup.lights, s.setup.spot_lights) = (Some(points), Some(spots));
        }
        ui.add(egui::Slider::new(&mut s.setup.threshold, 0.001..=2.0).logarithmic(true).text("intensity threshold"))
            .on_hover_text("each light's radius is sqrt(intensity / threshold): lower is more accurate and slower");
        ui.checkbox(&mut s.animate, "animate lights");
        egui::ComboBox::from_label("MSAA")
            .selected_text(format!("{}x", s.setup.msaa))
            .show_ui(ui, |ui| {
                for m in MSAA_CHOICES {
                    ui.selectable_value(&mut s.setup.msaa, m, format!("{m}x"));
                }
            })
            .response
            .on_hover_text("2x and 8x only where the GPU has them (an error says so otherwise)");
        ui.add_enabled_ui(tiled, |ui| {
            ui.checkbox(&mut s.heatmap, "heat map (lights per tile)").on_disabled_hover_text("needs a tiled method");
        });
        ui.add_enabled_ui(tiled && s.heatmap, |ui| {
            ui.horizontal(|ui| {
                ui.label("  of");
                ui.radio_value(&mut s.heatmap_of, HeatmapOf::Opaque, "opaque");
                ui.add_enabled_ui(info.blended.is_some(), |ui| {
                    ui.radio_value(&mut s.heatmap_of, HeatmapOf::Blended, "blended")
                        .on_hover_text("the transparent geometry's own light lists; tiles without it keep the image")
                        .on_disabled_hover_text("needs blended geometry (transparent objects)");
                });
                ui.add_enabled_ui(s.setup.vpl.is_some(), |ui| {
                    ui.radio_value(&mut s.heatmap_of, HeatmapOf::Vpl, "VPL")
                        .on_hover_text("the virtual point lights' own lists: VPLs per tile")
                        .on_disabled_hover_text("needs VPLs (the VPL section)");
                });
            });
        });
        if s.effective_heatmap() {
            legend(ui, info.capacity);
        }
        ui.checkbox(&mut s.setup.auto_exposure, "automatic exposure")
            .on_hover_text("from each frame's log-average luminance, mapped to middle grey (a compute pass)");
        ui.add_enabled_ui(!s.setup.auto_exposure, |ui| {
            ui.add(egui::Slider::new(&mut s.setup.exposure, 1e-3..=1e3).logarithmic(true).text("exposure"))
        });
    });
    egui::CollapsingHeader::new("Culling and passes").default_open(true).show(ui, |ui| {
        ui.add_enabled_ui(tiled, |ui| {
            ui.horizontal(|ui| {
                ui.label("tile size");
                for t in [8, 16, 32] {
                    ui.radio_value(&mut s.setup.tile_size, t, format!("{t}"));
                }
            });
            let mut grid = GridLayout::of(&s.setup);
            egui::ComboBox::from_label("light grid").selected_text(grid.label()).show_ui(ui, |ui| {
                for g in GridLayout::ALL {
                    ui.selectable_value(&mut grid, g, g.label());
                }
            });
            if grid != GridLayout::of(&s.setup) {
                grid.apply(&mut s.setup);
            }
            if let Some(c) = &mut s.setup.clusters {
                ui.horizontal(|ui| {
                    ui.label("cluster tile");
                    for t in [16, 32, 64, 128] {
                        ui.radio_value(&mut c.tile_size, t, format!("{t}"));
                    }
                });
                ui.add(egui::Slider::new(&mut c.slices, 1..=32).text("depth slices"));
                ui.checkbox(&mut c.geometry_only, "only clusters holding geometry");
            }
            ui.add_enabled_ui(s.setup.clusters.is_none(), |ui| {
                ui.checkbox(&mut s.setup.scatter, "light-centric assignment")
                    .on_hover_text("each light scatters itself into its tiles: same lists, cost ~ lights + pairs");
            });
            ui.checkbox(&mut s.setup.aabb, "sphere vs tile AABB test");
            ui.checkbox(&mut s.setup.spot_cone, "spot cone test");
            let mut two_level = !s.setup.flat_cull;
            ui.checkbox(&mut two_level, "two-level culling (64 px cells)");
            s.setup.flat_cull = !two_level;
        });
        knob_controls(ui, &mut s.setup.knobs, s.setup.method, Needs::Always);
    });
    shadow_controls(ui, s, info);
    vpl_controls(ui, s, info);
    egui::CollapsingHeader::new("Scene").default_open(false).show(ui, |ui| {
        let builtin = s.setup.scene == SceneSource::Default;
        ui.add_enabled_ui(builtin, |ui| {
            ui.add(
                egui::Slider::new(&mut s.setup.grid_objects, 0..=tiledlight_scene::MAX_GRID_OBJECTS)
                    .text("grid objects"),
            );
            ui.horizontal(|ui| {
                ui.label("density");
                ui.radio_value(&mut s.setup.density, GridDensity::Low, "low");
                ui.radio_value(&mut s.setup.density, GridDensity::Medium, "medium");
                ui.radio_value(&mut s.setup.density, GridDensity::High, "high");
            });
        });
        ui.horizontal(|ui| {
            if ui.radio(builtin, "built-in courtyard").clicked() && !builtin {
                s.setup.scene = SceneSource::Default;
            }
        });
        ui.horizontal(|ui| {
            ui.label("glTF");
            ui.text_edit_singleline(&mut st.scene_path);
            if ui.button("load").clicked() && !st.scene_path.trim().is_empty() {
                s.setup.scene = SceneSource::parse(st.scene_path.trim());
                s.setup.grid_objects = 0;
                s.setup.transparent_objects = 0;
            }
        });
        ui.checkbox(&mut s.vsync, "vsync");
    });
    transparency_controls(ui, s);
}

/// The transparent grid objects (0 to the grid objects, the default scene only) and how
/// blended geometry is composited (also a glTF scene's BLEND materials).
fn transparency_controls(ui: &mut egui::Ui, s: &mut Settings) {
    egui::CollapsingHeader::new("Transparency").default_open(true).show(ui, |ui| {
        let a = &mut s.setup;
        let builtin = a.scene == SceneSource::Default;
        // Fewer grid objects take the transparent ones down with them.
        a.transparent_objects = a.transparent_objects.min(a.grid_objects);
        ui.add_enabled_ui(builtin && a.grid_objects > 0, |ui| {
            ui.add(
                egui::Slider::new(&mut a.transparent_objects, 0..=a.grid_objects.max(1)).text("transparent objects"),
            )
            .on_hover_text("grid objects drawn as alpha-blended glass spheres, spread over the grid")
            .on_disabled_hover_text("needs grid objects of the built-in scene");
        });
        a.transparent_objects = a.transparent_objects.min(a.grid_objects);
        // How blended geometry is composited: the blend-mode row of the pass settings' table.
        knob_controls(ui, &mut a.knobs, a.method, Needs::Blended);
    });
}

/// The shadow-casting light counts (up to the scene's lights of each kind, at most
/// [`MAX_PANEL_CASTERS`]) and how the shadows are drawn.
fn shadow_controls(ui: &mut egui::Ui, s: &mut Settings, info: &Info<'_>) {
    egui::CollapsingHeader::new("Shadows").default_open(true).show(ui, |ui| {
        let sh = &mut s.setup;
        // The default scene's lights are the random ones: a smaller count takes the casters
        // down with it (a glTF scene's own lights are counted when it loads).
        if sh.scene == SceneSource::Default {
            let (points, spots) = sh.random_light_counts();
            let fit = |n: u64| u32::try_from(n).unwrap_or(u32::MAX);
            sh.shadow_point_lights = sh.shadow_point_lights.min(fit(points));
            sh.shadow_spot_lights = sh.shadow_spot_lights.min(fit(spots));
        }
        let cap = |n: usize| n.min(MAX_PANEL_CASTERS) as u32;
        // Casters set beyond the scene's lights (a flag) stay shown; the upload names them.
        let max_points = cap(info.lights.point).max(sh.shadow_point_lights);
        let max_spots = cap(info.lights.spot).max(sh.shadow_spot_lights);
        ui.add(egui::Slider::new(&mut sh.shadow_point_lights, 0..=max_points).text("shadow point lights"))
            .on_hover_text("the brightest point lights cast shadows: six cube faces each in the shadow atlas");
        ui.add(egui::Slider::new(&mut sh.shadow_spot_lights, 0..=max_spots).text("shadow spot lights"))
            .on_hover_text("the brightest spot lights cast shadows: one face each");
        ui.horizontal(|ui| {
            ui.label("casters by");
            ui.radio_value(&mut sh.casters_by, CasterChoice::Brightness, "brightness")
                .on_hover_text("the brightest lights of each kind cast the shadows");
            ui.radio_value(&mut sh.casters_by, CasterChoice::Contribution, "contribution").on_hover_text(
                "the lights that pour the most light onto what the camera sees, estimated from one frame \
                 when the lights are made (chosen again when the lights or this choice change, not when \
                 the camera moves)",
            );
        });
        // How the shadows are drawn: the shadow rows of the pass settings' table.
        knob_controls(ui, &mut sh.knobs, sh.method, Needs::Shadows);
    });
}

/// The virtual point lights (AMD's sample has them too): on/off, RSM size, block size,
/// colour and brightness thresholds, cap and shading model. Every control goes through
/// [`Settings::set_vpl`] (as the script's `vpl*` keys do); a change rebuilds the renderer
/// when applied, settings changed while VPLs are off are kept for when they are on.
fn vpl_controls(ui: &mut egui::Ui, s: &mut Settings, info: &Info<'_>) {
    egui::CollapsingHeader::new("Virtual point lights").default_open(false).show(ui, |ui| {
        let casters = s.setup.shadow_point_lights + s.setup.shadow_spot_lights > 0;
        let mut on = s.setup.vpl.is_some();
        let c = s.vpl_config();
        ui.add_enabled_ui(casters || on, |ui| {
            ui.checkbox(&mut on, "VPLs (one-bounce indirect light)")
                .on_hover_text("reflective shadow maps of the shadow-casting lights, one VPL per texel block")
                .on_disabled_hover_text("needs shadow-casting lights (the Shadows section)");
        });
        if on != s.setup.vpl.is_some() {
            s.set_vpl(VplControl::On(on));
        }
        ui.add_enabled_ui(on, |ui| {
            let mut size = c.rsm_size;
            egui::ComboBox::from_label("RSM size").selected_text(format!("{size}")).show_ui(ui, |ui| {
                for n in VPL_RSM_SIZES {
                    ui.selectable_value(&mut size, n, format!("{n}"));
                }
            });
            let mut block = c.block;
            ui.horizontal(|ui| {
                ui.label("block");
                for b in VPL_BLOCKS.iter().copied().filter(|&b| b <= size && size.is_multiple_of(b)) {
                    ui.radio_value(&mut block, b, format!("{b}"));
                }
            })
            .response
            .on_hover_text("texels per side of the block one VPL stands for");
            let mut colour = c.colour_threshold;
            ui.add(egui::Slider::new(&mut colour, 0.0..=1.0).text("colour threshold"))
                .on_hover_text("keep a VPL only when a channel of its normalised colour reaches this");
            let mut brightness = c.brightness_threshold;
            ui.add(egui::Slider::new(&mut brightness, 0.0..=2.0).text("brightness threshold"))
                .on_hover_text("keep a VPL only when its colour's length exceeds this");
            let mut cap = c.cap;
            ui.add(egui::Slider::new(&mut cap, 1..=1 << 20).logarithmic(true).text("cap"))
                .on_hover_text("most VPLs; the rest are refused and reported");
            let mut shading = c.shading;
            ui.horizontal(|ui| {
                ui.label("shading");
                ui.radio_value(&mut shading, VplShading::Sample, "sample")
                    .on_hover_text("TiledLighting11's smoothstep to the VPL's radius, no inverse square");
                ui.radio_value(&mut shading, VplShading::Physical, "physical")
                    .on_hover_text("flux x cos x cos / d^2 (Dachsbacher and Stamminger 2005)");
            });
            // A smaller RSM takes the block down to one that divides it.
            if size != c.rsm_size {
                s.set_vpl(VplControl::RsmSize(size));
                if !size.is_multiple_of(block) || block > size {
                    block =
                        VPL_BLOCKS.iter().copied().filter(|&b| b <= size && size.is_multiple_of(b)).max().unwrap_or(1);
                }
            }
            let changes = [
                (block != c.block, VplControl::Block(block)),
                (colour != c.colour_threshold, VplControl::ColourThreshold(colour)),
                (brightness != c.brightness_threshold, VplControl::BrightnessThreshold(brightness)),
                (cap != c.cap, VplControl::Cap(cap)),
                (shading != c.shading, VplControl::Shading(shading)),
            ];
            for (changed, control) in changes {
                if changed {
                    s.set_vpl(control);
                }
            }
        });
        if let Some((kept, refused)) = info.stats.vpls {
            ui.label(format!("{kept} VPLs in the last frame, {refused} refused by the cap"));
        }
    });
}

/// The heat map's palette from 1 light to the capacity, log scale, and the overflow colour.
fn legend(ui: &mut egui::Ui, capacity: u32) {
    let (rect, _) = ui.allocate_exact_size(egui::vec2(ui.available_width().min(240.0), 14.0), egui::Sense::hover());
    let painter = ui.painter_at(rect);
    let steps = 48;
    for k in 0..steps {
        let t0 = k as f32 / steps as f32;
        let x0 = rect.left() + rect.width() * t0;
        let x1 = rect.left() + rect.width() * (k + 1) as f32 / steps as f32;
        let r = egui::Rect::from_x_y_ranges(x0..=x1, rect.y_range());
        painter.rect_filled(r, 0.0, rgb(heatmap_palette(t0)));
    }
    let (lrect, _) = ui.allocate_exact_size(egui::vec2(rect.width(), 12.0), egui::Sense::hover());
    let lp = ui.painter_at(lrect);
    for v in label_values(capacity) {
        let x = lrect.left() + lrect.width() * heatmap_t(v, capacity);
        lp.text(
            egui::pos2(x.min(lrect.right() - 8.0), lrect.top()),
            egui::Align2::CENTER_TOP,
            v.to_string(),
            egui::FontId::monospace(9.0),
            Color32::LIGHT_GRAY,
        );
    }
    ui.horizontal(|ui| {
        let (r, _) = ui.allocate_exact_size(egui::vec2(12.0, 12.0), egui::Sense::hover());
        ui.painter().rect_filled(r, 0.0, rgb(HEATMAP_OVERFLOW));
        ui.label(format!("overflow (more than {capacity} lights)"));
    });
}

fn camera_section(ui: &mut egui::Ui, rig: &mut CameraRig, commands: &mut Vec<Command>) {
    egui::CollapsingHeader::new("Camera").default_open(false).show(ui, |ui| {
        ui.horizontal(|ui| {
            ui.radio_value(&mut rig.mode, Mode::Fly, "fly");
            ui.radio_value(&mut rig.mode, Mode::Orbit, "orbit");
        });
        ui.add(egui::Slider::new(&mut rig.speed, 0.01..=1000.0).logarithmic(true).text("speed m/s"));
        let mut fov = rig.fov_y.to_degrees();
        if ui.add(egui::Slider::new(&mut fov, 10.0..=120.0).text("fov")).changed() {
            rig.fov_y = fov.to_radians();
        }
        let e = rig.eye;
        ui.label(RichText::new(format!("eye {:.2} {:.2} {:.2}", e.x, e.y, e.z)).small());
        ui.horizontal(|ui| {
            if ui.button("reset camera (R)").clicked() {
                commands.push(Command::ResetCamera);
            }
            if ui.button("save camera (C)").clicked() {
                commands.push(Command::SaveCamera);
            }
        });
    });
}

/// One control a row of the pass settings' table (`tiledlight_gpu::knobs`), enabled for the
/// methods the row applies to, its help on hover: a new row needs no code here.
/// The rows a section of the panel shows: the pass settings' section those read always,
/// the shadow section the shadow rows, the transparency section the blend mode.
fn section_rows(needs: Needs) -> impl Iterator<Item = &'static Knob> {
    KNOBS.iter().filter(move |r| r.needs == needs)
}

fn knob_controls(ui: &mut egui::Ui, knobs: &mut Knobs, method: Method, needs: Needs) {
    for row in section_rows(needs) {
        let text = (row.get)(knobs);
        let mut new = text.clone();
        ui.add_enabled_ui((row.applies)(method.traits()), |ui| {
            let response = match (row.control, row.kind) {
                (Control::Checkbox, _) => {
                    let mut on = text == "on";
                    let r = ui.checkbox(&mut on, row.label);
                    new = if on { "on" } else { "off" }.into();
                    r
                }
                (Control::Slider(lo, hi), Kind::Count) => {
                    let mut v: u32 = text.parse().unwrap_or_default();
                    let r = ui.add(egui::Slider::new(&mut v, lo as u32..=hi as u32).text(row.label));
                    new = v.to_string();
                    r
                }
                (Control::Slider(lo, hi), _) => {
                    let mut v: f64 = text.parse().unwrap_or_default();
                    let r = ui.add(egui::Slider::new(&mut v, lo..=hi).text(row.label));
                    new = (v as f32).to_string();
                    r
                }
                (Control::Choice, Kind::Choice(names) | Kind::Values(names)) => {
                    egui::ComboBox::from_label(row.label)
                        .selected_text(text.as_str())
                        .show_ui(ui, |ui| {
                            for name in names {
                                ui.selectable_value(&mut new, name.to_string(), *name);
                            }
                        })
                        .response
                }
                (Control::Choice, _) => ui.label(format!("{}: {text}", row.label)),
            };
            response.on_hover_text(row.help()).on_disabled_hover_text(format!("not read by {}", method.label()));
        });
        if new != text {
            // The control offers only values the row parses.
            let _ = (row.set)(knobs, &new);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What the panel shows, fixed: 1,024 lights, one timed pass.
    struct Fixture {
        lights: LightSummary,
        memory: MemoryReport,
        stats: Stats,
    }

    impl Fixture {
        fn new() -> Self {
            Fixture {
                lights: LightSummary { point: 1024, spot: 0, from_file: 0, random: 1024 },
                memory: MemoryReport::default(),
                stats: Stats {
                    passes: vec![PassTime { label: "forward.shade".into(), ms: 1.25 }],
                    timestamps: true,
                    ..Default::default()
                },
            }
        }

        fn info(&self, size: (f32, f32)) -> Info<'_> {
            Info {
                adapter: "adapter",
                scene: "scene".into(),
                lights: &self.lights,
                memory: &self.memory,
                capacity: 512,
                shadow_atlas: None,
                blended: None,
                size: (size.0 as u32, size.1 as u32),
                stats: &self.stats,
            }
        }
    }

    /// Every text `ui_fn` draws in a window of `size` after a few frames (egui sizes a new
    /// window on its first frame without showing it): (text, top y, bottom y).
    fn collect_texts(size: (f32, f32), mut ui_fn: impl FnMut(&mut egui::Ui)) -> Vec<(String, f32, f32)> {
        let ctx = egui::Context::default();
        let mut out = Vec::new();
        for _ in 0..3 {
            let raw = egui::RawInput {
                screen_rect: Some(egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(size.0, size.1))),
                ..Default::default()
            };
            let mut output = ctx.run_ui(raw, &mut ui_fn);
            // No renderer here to upload the font atlas to.
            output.textures_delta.clear();
            out.clear();
            let mut stack: Vec<egui::Shape> = output.shapes.into_iter().map(|c| c.shape).collect();
            while let Some(shape) = stack.pop() {
                match shape {
                    egui::Shape::Text(t) => {
                        let r = t.galley.rect.translate(t.pos.to_vec2());
                        out.push((t.galley.text().to_string(), r.top(), r.bottom()));
                    }
                    egui::Shape::Vec(v) => stack.extend(v),
                    _ => {}
                }
            }
        }
        out
    }

    /// Every text the whole panel draws in a window of `size`, at its default place.
    fn panel_texts(size: (f32, f32)) -> Vec<(String, f32, f32)> {
        let mut st = UiState::default();
        let mut s = Settings::new(tiledlight_setup::Settings::default());
        let camera = tiledlight_cull::Camera::perspective(
            glam::Vec3::new(0.0, 2.0, 5.0),
            glam::Vec3::ZERO,
            glam::Vec3::Y,
            1.0,
            size.0 / size.1,
            0.1,
            None,
        )
        .unwrap();
        let mut rig = CameraRig::from_camera(&camera, 5.0);
        let fixture = Fixture::new();
        let info = fixture.info(size);
        collect_texts(size, |ui| {
            draw(ui.ctx(), &mut st, &mut s, &mut rig, &info, 1.0 / 60.0);
        })
    }

    /// Issue 47: at 1280x720 the panel shows the method, the light counts and the main dials
    /// above the fold, and the statistics collapsed (their pass table not drawn), with the
    /// frame summary on the first line.
    #[test]
    fn the_panel_shows_method_and_lights_first_at_720p() {
        let texts = panel_texts((1280.0, 720.0));
        let find = |what: &str| {
            texts
                .iter()
                .find(|(t, ..)| t == what)
                .unwrap_or_else(|| {
                    panic!("the panel draws no {what:?}: {:?}", texts.iter().map(|t| &t.0).collect::<Vec<_>>())
                })
                .clone()
        };
        for what in
            ["method", "point lights", "spot lights", "intensity threshold", "MSAA", "heat map (lights per tile)"]
        {
            let (_, top, bottom) = find(what);
            assert!(top >= 0.0 && bottom <= 720.0, "{what} is drawn at {top}..{bottom}, outside the 720 px window");
        }
        assert!(find("method").1 < find("Culling and passes").1, "the method comes before the culling");
        let summary = texts.iter().find(|(t, ..)| t.starts_with("1280x720  frame")).expect("the summary line");
        assert!(summary.0.contains("GPU 1.25 ms") && summary.1 < find("method").1, "{summary:?}");
        // The statistics alone: a header, collapsed (its pass table not drawn).
        let fixture = Fixture::new();
        let stats = collect_texts((1280.0, 720.0), |ui| stats_section(ui, &fixture.info((1280.0, 720.0))));
        assert!(stats.iter().any(|(t, ..)| t == "Statistics"), "{stats:?}");
        assert!(!stats.iter().any(|(t, ..)| t == "forward.shade"), "the statistics are open by default: {stats:?}");
    }

    #[test]
    fn usage_lists_every_key() {
        let usage = include_str!("../../../../docs/USAGE.md");
        for (k, what) in KEYS {
            let row = format!("| {k} | {what} |");
            assert!(usage.contains(&row), "docs/USAGE.md has no row {row:?}");
        }
    }

    /// Every row is shown in exactly one section of the panel.
    #[test]
    fn every_row_is_in_one_section() {
        let mut shown: Vec<&str> = [Needs::Always, Needs::Shadows, Needs::Blended]
            .into_iter()
            .flat_map(section_rows)
            .map(|r| r.name)
            .collect();
        shown.sort_unstable();
        let mut all: Vec<&str> = KNOBS.iter().map(|r| r.name).collect();
        all.sort_unstable();
        assert_eq!(shown, all);
        assert!(section_rows(Needs::Shadows).all(|r| r.name.starts_with("shadow-")));
        assert_eq!(section_rows(Needs::Blended).map(|r| r.name).collect::<Vec<_>>(), ["blend-mode"]);
    }

    #[test]
    fn history_is_bounded() {
        let mut s = Stats::default();
        for i in 0..HISTORY + 10 {
            s.push_frame(i as f32);
        }
        assert_eq!(s.history.len(), HISTORY);
        assert!(s.mean_frame_ms() > 10.0);
    }
}
