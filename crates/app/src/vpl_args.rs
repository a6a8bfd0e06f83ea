//! The virtual-point-light flags (`--vpl` and its settings), flattened into
//! [`crate::scene_setup::SceneArgs`] so `render`, `bench`, the lab and the viewer share
//! them, their conversion into `tiledlight_cull::vpl::VplConfig`, and the `warning:` line
//! when the cap refused VPLs. May depend on tiledlight-cull and tiledlight-gpu (the
//! renderer's VPL count); the subcommands call it.

use clap::{Args, ValueEnum};
use tiledlight_cull::vpl::{VplConfig, VplShading, DEFAULT_BLOCK, DEFAULT_CAP, DEFAULT_RSM_SIZE};

/// How VPLs light a surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum VplShadingArg {
    /// TiledLighting11's: smoothstep to the VPL's radius, no inverse square.
    Sample,
    /// Dachsbacher and Stamminger's: flux x cos x cos / max(d^2, clamp^2).
    Physical,
}

impl From<VplShadingArg> for VplShading {
    fn from(a: VplShadingArg) -> Self {
        match a {
            VplShadingArg::Sample => VplShading::Sample,
            VplShadingArg::Physical => VplShading::Physical,
        }
    }
}

impl From<VplShading> for VplShadingArg {
    fn from(s: VplShading) -> Self {
        match s {
            VplShading::Sample => VplShadingArg::Sample,
            VplShading::Physical => VplShadingArg::Physical,
        }
    }
}

/// The VPL flags.
#[derive(Args, Clone, Debug, PartialEq)]
pub struct VplArgs {
    /// Virtual point lights: one-bounce indirect light from the shadow-casting lights'
    /// reflective shadow maps (needs --shadow-spot-lights or --shadow-point-lights).
    #[arg(help_heading = "VPLs", long)]
    pub vpl: bool,
    /// Texels per side of each caster face's reflective shadow map.
    #[arg(help_heading = "VPLs", hide_short_help = true, long, default_value_t = DEFAULT_RSM_SIZE, value_name = "4..512")]
    pub vpl_rsm_size: u32,
    /// Texels per side of the block one VPL stands for (divides --vpl-rsm-size).
    #[arg(help_heading = "VPLs", hide_short_help = true, long, default_value_t = DEFAULT_BLOCK, value_name = "N")]
    pub vpl_block: u32,
    /// Keep a VPL only when a channel of its normalised colour reaches this (0..1).
    #[arg(help_heading = "VPLs", hide_short_help = true, long, default_value_t = 0.0, value_name = "0..1")]
    pub vpl_colour_threshold: f32,
    /// Keep a VPL only when its colour's length exceeds this.
    #[arg(help_heading = "VPLs", hide_short_help = true, long, default_value_t = 0.0, value_name = "F")]
    pub vpl_brightness_threshold: f32,
    /// Most VPLs; the rest are refused and reported.
    #[arg(help_heading = "VPLs", hide_short_help = true, long, default_value_t = DEFAULT_CAP, value_name = "N")]
    pub vpl_cap: u32,
    /// How VPLs light a surface.
    #[arg(help_heading = "VPLs", hide_short_help = true, long, value_enum, default_value_t = VplShadingArg::Sample)]
    pub vpl_shading: VplShadingArg,
}

impl VplArgs {
    /// The settings, when `--vpl` is given (checked by `Settings::validate`).
    pub fn config(&self) -> Option<VplConfig> {
        self.vpl.then(|| VplConfig {
            rsm_size: self.vpl_rsm_size,
            block: self.vpl_block,
            colour_threshold: self.vpl_colour_threshold,
            brightness_threshold: self.vpl_brightness_threshold,
            cap: self.vpl_cap,
            shading: self.vpl_shading.into(),
            ..VplConfig::default()
        })
    }

    /// The flags that give `config` (None: the defaults without `--vpl`).
    pub fn of(config: Option<VplConfig>) -> Self {
        let c = config.unwrap_or_default();
        Self {
            vpl: config.is_some(),
            vpl_rsm_size: c.rsm_size,
            vpl_block: c.block,
            vpl_colour_threshold: c.colour_threshold,
            vpl_brightness_threshold: c.brightness_threshold,
            vpl_cap: c.cap,
            vpl_shading: c.shading.into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_round_trip_through_the_config() {
        let none = VplArgs::of(None);
        assert_eq!(none.config(), None);
        let cfg = VplConfig { block: 4, cap: 100, shading: VplShading::Physical, ..VplConfig::default() };
        assert_eq!(VplArgs::of(Some(cfg)).config(), Some(cfg));
    }
}
