//! The visibility buffer's raster pass: the scene's opaque and masked draws into the
//! frame's depth and an `R32Uint` ID target of the same samples, through the depth
//! pre-pass's pipelines with a fragment stage writing `(instance << triangle_bits) |
//! triangle` (`shaders/depth_prepass.wgsl` with `IDS`). The split is
//! [`tiledlight_cull::visibility::IdLayout`], chosen from the scene's instance count and its
//! largest mesh; a scene past 32 bits is refused with the bits it needs. Depends on
//! tiledlight-gpu.

use tiledlight_cull::visibility::IdLayout;
use tiledlight_gpu::depth_prepass::{DepthPrepass, ID_FORMAT};
use tiledlight_gpu::features::Features;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::readback::read_texture;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::targets::texture_2d_msaa;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::util::buffer_init;
use tiledlight_gpu::view::Views;
use tiledlight_gpu::GpuError;

/// The raster pass and its ID target.
pub struct VisibilityRaster {
    pass: DepthPrepass,
    ids: wgpu::Texture,
    /// Test-only: a pixel and a buffer holding the wrong ID copied onto it after the pass.
    wrong_id: Option<((u32, u32), wgpu::Buffer)>,
    /// The ID target (multisampled with MSAA), read by [`crate::shading`].
    pub ids_view: wgpu::TextureView,
    /// How IDs split into instance and triangle.
    pub layout: IdLayout,
}

impl VisibilityRaster {
    /// The pass for `scene` on a `size` screen with the features' samples. `wrong_id`
    /// (tests only, one sample a pixel): that pixel's ID is overwritten after the pass with
    /// instance 0's triangle 0, a valid but wrong triangle.
    pub fn new(
        device: &wgpu::Device,
        views: &Views,
        scene: &SceneGpu,
        features: &Features,
        (size, wrong_id): ((u32, u32), Option<(u32, u32)>),
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
        if let Some((x, y)) = wrong_id {
            if features.msaa > 1 || x >= size.0 || y >= size.1 {
                return Err(GpuError::Config(format!(
                    "the wrong-ID test hook needs one sample a pixel and a pixel on the {}x{} screen, got ({x}, {y})",
                    size.0, size.1
                )));
            }
        }
        let instances = scene.instance_bounds.len() as u32;
        let layout = IdLayout::for_scene(instances.max(1), scene.max_triangles.max(1))?;
        let pass = DepthPrepass::with_ids(device, views, scene, features, layout.triangle_bits)?;
        let ids = texture_2d_msaa(
            device,
            "visibility.ids",
            size,
            ID_FORMAT,
            features.msaa,
            // COPY_SRC: tests read the IDs back (single-sampled).
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC
                | if wrong_id.is_some() { wgpu::TextureUsages::COPY_DST } else { wgpu::TextureUsages::empty() },
        );
        // A row of a texture copy is 256-byte aligned: one row of 64 IDs, the first used.
        let wrong_id = wrong_id.map(|p| {
            let mut row = [0u32; 64];
            row[0] = layout.pack(0, 0);
            (
                p,
                buffer_init(
                    device,
                    "visibility.test_wrong_id",
                    bytemuck::cast_slice(&row),
                    wgpu::BufferUsages::COPY_SRC,
                ),
            )
        });
        memory.add("visibility.ids", size.0 as u64 * size.1 as u64 * features.msaa as u64 * 4);
        let ids_view =
            ids.create_view(&wgpu::TextureViewDescriptor { label: Some("visibility.ids.view"), ..Default::default() });
        Ok(Self { pass, ids, wrong_id, ids_view, layout })
    }

    /// The last frame's IDs, row-major (one sample a pixel only; stalls the GPU).
    pub fn read_ids(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Vec<u32>, GpuError> {
        if self.ids.sample_count() > 1 {
            return Err(GpuError::Config("multisampled IDs cannot be read back".into()));
        }
        let bytes = read_texture(device, queue, &self.ids, wgpu::TextureAspect::All, 4)?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
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
        if let Some(((x, y), buffer)) = &self.wrong_id {
            encoder.copy_buffer_to_texture(
                wgpu::TexelCopyBufferInfo {
                    buffer,
                    layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(256), rows_per_image: None },
                },
                wgpu::TexelCopyTextureInfo {
                    texture: &self.ids,
                    mip_level: 0,
                    origin: wgpu::Origin3d { x: *x, y: *y, z: 0 },
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
            );
        }
    }
}
