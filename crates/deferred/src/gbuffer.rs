//! The G-buffer pass: the scene drawn once into what the shared BRDF needs per pixel, with
//! reversed-Z depth. Formats, chosen for the comparison with Forward+ to hold:
//! - albedo + metallic: `Rgba8UnormSrgb` (4 B): base colours come from 8-bit sRGB textures
//!   and factors, so 8-bit sRGB loses little;
//! - normal + roughness: `Rgba16Float` (8 B): an 8-bit or 10-bit normal moves GGX highlights
//!   visibly at low roughness (d ln D / d theta peaks near 2 / alpha, alpha = roughness^2:
//!   50 per radian at roughness 0.2), which would break the comparison with Forward+;
//! - depth: `Depth32Float` (4 B), world position rebuilt from it;
//! - the stress knob's extra targets: `Rgba8Unorm`, one texture each, written white;
//! - emission + occlusion: `Rgba16Float` (8 B), only in a scene with emissive or
//!   occlusion-mapped materials ([`MaterialFeatures::emission_target`]): emitted radiance
//!   is HDR (emissive strength), and the shading adds `ambient x albedo x occlusion +
//!   emission` from it. Normal maps and metallic-roughness textures add nothing: targets 0
//!   and 1 hold their result.
//!
//! 16 bytes a pixel with 2 targets (33 MB at 1080p), plus 4 per extra target and 8 with the
//! emission target (24 B a pixel, 50 MB at 1080p), times the MSAA sample count: every target
//! is multisampled with MSAA. Pipelines exist per draw kind the scene has. Depends on
//! tiledlight-gpu.

use tiledlight_gpu::bindings::PassBindings;
use tiledlight_gpu::depth_prepass::DEPTH_FORMAT;
#[cfg(doc)]
use tiledlight_gpu::scene_gpu::MaterialFeatures;
use tiledlight_gpu::scene_gpu::{SceneGpu, SCENE_GROUPS};
use tiledlight_gpu::scene_raster::{begin_pass, cleared, DepthUse, RasterTargets, SceneRaster};
use tiledlight_gpu::targets::texture_2d_msaa;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::util::keyed_module;
use tiledlight_gpu::variants::{GBufferKey, MaterialKey};
use tiledlight_gpu::view::Views;
use tiledlight_gpu::GpuError;

/// Format of target 0 (albedo, metallic).
pub const ALBEDO_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// Format of target 1 (normal, roughness).
pub const NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Format of the extra (stress) targets.
pub const EXTRA_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Format of the emission + occlusion target (scenes with emission or occlusion maps).
pub const EMISSION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// The emission target's colour attachment (`@location` in `shaders/gbuffer.wgsl`): after
/// the most targets the stress knob makes, so its location does not depend on it.
pub const EMISSION_LOCATION: usize = 5;
/// Test-only values of the extra targets 0, 1, 2 (RGB, 8-bit unorm, so stored exactly),
/// written instead of white by the `EXTRA_TEST_VALUES` variant of `shaders/gbuffer.wgsl`
/// (keep the two in step). Different per target and per channel, so a target read twice,
/// one never read, or channels swapped all change the product.
pub const EXTRA_TEST_VALUES: [[u8; 3]; 3] = [[204, 153, 230], [179, 230, 128], [230, 204, 153]];

/// Fewest and most G-buffer render targets (the sample's slider).
pub const RT_RANGE: std::ops::RangeInclusive<u32> = 2..=5;

/// The G-buffer textures of one screen size.
pub struct GBuffer {
    /// Albedo and metallic.
    pub albedo: wgpu::Texture,
    /// Normal and roughness.
    pub normal: wgpu::Texture,
    /// Extra white targets, one texture each (multisampled textures cannot be array layers).
    pub extra: Vec<wgpu::Texture>,
    /// Emission (rgb) and occlusion (alpha), only for scenes that have either.
    pub emission: Option<wgpu::Texture>,
    albedo_view: wgpu::TextureView,
    normal_view: wgpu::TextureView,
    extra_views: Vec<wgpu::TextureView>,
    emission_view: Option<wgpu::TextureView>,
    samples: u32,
}

impl GBuffer {
    /// Targets for `w` x `h` with `rts` render targets (2..=5) of `samples` samples each,
    /// and the emission target when `emission`.
    pub fn new(
        device: &wgpu::Device,
        (w, h): (u32, u32),
        rts: u32,
        samples: u32,
        emission: bool,
    ) -> Result<Self, GpuError> {
        if !RT_RANGE.contains(&rts) {
            return Err(GpuError::Config(format!("G-buffer render targets {rts} must be in 2..=5")));
        }
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let target = |label: &str, format| texture_2d_msaa(device, label, (w, h), format, samples, usage);
        let view = |t: &wgpu::Texture, label: &str| {
            t.create_view(&wgpu::TextureViewDescriptor { label: Some(label), ..Default::default() })
        };
        let albedo = target("deferred.gbuffer.albedo", ALBEDO_FORMAT);
        let normal = target("deferred.gbuffer.normal", NORMAL_FORMAT);
        let extra: Vec<wgpu::Texture> =
            (2..rts).map(|k| target(&format!("deferred.gbuffer.extra{}", k - 2), EXTRA_FORMAT)).collect();
        let extra_views = extra.iter().map(|t| view(t, "deferred.gbuffer.extra.view")).collect();
        let emission = emission.then(|| target("deferred.gbuffer.emission", EMISSION_FORMAT));
        Ok(Self {
            albedo_view: view(&albedo, "deferred.gbuffer.albedo.view"),
            normal_view: view(&normal, "deferred.gbuffer.normal.view"),
            emission_view: emission.as_ref().map(|t| view(t, "deferred.gbuffer.emission.view")),
            albedo,
            normal,
            extra,
            extra_views,
            emission,
            samples,
        })
    }

