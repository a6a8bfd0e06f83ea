//! Light-centric assignment: each light scatters itself into the lists of the tiles (or
//! clusters) it covers, so a frame's cost grows with lights + (list, light) pairs rather
//! than lights x tiles, which is what a million lights needs (the tile-centric kernel,
//! [`super::tile`], tests every light in every tile or cell). The steps of a frame,
//! all in one compute pass (`shaders/tile_depth.wgsl`, `shaders/assign.wgsl`):
//!
//! 1. **Tile depth**: a workgroup per grid tile writes the view-distance range of its
//!    surfaces into the grid's tile ranges and, for 2.5D culling or clusters, its 32-bit
//!    depth-occupancy mask.
//! 2. **Count**: a thread per light finds its tile rectangle (binary searches on the same
//!    side planes the tile-centric kernel tests; a sphere reaching the eye plane, where
//!    those tests are not monotone, gets the tiles its part beyond the near plane projects
//!    to: `tiledlight_cull::assign::near_cap_rect`), tests each tile of it with the
//!    tile-centric kernel's own code (`common/tile_tests.wgsl`; clusters: the light's depth
//!    slices) and counts hits per list. It keeps the rectangle for the later passes. A
//!    light covering more than [`BIG_TILES`] tiles is queued and counted, in a second
//!    dispatch, by a team of [`TEAM`] threads, tile by tile (one thread would stall its
//!    warp); one covering more than [`HUGE_BLOCKS`] blocks, or reaching the eye plane with
//!    more than [`BIG_TILES`] tiles (the only walks that need the per-tile plane test), by
//!    one or more whole workgroups (see there).
//! 3. **Allocate**: a thread per list; 256 lists' counts are scanned in workgroup memory and
//!    allocated with one atomic add on the grid's counter (the light grid's contract: a
//!    full index buffer drops and counts, never writes out of bounds).
//! 4. **Write**: the same walk again (the rectangle read back), each hit stored at its
//!    list's cursor.
//!
//! The walks go over blocks of 4 x 4 tiles and, for tile layouts, skip a block whose
//! surfaces all lie nearer or farther than the light reaches (step 1 keeps each block's
//! range): most of a dense scene's lights are hidden behind walls, and their walks then
//! cost a block test instead of a test per tile. Clusters cannot skip so (an empty cluster
//! still gets lights, which is what serves transparent geometry).
//!
//! The lists hold the tile-centric kernel's lights (the order within a list differs) except
//! those of a light reaching the eye plane in tiles its part beyond the near plane cannot
//! cover (false positives of the per-tile plane test, which the gather keeps): the CPU
//! twin is `tiledlight_cull::cull_tiles_scatter` for tiles, half-z and 2.5D, and
//! `tiledlight_cull`'s clusters (which use the same rectangle) for the clustered layout.
//! On the H200 the eye-plane rectangle cut the million-light preset's assignment from 0.76
//! to 0.22 ms: ~2,800 of its lights got the whole grid (docs/PERFORMANCE.md).
//! Depends on wgpu, [`super::options`] (options, depth binding), [`super::clusters`] (the
//! clustered variant), [`crate::light_grid`], [`crate::light_buffers`], [`crate::view`],
//! [`crate::bindings`].

use crate::define::Define;
use tiledlight_cull::TileGrid;

use crate::bindings::{create_layout, Binding, Cond, PassBindings, PassGroup};
use crate::error::GpuError;
use crate::light_buffers::LightBuffers;
use crate::light_grid::{compute_bindings, LightGrid};
use crate::memory::MemoryReport;
use crate::timer::GpuTimer;
use crate::util::{buffer_zeroed, compute_pipeline, compute_pipeline_at, keyed_module};
use crate::variants::{AssignKey, CullTests, ShaderKey, TileDepthKey, TileDepthOutput};
use crate::view::Views;

use super::options::{CullOptions, DEPTH_BINDING};

