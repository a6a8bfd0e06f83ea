//! Each light's contribution to a frame on the GPU (`shaders/light_contribution.wgsl`):
//! a workgroup per 16x16 tile of a one-list-per-tile light grid sums, for each light of
//! the tile's list, its unshadowed arrival at the tile's surface pixels, weighted by its
//! brightness, into a 64-bit fixed-point score per light. The steps and the CPU twin are
//! in `tiledlight_cull::contribution`. It picks the shadow casters by contribution
//! (`tiledlight_frame::caster_rank`). Depends on wgpu, [`crate::light_grid`],
//! [`crate::light_buffers`], [`crate::view`], [`crate::bindings`].

use crate::define::Define;
use crate::handles::Depth;
use tiledlight_cull::contribution::pair_scale;

use crate::bindings::{create_layout, Binding, Cond, PassBindings, PassGroup};
use crate::error::GpuError;
use crate::light_buffers::LightBuffers;
use crate::light_grid::LightGrid;
use crate::readback::read_buffer;
use crate::timer::GpuTimer;
use crate::util::{buffer_entry, buffer_init, buffer_zeroed, compute_pipeline, keyed_module};
use crate::variants::{ContributionKey, ShaderKey};
use crate::view::Views;

/// The kernel's tile side: the grid it reads must be tiled at this size, one list a tile.
pub const CONTRIBUTION_TILE: u32 = 16;

const CS: wgpu::ShaderStages = wgpu::ShaderStages::COMPUTE;

/// The bindings of [`LightContribution`] (`shaders/light_contribution.wgsl`): group 0 the
/// view; group 1 the depth (0), shading lights (1), lighting uniform (2), parameters (3),
/// the scores it writes (4), the light grid (5) and its indices (6), with `SPOTS` the
/// spots (7).
pub const CONTRIBUTION_BINDINGS: PassBindings = PassBindings {
    entry: "light_contribution.wgsl",
    source: file!(),
    groups: &[
        PassGroup::new(0, crate::view::BINDINGS),
        PassGroup::new(
            1,
            &[
                Binding::texture(0, CS, wgpu::TextureSampleType::Float { filterable: false }),
                Binding::storage(1, CS),
                Binding::uniform(2, CS),
                Binding::uniform(3, CS),
                Binding::storage_rw(4, CS),
                Binding::storage(5, CS),
                Binding::storage(6, CS),
                Binding::storage(7, CS).when(Cond::Defined(Define::Spots)),
            ],
        ),
    ],
};

/// What the kernel reads: the frame's single-sampled depth, the lights with their
/// `Lighting` uniform, and the light grid culled from that depth.
#[derive(Clone, Copy)]
pub struct ContributionInputs<'a> {
    /// The frame's depth, single-sampled (another count is refused).
    pub depth: Depth<'a>,
    /// The lights, packed as the grid indexes them.
    pub lights: &'a LightBuffers,
    /// Their `Lighting` uniform (the point-light count).
    pub lighting: &'a wgpu::Buffer,
    /// The grid: 16-pixel tiles, one list a tile.
    pub grid: &'a LightGrid,
}

/// The contribution kernel, its score buffer and its bind group.
pub struct LightContribution {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    scores: wgpu::Buffer,
    /// The parameters uniform (`scale`), rewritten only by [`Self::set_scale`].
    params: wgpu::Buffer,
    /// Units per brightness-weighted attenuation sum, as the CPU twin takes it.
    pub scale: f32,
    tiles: (u32, u32),
}

