//! The G-buffer pass: the scene drawn once into what the shared BRDF needs per pixel, with
//! reversed-Z depth. Layout (issue 31), each field's precision in `docs/ARCHITECTURE.md`:
//! - the surface: one `Rgba16Uint` target (8 B) packing the octahedral normal (2 x 14
//!   bits, at most 0.0151 degrees off), the sRGB base colour (8 bits a channel), roughness
//!   (8 bits) and metallic (4 bits), as [`tiledlight_cull::gbuffer`] (its CPU twin) lays
//!   out. One target, because on the H200 each colour target of this pass costs about as
//!   much as doubling one's bytes (`docs/PERFORMANCE.md`, the stress knob); integer, because
//!   the fields are bit-packed (`Rgba16Uint` multisamples; 32-bit-channel formats do not);
//! - depth: `Depth32Float` (4 B), world position rebuilt from it;
//! - the stress knob's extra targets: `Rgba8Unorm`, one texture each, written white;
//! - emission (+ occlusion): only in a scene with emissive or occlusion-mapped materials
//!   ([`MaterialFeatures::emission_target`]). Emitted radiance is HDR (emissive
//!   strength): `Rg11b10Ufloat` (4 B: 6-bit mantissas for red and green, 5 for blue, so
//!   within 1/128 and 1/64 of the value; 6.1e-5 to 65,024) where the device can render to
//!   it and nothing is occlusion-mapped; otherwise `Rgba16Float` (8 B), occlusion in alpha.
//!   The shading adds `ambient x albedo x occlusion + emission` from it. Only materials
//!   that emit or are occlusion-mapped write it ([`GBufferPass::record`] says how and why).
//!
//! 12 bytes a pixel with no extra target (25 MB at 1080p), plus 4 per extra target and 4
//! or 8 with the emission target, times the MSAA sample count: every target is
//! multisampled with MSAA. Pipelines exist per draw kind the scene has. Depends on
//! tiledlight-gpu and tiledlight-cull.

use tiledlight_cull::gbuffer::TEXEL_BYTES;
use tiledlight_gpu::bindings::PassBindings;
use tiledlight_gpu::depth_prepass::DEPTH_FORMAT;
use tiledlight_gpu::draw_order::DrawOrder;
use tiledlight_gpu::recording::Recording;
use tiledlight_gpu::scene_gpu::{MaterialFeatures, SceneGpu, SCENE_GROUPS};
use tiledlight_gpu::scene_raster::{begin_pass, cleared, DepthUse, RasterTargets, SceneRaster};
use tiledlight_gpu::targets::texture_2d_msaa;
use tiledlight_gpu::util::keyed_module;
use tiledlight_gpu::variants::{GBufferKey, MaterialKey};
use tiledlight_gpu::view::Views;
use tiledlight_gpu::GpuError;

/// Format of target 0, the packed surface ([`tiledlight_cull::gbuffer`]).
pub const SURFACE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Uint;
/// Format of the extra (stress) targets.
pub const EXTRA_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Format of the emission target when something is occlusion-mapped (occlusion in alpha)
/// or the device cannot render to [`EMISSION_FORMAT_SMALL`].
pub const EMISSION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Format of the emission target of a scene that emits and has no occlusion maps, on a
/// device with `RG11B10UFLOAT_RENDERABLE` (4 B instead of 8; reads back alpha 1, no
/// occlusion).
pub const EMISSION_FORMAT_SMALL: wgpu::TextureFormat = wgpu::TextureFormat::Rg11b10Ufloat;
/// The emission target's colour attachment (`@location` in `shaders/gbuffer.wgsl`): after
/// the most targets the stress knob makes, so its location does not depend on it.
pub const EMISSION_LOCATION: usize = 4;

/// The emission target's format for a scene with `materials`' features on `device`, or
/// none when nothing emits or is occlusion-mapped.
pub fn emission_format(device: &wgpu::Device, materials: &MaterialFeatures) -> Option<wgpu::TextureFormat> {
    if !materials.emission_target() {
        return None;
    }
    let small = !materials.occlusion && device.features().contains(wgpu::Features::RG11B10UFLOAT_RENDERABLE);
    Some(if small { EMISSION_FORMAT_SMALL } else { EMISSION_FORMAT })
}
/// Test-only values of the extra targets 0, 1, 2 (RGB, 8-bit unorm, so stored exactly),
/// written instead of white by the `EXTRA_TEST_VALUES` variant of `shaders/gbuffer.wgsl`
/// (keep the two in step). Different per target and per channel, so a target read twice,
/// one never read, or channels swapped all change the product.
pub const EXTRA_TEST_VALUES: [[u8; 3]; 3] = [[204, 153, 230], [179, 230, 128], [230, 204, 153]];

/// Fewest and most G-buffer render targets (the sample's slider).
pub const RT_RANGE: std::ops::RangeInclusive<u32> = 2..=5;

