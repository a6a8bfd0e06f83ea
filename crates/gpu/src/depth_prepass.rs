//! The depth pre-pass: reversed-Z `Depth32Float` of the scene's geometry, depth-only for
//! opaque materials and with an alpha-test fragment stage for masked ones. Both methods
//! (and the brute-force reference) start with it. Pipelines exist only for the draw kinds
//! the scene has. Depends on wgpu, [`crate::scene_gpu`], [`crate::scene_raster`] and [`crate::view`].

use crate::bindings::{Binding, Cond, PassBindings, PassGroup};
use crate::define::Define;
use crate::error::GpuError;
use crate::features::Features;
use crate::recording::Recording;
use crate::scene_gpu::{DrawCount, DrawKind, SceneGpu, POSITION_LAYOUT, SCENE_GROUPS, TEXTURE_BINDINGS};
use crate::scene_raster::{begin_pass, cleared, scene_pipeline, DepthUse, SceneDraw, SceneInputs, SceneRaster};
use crate::util::{keyed_module, pipeline_layout};
use crate::variants::{AtomicIdsKey, DepthPrepassKey, VisibilityRasterKey};
use tiledlight_cull::draw_order::DrawOrder;

/// Format of the visibility buffer's IDs.
pub const ID_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;

use crate::view::Views;

/// Depth format of every depth buffer (reversed-Z: clear 0, compare GreaterEqual when writing, Equal when shading after the pre-pass).
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The bindings of the depth pre-pass (`shaders/depth_prepass.wgsl`): the scene's groups,
/// the material textures only in the masked pipelines of textured scenes, and of those only
/// the base colour slot (the alpha test reads nothing else). Its layouts are the views' and
/// the scene's own: the material bind groups it sets hold the scene's other slots too,
/// which a pipeline layout may have unread.
pub const DEPTH_PREPASS_BINDINGS: PassBindings = PassBindings {
    entry: "depth_prepass.wgsl",
    source: file!(),
    groups: &[
        SCENE_GROUPS[0],
        SCENE_GROUPS[1],
        PassGroup::new(2, TEXTURE_BINDINGS).when(Cond::Defined(Define::Textures)),
        PassGroup::new(2, ATOMIC_TEXELS)
            .when(Cond::All(&[Cond::Defined(Define::Atomic), Cond::NotDefined(Define::Textures)])),
        PassGroup::new(3, ATOMIC_TEXELS)
            .when(Cond::All(&[Cond::Defined(Define::Atomic), Cond::Defined(Define::Textures)])),
    ],
};

/// With `ATOMIC`: the compute raster's 64-bit texels, written by the fragment stage.
pub const ATOMIC_TEXELS: &[Binding] = &[Binding::storage_rw(0, wgpu::ShaderStages::FRAGMENT)];

/// The depth pre-pass pipelines.
pub struct DepthPrepass {
    raster: SceneRaster,
    label: &'static str,
    /// What the last [`Self::record`] drew ([`Self::drawn_last`]).
    drawn: std::sync::Mutex<DrawCount>,
}

/// What a depth-only drawing of the scene writes: the pre-pass's depth buffer or a shadow
/// atlas (same shaders, views and scene bind groups; another format and label).
#[derive(Clone, Copy, Debug)]
pub struct DepthTarget {
    /// Label of the pipelines, the pass and its timer.
    pub label: &'static str,
    /// Depth format.
    pub format: wgpu::TextureFormat,
    /// Samples per pixel.
    pub samples: u32,
}

impl DepthPrepass {
    /// Builds a pipeline per draw kind the features list (`draw_kinds`), drawing
    /// `features.msaa` depth samples a pixel; masked kinds of a textured scene (`textures`)
    /// sample `scene`'s material textures.
    pub fn new(device: &wgpu::Device, views: &Views, scene: &SceneGpu, features: &Features) -> Result<Self, GpuError> {
        let target = DepthTarget { label: "depth_prepass", format: DEPTH_FORMAT, samples: features.msaa };
        Self::for_target(device, views, scene, features, target)
    }

    /// The pipelines drawing the scene's opaque and masked depth into `target`.
    pub fn for_target(
        device: &wgpu::Device,
        views: &Views,
        scene: &SceneGpu,
        features: &Features,
        target: DepthTarget,
    ) -> Result<Self, GpuError> {
        Self::for_kinds(device, views, scene, (features, &features.draw_kinds), target)
    }

