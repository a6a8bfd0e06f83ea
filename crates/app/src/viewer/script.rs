//! `--script`: a scripted run of the viewer for tests and demos. A `;`-separated list of
//! `key=value` actions, one applied per frame after the first frame, e.g.
//! `method=deferred;lights=300;scene=missing.gltf;heatmap=on`. Each action edits a copy of
//! the viewer's [`Settings`] exactly as the panel's widget does, and the viewer applies it
//! through the same path (so a bad value shows up in the panel as a widget's would).
//! `wait=N` renders N frames before the next action. Depends on [`super::settings`],
//! [`crate::scene_setup`] (the flags' value names) and tiledlight-setup.

use anyhow::{bail, Context, Result};
use clap::ValueEnum;

use super::settings::{Settings, VplControl};
use tiledlight_gpu::heatmap::HeatmapOf;
use tiledlight_gpu::knobs::KNOBS;
use tiledlight_setup::camera_rig::Mode;

/// One step of a script.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Set a control, as its widget would.
    Set {
        /// The control.
        key: String,
        /// Its new value, as text.
        value: String,
    },
    /// Switch the camera to fly or orbit.
    Camera(Mode),
    /// Render this many frames before the next action.
    Wait(u32),
    /// Ask the window system for a new window size (pixels), as a user's resize would.
    Window(u32, u32),
}

/// The keys `Action::Set` understands: every row of the run settings' table and of the
/// pass settings' table (by name), then the viewer's own.
pub fn keys() -> String {
    let rows = tiledlight_setup::SETTINGS.iter().map(|r| r.name).chain(KNOBS.iter().map(|r| r.name));
    let own = [
        "half-z",
        "heatmap (on, off, opaque, blended, vpl)",
        "vpl (on, off)",
        "vpl-rsm-size",
        "vpl-block",
        "vpl-colour-threshold",
        "vpl-brightness-threshold",
        "vpl-cap",
        "vpl-shading (sample, physical)",
        "animate",
        "vsync",
        "camera",
        "window",
        "wait",
    ];
    rows.chain(own).collect::<Vec<_>>().join(", ")
}

/// Parses a script; an unknown key or a malformed action is an error naming it.
pub fn parse(script: &str) -> Result<Vec<Action>> {
    let mut out = Vec::new();
    for item in script.split(';').map(str::trim).filter(|s| !s.is_empty()) {
        let Some((key, value)) = item.split_once('=') else {
            bail!("--script: '{item}' is not key=value (keys: {})", keys());
        };
        let (key, value) = (key.trim(), value.trim());
        let action = match key {
            "wait" => Action::Wait(value.parse().with_context(|| format!("--script: wait={value}: not a count"))?),
            "window" => {
                let size = value.split_once('x').and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)));
                match size {
                    Some((w, h)) if w > 0 && h > 0 => Action::Window(w, h),
                    _ => bail!("--script: window={value}: expected WIDTHxHEIGHT in pixels"),
                }
            }
            "camera" => Action::Camera(match value {
                "fly" => Mode::Fly,
                "orbit" => Mode::Orbit,
                _ => bail!("--script: camera={value}: expected fly or orbit"),
            }),
            _ => {
                // Check the value now, so a typo fails before the window opens.
                set(&mut Settings::new(Default::default()), key, value)?;
                Action::Set { key: key.into(), value: value.into() }
            }
        };
        out.push(action);
    }
    Ok(out)
}

fn on_off(key: &str, v: &str) -> Result<bool> {
    match v {
        "on" | "true" | "1" => Ok(true),
        "off" | "false" | "0" => Ok(false),
        _ => bail!("--script: {key}={v}: expected on or off"),
    }
}

fn number<T: std::str::FromStr>(key: &str, v: &str) -> Result<T> {
    v.parse().map_err(|_| anyhow::anyhow!("--script: {key}={v}: not a number"))
}

