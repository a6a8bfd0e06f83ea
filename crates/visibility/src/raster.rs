//! The visibility buffer's raster pass: the scene's opaque and masked draws into the
//! frame's depth and an `R32Uint` ID target of the same samples, through the depth
//! pre-pass's pipelines with a fragment stage writing `(instance << triangle_bits) |
//! triangle` (`shaders/visibility_raster.wgsl`). The split is
//! [`tiledlight_cull::visibility::IdLayout`], chosen from the scene's instance count and its
//! largest mesh; a scene past 32 bits is refused with the bits it needs. Depends on
//! tiledlight-gpu.

use tiledlight_cull::visibility::IdLayout;
use tiledlight_gpu::depth_prepass::{DepthPrepass, ID_FORMAT};
use tiledlight_gpu::features::Features;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::targets::texture_2d_msaa;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::view::Views;
use tiledlight_gpu::GpuError;

/// The raster pass and its ID target.
pub struct VisibilityRaster {
    pass: DepthPrepass,
    _ids: wgpu::Texture,
    /// The ID target (multisampled with MSAA), read by [`crate::shading`].
    pub ids_view: wgpu::TextureView,
    /// How IDs split into instance and triangle.
    pub layout: IdLayout,
}

impl VisibilityRaster {
    /// The pass for `scene` on a `size` screen with the features' samples.
    pub fn new(
        device: &wgpu::Device,
        views: &Views,
        scene: &SceneGpu,
        features: &Features,
        size: (u32, u32),
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
        let instances = scene.instance_bounds.len() as u32;
        let layout = IdLayout::for_scene(instances.max(1), scene.max_triangles.max(1))?;
        let pass = DepthPrepass::with_ids(device, views, scene, features, layout.triangle_bits)?;
        let ids = texture_2d_msaa(
            device,
            "visibility.ids",
            size,
            ID_FORMAT,
            features.msaa,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        memory.add("visibility.ids", size.0 as u64 * size.1 as u64 * features.msaa as u64 * 4);
        let ids_view = ids.create_view(&wgpu::TextureViewDescriptor {
            label: Some("visibility.ids.view"),
            ..Default::default()
        });
        Ok(Self { pass, _ids: ids, ids_view, layout })
    }

    /// Clears and draws depth and IDs.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: &GpuTimer,
        view: (&Views, u32),
        scene: &SceneGpu,
        depth: &wgpu::TextureView,
    ) {
        self.pass.record_with_ids(encoder, timer, view, scene, (depth, &self.ids_view));
    }
}