/// A light whose tile rectangle holds more tiles than this is walked by a team of [`TEAM`]
/// threads instead of one (a thread's walk holds up its whole warp: on the H200 at a
/// million lights, 64 cost 3.1 ms of assignment, most of it threads waiting on long walks).
/// Once the team walks lost their block test and the whole-grid test (`visit_tiles`), 4
/// beat 8 at 100,000 lights (0.151 -> 0.146 ms, the 0.15 target) for 5-8% more at
/// a million (preset 0.212 -> 0.224 ms, uniform 0.387 -> 0.419; 6: 0.149 / 0.213 / 0.388):
/// docs/PERFORMANCE.md.
pub const BIG_TILES: u32 = 4;

/// Threads of a team walking one big light (lanes of one warp on NVIDIA; on the H200 16 and 8
/// were 10-40% slower from 1,024 to 100,000 lights, faster only for a million uniform
/// lights).
pub const TEAM: u32 = 32;

/// Most workgroups of the big-light passes, 256 / [`TEAM`] teams each (team `t` of the frame
/// takes every `teams * groups`-th queued light); `record` dispatches about a team per light
/// (at least 512 workgroups): on the H200 512 workgroups left half the GPU idle at 100,000
/// lights and more (0.47 -> 0.17 ms with the rectangles kept and teams spread by tiles).
const BIG_GROUPS: u32 = 4096;

/// A light whose rectangle holds more blocks than this (512 tiles) is a huge light: while
/// there are at most as many huge lights as workgroups, each gets `workgroups / huge` of
/// them, which test its blocks a thread a block, gather the reached ones in workgroup
/// memory and spread their tiles over their threads. On the H200 at 1,024 lights (a few
/// hundred lights of 300-8,000 tiles) a team walking 16-64 tiles a lane cost 0.13 ms, this
/// 0.09 (16 blocks: 0.13 again, too many huge lights for the workgroups; 128: 0.13).
pub const HUGE_BLOCKS: u32 = 32;

/// With more huge lights than workgroups, the barrier-free walk: a light of more blocks
/// than this gets a whole workgroup, the others a team, block by block (gathering in
/// workgroup memory costs three barriers a light, which a saturated GPU cannot hide).
pub const WIDE_BLOCKS: u32 = 128;

/// Side of a block in tiles: the walks skip blocks whose surfaces a light cannot reach in
/// depth (`BLOCK` in `shaders/assign.wgsl` and `shaders/tile_depth.wgsl`).
const BLOCK: u32 = 4;

/// Threads of the per-light and per-list workgroups (`shaders/assign.wgsl`).
const GROUP: u32 = 256;

/// The bindings of the tile-depth pass (`shaders/tile_depth.wgsl`). Group 1: depth (0), the
/// tile masks it writes (3, for 2.5D or clusters), the blocks' depth ranges (4, tiles). Group 2: the light grid, tile ranges
/// included.
pub const TILE_DEPTH_BINDINGS: PassBindings = PassBindings {
    entry: "tile_depth.wgsl",
    source: file!(),
    groups: &[
        PassGroup::new(0, crate::view::BINDINGS),
        PassGroup::new(
            1,
            &[
                DEPTH_BINDING,
                Binding::storage_rw(3, wgpu::ShaderStages::COMPUTE)
                    .when(Cond::Any(&[Cond::Defined(Define::DepthMask), Cond::Defined(Define::Clustered)])),
                Binding::storage_rw(4, wgpu::ShaderStages::COMPUTE).when(Cond::NotDefined(Define::Clustered)),
            ],
        ),
        PassGroup::new(2, &compute_bindings(Cond::Always)),
    ],
};

