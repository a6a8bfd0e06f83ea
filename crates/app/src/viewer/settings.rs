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
//! | heat map (tiled methods only), its lists (opaque, blended or VPL) | nothing (switched in place) |
//! | VPLs on/off, RSM size, block, thresholds, cap, shading model | the renderer (tiledlight-setup: `Settings::vpl`) |
//! | VPL settings while VPLs are off | nothing (kept for when they are switched on) |
//! | vsync | surface configuration |
//! | animation | nothing (lights are moved and uploaded each frame while it is on) |
//!
//! Pure data (no GPU): depends on tiledlight-setup and tiledlight-gpu's `HeatmapOf`.

use tiledlight_cull::vpl::{VplConfig, VplShading};
use tiledlight_gpu::heatmap::HeatmapOf;
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
    /// The lists the heat map shows: the alpha-blended geometry's own (when the scene has
    /// blended geometry) or the VPLs' (with VPLs); the opaque lists otherwise.
    pub heatmap_of: HeatmapOf,
    /// Move the lights every frame.
    pub animate: bool,
    /// Wait for vertical blank when presenting.
    pub vsync: bool,
    /// The VPL settings last shown in the panel: `setup.vpl` while VPLs are on, kept while
    /// they are off so that switching them on again restores them.
    pub vpl_last: VplConfig,
}

/// One of the panel's VPL controls (and the script's `vpl*` keys), as it sets
/// `tiledlight_cull::vpl::VplConfig` ([`Settings::set_vpl`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VplControl {
    /// VPLs on or off (`Settings::vpl` Some or None).
    On(bool),
    /// RSM texels per face side (`rsm_size`).
    RsmSize(u32),
    /// Texels per VPL block side (`block`).
    Block(u32),
    /// `colour_threshold`.
    ColourThreshold(f32),
    /// `brightness_threshold`.
    BrightnessThreshold(f32),
    /// Most VPLs (`cap`).
    Cap(u32),
    /// The shading model (`shading`).
    Shading(VplShading),
}

/// RSM sizes the panel offers (texels per face side).
pub const VPL_RSM_SIZES: [u32; 6] = [8, 16, 32, 64, 128, 256];
/// VPL block sizes the panel offers (texels per block side).
pub const VPL_BLOCKS: [u32; 5] = [1, 2, 4, 8, 16];

impl Settings {
    /// The settings of a run started with `setup`.
    pub fn new(setup: tiledlight_setup::Settings) -> Self {
        let vpl_last = setup.vpl.unwrap_or_default();
        Self { setup, heatmap: false, heatmap_of: HeatmapOf::Opaque, animate: true, vsync: true, vpl_last }
    }

    /// The VPL settings the panel shows: those in use, or the last ones while VPLs are off.
    pub fn vpl_config(&self) -> VplConfig {
        self.setup.vpl.unwrap_or(self.vpl_last)
    }

    /// Applies one VPL control: switching VPLs on uses the settings last shown; a setting
    /// changed while VPLs are off is kept for later and rebuilds nothing.
    pub fn set_vpl(&mut self, control: VplControl) {
        let mut cfg = self.vpl_config();
        let mut on = self.setup.vpl.is_some();
        match control {
            VplControl::On(v) => on = v,
            VplControl::RsmSize(n) => cfg.rsm_size = n,
            VplControl::Block(n) => cfg.block = n,
            VplControl::ColourThreshold(t) => cfg.colour_threshold = t,
            VplControl::BrightnessThreshold(t) => cfg.brightness_threshold = t,
            VplControl::Cap(n) => cfg.cap = n,
            VplControl::Shading(m) => cfg.shading = m,
        }
        self.vpl_last = cfg;
        self.setup.vpl = on.then_some(cfg);
    }

    /// The lists the heat map shows of a frame with (`blended`) or without blended
    /// geometry: the opaque lists where the chosen ones do not exist.
    pub fn shown_heatmap(&self, blended: bool) -> HeatmapOf {
        match self.heatmap_of {
            HeatmapOf::Blended if blended => HeatmapOf::Blended,
            HeatmapOf::Vpl if self.setup.vpl.is_some() => HeatmapOf::Vpl,
            _ => HeatmapOf::Opaque,
        }
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
    /// Switch the heat map pass on or off, or between the opaque, blended and VPL lists
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
        heatmap: old.effective_heatmap() != new.effective_heatmap() || old.heatmap_of != new.heatmap_of,
        surface: old.vsync != new.vsync,
    }
}

/// The methods in the panel's order (and the order the method key cycles through).
pub const METHODS: [Method; 5] = [
    Method::ForwardPlus,
    Method::TiledDeferred,
    Method::Visibility,
    Method::BruteForce { cutoff: true },
    Method::BruteForce { cutoff: false },
];