/// Sets control `key` of `s` to `value` (range checks happen when the viewer applies it,
/// as for the widgets).
pub fn set(s: &mut Settings, key: &str, value: &str) -> Result<()> {
    let a = &mut s.setup;
    // A row of either settings table parses its own value.
    if let Some(set) = a.set_row(key, value) {
        return set.map_err(|e| anyhow::anyhow!("--script: {e}"));
    }
    match key {
        "half-z" => a.half_z = on_off(key, value)?,
        // on (the opaque lists), off, or the lists to show: opaque, blended (the blended
        // geometry's) or vpl (the VPLs').
        "heatmap" => {
            (s.heatmap, s.heatmap_of) = match HeatmapOf::ALL.into_iter().find(|o| o.name() == value) {
                Some(of) => (true, of),
                None => (
                    on_off(key, value).map_err(|_| {
                        anyhow::anyhow!("--script: heatmap={value}: expected on, off, opaque, blended or vpl")
                    })?,
                    HeatmapOf::Opaque,
                ),
            }
        }
        "vpl" => s.set_vpl(VplControl::On(on_off(key, value)?)),
        "vpl-rsm-size" => s.set_vpl(VplControl::RsmSize(number(key, value)?)),
        "vpl-block" => s.set_vpl(VplControl::Block(number(key, value)?)),
        "vpl-colour-threshold" => s.set_vpl(VplControl::ColourThreshold(number(key, value)?)),
        "vpl-brightness-threshold" => s.set_vpl(VplControl::BrightnessThreshold(number(key, value)?)),
        "vpl-cap" => s.set_vpl(VplControl::Cap(number(key, value)?)),
        "vpl-shading" => s.set_vpl(VplControl::Shading(
            crate::vpl_args::VplShadingArg::from_str(value, true)
                .map_err(|e| anyhow::anyhow!("--script: vpl-shading={value}: {e}"))?
                .into(),
        )),
        "animate" => s.animate = on_off(key, value)?,
        "vsync" => s.vsync = on_off(key, value)?,
        _ => bail!("--script: unknown key '{key}' (keys: {})", keys()),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiledlight_setup::SceneSource;

    #[test]
    fn parses_actions() {
        let a = parse(" method=deferred; lights=300 ;wait=2;camera=orbit;scene=x.gltf;window=64x48").unwrap();
        assert_eq!(a.len(), 6);
        assert_eq!(a[5], Action::Window(64, 48));
        assert_eq!(a[0], Action::Set { key: "method".into(), value: "deferred".into() });
        assert_eq!(a[2], Action::Wait(2));
        assert_eq!(a[3], Action::Camera(Mode::Orbit));
        let mut s = Settings::new(Default::default());
        set(&mut s, "method", "brute-force").unwrap();
        set(&mut s, "scene", "x.gltf").unwrap();
        assert_eq!(s.setup.scene, SceneSource::File("x.gltf".into()));
        set(&mut s, "heatmap", "on").unwrap();
        assert_eq!((s.setup.method, s.heatmap), (tiledlight_setup::Method::BruteForce { cutoff: true }, true));
        set(&mut s, "heatmap", "blended").unwrap();
        assert_eq!((s.heatmap, s.heatmap_of), (true, HeatmapOf::Blended));
        set(&mut s, "heatmap", "vpl").unwrap();
        assert_eq!((s.heatmap, s.heatmap_of), (true, HeatmapOf::Vpl));
        set(&mut s, "heatmap", "on").unwrap();
        assert_eq!((s.heatmap, s.heatmap_of), (true, HeatmapOf::Opaque));
        for (k, v) in [
            ("shadow-point-lights", "8"),
            ("shadow-spot-lights", "4"),
            ("shadow-size", "512"),
            ("shadow-filter", "3"),
            ("shadow-format", "d32"),
        ] {
            set(&mut s, k, v).unwrap();
        }
        let a = &s.setup;
        assert_eq!((a.shadow_point_lights, a.shadow_spot_lights, a.knobs.shadow_size), (8, 4, 512));
        assert_eq!(
            (a.knobs.shadow_filter, a.knobs.shadow_format),
            (tiledlight_cull::shadow::ShadowFilter::Pcf3, tiledlight_cull::shadow::ShadowFormat::Depth32)
        );
        set(&mut s, "transparent-objects", "20").unwrap();
        set(&mut s, "blend-mode", "wboit").unwrap();
        assert_eq!(
            (s.setup.transparent_objects, s.setup.knobs.blend_mode),
            (20, tiledlight_gpu::features::BlendMode::WeightedOit)
        );
        set(&mut s, "grid", "clustered").unwrap();
        assert!(s.setup.clusters.is_some());
        set(&mut s, "grid", "2.5d").unwrap();
        assert!(s.setup.depth_mask && s.setup.clusters.is_none());
        set(&mut s, "assign", "scatter").unwrap();
        assert!(s.setup.scatter);
        assert!(set(&mut s, "assign", "sideways").is_err());
        assert!(set(&mut s, "grid", "hexagonal").is_err());
    }

    #[test]
    fn vpl_keys_set_the_panels_vpl_controls() {
        use tiledlight_cull::vpl::{VplConfig, VplShading};
        let mut s = Settings::new(Default::default());
        set(&mut s, "vpl-block", "4").unwrap();
        assert_eq!(s.setup.vpl, None, "a setting while VPLs are off keeps them off");
        set(&mut s, "vpl", "on").unwrap();
        for (k, v) in [
            ("vpl-rsm-size", "64"),
            ("vpl-colour-threshold", "0.2"),
            ("vpl-brightness-threshold", "0.05"),
            ("vpl-cap", "500"),
            ("vpl-shading", "physical"),
        ] {
            set(&mut s, k, v).unwrap();
        }
        let want = VplConfig {
            rsm_size: 64,
            block: 4,
            colour_threshold: 0.2,
            brightness_threshold: 0.05,
            cap: 500,
            shading: VplShading::Physical,
            ..VplConfig::default()
        };
        assert_eq!(s.setup.vpl, Some(want));
        set(&mut s, "vpl", "off").unwrap();
        assert_eq!((s.setup.vpl, s.vpl_config()), (None, want));
        let e = |a: &str| format!("{:#}", parse(a).unwrap_err());
        assert!(e("vpl=maybe").contains("vpl=maybe: expected on or off"));
        assert!(e("vpl-cap=lots").contains("vpl-cap=lots: not a number"));
        assert!(e("vpl-shading=fancy").contains("vpl-shading=fancy"));
    }

    #[test]
    fn bad_actions_are_named() {
        let e = |s: &str| format!("{:#}", parse(s).unwrap_err());
        assert!(e("method").contains("'method' is not key=value"));
        assert!(e("zoom=3").contains("unknown key 'zoom'"));
        assert!(e("lights=many").contains("lights 'many': expected a whole number"), "{}", e("lights=many"));
        assert!(e("method=fast").contains("method 'fast'"), "{}", e("method=fast"));
        assert!(e("heatmap=maybe").contains("heatmap=maybe: expected on, off, opaque, blended or vpl"));
        assert!(
            e("shadow-size=big").contains("shadow-size 'big': expected a whole number"),
            "{}",
            e("shadow-size=big")
        );
        assert!(e("shadow-format=d24").contains("shadow-format 'd24': expected one of d16, d32"));
        assert!(e("transparent-objects=some").contains("transparent-objects 'some': expected a whole number"));
        assert!(e("grid=hex").contains("grid 'hex': expected one of tiled, half-z, 2.5d, clustered"));
        assert!(e("casters-by=luck").contains("casters-by 'luck': expected one of brightness, contribution"));
        assert!(e("blend-mode=additive").contains("blend-mode 'additive': expected one of sorted, wboit"));
        assert!(e("wait=-1").contains("wait=-1"));
        assert!(e("window=0x5").contains("WIDTHxHEIGHT"));
    }
}
