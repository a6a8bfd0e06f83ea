//! The frame plan: every pass of a frame, in order, for both methods, decided once from the
//! scene features ([`Features`]) when a renderer is built. The renderers record exactly
//! these steps, each with the pass struct they built for it; tests and the app read the
//! plan to see what a frame does (and that a feature the scene lacks costs no pass).
//!
//! ```text
//! shadows  shadow atlas: the faces of casters that moved (only when a light casts shadows)
//! vpl      RSM + VPL generation of the casters that moved (only with `--vpl`)
//! head     depth pre-pass (Forward+, brute force)      | G-buffer (Tiled Deferred)
//! culling  cells + tiles -> light grid (Forward+)      | (Tiled Deferred culls in its shading pass)
//!          [VPLs -> their own light grid (either method, `--vpl`)]
//!          or light-centric assignment (either method: tile depth, count, allocate, write)
//! middle   forward shading (Forward+ / brute force)     | cull + shade, [MSAA resolve] (Tiled Deferred;
//!                                                         shade only when the lists were assigned)
//! blended  blended depth, blended culling (tiled), blended shading + composite (only with
//!          alpha-blended geometry; the same passes for both methods)
//! tail     tonemap, heat map (tiled methods; drawn when switched on)
//! ```
//!
//! A method's own steps come from its registration ([`crate::method::Registration`]);
//! a new shared pass touches its own Rust file, its WGSL, one line here and, when the scene
//! decides whether it exists, one field of [`Features`]. Depends on tiledlight-gpu's
//! `features` (the method and the features); lives with the frame that records it.

use tiledlight_gpu::features::Features;
#[cfg(test)]
use tiledlight_gpu::features::Method;

/// One step of a frame. Each names the pass struct that records it and its timer label.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Step {
    /// The shadow faces of the casters that moved (`shadow.atlas`; only with shadows).
    ShadowMaps,
    /// Virtual point lights (tiledlight-vpl): the casters' reflective shadow maps and the
    /// VPLs generated from them, when the casters moved (`vpl.rsm`, `vpl.generate`; only
    /// with `--vpl`).
    Vpl,
    /// Depth of the opaque and masked geometry (`depth_prepass`).
    DepthPrepass,
    /// Tiled Deferred's G-buffer, with depth (`deferred.gbuffer`).
    GBuffer,
    /// Forward+'s culling into the light grid, two-level when the features say so
    /// (`forward.cull`).
    Cull,
    /// The culling of the VPLs into a light grid of their own, one list per tile, by the
    /// lights' culling pass (`forward.cull_vpls`, `deferred.cull_vpls`; only with `--vpl`).
    VplCull,
    /// Forward shading of each fragment's grid list (`forward.shade`).
    ForwardShade,
    /// Every light for every fragment (`brute_force.shade`).
    BruteForceShade,
    /// Tiled Deferred's cells (two-level) and its cull-and-shade pass
    /// (`deferred.cull_cells`, `deferred.shade`); with light-centric assignment, the
    /// assignment's passes (`deferred.assign.*`) and a pass that only shades.
    DeferredShade,
    /// Averages the per-sample shading of MSAA edge pixels (`deferred.resolve`).
    DeferredResolve,
    /// The visibility buffer's depth and triangle IDs (`visibility.raster`).
    VisibilityRaster,
    /// The visibility buffer's material-and-lights pass over the light grid
    /// (`visibility.shade`; one dispatch per material of a textured scene).
    VisibilityShade,
    /// Its MSAA edge pixels averaged (`visibility.resolve`).
    VisibilityResolve,
    /// The traced reference's every-light pass with a shadow ray per light over the
    /// visibility buffer (`traced.shade`, in bands of tile rows).
    TracedShade,
    /// Depth of the blended geometry, in its own buffer (`blended.depth`; only with blended
    /// geometry).
    BlendedDepth,
    /// Culling for blended geometry into its own light grid (`blended.cull`; tiled methods).
    BlendedCull,
    /// Blended geometry shaded back to front into the transparent layer, composited over the
    /// opaque image (`blended.shade`, `blended.composite`).
    BlendedShade,
    /// HDR to the display image (`tonemap`).
    Tonemap,
    /// Lights per tile over the image, when switched on (`heatmap`).
    Heatmap,
}

