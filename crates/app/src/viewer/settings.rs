//! What the viewer's controls set, and what a change of them must rebuild. The panel and
//! the `--script` actions both edit a copy of [`Settings`]; the viewer then compares it
//! with the settings in use ([`plan`]) and rebuilds only what depends on what changed.
//! Scene, lights, screen and renderer settings are tiledlight-setup's, and so is the
//! decision of what their change rebuilds ([`tiledlight_setup::rebuild_plan`]: scene +
//! lights + renderer, new light buffers + renderer, light data in place, renderer). The
//! viewer adds its own controls:
//!
//! | changed | rebuilt |
//! | --- | --- |
//! | heat map (tiled methods only), its lists (opaque or blended) | nothing (switched in place) |
//! | vsync | surface configuration |
//! | animation | nothing (lights are moved and uploaded each frame while it is on) |
//!
//! Pure data (no GPU): depends on tiledlight-setup only.

use tiledlight_setup::{rebuild_plan, Method, Rebuild};

/// MSAA sample counts offered in the panel (the MSAA work wires them to the renderers).
pub const MSAA_CHOICES: [u32; 4] = [1, 2, 4, 8];

/// Everything the viewer's controls set.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Scene, lights, screen (the window's size in pixels) and renderer settings, exactly
    /// as `render` and `bench` build from their flags.
    pub setup: tiledlight_setup::Settings,
    /// Draw the lights-per-tile heat map over the image (tiled methods only).
    pub heatmap: bool,
    /// The heat map shows the alpha-blended geometry's own lists (when the scene has
    /// blended geometry; the opaque lists otherwise).
    pub heatmap_blended: bool,
    /// Move the lights every frame.
    pub animate: bool,
    /// Wait for vertical blank when presenting.
    pub vsync: bool,
}

impl Settings {
    /// The settings of a run started with `setup`.
    pub fn new(setup: tiledlight_setup::Settings) -> Self {
        Self { setup, heatmap: false, heatmap_blended: false, animate: true, vsync: true }
    }

    /// The heat map as the renderer gets it: only methods with tiles have one.
    pub fn effective_heatmap(&self) -> bool {
        self.heatmap && self.setup.method.is_tiled()
    }
}

/// What a change of settings must rebuild.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Plan {
    /// Scene, lights, camera and renderer, as tiledlight-setup decides for the scene,
    /// light, screen and renderer settings (`Prepared::reconfigure` carries it out).
    pub setup: Rebuild,
    /// Build a new renderer (the setup's reason).
    pub renderer: bool,
    /// Switch the heat map pass on or off, or between the opaque and the blended lists
    /// (nothing is rebuilt).
    pub heatmap: bool,
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
    let setup = rebuild_plan(&old.setup, &new.setup);
    Plan {
        setup,
        renderer: setup.renderer,
        heatmap: old.effective_heatmap() != new.effective_heatmap() || old.heatmap_blended != new.heatmap_blended,
        surface: old.vsync != new.vsync,
    }
}

/// The methods in the panel's order, with their labels.
pub const METHODS: [(Method, &str); 4] = [
    (Method::ForwardPlus, "Forward+"),
    (Method::Deferred, "Tiled Deferred"),
    (Method::BruteForce, "Brute force"),
    (Method::BruteForceNoCutoff, "Brute force, no cutoff"),
];

/// The panel's label of a method.
pub fn method_label(m: Method) -> &'static str {
    METHODS.iter().find(|(x, _)| *x == m).map_or("?", |(_, l)| l)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiledlight_setup::Reload;

    fn base() -> Settings {
        Settings::new(tiledlight_setup::Settings { width: 320, height: 180, ..Default::default() })
    }

    fn with(f: impl FnOnce(&mut Settings)) -> Plan {
        let old = base();
        let mut new = old.clone();
        f(&mut new);
        plan(&old, &new)
    }

    #[test]
    fn viewer_controls_rebuild_only_what_depends_on_them() {
        assert!(with(|_| {}).is_empty());
        assert!(with(|s| s.animate = false).is_empty());
        assert_eq!(with(|s| s.vsync = false), Plan { surface: true, ..Plan::default() });
        assert_eq!(with(|s| s.heatmap = true), Plan { heatmap: true, ..Plan::default() });
        assert_eq!(with(|s| s.heatmap_blended = true), Plan { heatmap: true, ..Plan::default() });
        let p = with(|s| s.setup.exposure = 2.0);
        assert!(p.setup.exposure && !p.renderer, "exposure is set, not rebuilt: {p:?}");
    }

    #[test]
    fn setup_settings_follow_the_library_plan() {
        let p = with(|s| s.setup.seed = 9);
        assert_eq!((p.setup.reload, p.renderer), (Reload::LightData, false));
        let p = with(|s| s.setup.lights = Some(7));
        assert_eq!((p.setup.reload, p.renderer), (Reload::LightBuffers, true));
        let p = with(|s| s.setup.method = Method::Deferred);
        assert_eq!((p.setup.reload, p.renderer, p.surface), (Reload::Nothing, true, false));
        let p = with(|s| s.setup.grid_objects = 10);
        assert_eq!((p.setup.reload, p.renderer), (Reload::Scene, true));
        let p = with(|s| s.setup.shadow_spot_lights = 4);
        assert_eq!((p.setup.reload, p.renderer), (Reload::LightBuffers, true));
        let p = with(|s| (s.setup.shadow_point_lights, s.setup.shadow_filter) = (2, 1));
        assert_eq!((p.setup.reload, p.renderer), (Reload::LightBuffers, true));
        let p = with(|s| (s.setup.grid_objects, s.setup.transparent_objects) = (50, 20));
        assert_eq!((p.setup.reload, p.renderer), (Reload::Scene, true));
        let mut glass = base();
        (glass.setup.grid_objects, glass.setup.transparent_objects) = (50, 20);
        let mut oit = glass.clone();
        oit.setup.blend_mode = tiledlight_gpu::features::BlendMode::WeightedOit;
        let p = plan(&glass, &oit);
        assert_eq!((p.setup.reload, p.renderer, p.surface), (Reload::Nothing, true, false));
        // Without blended geometry the mode is not used: nothing to rebuild.
        assert!(with(|s| s.setup.blend_mode = tiledlight_gpu::features::BlendMode::WeightedOit).is_empty());
    }

    #[test]
    fn heat_map_of_an_untiled_method_changes_nothing() {
        let mut old = base();
        old.setup.method = Method::BruteForce;
        let mut new = old.clone();
        new.heatmap = true;
        assert!(plan(&old, &new).is_empty());
    }
}