    /// The pipelines drawing the depth of the draws of `kinds` (the blended path's own
    /// depth) into `target`.
    pub fn for_kinds(
        device: &wgpu::Device,
        views: &Views,
        scene: &SceneGpu,
        (features, kinds): (&Features, &[DrawKind]),
        target: DepthTarget,
    ) -> Result<Self, GpuError> {
        Self::build(device, views, scene, (features, kinds), target, None)
    }

    /// The visibility buffer's raster pass (`shaders/depth_prepass.wgsl` with `IDS`): the
    /// depth pre-pass's draws, each fragment also writing its `R32Uint` ID, `(instance <<
    /// triangle_bits) | triangle` ([`tiledlight_cull::visibility::IdLayout`]). Needs
    /// `wgpu::Features::PRIMITIVE_INDEX`.
    pub fn with_ids(
        device: &wgpu::Device,
        views: &Views,
        scene: &SceneGpu,
        features: &Features,
        triangle_bits: u32,
    ) -> Result<Self, GpuError> {
        if !device.features().contains(wgpu::Features::PRIMITIVE_INDEX) {
            return Err(GpuError::Config(
                "the visibility buffer's triangle IDs need wgpu's PRIMITIVE_INDEX feature (Vulkan: geometryShader), \
                 which this device was not created with"
                    .into(),
            ));
        }
        let target = DepthTarget { label: "visibility.raster", format: DEPTH_FORMAT, samples: features.msaa };
        Self::build(device, views, scene, (features, &features.draw_kinds), target, Some((triangle_bits, None)))
    }

    /// The alpha-masked draws of the visibility buffer's compute raster (`IDS ATOMIC`): no
    /// depth attachment; each fragment passing the alpha test resolves its (depth, ID)
    /// texel into the buffer bound with `texels` (at group 2, or 3 after the material
    /// textures) by `atomicMax`. The pass attaches the ID target with writes masked (a
    /// render pass needs an attachment). Opaque kinds are the compute pass's: none here.
    pub fn with_atomic_ids(
        device: &wgpu::Device,
        views: &Views,
        scene: &SceneGpu,
        features: &Features,
        (triangle_bits, texels): (u32, &wgpu::BindGroupLayout),
    ) -> Result<Self, GpuError> {
        let kinds: Vec<DrawKind> = features.draw_kinds.iter().copied().filter(|k| k.masked && !k.blended).collect();
        let target = DepthTarget { label: "visibility.raster.masked", format: DEPTH_FORMAT, samples: 1 };
        Self::build(device, views, scene, (features, &kinds), target, Some((triangle_bits, Some(texels))))
    }