    /// Number of render targets.
    pub fn rts(&self) -> u32 {
        2 + self.extra.len() as u32
    }

    /// Samples per pixel.
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// Bytes of the colour targets (depth not included), every sample counted.
    pub fn bytes(&self) -> u64 {
        let px = self.albedo.width() as u64 * self.albedo.height() as u64 * self.samples as u64;
        px * (4 + 8 + 4 * self.extra.len() as u64 + if self.emission.is_some() { 8 } else { 0 })
    }

    /// View of the albedo target.
    pub fn albedo_view(&self) -> &wgpu::TextureView {
        &self.albedo_view
    }
    /// View of the normal target.
    pub fn normal_view(&self) -> &wgpu::TextureView {
        &self.normal_view
    }
    /// Views of the extra targets, in order.
    pub fn extra_views(&self) -> &[wgpu::TextureView] {
        &self.extra_views
    }
    /// View of the emission target, when the scene has one.
    pub fn emission_view(&self) -> Option<&wgpu::TextureView> {
        self.emission_view.as_ref()
    }
}

/// The bindings of the G-buffer pass (`shaders/gbuffer.wgsl`): the scene's groups, the
/// material textures with `TEXTURES` (and the slots of the other material defines). Its layouts are the views' and the scene's own.
pub const GBUFFER_BINDINGS: PassBindings =
    PassBindings { entry: "gbuffer.wgsl", source: file!(), groups: &SCENE_GROUPS };

/// The G-buffer pass's pipelines.
pub struct GBufferPass {
    /// Pipelines per draw kind and the scene's groups.
    raster: SceneRaster,
}

impl GBufferPass {
    /// One pipeline per draw kind of `scene`, writing `rts` targets of `samples` samples.
    /// `test_values` (tests only) writes [`EXTRA_TEST_VALUES`] into the extra targets
    /// instead of white.
    pub fn new(
        device: &wgpu::Device,
        views: &Views,
        scene: &SceneGpu,
        rts: u32,
        samples: u32,
        test_values: bool,
    ) -> Result<Self, GpuError> {
        let mut targets = vec![
            Some(wgpu::ColorTargetState { format: ALBEDO_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL }),
            Some(wgpu::ColorTargetState { format: NORMAL_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL }),
        ];
        for _ in 2..rts {
            targets.push(Some(wgpu::ColorTargetState {
                format: EXTRA_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            }));
        }
        let emission = scene.material_features.emission_target();
        if emission {
            targets.resize(EMISSION_LOCATION, None);
            targets.push(Some(wgpu::ColorTargetState {
                format: EMISSION_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            }));
        }
        let fs = format!("fs_gbuffer{rts}");
        let materials = MaterialKey::of(&scene.material_features);
        let raster = SceneRaster::materials(
            device,
            "deferred.gbuffer",
            (views, scene),
            &[],
            &scene.opaque_kinds(),
            |kind| {
                let key = GBufferKey { alpha_mask: kind.masked, materials, emission, extra_test_values: test_values };
                keyed_module(device, &key)
            },
            &RasterTargets {
                depth: DepthUse::Write,
                depth_format: DEPTH_FORMAT,
                samples,
                fragment: (&fs, &targets),
                constants: &[],
            },
        )?;
        Ok(Self { raster })
    }

    /// Clears and fills the G-buffer and `depth` with the scene seen from view slot `view`.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: &GpuTimer,
        (views, view): (&Views, u32),
        scene: &SceneGpu,
        gbuffer: &GBuffer,
        depth: &wgpu::TextureView,
    ) {
        let clear = |view| cleared(view, None, wgpu::Color::BLACK);
        let mut attachments = vec![clear(&gbuffer.albedo_view), clear(&gbuffer.normal_view)];
        attachments.extend(gbuffer.extra_views.iter().map(clear));
        if let Some(e) = &gbuffer.emission_view {
            attachments.resize(EMISSION_LOCATION, None);
            attachments.push(clear(e));
        }
        let t = timer.begin("deferred.gbuffer", encoder);
        {
            let mut pass = begin_pass(
                encoder,
                "deferred.gbuffer",
                &attachments,
                (depth, wgpu::LoadOp::Clear(0.0)),
                t.render_writes(),
            );
            self.raster.bind(&mut pass, Some((views, view)), scene);
            self.raster.draw(&mut pass, scene, None);
        }
        timer.end(encoder, t);
    }
}
