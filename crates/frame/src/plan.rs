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
//! A method's own steps come from its registration ([`crate::method::Registration`], given
//! by [`crate::registry::plan`]);
//! a new shared pass touches its own Rust file, its WGSL, one line here and, when the scene
//! decides whether it exists, one field of [`Features`]. Depends on tiledlight-gpu's
//! `features` (the method and the features); lives with the frame that records it.

use tiledlight_gpu::features::Features;

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
    /// The stochastic method's pass: candidates, one kept and one shadow ray a pixel, the
    /// frames accumulated (`stochastic.shade`).
    StochasticShade,
    /// The stochastic method's denoiser over its history (`stochastic.denoise`; only with
    /// `--denoise N` > 0).
    StochasticDenoise,
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
    /// The frame of `features` around `method_steps`, the steps of its method's
    /// registration (`crate::registry::plan` passes them): the whole frame reads here.
    pub fn new(features: &Features, method_steps: &[Step]) -> Self {
        let mut steps = Vec::new();
        // Shadow maps first: every method's shading reads them.
        if features.shadows.is_some() {
            steps.push(Step::ShadowMaps);
        }
        // VPLs after the shadow faces whose views their RSM draws from.
        if features.vpl {
            steps.push(Step::Vpl);
        }
        // The method's steps: what writes depth, its culling, its shading.
        steps.extend_from_slice(method_steps);
        // Blended geometry, over the opaque image, both methods alike.
        // Frustum clusters already list every light a blended surface can see.
        if features.blended() {
            if !features.frustum_clusters {
                steps.push(Step::BlendedDepth);
                if features.method.tiled {
                    steps.push(Step::BlendedCull);
                }
            }
            steps.push(Step::BlendedShade);
        }
        // Tail.
        steps.push(Step::Tonemap);
        if features.method.tiled {
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