/// A 256 x 1 `Rgba8UnormSrgb` texture holding every 8-bit code (texel k is (k, k, k, 255)):
/// read with `textureLoad`, it gives the adapter's own sRGB decode of each code (the
/// G-buffer's base colour table, [`GBuffer::srgb_lut_view`]; tests measure the decode with it).
pub fn srgb_code_table(device: &wgpu::Device, queue: &wgpu::Queue, label: &str) -> wgpu::Texture {
    wgpu::util::DeviceExt::create_texture_with_data(
        device,
        queue,
        &wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width: 256, height: 1, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8UnormSrgb,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        &(0..=255u8).flat_map(|k| [k, k, k, 255]).collect::<Vec<u8>>(),
    )
}

/// The G-buffer textures of one screen size.
pub struct GBuffer {
    /// The packed surface (normal, base colour, roughness, metallic).
    pub surface: wgpu::Texture,
    /// Extra white targets, one texture each (multisampled textures cannot be array layers).
    pub extra: Vec<wgpu::Texture>,
    /// Emission (rgb) and occlusion (alpha), only for scenes that have either.
    pub emission: Option<wgpu::Texture>,
    surface_view: wgpu::TextureView,
    srgb_lut_view: wgpu::TextureView,
    extra_views: Vec<wgpu::TextureView>,
    emission_view: Option<wgpu::TextureView>,
    samples: u32,
}

impl GBuffer {
    /// Targets for `w` x `h` with the stress knob at `rts` (2..=5: `rts - 2` extra targets)
    /// of `samples` samples each, and the emission target in `emission`'s format if any
    /// ([`emission_format`]).
    pub fn new(
        (device, queue): (&wgpu::Device, &wgpu::Queue),
        (w, h): (u32, u32),
        rts: u32,
        samples: u32,
        emission: Option<wgpu::TextureFormat>,
    ) -> Result<Self, GpuError> {
        if !RT_RANGE.contains(&rts) {
            return Err(GpuError::Config(format!("G-buffer render targets {rts} must be in 2..=5")));
        }
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let target = |label: &str, format| texture_2d_msaa(device, label, (w, h), format, samples, usage);
        let view = |t: &wgpu::Texture, label: &str| {
            t.create_view(&wgpu::TextureViewDescriptor { label: Some(label), ..Default::default() })
        };
        let surface = target("deferred.gbuffer.surface", SURFACE_FORMAT);
        let extra: Vec<wgpu::Texture> =
            (2..rts).map(|k| target(&format!("deferred.gbuffer.extra{}", k - 2), EXTRA_FORMAT)).collect();
        let extra_views = extra.iter().map(|t| view(t, "deferred.gbuffer.extra.view")).collect();
        let emission = emission.map(|format| target("deferred.gbuffer.emission", format));
        let srgb_lut = srgb_code_table(device, queue, "deferred.gbuffer.srgb_lut");
        Ok(Self {
            srgb_lut_view: view(&srgb_lut, "deferred.gbuffer.srgb_lut.view"),
            surface_view: view(&surface, "deferred.gbuffer.surface.view"),
            emission_view: emission.as_ref().map(|t| view(t, "deferred.gbuffer.emission.view")),
            surface,
            extra,
            extra_views,
            emission,
            samples,
        })
    }

    /// The stress knob's setting (`2 +` the extra targets), as the sample counts it.
    pub fn rts(&self) -> u32 {
        2 + self.extra.len() as u32
    }

    /// Samples per pixel.
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// Bytes of one sample of the colour targets (depth not included).
    pub fn bytes_per_sample(&self) -> u64 {
        let emission = self.emission.as_ref().map_or(0, |t| t.format().block_copy_size(None).unwrap_or(0));
        TEXEL_BYTES + 4 * self.extra.len() as u64 + u64::from(emission)
    }

    /// What a sample holds, for the memory report: e.g. "8 B a sample: surface 8" or
    /// "16 B a sample: surface 8 + 2 extra x 4 + emission Rg11b10Ufloat 4", times the
    /// samples (depth besides).
    pub fn describe(&self) -> String {
        let mut parts = vec![format!("surface {TEXEL_BYTES}")];
        if !self.extra.is_empty() {
            parts.push(format!("{} extra x 4", self.extra.len()));
        }
        if let Some(t) = &self.emission {
            parts.push(format!("emission {:?} {}", t.format(), t.format().block_copy_size(None).unwrap_or(0)));
        }
        let samples = if self.samples > 1 { format!(", {} samples", self.samples) } else { String::new() };
        format!("{} B a sample: {}{samples}", self.bytes_per_sample(), parts.join(" + "))
    }

    /// Bytes of the colour targets (depth not included), every sample counted.
    pub fn bytes(&self) -> u64 {
        let px = self.surface.width() as u64 * self.surface.height() as u64 * self.samples as u64;
        px * self.bytes_per_sample()
    }

    /// The base colour's decoding table: a 256 x 1 `Rgba8UnormSrgb` texture holding every
    /// code, so the shading decodes a texel's 8-bit sRGB base colour through the texture
    /// unit, exactly as the material textures it came from were decoded (an adapter's sRGB
    /// decode may stray from the formula: lavapipe's by 2.5% at code 5), and the packed
    /// G-buffer round-trips a texture's colour exactly, as an `Rgba8UnormSrgb` target did.
    pub fn srgb_lut_view(&self) -> &wgpu::TextureView {
        &self.srgb_lut_view
    }