impl LightContribution {
    /// Builds the kernel for `inputs` (built after the grid has its final size: a grid that
    /// grows afterwards needs a new kernel). A grid of another tile size or with several lists a
    /// tile (half-z, clusters) is an error naming it: the kernel reads one list a tile.
    pub fn new(device: &wgpu::Device, views: &Views, inputs: ContributionInputs<'_>) -> Result<Self, GpuError> {
        let g = inputs.grid;
        if g.tiles.tile_size != CONTRIBUTION_TILE || g.lists_per_tile != 1 {
            return Err(GpuError::Config(format!(
                "the contribution estimate reads {CONTRIBUTION_TILE}-pixel tiles with one list each; \
                 this grid has {}-pixel tiles with {} lists each",
                g.tiles.tile_size, g.lists_per_tile
            )));
        }
        if inputs.depth.samples != 1 {
            return Err(GpuError::Config(format!(
                "the contribution estimate reads one depth sample a pixel, not {}",
                inputs.depth.samples
            )));
        }
        let key = ContributionKey { spots: inputs.lights.has_spots() };
        let layout = create_layout(device, "contribution.layout", CONTRIBUTION_BINDINGS.group(1), &key.defines());
        let module = keyed_module(device, &key)?;
        let pipeline = compute_pipeline(device, "contribution", &[&views.layout, &layout], &module, &[]);
        let scale = pair_scale(&inputs.lights.packed, CONTRIBUTION_TILE);
        let params = buffer_init(
            device,
            "contribution.params",
            bytemuck::cast_slice(&[scale, 0.0, 0.0, 0.0]),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let scores = buffer_zeroed(
            device,
            "contribution.scores",
            inputs.lights.len().max(1) as u64 * 8,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        );
        let bind_group = Self::group(device, &layout, (&params, &scores), inputs);
        Ok(Self { pipeline, bind_group, scores, params, scale, tiles: (g.tiles.tiles_x, g.tiles.tiles_y) })
    }

    /// Test-only: quantises with `scale` units per brightness-weighted sum instead of
    /// [`pair_scale`]'s, from the next recorded run on. Under `pair_scale` no (tile, light)
    /// pair can reach the `u32` range by design, so the kernel's saturation and its 64-bit
    /// carry are only reachable with a larger scale (tests/tests/boundaries.rs).
    pub fn set_scale(&mut self, queue: &wgpu::Queue, scale: f32) {
        self.scale = scale;
        queue.write_buffer(&self.params, 0, bytemuck::cast_slice(&[scale, 0.0, 0.0, 0.0]));
    }

    fn group(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        (params, scores): (&wgpu::Buffer, &wgpu::Buffer),
        inputs: ContributionInputs<'_>,
    ) -> wgpu::BindGroup {
        let mut entries = vec![
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(inputs.depth.view) },
            buffer_entry(1, &inputs.lights.shading),
            buffer_entry(2, inputs.lighting),
            buffer_entry(3, params),
            buffer_entry(4, scores),
            buffer_entry(5, &inputs.grid.grid),
            buffer_entry(6, inputs.grid.indices()),
        ];
        if let Some(s) = &inputs.lights.spots {
            entries.push(buffer_entry(7, s));
        }
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("contribution.bind_group"),
            layout,
            entries: &entries,
        })
    }

    /// Records the clearing of the scores and the kernel (one workgroup a tile) for view
    /// slot `view`, after the culling that filled the grid.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &GpuTimer, (views, view): (&Views, u32)) {
        encoder.clear_buffer(&self.scores, 0, None);
        let t = timer.begin("contribution", encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("contribution"),
                timestamp_writes: t.compute_writes(),
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, views.bind_group(), &views.offsets(view));
            pass.set_bind_group(1, &self.bind_group, &[]);
            pass.dispatch_workgroups(self.tiles.0, self.tiles.1, 1);
        }
        timer.end(encoder, t);
    }

    /// Each light's score (packed order) from the last recorded and submitted run.
    pub fn read(&self, device: &wgpu::Device, queue: &wgpu::Queue, lights: u32) -> Result<Vec<u64>, GpuError> {
        let words: Vec<u32> = read_buffer(device, queue, &self.scores)?;
        Ok(words.chunks_exact(2).take(lights as usize).map(|w| w[0] as u64 | (w[1] as u64) << 32).collect())
    }
}
