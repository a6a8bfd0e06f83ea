//! What every renderer draws into: the depth / HDR / display targets of one screen size
//! ([`DisplayTargets`]) and the check of an MSAA sample count against the adapter. Depends
//! on wgpu and the rest of this crate.

use crate::context::GpuContext;
use crate::depth_prepass::DEPTH_FORMAT;
use crate::error::GpuError;
use crate::handles::{Depth, Hdr, Ldr};
use crate::tonemap::HDR_FORMAT;

pub use crate::util::{texture_2d, texture_2d_msaa};

/// Fails with a message naming the format and the adapter's sample counts when `samples`
/// is not 1, 2, 4 or 8 or when the adapter cannot multisample `formats` that many times
/// (WebGPU guarantees only 1 and 4; 2 and 8 need adapter-specific format features).
pub fn check_msaa(ctx: &GpuContext, samples: u32, formats: &[wgpu::TextureFormat]) -> Result<(), GpuError> {
    if !matches!(samples, 1 | 2 | 4 | 8) {
        return Err(GpuError::Config(format!("MSAA {samples}x: the sample count must be 1, 2, 4 or 8")));
    }
    if samples == 1 {
        return Ok(());
    }
    let specific = ctx.device.features().contains(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES);
    for &format in formats {
        let ok = if specific {
            ctx.adapter.get_texture_format_features(format).flags.sample_count_supported(samples)
        } else {
            samples == 4
        };
        if !ok {
            let counts: Vec<String> = [2, 4, 8]
                .into_iter()
                .filter(|&n| {
                    if specific {
                        ctx.adapter.get_texture_format_features(format).flags.sample_count_supported(n)
                    } else {
                        n == 4
                    }
                })
                .map(|n| format!("{n}x"))
                .collect();
            return Err(GpuError::Config(format!(
                "MSAA {samples}x is not supported by {} for {format:?} render targets (it supports: 1x{}{})",
                ctx.info.name,
                if counts.is_empty() { "" } else { ", " },
                counts.join(", ")
            )));
        }
    }
    Ok(())
}

/// Depth, linear HDR and tonemapped display targets of one screen.
pub struct DisplayTargets {
    /// Reversed-Z depth, with `samples` samples per pixel.
    pub depth: wgpu::Texture,
    /// Linear HDR lighting.
    pub hdr: wgpu::Texture,
    /// Tonemapped sRGB image (`Rgba8Unorm` holding sRGB-encoded bytes).
    pub ldr: wgpu::Texture,
    /// View of `depth`.
    pub depth_view: wgpu::TextureView,
    /// View of `hdr`.
    pub hdr_view: wgpu::TextureView,
    /// The `Rgba8UnormSrgb` view of `ldr` (render passes: the heat map's blending).
    pub ldr_view: wgpu::TextureView,
    /// The plain `Rgba8Unorm` view of `ldr` the compute tonemap writes.
    pub ldr_storage_view: wgpu::TextureView,
    /// MSAA samples per pixel of `depth` (the HDR and display images are resolved).
    pub samples: u32,
}

impl DisplayTargets {
    /// Targets for `w` x `h` with a `samples`-sample depth buffer; `hdr_usage` adds how the
    /// method writes the HDR image (render attachment for Forward+, storage for Tiled
    /// Deferred's compute shading).
    pub fn new(
        device: &wgpu::Device,
        prefix: &str,
        (w, h): (u32, u32),
        samples: u32,
        hdr_usage: wgpu::TextureUsages,
    ) -> Self {
        Self::with_depth(device, prefix, (w, h), samples, hdr_usage, None)
    }

    /// [`Self::new`] with another depth target: `depth` gives its format and usage (the
    /// visibility buffer's compute raster writes an `R32Float` depth from compute), or None
    /// for the `Depth32Float` render attachment.
    pub fn with_depth(
        device: &wgpu::Device,
        prefix: &str,
        (w, h): (u32, u32),
        samples: u32,
        hdr_usage: wgpu::TextureUsages,
        depth: Option<(wgpu::TextureFormat, wgpu::TextureUsages)>,
    ) -> Self {
        use wgpu::TextureUsages as U;
        // A multisampled texture cannot be copied: read_depth uses a kernel for it.
        let copy = if samples == 1 { U::COPY_SRC } else { U::empty() };
        let (depth_format, depth_usage) = depth.unwrap_or((DEPTH_FORMAT, U::RENDER_ATTACHMENT));
        let depth = texture_2d_msaa(
            device,
            &format!("{prefix}.depth"),
            (w, h),
            depth_format,
            samples,
            depth_usage | U::TEXTURE_BINDING | copy,
        );
        let hdr = texture_2d(
            device,
            &format!("{prefix}.hdr"),
            (w, h),
            HDR_FORMAT,
            hdr_usage | U::TEXTURE_BINDING | U::COPY_SRC,
        );
        // Written by the compute tonemap (storage, raw sRGB bytes), blended onto by the heat
        // map and read back: the render passes use its sRGB view.
        let ldr = crate::tonemap::ldr_texture(
            device,
            &format!("{prefix}.ldr"),
            (w, h),
            U::STORAGE_BINDING | U::RENDER_ATTACHMENT | U::COPY_SRC,
        );
        Self {
            depth_view: depth.create_view(&wgpu::TextureViewDescriptor {
                label: Some(&format!("{prefix}.depth.view")),
                ..Default::default()
            }),
            hdr_view: hdr.create_view(&wgpu::TextureViewDescriptor {
                label: Some(&format!("{prefix}.hdr.view")),
                ..Default::default()
            }),
            ldr_view: crate::tonemap::ldr_srgb_view(&ldr, &format!("{prefix}.ldr.view")),
            ldr_storage_view: ldr.create_view(&wgpu::TextureViewDescriptor {
                label: Some(&format!("{prefix}.ldr.storage_view")),
                ..Default::default()
            }),
            depth,
            hdr,
            ldr,
            samples,
        }
    }

    /// Bytes of the three targets (the depth buffer has `samples` values a pixel).
    pub fn bytes(&self) -> u64 {
        let px = self.depth.width() as u64 * self.depth.height() as u64;
        px * (4 * self.samples as u64 + 8 + 4)
    }
}

/// The handles of a frame's display targets.
pub fn target_handles(t: &DisplayTargets) -> (Depth<'_>, Hdr<'_>, Ldr<'_>) {
    (
        Depth { view: &t.depth_view, samples: t.samples },
        Hdr { view: &t.hdr_view },
        Ldr { view: &t.ldr_view, storage: &t.ldr_storage_view },
    )
}