    /// View of the packed surface target.
    pub fn surface_view(&self) -> &wgpu::TextureView {
        &self.surface_view
    }
    /// Views of the extra targets, in order.
    pub fn extra_views(&self) -> &[wgpu::TextureView] {
        &self.extra_views
    }
    /// The emission target's format, when the scene has one.
    pub fn emission_format(&self) -> Option<wgpu::TextureFormat> {
        self.emission.as_ref().map(|t| t.format())
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
    /// With an emission target and materials that neither emit nor are occlusion-mapped:
    /// their pipelines (the emission target's write mask empty) and the instance slots
    /// they draw, then the slots the full pipelines draw (see [`GBufferPass::record`]).
    quiet: Option<QuietDraws>,
}

/// The draws that leave the emission target alone.
struct QuietDraws {
    raster: SceneRaster,
    quiet_slots: Vec<bool>,
    loud_slots: Vec<bool>,
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
        let mut targets = vec![Some(wgpu::ColorTargetState {
            format: SURFACE_FORMAT,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        })];
        for _ in 2..rts {
            targets.push(Some(wgpu::ColorTargetState {
                format: EXTRA_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            }));
        }
        let emission_format = emission_format(device, &scene.material_features);
        if let Some(format) = emission_format {
            targets.resize(EMISSION_LOCATION, None);
            targets.push(Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL }));
        }
        let emission = emission_format.is_some();
        let fs = format!("fs_gbuffer{rts}");
        let materials = MaterialKey::of(&scene.material_features);
        let build = |label: &str, targets: &[Option<wgpu::ColorTargetState>]| {
            SceneRaster::materials(
                device,
                label,
                (views, scene),
                &[],
                &scene.opaque_kinds(),
                |kind| {
                    let key =
                        GBufferKey { alpha_mask: kind.masked, materials, emission, extra_test_values: test_values };
                    keyed_module(device, &key)
                },
                &RasterTargets {
                    depth: DepthUse::Write,
                    depth_format: DEPTH_FORMAT,
                    samples,
                    fragment: (&fs, targets),
                    constants: &[],
                },
            )
        };
        let raster = build("deferred.gbuffer", &targets)?;
        // Slots of instances whose material writes the emission target, and of the others.
        let slots = scene.draws.iter().map(|d| d.instances.end).max().unwrap_or(0) as usize;
        let mut loud_slots = vec![false; slots];
        for d in &scene.draws {
            for slot in d.instances.clone() {
                loud_slots[slot as usize] = scene.material_unlit.get(d.material).copied().unwrap_or(true);
            }
        }
        let quiet = if emission && loud_slots.iter().any(|&l| !l) {
            let mut masked = targets.clone();
            if let Some(Some(t)) = masked.get_mut(EMISSION_LOCATION) {
                t.write_mask = wgpu::ColorWrites::empty();
            }
            Some(QuietDraws {
                raster: build("deferred.gbuffer.quiet", &masked)?,
                quiet_slots: loud_slots.iter().map(|&l| !l).collect(),
                loud_slots,
            })
        } else {
            None
        };
        Ok(Self { raster, quiet })
    }

    /// Clears and fills the G-buffer and `depth` with the scene seen from view slot `view`,
    /// drawn in `order` (the instance buffer's when None; nearest first exports fewer hidden
    /// fragments, [`tiledlight_gpu::draw_order`]).
    pub fn record(
        &self,
        r: &mut Recording<'_>,
        order: Option<&DrawOrder>,
        gbuffer: &GBuffer,
        depth: &wgpu::TextureView,
    ) {
        let (encoder, timer, (views, view), scene) = (&mut *r.encoder, r.timer, r.view, r.scene);
        let clear = |view| cleared(view, None, wgpu::Color::BLACK);
        let mut attachments = vec![clear(&gbuffer.surface_view)];
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
            match &self.quiet {
                // The materials that leave the emission target at its clear value (no
                // emission, occlusion 1) draw first, with its writes masked: a fragment that
                // exports nothing to a target may cost less. Then the rest, depth-tested
                // against the quiet ones: an emitting surface behind a quiet one fails the
                // test, so no hidden surface's emission is left under a nearer quiet one
                // (drawn the other way round it would be: tests/tests/deferred.rs
                // emission_of_a_hidden_surface_never_shows_through catches that).
                Some(q) => {
                    q.raster.bind(&mut pass, Some((views, view)), scene);
                    q.raster.draw(&mut pass, scene, Some(&q.quiet_slots), order);
                    self.raster.bind(&mut pass, Some((views, view)), scene);
                    self.raster.draw(&mut pass, scene, Some(&q.loud_slots), order);
                }
                None => {
                    self.raster.bind(&mut pass, Some((views, view)), scene);
                    self.raster.draw(&mut pass, scene, None, order);
                }
            }
        }
        timer.end(encoder, t);
    }
}
