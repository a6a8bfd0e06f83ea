//! Every method, registered once: [`METHODS`] lists each method's
//! [`Registration`] (its frame's module declares it), [`registration`] finds a method's,
//! [`plan`] builds a frame's plan around its steps. The renderer reads this and nothing
//! else matches on methods. Adding a method: its crate or module with its passes and WGSL,
//! one file in this crate with its frame (a `MethodFrame`, its target needs, its steps and
//! its registration), one line in [`METHODS`], and its variant of [`Method`] (name, label,
//! summary). Depends on the method frames ([`crate::forward_plus`],
//! [`crate::tiled_deferred`], [`crate::visibility`]), [`crate::method`] and [`crate::plan`];
//! only [`crate::FrameRenderer`] depends on it.

use crate::methods::Method;
use tiledlight_gpu::features::Features;

use crate::method::Registration;
use crate::plan::FramePlan;

/// Every method's registration (each of [`Method::ALL`] by exactly one).
pub const METHODS: [&Registration; 6] = [
    &crate::forward_plus::FORWARD_PLUS,
    &crate::forward_plus::BRUTE_FORCE,
    &crate::tiled_deferred::REGISTRATION,
    &crate::visibility::REGISTRATION,
    &crate::visibility::TRACED,
    &crate::visibility::STOCHASTIC,
];

/// The registration of `method`.
pub fn registration(method: Method) -> &'static Registration {
    METHODS.into_iter().find(|r| (r.renders)(method)).unwrap_or_else(|| panic!("{method:?} is not registered"))
}

/// The plan of a frame of `method` with `features`: the shared steps around the method's.
pub fn plan(method: Method, features: &Features) -> FramePlan {
    FramePlan::new(features, &(registration(method).steps)(features))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Step;
    use tiledlight_gpu::scene_gpu::DrawKind;

    fn features(method: Method, msaa: u32) -> Features {
        Features {
            method: method.traits(),
            spot_lights: false,
            spot_cone: false,
            textures: false,
            materials: Default::default(),
            draw_kinds: vec![DrawKind { masked: false, double_sided: false, blended: false }],
            msaa,
            half_z: false,
            coarse: true,
            aabb: false,
            extra_targets: 0,
            blended_kinds: vec![],
            frustum_clusters: false,
            blend_mode: Default::default(),
            shadows: None,
            vpl: false,
            knobs: Default::default(),
        }
    }

    /// Each method is rendered by exactly one registration, and each registration renders
    /// some method.
    #[test]
    fn every_method_is_registered_once() {
        for m in Method::ALL {
            let n = METHODS.iter().filter(|r| (r.renders)(m)).count();
            assert_eq!(n, 1, "{m:?}: {n} registrations");
            assert!((registration(m).renders)(m));
        }
        for r in METHODS {
            assert!(Method::ALL.into_iter().any(|m| (r.renders)(m)), "{} renders no method", r.building);
        }
    }

    #[test]
    fn the_early_outs_ablation_is_one_pipeline_constant() {
        let mut f = features(Method::ForwardPlus, 1);
        assert!(f.light_constants().is_empty(), "the default passes no constant: the shaders' default holds");
        f.knobs.early_outs = false;
        assert_eq!(f.light_constants(), [("EARLY_OUTS", 0.0)]);
    }

    #[test]
    fn each_method_has_its_passes_and_the_shared_tail() {
        use Step::*;
        let plan = |m, s| plan(m, &features(m, s)).steps().to_vec();
        assert_eq!(plan(Method::ForwardPlus, 1), [DepthPrepass, Cull, ForwardShade, Tonemap, Heatmap]);
        assert_eq!(plan(Method::BruteForce { cutoff: true }, 4), [DepthPrepass, BruteForceShade, Tonemap]);
        assert_eq!(plan(Method::TiledDeferred, 1), [GBuffer, DeferredShade, Tonemap, Heatmap]);
        assert_eq!(plan(Method::TRUTH, 1), [VisibilityRaster, TracedShade, Tonemap]);
        assert_eq!(plan(Method::TRUTH, 4), [VisibilityRaster, TracedShade, VisibilityResolve, Tonemap]);
        assert_eq!(plan(Method::TiledDeferred, 4), [GBuffer, DeferredShade, DeferredResolve, Tonemap, Heatmap]);
    }

    #[test]
    fn blended_geometry_adds_its_passes_to_both_methods() {
        use Step::*;
        let blended = |m| {
            let mut f = features(m, 1);
            f.blended_kinds = vec![DrawKind { masked: false, double_sided: true, blended: true }];
            plan(m, &f).steps().to_vec()
        };
        assert_eq!(
            blended(Method::ForwardPlus),
            [DepthPrepass, Cull, ForwardShade, BlendedDepth, BlendedCull, BlendedShade, Tonemap, Heatmap]
        );
        assert_eq!(
            blended(Method::TiledDeferred),
            [GBuffer, DeferredShade, BlendedDepth, BlendedCull, BlendedShade, Tonemap, Heatmap]
        );
        assert_eq!(
            blended(Method::BruteForce { cutoff: true }),
            [DepthPrepass, BruteForceShade, BlendedDepth, BlendedShade, Tonemap]
        );
        // Frustum clusters serve blended geometry: no blended depth or lists.
        let mut f = features(Method::ForwardPlus, 1);
        f.blended_kinds = vec![DrawKind { masked: false, double_sided: true, blended: true }];
        f.frustum_clusters = true;
        assert_eq!(
            plan(Method::ForwardPlus, &f).steps(),
            [DepthPrepass, Cull, ForwardShade, BlendedShade, Tonemap, Heatmap]
        );
        assert!(!plan(Method::ForwardPlus, &features(Method::ForwardPlus, 1)).has(BlendedDepth));
    }

    #[test]
    fn vpls_follow_the_shadow_maps_and_exist_only_when_asked_for() {
        use Step::*;
        let bf = Method::BruteForce { cutoff: true };
        let mut f = features(bf, 1);
        f.shadows = Some(tiledlight_gpu::features::Shadows { points: 0, spots: 1, options: Default::default() });
        assert!(!plan(bf, &f).has(Vpl), "no --vpl, no VPL step");
        f.vpl = true;
        assert_eq!(plan(bf, &f).steps(), [ShadowMaps, Vpl, DepthPrepass, BruteForceShade, Tonemap]);
        let mut with = |m: Method| {
            f.method = m.traits();
            plan(m, &f).steps().to_vec()
        };
        assert_eq!(
            with(Method::ForwardPlus),
            [ShadowMaps, Vpl, DepthPrepass, Cull, VplCull, ForwardShade, Tonemap, Heatmap]
        );
        assert_eq!(with(Method::TiledDeferred), [ShadowMaps, Vpl, GBuffer, VplCull, DeferredShade, Tonemap, Heatmap]);
    }

    #[test]
    fn no_feature_no_pass() {
        // Without MSAA there is no resolve; without tiles no culling and no heat map.
        assert!(!plan(Method::TiledDeferred, &features(Method::TiledDeferred, 1)).has(Step::DeferredResolve));
        let m = Method::BruteForce { cutoff: false };
        let bf = plan(m, &features(m, 1));
        assert!(!bf.has(Step::Cull) && !bf.has(Step::Heatmap));
    }
}