/// The bindings of the assignment kernels (`shaders/assign.wgsl`). Group 1: bounding
/// spheres (1), the lighting uniform (9), the blocks' depth ranges (2, tiles), with
/// `SPOT_CONE` the shading lights (6) and spots
/// (7), the tile masks (3, 2.5D or geometry-only clusters), the per-list counts (4), the
/// big-light queue (5), each light's tile rectangle (8). Group 2: the light grid, tile ranges included.
pub const ASSIGN_BINDINGS: PassBindings = PassBindings {
    entry: "assign.wgsl",
    source: file!(),
    groups: &[
        PassGroup::new(0, crate::view::BINDINGS),
        PassGroup::new(
            1,
            &[
                Binding::storage(1, wgpu::ShaderStages::COMPUTE),
                Binding::uniform(9, wgpu::ShaderStages::COMPUTE),
                Binding::storage(2, wgpu::ShaderStages::COMPUTE).when(Cond::NotDefined(Define::Clustered)),
                Binding::storage(6, wgpu::ShaderStages::COMPUTE).when(Cond::Defined(Define::SpotCone)),
                Binding::storage(7, wgpu::ShaderStages::COMPUTE).when(Cond::Defined(Define::SpotCone)),
                Binding::storage(3, wgpu::ShaderStages::COMPUTE)
                    .when(Cond::Any(&[Cond::Defined(Define::DepthMask), Cond::Defined(Define::GeometryOnly)])),
                Binding::storage_rw(4, wgpu::ShaderStages::COMPUTE),
                Binding::storage_rw(5, wgpu::ShaderStages::COMPUTE),
                Binding::storage_rw(8, wgpu::ShaderStages::COMPUTE),
            ],
        ),
        PassGroup::new(2, &compute_bindings(Cond::Always)),
    ],
};

/// The passes of light-centric assignment into one light grid, built once per screen,
/// light set and options.
pub struct LightAssign {
    tile_depth: wgpu::ComputePipeline,
    depth_group: wgpu::BindGroup,
    count: wgpu::ComputePipeline,
    count_big: wgpu::ComputePipeline,
    allocate: wgpu::ComputePipeline,
    write: wgpu::ComputePipeline,
    write_big: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    /// Per list: the count, then the write cursor.
    list_counts: wgpu::Buffer,
    /// The big- and huge-light queues: their lengths, then light indices (big from the
    /// start, huge from the end).
    big_lights: wgpu::Buffer,
    /// Per block of 4 x 4 tiles, its surfaces' depth range (tile layouts).
    block_ranges: Option<wgpu::Buffer>,
    /// Per tile: the 2.5D bins or the cluster slices that hold a surface (read by tests).
    pub masks: Option<wgpu::Buffer>,
    tiles: TileGrid,
    lists: u32,
    lights: u32,
}

/// A pipeline and its workgroup counts (x, y).
type Dispatch<'a> = (&'a wgpu::ComputePipeline, (u32, u32));

/// Threads a side of the tile-depth workgroup for tiles of `tile_size` pixels (a divisor of
/// it): 8 for 16-pixel tiles, each thread reading 2 x 2 pixels, which halved the shared
/// atomics of the reduction (H200, 1080p: 0.015 -> 0.012 ms); 8 or 16 for the others.
fn depth_threads(tile_size: u32) -> u32 {
    (tile_size / 2).clamp(8, 16)
}

/// A dispatch of `n` workgroups, folded into two dimensions past the 65,535 limit (the
/// kernels rebuild the index as `x + y * groups_x`).
fn dispatch_size(n: u32) -> (u32, u32) {
    let x = n.clamp(1, 65_535);
    (x, n.div_ceil(x).max(1))
}