    fn build(
        device: &wgpu::Device,
        views: &Views,
        scene: &SceneGpu,
        (features, kinds): (&Features, &[DrawKind]),
        target: DepthTarget,
        ids: Option<(u32, Option<&wgpu::BindGroupLayout>)>,
    ) -> Result<Self, GpuError> {
        let atomic = ids.and_then(|(_, t)| t);
        let write_mask = if atomic.is_some() { wgpu::ColorWrites::empty() } else { wgpu::ColorWrites::ALL };
        let id_target = [Some(wgpu::ColorTargetState { format: ID_FORMAT, blend: None, write_mask })];
        let constants = ids.map(|(bits, _)| [("TRIANGLE_BITS", bits as f64)]);
        let constants: &[(&str, f64)] = constants.as_ref().map_or(&[], |c| &c[..]);
        let mut pipelines = Vec::new();
        let samples = target.samples;
        let textures = scene.textures.as_ref().filter(|_| features.textures);
        let layouts = scene.vertex_layouts();
        for &kind in kinds {
            let (key, layout) = if kind.masked {
                match textures {
                    Some(t) => (
                        // The alpha test reads the base colour slot only: its texture
                        // coordinate set may be set 1.
                        DepthPrepassKey::MaskedTextured { uv1: features.materials.uv1 },
                        pipeline_layout(
                            device,
                            "depth_prepass.masked.layout",
                            &[&[&views.layout, &scene.layout, &t.layout][..], atomic.as_slice()].concat(),
                        ),
                    ),
                    None => (
                        DepthPrepassKey::Masked,
                        pipeline_layout(
                            device,
                            "depth_prepass.masked.layout",
                            &[&[&views.layout, &scene.layout][..], atomic.as_slice()].concat(),
                        ),
                    ),
                }
            } else {
                (
                    DepthPrepassKey::Opaque,
                    pipeline_layout(device, "depth_prepass.layout", &[&views.layout, &scene.layout]),
                )
            };
            let module = match ids {
                None => keyed_module(device, &key)?,
                Some((_, None)) => keyed_module(device, &VisibilityRasterKey(key))?,
                Some((_, Some(_))) => keyed_module(device, &AtomicIdsKey(key))?,
            };
            let (vs, buffers): (&str, &[Option<wgpu::VertexBufferLayout<'_>>]) =
                if kind.masked { ("vs_masked", &layouts) } else { ("vs_main", &POSITION_LAYOUT) };
            let label = format!(
                "{}{}{}{}",
                target.label,
                if kind.masked { ".masked" } else { "" },
                if kind.blended { ".blended" } else { "" },
                if kind.double_sided { ".double_sided" } else { "" }
            );
            let pipeline = scene_pipeline(
                device,
                kind,
                &SceneDraw {
                    label: &label,
                    layout: &layout,
                    module: &module,
                    vertex: (vs, buffers),
                    depth: if atomic.is_some() { DepthUse::None } else { DepthUse::Write },
                    samples,
                    fragment: match ids {
                        Some(_) => Some((if kind.masked { "fs_masked" } else { "fs_main" }, &id_target[..])),
                        None => kind.masked.then_some(("fs_masked", &[][..])),
                    },
                    depth_format: target.format,
                    constants,
                },
            );
            pipelines.push((kind, pipeline));
        }
        Ok(Self {
            raster: SceneRaster::from_pipelines(pipelines, SceneInputs::DepthOnly),
            label: target.label,
            drawn: std::sync::Mutex::new(DrawCount::default()),
        })
    }

    /// Draws the scene seen from view slot `view` into the pass's depth attachment: the
    /// instances set in `visible` (by instance slot), or all, in `order` (the instance
    /// buffer's when None).
    pub fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        (views, view): (&Views, u32),
        scene: &SceneGpu,
        visible: Option<&[bool]>,
        order: Option<&DrawOrder>,
    ) -> DrawCount {
        self.raster.bind(pass, Some((views, view)), scene);
        self.raster.draw(pass, scene, visible, order)
    }

    /// Clears `depth` to 0 and `ids` to [`tiledlight_cull::visibility::NO_TRIANGLE`] and
    /// draws the scene's depth and IDs (a pass built by [`Self::with_ids`]).
    pub fn record_with_ids(&self, r: &mut Recording<'_>, (depth, ids): (&wgpu::TextureView, &wgpu::TextureView)) {
        let (encoder, timer, (views, view), scene) = (&mut *r.encoder, r.timer, r.view, r.scene);
        let t = timer.begin(self.label, encoder);
        {
            let no_triangle = f64::from(tiledlight_cull::visibility::NO_TRIANGLE);
            let clear = wgpu::Color { r: no_triangle, g: 0.0, b: 0.0, a: 0.0 };
            let colors = [cleared(ids, None, clear)];
            let mut pass =
                begin_pass(encoder, self.label, &colors, (depth, wgpu::LoadOp::Clear(0.0)), t.render_writes());
            // The instance buffer's order: where two surfaces tie in depth the later
            // draw keeps the pixel, and the compute raster's rule (the larger ID) matches
            // that order only (`crate::draw_order`).
            self.draw(&mut pass, (views, view), scene, None, None);
        }
        timer.end(encoder, t);
    }

    /// Clears `depth` to 0 (far, reversed-Z) and draws the scene seen from view slot `view`
    /// into it, in `order` (the instance buffer's when None).
    pub fn record(&self, r: &mut Recording<'_>, order: Option<&DrawOrder>, depth: &wgpu::TextureView) {
        let (encoder, timer, (views, view), scene) = (&mut *r.encoder, r.timer, r.view, r.scene);
        let t = timer.begin(self.label, encoder);
        {
            let mut pass = begin_pass(encoder, self.label, &[], (depth, wgpu::LoadOp::Clear(0.0)), t.render_writes());
            let drawn = self.draw(&mut pass, (views, view), scene, None, order);
            *self.drawn.lock().expect("pre-pass draw count") = drawn;
        }
        timer.end(encoder, t);
    }

    /// The draw calls and instances the last [`Self::record`] recorded. A sorted order
    /// breaks a draw's instances into more runs (one call each) than the instance buffer's
    /// order, so tests see from it that the pass drew in the order it was given (the
    /// image cannot show it: `--draw-order` changes no pixel).
    pub fn drawn_last(&self) -> DrawCount {
        *self.drawn.lock().expect("pre-pass draw count")
    }
}
