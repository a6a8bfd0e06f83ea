//! Every shader define, spelled once. The WGSL entry files declare the defines they take
//! (`// variants:` lines, checked by the preprocessor) and test them with `#ifdef`; in
//! Rust a define is a [`Define`], never a string: the variant keys
//! ([`crate::variants`]) push [`Define::name`]s, and the bindings' conditions
//! ([`crate::bindings::Cond`]) hold the enum, so a misspelt define does not compile. The
//! names given to the preprocessor are the WGSL's, [`Define::name`]; a unit test checks
//! that the enum and the entry files' declarations are the same set. Depends on nothing.

macro_rules! defines {
    ($($(#[$doc:meta])* $variant:ident = $name:literal,)*) => {
        /// A shader define (module doc).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Define {
            $($(#[$doc])* $variant,)*
        }

        impl Define {
            /// Every define.
            pub const ALL: &'static [Define] = &[$(Define::$variant,)*];

            /// Its name in WGSL (`#ifdef NAME`).
            pub const fn name(self) -> &'static str {
                match self {
                    $(Define::$variant => $name,)*
                }
            }
        }
    };
}

defines! {
    /// Alpha-masked materials (discard below the cutoff).
    AlphaMask = "ALPHA_MASK",
    /// The compute raster's masked draws resolving IDs with atomics.
    Atomic = "ATOMIC",
    /// Tonemapping with the exposure computed on the GPU.
    AutoExposure = "AUTO_EXPOSURE",
    /// A pass over the blended geometry's grid.
    Blended = "BLENDED",
    /// Every light for every pixel (no list).
    BruteForce = "BRUTE_FORCE",
    /// The clustered light grid.
    Clustered = "CLUSTERED",
    /// Two-level culling (64x64-pixel cells first).
    Coarse = "COARSE",
    /// The stochastic method's denoiser: its shading pass leaves the filter's guide.
    Denoise = "DENOISE",
    /// 2.5D culling's depth masks.
    DepthMask = "DEPTH_MASK",
    /// Test hook: one light dropped from every list.
    DropLight = "DROP_LIGHT",
    /// Tiled Deferred's emission target.
    Emission = "EMISSION",
    /// Tiled Deferred's extra G-buffer targets (the stress knob; how many is the constant
    /// `EXTRA_TARGETS`).
    ExtraRts = "EXTRA_RTS",
    /// Test hook: the extra targets written with test values instead of white.
    ExtraTestValues = "EXTRA_TEST_VALUES",
    /// Clusters: only those holding a surface get lights.
    GeometryOnly = "GEOMETRY_ONLY",
    /// Two lists per tile, split at the middle of its depth range.
    HalfZ = "HALF_Z",
    /// The visibility buffer's triangle IDs.
    Ids = "IDS",
    /// Several samples a pixel.
    Msaa = "MSAA",
    /// Normal maps.
    NormalMap = "NORMAL_MAP",
    /// Plain inverse-square falloff (no radius window).
    NoCutoff = "NO_CUTOFF",
    /// The stochastic method's spatial reuse: its pass runs twice, sampling then reusing
    /// the neighbours' reservoirs.
    Reuse = "REUSE",
    /// The shadow atlas.
    Shadows = "SHADOWS",
    /// The contribution estimate's spot lights.
    Spots = "SPOTS",
    /// Culling: the spot cone test.
    SpotCone = "SPOT_CONE",
    /// Spot lights in the shading.
    SpotLights = "SPOT_LIGHTS",
    /// The stochastic method's light sampler (with `TRACED`: its one ray a pixel).
    Stochastic = "STOCHASTIC",
    /// Base-colour textures.
    Textures = "TEXTURES",
    /// The traced reference's shadow rays.
    Traced = "TRACED",
    /// Alpha masks in the traced reference's rays.
    TraceMasks = "TRACE_MASKS",
    /// A second texture coordinate set.
    Uv1 = "UV1",
    /// The visibility buffer's surface reconstruction.
    Visibility = "VISIBILITY",
    /// Virtual point lights.
    Vpls = "VPLS",
    /// Weighted blended order-independent transparency.
    Wboit = "WBOIT",
}

/// The names of `defines`, for the preprocessor.
pub fn names(defines: &[Define]) -> Vec<&'static str> {
    defines.iter().map(|d| d.name()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// The enum and the entry files' `// variants:` lines name the same defines: none
    /// declared in WGSL without its Rust spelling, none in Rust that no file takes.
    #[test]
    fn the_enum_is_every_declared_define() {
        let declared: BTreeSet<String> =
            crate::shader::SHADER_FILES.iter().flat_map(|(_, text)| crate::shader::variants_in(text)).collect();
        let spelled: BTreeSet<String> = Define::ALL.iter().map(|d| d.name().to_string()).collect();
        assert_eq!(spelled, declared);
        assert_eq!(spelled.len(), Define::ALL.len(), "a name spelled twice");
    }
}