#[cfg(test)]
mod tests {
    use super::*;
    use tiledlight_cull::shadow::ShadowFilter;
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
        assert_eq!(with(|s| s.heatmap_of = HeatmapOf::Blended), Plan { heatmap: true, ..Plan::default() });
        assert_eq!(with(|s| s.heatmap_of = HeatmapOf::Vpl), Plan { heatmap: true, ..Plan::default() });
        let p = with(|s| s.setup.exposure = 2.0);
        assert!(p.setup.exposure && !p.renderer, "exposure is set, not rebuilt: {p:?}");
    }

    #[test]
    fn setup_settings_follow_the_library_plan() {
        let p = with(|s| s.setup.seed = 9);
        assert_eq!((p.setup.reload, p.renderer), (Reload::LightData, false));
        let p = with(|s| s.setup.lights = Some(7));
        assert_eq!((p.setup.reload, p.renderer), (Reload::LightBuffers, true));
        let p = with(|s| s.setup.method = Method::TiledDeferred);
        assert_eq!((p.setup.reload, p.renderer, p.surface), (Reload::Nothing, true, false));
        let p = with(|s| s.setup.grid_objects = 10);
        assert_eq!((p.setup.reload, p.renderer), (Reload::Scene, true));
        let p = with(|s| s.setup.shadow_spot_lights = 4);
        assert_eq!((p.setup.reload, p.renderer), (Reload::LightBuffers, true));
        let p = with(|s| (s.setup.shadow_point_lights, s.setup.knobs.shadow_filter) = (2, ShadowFilter::Tap1));
        assert_eq!((p.setup.reload, p.renderer), (Reload::LightBuffers, true));
        let p = with(|s| (s.setup.grid_objects, s.setup.transparent_objects) = (50, 20));
        assert_eq!((p.setup.reload, p.renderer), (Reload::Scene, true));
        let mut glass = base();
        (glass.setup.grid_objects, glass.setup.transparent_objects) = (50, 20);
        let mut oit = glass.clone();
        oit.setup.knobs.blend_mode = tiledlight_gpu::features::BlendMode::WeightedOit;
        let p = plan(&glass, &oit);
        assert_eq!((p.setup.reload, p.renderer, p.surface), (Reload::Nothing, true, false));
        // Without blended geometry the mode is not used: nothing to rebuild.
        assert!(with(|s| s.setup.knobs.blend_mode = tiledlight_gpu::features::BlendMode::WeightedOit).is_empty());
    }

    #[test]
    fn each_vpl_control_sets_its_field_and_rebuilds_the_renderer() {
        let mut casters = base();
        casters.setup.shadow_spot_lights = 2;
        let d = VplConfig::default();
        // Each control changes its own field of the config and nothing else.
        let cases: [(VplControl, VplConfig); 6] = [
            (VplControl::RsmSize(64), VplConfig { rsm_size: 64, ..d }),
            (VplControl::Block(4), VplConfig { block: 4, ..d }),
            (VplControl::ColourThreshold(0.25), VplConfig { colour_threshold: 0.25, ..d }),
            (VplControl::BrightnessThreshold(0.5), VplConfig { brightness_threshold: 0.5, ..d }),
            (VplControl::Cap(1000), VplConfig { cap: 1000, ..d }),
            (VplControl::Shading(VplShading::Physical), VplConfig { shading: VplShading::Physical, ..d }),
        ];
        let mut on = casters.clone();
        on.set_vpl(VplControl::On(true));
        assert_eq!(on.setup.vpl, Some(d), "switched on: the default settings");
        let p = plan(&casters, &on);
        assert!(p.renderer, "VPLs on: a new renderer: {p:?}");
        assert_eq!(on.setup.frame_settings(false).vpl, Some(d));
        assert_eq!(on.setup.frame_settings(false).vpl, Some(d));
        for (control, want) in cases {
            let mut s = on.clone();
            s.set_vpl(control);
            assert_eq!(s.setup.vpl, Some(want), "{control:?}");
            assert_eq!(s.vpl_config(), want, "{control:?}");
            assert!(plan(&on, &s).renderer, "{control:?} rebuilds the renderer");
            // Changed while off: kept, nothing rebuilt, restored when switched on.
            let mut off = casters.clone();
            off.set_vpl(control);
            assert_eq!(off.setup.vpl, None, "{control:?} leaves VPLs off");
            assert!(plan(&casters, &off).is_empty(), "{control:?} while off rebuilds nothing");
            off.set_vpl(VplControl::On(true));
            assert_eq!(off.setup.vpl, Some(want), "{control:?} kept for when VPLs are on");
        }
        // Off again: no VPLs in either renderer's settings (no VPL step, buffer or pass),
        // a new renderer, and the settings kept.
        let mut s = on.clone();
        s.set_vpl(VplControl::Block(8));
        let before = s.clone();
        s.set_vpl(VplControl::On(false));
        assert_eq!(s.setup.vpl, None);
        assert_eq!((s.setup.frame_settings(false).vpl, s.setup.frame_settings(false).vpl), (None, None));
        assert!(plan(&before, &s).renderer);
        assert_eq!(s.vpl_config().block, 8);
        // The panel's choices are settings the twin accepts with the default block.
        for n in VPL_RSM_SIZES {
            VplConfig { rsm_size: n, ..d }.validate().unwrap();
        }
        for b in VPL_BLOCKS {
            VplConfig { rsm_size: 32, block: b, ..d }.validate().unwrap();
        }
    }

    #[test]
    fn heat_map_of_an_untiled_method_changes_nothing() {
        let mut old = base();
        old.setup.method = Method::BruteForce { cutoff: true };
        let mut new = old.clone();
        new.heatmap = true;
        assert!(plan(&old, &new).is_empty());
    }
}
