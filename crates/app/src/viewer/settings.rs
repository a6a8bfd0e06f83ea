//! What the viewer's controls set, and what a change of them must rebuild. The panel and
//! the `--script` actions both edit a copy of [`Settings`]; the viewer then compares it
//! with the settings in use ([`plan`]) and rebuilds only what depends on what changed:
//!
//! | changed | rebuilt |
//! | --- | --- |
//! | scene, grid objects, density (threshold of a glTF scene's own lights) | scene + lights + renderer |
//! | point/spot light counts | light buffers + renderer (bind groups and list sizes follow the counts) |
//! | seed, threshold (same counts) | light data rewritten in place, nothing else |
//! | method, tile size, capacity, tests, half-z, G-buffer RTs, heat map, window size | renderer |
//! | vsync | surface configuration |
//! | animation | nothing (lights are moved and uploaded each frame while it is on) |
//!
//! Pure data (no GPU): depends on [`crate::scene_setup`] only.

use crate::scene_setup::{MethodArg, SceneArgs, SceneSource};

/// MSAA sample counts offered in the panel (the MSAA work wires them to the renderers).
pub const MSAA_CHOICES: [u32; 4] = [1, 2, 4, 8];

/// Everything the viewer's controls set.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Scene, lights, screen (the window's size in pixels) and renderer flags, exactly as
    /// `render` and `bench` take them.
    pub args: SceneArgs,
    /// Draw the lights-per-tile heat map over the image (tiled methods only).
    pub heatmap: bool,
    /// Move the lights every frame.
    pub animate: bool,
    /// Wait for vertical blank when presenting.
    pub vsync: bool,
}

impl Settings {
    /// The settings of a run started with `args`.
    pub fn new(args: SceneArgs) -> Self {
        Self { args, heatmap: false, animate: true, vsync: true }
    }

    /// The heat map as the renderer gets it: only methods with tiles have one.
    pub fn effective_heatmap(&self) -> bool {
        self.heatmap && self.args.method.is_tiled()
    }
}

/// What a change of settings must rebuild (each implies nothing about the others: the
/// viewer rebuilds the renderer after a scene or a reallocation of the light buffers).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Plan {
    /// Load (or generate) the scene again, with its lights.
    pub scene: bool,
    /// Regenerate the random lights.
    pub lights: bool,
    /// Build a new renderer.
    pub renderer: bool,
    /// Reconfigure the window surface.
    pub surface: bool,
}

impl Plan {
    /// True when nothing needs rebuilding.
    pub fn is_empty(&self) -> bool {
        *self == Plan::default()
    }
}

/// What going from `old` to `new` must rebuild.
pub fn plan(old: &Settings, new: &Settings) -> Plan {
    let (a, b) = (&old.args, &new.args);
    let file_scene = matches!(b.source(), SceneSource::File(_));
    let scene = a.scene != b.scene
        || a.grid_objects != b.grid_objects
        || a.density != b.density
        // A glTF file's own lights get their radii from the threshold when it is loaded.
        || (file_scene && a.threshold != b.threshold)
        || a.camera != b.camera;
    let lights = !scene
        && (a.lights != b.lights || a.spot_lights != b.spot_lights || a.seed != b.seed || a.threshold != b.threshold);
    let renderer = scene
        || a.method != b.method
        || a.tile_size != b.tile_size
        || a.capacity != b.capacity
        || a.aabb != b.aabb
        || a.half_z != b.half_z
        || a.spot_cone != b.spot_cone
        || a.flat_cull != b.flat_cull
        || a.gbuffer_rts != b.gbuffer_rts
        || a.exposure != b.exposure
        || a.width != b.width
        || a.height != b.height
        || a.msaa != b.msaa
        || a.edge_distance != b.edge_distance
        || a.edge_normal_deg != b.edge_normal_deg
        || old.effective_heatmap() != new.effective_heatmap();
    Plan { scene, lights, renderer, surface: old.vsync != new.vsync }
}

/// The methods in the panel's order, with their labels.
pub const METHODS: [(MethodArg, &str); 4] = [
    (MethodArg::ForwardPlus, "Forward+"),
    (MethodArg::Deferred, "Tiled Deferred"),
    (MethodArg::BruteForce, "Brute force"),
    (MethodArg::BruteForceNoCutoff, "Brute force, no cutoff"),
];

/// The panel's label of a method.
pub fn method_label(m: MethodArg) -> &'static str {
    METHODS.iter().find(|(x, _)| *x == m).map_or("?", |(_, l)| l)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> Settings {
        Settings::new(SceneArgs { width: 320, height: 180, ..SceneArgs::default() })
    }

    fn with(f: impl FnOnce(&mut Settings)) -> Plan {
        let old = base();
        let mut new = old.clone();
        f(&mut new);
        plan(&old, &new)
    }

    #[test]
    fn sliders_rebuild_only_what_depends_on_them() {
        assert!(with(|_| {}).is_empty());
        assert!(with(|s| s.animate = false).is_empty());
        assert_eq!(with(|s| s.vsync = false), Plan { surface: true, ..Plan::default() });
        assert_eq!(with(|s| s.args.threshold *= 2.0), Plan { lights: true, ..Plan::default() });
        assert_eq!(with(|s| s.args.lights = Some(7)), Plan { lights: true, ..Plan::default() });
        assert_eq!(with(|s| s.args.seed = 9), Plan { lights: true, ..Plan::default() });
        for f in [
            (|s: &mut Settings| s.args.method = MethodArg::Deferred) as fn(&mut Settings),
            |s| s.args.tile_size = 32,
            |s| s.args.half_z = true,
            |s| s.args.gbuffer_rts = 4,
            |s| s.heatmap = true,
            |s| s.args.width = 640,
        ] {
            assert_eq!(with(f), Plan { renderer: true, ..Plan::default() });
        }
        let p = with(|s| s.args.grid_objects = 10);
        assert!(p.scene && p.renderer && !p.lights);
    }

    #[test]
    fn heat_map_of_an_untiled_method_changes_nothing() {
        let mut old = base();
        old.args.method = MethodArg::BruteForce;
        let mut new = old.clone();
        new.heatmap = true;
        assert!(plan(&old, &new).is_empty());
    }

    #[test]
    fn threshold_of_a_gltf_scene_reloads_it() {
        let mut old = base();
        old.args.scene = "a.glb".into();
        let mut new = old.clone();
        new.args.threshold *= 2.0;
        let p = plan(&old, &new);
        assert!(p.scene && p.renderer && !p.lights);
    }
}
