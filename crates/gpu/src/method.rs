//! What this crate knows of methods: the traits of a frame's method that its passes read
//! ([`MethodTraits`]; the methods themselves are `tiledlight_frame::Method`), which
//! rasteriser draws the visibility buffer ([`Raster`]) and who draws the compute raster's
//! large triangles ([`LargeRaster`]); re-exported by [`crate::features`]. A leaf module:
//! depends only on [`crate::context`] (the compute raster's device features), so the pass
//! settings' table ([`crate::knobs`](mod@crate::knobs)) and the features can both name them.

use crate::context::COMPUTE_RASTER_FEATURES;

/// What this crate's passes and the pass settings' table need to know of a frame's method:
/// its traits, not its name. The methods themselves (`tiledlight_frame::Method`) and their
/// registrations live above this crate, so a new method is declared there and only says
/// which of these it has.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MethodTraits {
    /// Tiles: culling, the light grid, the heat map. The others are references (every
    /// light for every pixel).
    pub tiled: bool,
    /// A G-buffer (Tiled Deferred): its extra targets, its MSAA edge test.
    pub gbuffer: bool,
    /// The visibility buffer's surface: its raster and its MSAA edge test.
    pub visibility_buffer: bool,
    /// Shadows by rays through the scene's BVH (no shadow maps).
    pub traced: bool,
    /// A few lights a pixel, sampled by what they would contribute, each shadowed by a ray,
    /// frames accumulated (the stochastic method): its candidates and history.
    pub stochastic: bool,
    /// Lights end at their radius (the windowed falloff); false only for the references
    /// without it (plain inverse-square).
    pub cutoff: bool,
}

impl MethodTraits {
    /// Every light for every pixel, no tiles.
    pub fn is_reference(self) -> bool {
        !self.tiled
    }
}

/// Which rasteriser draws the visibility buffer's depth and triangle IDs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Raster {
    /// The faster of the two on this adapter's class, where the compute raster can run:
    /// [`Raster::pick`].
    #[default]
    Auto,
    /// The hardware raster (the depth pre-pass's pipelines writing IDs).
    Hardware,
    /// The compute raster (64-bit atomics; one sample a pixel).
    Compute,
}

impl Raster {
    /// Every value, in the order the command line lists them.
    pub const ALL: [Raster; 3] = [Raster::Auto, Raster::Hardware, Raster::Compute];

    /// The flag value.
    pub const fn name(self) -> &'static str {
        match self {
            Raster::Auto => "auto",
            Raster::Hardware => "hardware",
            Raster::Compute => "compute",
        }
    }

    /// What it does, in one line (the command line's help).
    pub fn summary(self) -> &'static str {
        match self {
            Raster::Auto => "The faster on this adapter class where it can run (measured: docs/PERFORMANCE.md)",
            Raster::Hardware => "The hardware raster: depth pre-pass pipelines writing triangle IDs (any MSAA)",
            Raster::Compute => {
                "Compute: 64-bit atomicMax of (depth, ID) per pixel, large triangles and masked materials by \
                 the hardware (one sample a pixel; needs 64-bit buffer atomics)"
            }
        }
    }

    /// The value of flag value `name`.
    pub fn from_name(name: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|m| m.name() == name).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|m| m.name()).collect();
            format!("raster {name:?}: use one of {}", names.join(", "))
        })
    }

    /// [`Raster::Auto`] made concrete for an adapter of `device_type` whose device has
    /// `features`, drawing `msaa` samples: the compute raster where it can run (64-bit
    /// buffer atomics, one sample) and was measured faster (a discrete GPU: the H200,
    /// docs/PERFORMANCE.md), else the hardware raster (lavapipe's compute raster is the
    /// slower there). An explicit choice is kept as it is.
    pub fn pick(self, device_type: wgpu::DeviceType, features: wgpu::Features, msaa: u32) -> Raster {
        let can = features.contains(COMPUTE_RASTER_FEATURES);
        match self {
            Raster::Auto if can && msaa == 1 && device_type == wgpu::DeviceType::DiscreteGpu => Raster::Compute,
            Raster::Auto => Raster::Hardware,
            r => r,
        }
    }
}

/// `--raster` on a command line (feature `clap`).
#[cfg(feature = "clap")]
impl clap::ValueEnum for Raster {
    fn value_variants<'a>() -> &'a [Self] {
        &Self::ALL
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(clap::builder::PossibleValue::new(self.name()).help(self.summary()))
    }
}

/// Who draws the compute raster's large triangles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum LargeRaster {
    /// Compute: each triangle's 16 px screen tiles listed (`cs_large`), a workgroup a tile
    /// (`cs_large_tiles`, tiledlight-visibility's compute raster).
    #[default]
    Compute,
    /// The hardware raster, by one indirect draw (`visibility_raster_large.wgsl`).
    Hardware,
}

impl LargeRaster {
    /// Both, in the order the command line lists them.
    pub const ALL: [LargeRaster; 2] = [LargeRaster::Compute, LargeRaster::Hardware];

    /// The flag value.
    pub const fn name(self) -> &'static str {
        match self {
            LargeRaster::Compute => "compute",
            LargeRaster::Hardware => "hardware",
        }
    }
}
