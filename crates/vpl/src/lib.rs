//! tiledlight-vpl: virtual point lights (VPLs), one-bounce indirect light as
//! TiledLighting11 makes it ("Virtual Point Lights", reference 000, Figure 6).
//!
//! - [`rsm`]: reflective shadow maps of the shadow-casting lights (every shadow face, drawn
//!   again from the light through the face proper, not the atlas's widened field of view,
//!   by the G-buffer's shader into depth, albedo and normal atlases).
//! - [`generate`]: the compute pass making one VPL per texel block above two thresholds,
//!   appended with an atomic counter up to a cap, and the VPL buffers (shading data,
//!   culling spheres, the counter) that culling and shading read with no CPU readback.
//! - [`VplPath`]: both, as a renderer holds them: built once when the settings ask for
//!   VPLs, updated when the casters move, recorded after the shadow maps.
//!
//! The CPU twin of every formula (texel flux, blocks, thresholds, cap, both shading models
//! and the every-texel reference) is `tiledlight_cull::vpl`. Without `--vpl` nothing of this
//! crate exists in a frame: no RSM, no buffer, no pass, no shader variant. Depends on
//! tiledlight-gpu and tiledlight-cull; the renderers may depend on it, never the reverse.

pub mod generate;
pub mod rsm;

pub use generate::{VplBuffers, VplCount, VplGenerate};
pub use rsm::{Rsm, RsmLayout};
pub use tiledlight_cull::vpl::{VplConfig, VplShading};

use tiledlight_cull::light::PackedLights;
use tiledlight_cull::vpl::{GpuVplShading, VPL_GRID_PER_TILE};
use tiledlight_cull::TileGrid;
use tiledlight_gpu::culling::{CullOptions, LightCulling};
use tiledlight_gpu::handles::Depth;
use tiledlight_gpu::lights_group::VplBindings;
use tiledlight_gpu::memory::MemoryReport;
use tiledlight_gpu::scene_gpu::SceneGpu;
use tiledlight_gpu::shadow_atlas::ShadowAtlas;
use tiledlight_gpu::timer::GpuTimer;
use tiledlight_gpu::util::buffer_init;
use tiledlight_gpu::view::Views;
use tiledlight_gpu::GpuError;

/// The VPL half of a frame: the RSM, the generation pass and the VPL buffers.
pub struct VplPath {
    /// The reflective shadow maps.
    pub rsm: Rsm,
    /// The VPLs.
    pub buffers: VplBuffers,
    generate: VplGenerate,
    /// RSM and VPL bytes.
    pub memory: MemoryReport,
    config: VplConfig,
}

impl VplPath {
    /// The path for the casters of `atlas` with `config`, made current for `lights` (the
    /// atlas must have been updated with them): the next [`Self::record`] draws the RSM and
    /// generates. The RSM draws from views of its own (each face's own projection, not the
    /// atlas's widened one: [`rsm::rsm_view_proj`]), so it takes none of the frame's. Errors
    /// when there is no caster to make VPLs from.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &SceneGpu,
        atlas: &ShadowAtlas,
        lights: &PackedLights,
        config: &VplConfig,
    ) -> Result<Self, GpuError> {
        if atlas.layout.faces() == 0 {
            return Err(GpuError::Config(
                "VPLs are made from the shadow-casting lights' reflective shadow maps: no light casts a shadow".into(),
            ));
        }
        let rsm = Rsm::new(device, scene, atlas, config)?;
        let buffers = VplBuffers::new(device, config.cap)?;
        let generate = VplGenerate::new(device, &rsm, &buffers)?;
        rsm.update(queue, atlas, lights);
        let mut memory = MemoryReport::default();
        memory.extend(&rsm.memory);
        memory.extend(&buffers.memory);
        Ok(Self { rsm, buffers, generate, memory, config: *config })
    }

    /// Takes the casters' new faces (after the atlas's own `update`): the next frame redraws
    /// the RSM and regenerates the VPLs.
    pub fn update(&self, queue: &wgpu::Queue, atlas: &ShadowAtlas, lights: &PackedLights) {
        self.rsm.update(queue, atlas, lights);
    }

    /// The culling pass of the VPLs into a light grid of their own ([`cull_options`] from
    /// the lights' `cull`), reading `depth` over `grid`: the same pass as the lights'.
    pub fn culling(
        &self,
        device: &wgpu::Device,
        views: &Views,
        depth: Depth<'_>,
        (grid, cull): (TileGrid, &CullOptions),
    ) -> Result<LightCulling, GpuError> {
        let options = cull_options(cull, grid, self.config.cap, &device.limits());
        LightCulling::new(device, views, depth, &self.buffers.as_lights(), &self.buffers.lighting, grid, options)
    }

    /// What a shading pass binds of the VPLs: their buffers, a `VplShading` uniform of the
    /// path's shading model, and the lists of `culling` (None: every VPL, brute force).
    pub fn bindings(&self, device: &wgpu::Device, culling: Option<&LightCulling>) -> VplBindings {
        let shading = buffer_init(
            device,
            "vpl.shading",
            bytemuck::bytes_of(&GpuVplShading::new(&self.config)),
            wgpu::BufferUsages::UNIFORM,
        );
        VplBindings {
            vpls: self.buffers.vpls.clone(),
            shading,
            count: self.buffers.count.clone(),
            lists: culling.map(|c| (c.grid.grid.clone(), c.grid.indices().clone())),
        }
    }

    /// Draws the RSM and generates the VPLs when the casters moved since the last frame
    /// (`vpl.rsm`, `vpl.generate`); a still frame keeps the VPLs it has. Returns whether it
    /// recorded anything. The RSM draws from views of its own (see [`Self::new`]).
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer, scene: &SceneGpu) -> bool {
        if !self.rsm.record(encoder, timer, scene) {
            return false;
        }
        self.generate.record(encoder, timer, &self.buffers);
        true
    }
}

/// The culling options of the VPLs' own light grid (either method): the lights' tile size, tests and two-level
/// setting, one list per tile (no half-z, clusters, 2.5D masks or light-centric
/// assignment: the shading reads a tile's one list), no cone test (VPLs are points), and
/// index room for up to [`VPL_GRID_PER_TILE`] VPLs a tile on average (the VPLs of one 32x32
/// RSM face at block 1; lists past it lose VPLs, counted in the grid's header as the lights'
/// are and reported with them as dropped, and the grid does not grow) within the largest
/// storage binding.
pub fn cull_options(cull: &CullOptions, grid: TileGrid, cap: u32, limits: &wgpu::Limits) -> CullOptions {
    let most = (limits.max_storage_buffer_binding_size / 4).min(u32::MAX as u64);
    let pairs = (grid.tile_count() as u64 * cap.min(VPL_GRID_PER_TILE) as u64).clamp(1024, most) as u32;
    CullOptions {
        half_z: false,
        spot_cone: false,
        depth_mask: false,
        scatter: false,
        clusters: None,
        grid_pairs: Some(pairs),
        ..*cull
    }
}

/// Every pass binding declaration of this crate, for `cargo xtask validate-shaders`.
pub fn binding_declarations() -> Vec<tiledlight_gpu::bindings::PassBindings> {
    vec![generate::VPL_GENERATE_BINDINGS]
}