impl LightAssign {
    /// Builds the passes that fill `grid` (built with tile ranges: [`CullOptions::grid_layout`]
    /// with `ranges`) from `depth` (`options.samples` samples per pixel).
    pub fn new(
        device: &wgpu::Device,
        views: &Views,
        depth: &wgpu::TextureView,
        (lights, lighting): (&LightBuffers, &wgpu::Buffer),
        grid: &LightGrid,
        options: &CullOptions,
        memory: &mut MemoryReport,
    ) -> Result<Self, GpuError> {
        if grid.ranges.is_none() {
            return Err(GpuError::Config("light-centric assignment needs a light grid with tile ranges".into()));
        }
        let tiles = grid.tiles;
        let lists = grid.list_count() as u32;
        let clusters = options.clusters;
        let depth_mask = options.depth_mask && clusters.is_none();
        let geometry_only = clusters.is_some_and(|c| c.geometry_only);
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let masks = (depth_mask || clusters.is_some())
            .then(|| buffer_zeroed(device, "assign.tile_masks", tiles.tile_count() as u64 * 4, usage));
        let list_counts = buffer_zeroed(device, "assign.list_counts", lists as u64 * 4, usage);
        let big_lights = buffer_zeroed(device, "assign.big_lights", (lights.len() as u64 + 2) * 4, usage);
        // Per light: its tile rectangle, found by the count pass, read by the others (only
        // the bind group holds it).
        let light_rects = buffer_zeroed(device, "assign.light_rects", lights.len().max(1) as u64 * 8, usage);
        let blocks = (tiles.tiles_x.div_ceil(BLOCK) * tiles.tiles_y.div_ceil(BLOCK)) as u64;
        let block_ranges = clusters.is_none().then(|| buffer_zeroed(device, "assign.block_ranges", blocks * 8, usage));
        if let Some(b) = &block_ranges {
            memory.add("assign.block_ranges", b.size());
        }
        memory.add("assign.list_counts", list_counts.size());
        memory.add("assign.big_lights", big_lights.size());
        memory.add("assign.light_rects", light_rects.size());
        if let Some(m) = &masks {
            memory.add("assign.tile_masks", m.size());
        }

        // Step 1: tile depth (and masks).
        let (msaa, samples) = options.depth_variant();
        let output = if clusters.is_some() {
            TileDepthOutput::Clusters
        } else if depth_mask {
            TileDepthOutput::DepthMask
        } else {
            TileDepthOutput::Ranges
        };
        let depth_key = TileDepthKey { msaa, output };
        let layout = create_layout(device, "tile_depth.layout", TILE_DEPTH_BINDINGS.group(1), &depth_key.defines());
        let mut entries =
            vec![wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(depth) }];
        if let Some(m) = &masks {
            entries.push(wgpu::BindGroupEntry { binding: 3, resource: m.as_entire_binding() });
        }
        if let Some(b) = &block_ranges {
            entries.push(wgpu::BindGroupEntry { binding: 4, resource: b.as_entire_binding() });
        }
        let depth_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("tile_depth.bind_group"),
            layout: &layout,
            entries: &entries,
        });
        let module = keyed_module(device, &depth_key)?;
        let mut constants = vec![("TILE_SIZE", tiles.tile_size as f64), ("WG", depth_threads(tiles.tile_size) as f64)];
        constants.extend(samples);
        let tile_depth =
            compute_pipeline(device, "tile_depth", &[&views.layout, &layout, grid.layout()], &module, &constants);

        // Steps 2-4: count, allocate, write.
        let spot_cone = options.spot_cone && lights.has_spots() && clusters.is_none();
        let key = match clusters {
            Some(c) => AssignKey::Clusters { geometry_only: c.geometry_only },
            None => AssignKey::Tiles(CullTests {
                half_z: options.half_z,
                aabb: options.aabb,
                spot_cone,
                depth_mask,
                coarse: false,
            }),
        };
        let defines = key.defines();
        let layout = create_layout(device, "assign.layout", ASSIGN_BINDINGS.group(1), &defines);
        let mut entries = vec![
            wgpu::BindGroupEntry { binding: 1, resource: lights.cull.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 9, resource: lighting.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 4, resource: list_counts.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 5, resource: big_lights.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 8, resource: light_rects.as_entire_binding() },
        ];
        if let (true, Some(spots)) = (spot_cone, &lights.spots) {
            entries.push(wgpu::BindGroupEntry { binding: 6, resource: lights.shading.as_entire_binding() });
            entries.push(wgpu::BindGroupEntry { binding: 7, resource: spots.as_entire_binding() });
        }
        if let (true, Some(m)) = (depth_mask || geometry_only, &masks) {
            entries.push(wgpu::BindGroupEntry { binding: 3, resource: m.as_entire_binding() });
        }
        if let Some(b) = &block_ranges {
            entries.push(wgpu::BindGroupEntry { binding: 2, resource: b.as_entire_binding() });
        }
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("assign.bind_group"),
            layout: &layout,
            entries: &entries,
        });
        let module = keyed_module(device, &key)?;
        let constants = [
            ("TILE_SIZE", tiles.tile_size as f64),
            ("BIG_TILES", BIG_TILES as f64),
            ("HUGE_BLOCKS", HUGE_BLOCKS as f64),
            ("WIDE_BLOCKS", WIDE_BLOCKS as f64),
            ("TEAM", TEAM as f64),
            ("GRID_GUARD", f64::from(u8::from(grid.needs_guard(lights.len())))),
            // The light tests that are constants (common/tile_tests.wgsl); tile lists only.
            ("AABB_TEST", f64::from(u8::from(options.aabb && clusters.is_none()))),
            ("SPOT_CONE_TEST", f64::from(u8::from(spot_cone))),
        ];
        let groups = [&views.layout, &layout, grid.layout()];
        let pipeline =
            |label: &str, entry: &str| compute_pipeline_at(device, (label, entry), &groups, &module, &constants);
        Ok(Self {
            tile_depth,
            depth_group,
            count: pipeline("assign.count", "count_lights"),
            count_big: pipeline("assign.count_big", "count_big"),
            allocate: pipeline("assign.allocate", "allocate"),
            write: pipeline("assign.write", "write_lights"),
            write_big: pipeline("assign.write_big", "write_big"),
            group,
            list_counts,
            big_lights,
            block_ranges,
            masks,
            tiles,
            lists,
            lights: lights.len(),
        })
    }

    /// Records a frame's assignment into `grid` (the one it was built for), clearing the
    /// grid's counters first, as six timed compute passes: `{label}.depth` (step 1),
    /// `{label}.count` and `{label}.count_big` (2: a thread per light, then the big and
    /// huge lights), `{label}.allocate` (3), `{label}.write` and `{label}.write_big` (4),
    /// so the lab sees where the time goes (a pass boundary costs what the barrier between
    /// two dispatches costs anyway).
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: &GpuTimer,
        (views, view): (&Views, u32),
        grid: &LightGrid,
        label: &str,
    ) {
        grid.record_clear(encoder);
        encoder.clear_buffer(&self.list_counts, 0, None);
        encoder.clear_buffer(&self.big_lights, 0, Some(8));
        if let Some(b) = &self.block_ranges {
            encoder.clear_buffer(b, 0, None);
        }
        let per_light = dispatch_size(self.lights.div_ceil(GROUP));
        let per_list = dispatch_size(self.lists.div_ceil(GROUP));
        let depth = [(&self.tile_depth, (self.tiles.tiles_x, self.tiles.tiles_y))];
        // About a team per light, but at least 512 workgroups for the huge lights (each takes
        // a whole one): idle workgroups are not free (4,096 of them cost 0.03 ms a pass on
        // the H200 at 1,024 lights), too few leave huge lights waiting in line.
        let bg = self.lights.div_ceil(GROUP / TEAM).clamp(512, BIG_GROUPS);
        let count = [(&self.count, per_light)];
        let count_big = [(&self.count_big, (bg, 1))];
        let allocate = [(&self.allocate, per_list)];
        let write = [(&self.write, per_light)];
        let write_big = [(&self.write_big, (bg, 1))];
        let steps: [(&str, &[Dispatch<'_>]); 6] = [
            ("depth", &depth),
            ("count", &count),
            ("count_big", &count_big),
            ("allocate", &allocate),
            ("write", &write),
            ("write_big", &write_big),
        ];
        for (step, dispatches) in steps {
            let name = format!("{label}.{step}");
            let t = timer.begin(&name, encoder);
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(&name),
                    timestamp_writes: t.compute_writes(),
                });
                pass.set_bind_group(0, views.bind_group(), &views.offsets(view));
                pass.set_bind_group(1, if step == "depth" { &self.depth_group } else { &self.group }, &[]);
                pass.set_bind_group(2, grid.bind_group(), &[]);
                for (pipeline, size) in dispatches {
                    pass.set_pipeline(pipeline);
                    pass.dispatch_workgroups(size.0, size.1, 1);
                }
            }
            timer.end(encoder, t);
        }
        grid.record_readback(encoder);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dispatches_fold_past_the_limit() {
        assert_eq!(dispatch_size(0), (1, 1));
        assert_eq!(dispatch_size(4096), (4096, 1));
        assert_eq!(dispatch_size(65_536), (65_535, 2));
    }
}