/// The ordered steps of a frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FramePlan {
    steps: Vec<Step>,
}

impl FramePlan {
    /// The frame of `features`: the whole frame of both methods reads here.
    pub fn new(features: &Features) -> Self {
        let mut steps = Vec::new();
        // Shadow maps first: every method's shading reads them.
        if features.shadows.is_some() {
            steps.push(Step::ShadowMaps);
        }
        // VPLs after the shadow faces whose views their RSM draws from.
        if features.vpl {
            steps.push(Step::Vpl);
        }
        // The method's steps: what writes depth, its culling, its shading (its registration).
        steps.extend((crate::method::registration(features.method).steps)(features));
        // Blended geometry, over the opaque image, both methods alike.
        // Frustum clusters already list every light a blended surface can see.
        if features.blended() {
            if !features.frustum_clusters {
                steps.push(Step::BlendedDepth);
                if features.method.is_tiled() {
                    steps.push(Step::BlendedCull);
                }
            }
            steps.push(Step::BlendedShade);
        }
        // Tail.
        steps.push(Step::Tonemap);
        if features.method.is_tiled() {
            steps.push(Step::Heatmap);
        }
        Self { steps }
    }

    /// The steps, in order.
    pub fn steps(&self) -> &[Step] {
        &self.steps
    }

    /// True when the frame has `step`.
    pub fn has(&self, step: Step) -> bool {
        self.steps.contains(&step)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiledlight_gpu::scene_gpu::DrawKind;

    fn features(method: Method, msaa: u32) -> Features {
        Features {
            method,
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
        let plan = |m, s| FramePlan::new(&features(m, s)).steps().to_vec();
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
            FramePlan::new(&f).steps().to_vec()
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
        assert_eq!(FramePlan::new(&f).steps(), [DepthPrepass, Cull, ForwardShade, BlendedShade, Tonemap, Heatmap]);
        assert!(!FramePlan::new(&features(Method::ForwardPlus, 1)).has(BlendedDepth));
    }

    #[test]
    fn vpls_follow_the_shadow_maps_and_exist_only_when_asked_for() {
        use Step::*;
        let mut f = features(Method::BruteForce { cutoff: true }, 1);
        f.shadows = Some(tiledlight_gpu::features::Shadows { points: 0, spots: 1, options: Default::default() });
        assert!(!FramePlan::new(&f).has(Vpl), "no --vpl, no VPL step");
        f.vpl = true;
        assert_eq!(FramePlan::new(&f).steps(), [ShadowMaps, Vpl, DepthPrepass, BruteForceShade, Tonemap]);
        f.method = Method::ForwardPlus;
        assert_eq!(
            FramePlan::new(&f).steps(),
            [ShadowMaps, Vpl, DepthPrepass, Cull, VplCull, ForwardShade, Tonemap, Heatmap]
        );
        f.method = Method::TiledDeferred;
        assert_eq!(FramePlan::new(&f).steps(), [ShadowMaps, Vpl, GBuffer, VplCull, DeferredShade, Tonemap, Heatmap]);
    }

    #[test]
    fn no_feature_no_pass() {
        // Without MSAA there is no resolve; without tiles no culling and no heat map.
        assert!(!FramePlan::new(&features(Method::TiledDeferred, 1)).has(Step::DeferredResolve));
        let bf = FramePlan::new(&features(Method::BruteForce { cutoff: false }, 1));
        assert!(!bf.has(Step::Cull) && !bf.has(Step::Heatmap));
    }
}
