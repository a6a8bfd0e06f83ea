//! tiledlight-cull: the pure math of tiled light culling, with no GPU dependency.
//!
//! Cameras (reversed-Z perspective with finite or infinite far, orthographic), lights
//! and their GPU packing, tile frusta, the bounding tests, windowed attenuation and the
//! shared BRDF, the CPU reference culler that every GPU kernel is compared with
//! ([`mod@reference`], the dispatch at the top; below it the tile-centric [`gather`], the
//! light-centric [`assign`] with its tile rectangle, the tile [`volumes`] and per-volume
//! test they share, and the [`lists`] they fill), 2.5D depth masks ([`depth_mask`]), clustered
//! lists ([`cluster`]), the light grid's packing ([`grid`]), the shadow atlas's layout, projections and lookup
//! ([`shadow`]), and the CPU ray-cast visibility reference that shadow maps are compared
//! with ([`raycast`]: triangles in a BVH, segment occlusion), and an estimate of the
//! lights per tile for light counts the reference is too slow for ([`estimate`]), and the
//! CPU twin of virtual point lights: generation from a reflective shadow map, the two
//! shading models and the every-texel one-bounce reference ([`vpl`]); and an independent
//! raster of a depth buffer with the bounds a GPU's snapping allows ([`blended_depth`],
//! what the blended lists are checked against); and the visibility buffer's twin: its IDs,
//! perspective-correct barycentrics with their screen derivatives, and mip levels
//! ([`visibility`]); and the rules of its compute rasteriser: clipping, 1/256-px snapping,
//! the top-left rule, depth, and the 64-bit (depth, ID) resolve ([`raster`]); and the
//! traced reference's shadow rays in f32 as its GPU kernel casts them: the flattened
//! hierarchy, watertight triangle test and alpha masks ([`trace`]); and each light's
//! contribution to a frame, which picks shadow casters by what they light on screen
//! ([`contribution`]); and unit normals in two fixed-point numbers, the octahedral map
//! with its error bound ([`octahedral`]), and the compact G-buffer texel that packs a
//! surface sample into 64 bits ([`gbuffer`]); and the order the depth pre-pass and the
//! G-buffer draw instances in, nearest first ([`draw_order`]); and material texture
//! sampling as the shaders filter texels themselves: mip chains, levels, wraps
//! ([`texture`]); and the stochastic method's light sampler (resampled importance sampling
//! into a reservoir, one shadow ray a pixel: [`stochastic`]) and its denoiser (an à-trous filter
//! guided by the surface and the estimate's variance: [`denoise`]).
//! Depends only on glam, bytemuck and thiserror; every other crate may depend on it.

pub mod error;

pub mod layout;
pub mod light;
pub mod light_tree;
pub mod lists;
pub mod material;
pub use error::CullError;
pub use light::{Light, LightKind};
pub mod assign;
pub mod blended_depth;
pub mod bounds;
pub mod brdf;
pub mod camera;
pub mod cluster;
pub mod contribution;
pub mod denoise;
pub mod depth_mask;
pub mod draw_order;
pub mod estimate;
pub mod exposure;
pub mod gather;
pub mod gbuffer;
pub mod grid;
pub mod octahedral;
pub mod raster;
pub mod raycast;
pub mod reference;
pub mod reuse;
pub mod shadow;
pub mod stochastic;
pub mod temporal;
pub mod texture;
pub mod tiles;
pub mod trace;
pub mod visibility;
pub mod volumes;
pub mod vpl;

pub use camera::{Camera, DepthParams, Projection};
pub use cluster::cull_clusters;
pub use gather::cull_tiles_blended;
pub use lists::{ClusterConfig, CullConfig, TileLists};
pub use reference::cull_tiles;
pub use tiles::TileGrid;

/// The workspace's shared proptest configuration (fixed seed unless `PROPTEST_RNG_SEED`),
/// for the unit tests' property tests.
#[cfg(test)]
#[path = "../tests/common/seed.rs"]
pub(crate) mod test_seed;

#[cfg(test)]
mod test_seed_tests {
    //! The shared proptest configuration (tested here once, not in every test binary that
    //! includes it).
    use crate::test_seed::*;
    use proptest::test_runner::{Config, RngSeed};

    #[test]
    fn unset_variables_give_the_fixed_seed_and_the_asked_cases() {
        let c = config_from(17, |_| false);
        assert_eq!(c.cases, 17);
        assert!(matches!(c.rng_seed, RngSeed::Fixed(DEFAULT_SEED)), "{:?}", c.rng_seed);
    }

    #[test]
    fn set_variables_are_left_to_proptest() {
        // With both variables "set", the values come from proptest's own reading of the
        // environment (here: whatever the process has), never from the defaults above.
        let c = config_from(17, |_| true);
        let d = Config::default();
        assert_eq!(c.cases, d.cases);
        assert_eq!(format!("{:?}", c.rng_seed), format!("{:?}", d.rng_seed));
    }
}
