//! The light grid: the one contract for "which lights may touch this pixel" between the
//! culling layouts and every shading path (`shaders/common/light_grid.wgsl`).
//!
//! 1. The layout (tiles; half-z's two lists a tile; 2.5D masks; clusters) fixes the number
//!    of lists. Per list the grid holds `(first, count)`: the list's light
//!    indices are `indices[first .. first + count]` of one global buffer.
//! 2. Each frame the culling kernel allocates every list's indices with one atomic add on
//!    the frame's counter, so the index buffer is sized from the real number of (list,
//!    light) pairs, not lists x a worst-case capacity.
//! 3. When the buffer is too small for a frame, nothing is written out of bounds: a list
//!    keeps the indices that fit, the header counts the missing pairs and lists, and
//!    [`LightGrid::status`] / [`LightGrid::poll_status`] report them.
//! 4. The renderer then grows the buffer ([`LightGrid::grow`]) for the next frame, unless
//!    the budget was fixed ([`CullOptions::grid_pairs`]) or the device cannot bind more.
//!
//! The buffers are built once per screen; only the index buffer is re-created when it grows
//! (with the one bind group that holds it here, and the shading pass's that reads it).
//! Depends on wgpu, [`crate::readback`] and [`crate::bindings`]; the culling techniques
//! ([`crate::culling`]) fill it and own its budget, never the other way round.
//!
//! [`CullOptions::grid_pairs`]: crate::culling::CullOptions::grid_pairs

use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use tiledlight_cull::TileGrid;

use crate::bindings::{create_layout, Binding, Cond};
use crate::error::GpuError;
use crate::memory::MemoryReport;
use crate::readback::{read_buffer, read_buffer_range};
use crate::util::{buffer_init, check_storage_binding};

/// The grid buffer's header: this frame's counters and the index buffer's length.
///
/// Keep in sync with `shaders/common/light_grid.wgsl` (`LightGridHeader`); `cargo xtask
/// validate-shaders` checks it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightGridHeader {
    /// Indices allocated this frame (may exceed `capacity`: the excess was not stored).
    pub allocated: u32,
    /// (list, light) pairs found this frame. The kernels count them apart only when the
    /// allocation counter is guarded against wrapping (`needs_guard`); otherwise the
    /// counter is the pair count (one same-address atomic a tile instead of two).
    /// [`GridStatus::from_gpu`] fills it in.
    pub pairs: u32,
    /// Pairs that did not fit in the index buffer.
    pub dropped_pairs: u32,
    /// Lists that lost at least one light because the index buffer was full.
    pub dropped_lists: u32,
    /// Lists longer than the kernel's workgroup list (culled a second time into the grid).
    pub spilled_lists: u32,
    /// Length of the index buffer, in indices (written by the host).
    pub capacity: u32,
    /// Tiles across and down (the layout, written by the host).
    pub tiles: [u32; 2],
    /// Tile side in pixels.
    pub tile_size: u32,
    /// Lists per tile (2 with half-z).
    pub lists_per_tile: u32,
    /// The culling kernel's workgroup list length (the heat map's palette top).
    pub list_capacity: u32,
    /// Clustered layouts (`lists_per_tile` slices): the far end of slice 0, metres.
    pub slice_first: f32,
    /// Clustered layouts: `(slices - 1) / ln(last / first)` of the exponential slices.
    pub slice_scale: f32,
    /// Padding to 56 bytes.
    pub _pad0: u32,
}

/// Bytes of the counters cleared each frame (every header word before `capacity`).
const COUNTER_BYTES: u64 = 20;
/// Bytes of the header.
pub const HEADER_BYTES: u64 = std::mem::size_of::<LightGridHeader>() as u64;

/// Indices a list is given before the first frame has said how many it needs: enough for
/// the default scenes without a regrow, small enough that 1080p with 1,024 lights stays
/// near 1 MiB (the old layout's lists x capacity took 31.9 MiB there).
pub const INITIAL_PER_TILE: u32 = 32;

/// What the last frame did with the light grid.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GridStatus {
    /// The frame's header as the GPU left it.
    pub header: LightGridHeader,
}

impl GridStatus {
    /// The status of a header as the GPU left it, with `pairs` filled in from the
    /// allocation counter when the kernel did not count them apart (no wrap guard).
    pub fn from_gpu(mut header: LightGridHeader) -> Self {
        header.pairs = header.pairs.max(header.allocated);
        Self { header }
    }

    /// Indices the frame needed: its pairs.
    pub fn needed(&self) -> u32 {
        self.header.pairs
    }

    /// True when every pair found was stored.
    pub fn complete(&self) -> bool {
        self.header.dropped_pairs == 0
    }
}

impl std::fmt::Display for GridStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let h = &self.header;
        write!(f, "{} pairs in a grid of {} indices", h.pairs, h.capacity)?;
        if h.spilled_lists > 0 {
            write!(f, ", {} lists longer than the workgroup list (culled twice)", h.spilled_lists)?;
        }
        if h.dropped_pairs > 0 {
            write!(f, "; DROPPED {} lights from {} lists (grid full)", h.dropped_pairs, h.dropped_lists)?;
        }
        Ok(())
    }
}

/// Per-list lights as read back from the GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuTileLists {
    /// True light count per list.
    pub counts: Vec<u32>,
    /// Stored indices per list, in the GPU's order (fewer than the count only when the grid
    /// was full).
    pub lists: Vec<Vec<u32>>,
    /// Lists that lost lights because the grid was full, as counted on the GPU.
    pub overflowing: u32,
    /// (list, light) pairs found, as counted on the GPU.
    pub pairs: u32,
    /// The frame's header.
    pub status: GridStatus,
}

/// States of the non-blocking header readback.
const IDLE: u8 = 0;
const COPIED: u8 = 1;
const MAPPING: u8 = 2;
const MAPPED: u8 = 3;

/// The layout of a grid: which lists exist and how the kernels that fill it are set up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridLayout {
    /// The tiling.
    pub tiles: TileGrid,
    /// Lists per tile (2 with half-z).
    pub lists_per_tile: u32,
    /// The culling kernel's workgroup list length.
    pub list_capacity: u32,
    /// Keep the per-tile depth ranges (half-z lookups by pixel, light-centric assignment).
    pub ranges: bool,
    /// Clustered layouts: the first slice's far end and the slices' scale (header fields
    /// `slice_first`, `slice_scale`).
    pub slicing: Option<(f32, f32)>,
}

/// The culling kernels' group (group 2 of `shaders/cull.wgsl` and Tiled Deferred's kernels),
/// all read-write: the grid (0), the indices (1) and, when `ranges` holds, the per-tile
/// depth ranges (2). The culling pass has ranges with `HALF_Z`, Tiled Deferred never.
pub const fn compute_bindings(ranges: Cond) -> [Binding; 3] {
    let cs = wgpu::ShaderStages::COMPUTE;
    [Binding::storage_rw(0, cs), Binding::storage_rw(1, cs), Binding::storage_rw(2, cs).when(ranges)]
}

/// The light grid of one screen and layout: the grid buffer (header + one `(first, count)`
/// per list), the index buffer, and with half-z the per-tile depth ranges.
pub struct LightGrid {
    /// The tiling.
    pub tiles: TileGrid,
    /// Lists per tile (2 with half-z).
    pub lists_per_tile: u32,
    /// Header, then `(first, count)` per list.
    pub grid: wgpu::Buffer,
    /// Light indices (grows).
    indices: wgpu::Buffer,
    /// Per tile near and far view distance (half-z only).
    pub ranges: Option<wgpu::Buffer>,
    /// Indices the buffer holds.
    capacity: u32,
    /// The budget was fixed by the settings: never grows.
    fixed: bool,
    /// Largest index count the device can bind.
    max_capacity: u32,
    layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    readback: wgpu::Buffer,
    readback_state: Arc<AtomicU8>,
    label: &'static str,
}

impl LightGrid {
    /// The grid of `layout` for `num_lights` lights. `fixed_pairs`: a fixed index budget
    /// (never grows) instead of the automatic one.
    pub fn new(
        device: &wgpu::Device,
        label: &'static str,
        layout: GridLayout,
        num_lights: u32,
        fixed_pairs: Option<u32>,
    ) -> Result<Self, GpuError> {
        let GridLayout { tiles, lists_per_tile, list_capacity, ranges, slicing } = layout;
        let max_binding = device.limits().max_storage_buffer_binding_size;
        let lists = tiles.tile_count() as u64 * lists_per_tile as u64;
        let grid_bytes = HEADER_BYTES + lists * 8;
        check_storage_binding(&device.limits(), grid_bytes, || format!("the light grid of {lists} lists"))?;
        let max_capacity = (max_binding / 4).min(u32::MAX as u64) as u32;
        let capacity = match fixed_pairs {
            Some(0) => return Err(GpuError::Config("a fixed light-grid budget must hold at least one index".into())),
            Some(n) if n > max_capacity => {
                return Err(GpuError::Limit {
                    what: format!("a light-grid budget of {n} indices"),
                    name: "max_storage_buffer_binding_size",
                    limit: max_binding,
                    asked: format!("{} bytes", n as u64 * 4),
                })
            }
            Some(n) => n,
            None => initial_capacity(tiles.tile_count() as u64, num_lights).min(max_capacity as u64) as u32,
        };
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let header = LightGridHeader {
            capacity,
            tiles: [tiles.tiles_x, tiles.tiles_y],
            tile_size: tiles.tile_size,
            lists_per_tile,
            list_capacity,
            slice_first: slicing.map_or(0.0, |s| s.0),
            slice_scale: slicing.map_or(0.0, |s| s.1),
            ..Default::default()
        };
        let mut contents = vec![0u8; grid_bytes as usize];
        contents[..HEADER_BYTES as usize].copy_from_slice(bytemuck::bytes_of(&header));
        let grid = buffer_init(device, &format!("{label}.grid"), &contents, usage);
        let indices = index_buffer(device, label, capacity);
        let ranges =
            ranges.then(|| buffer_init(device, &format!("{label}.ranges"), &vec![0u8; tiles.tile_count() * 8], usage));
        let layout = create_layout(
            device,
            &format!("{label}.layout"),
            &compute_bindings(Cond::from_bool(ranges.is_some())),
            &[],
        );
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(&format!("{label}.header_readback")),
            size: HEADER_BYTES,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let bind_group = compute_group(device, label, &layout, &grid, &indices, ranges.as_ref());
        Ok(Self {
            tiles,
            lists_per_tile,
            grid,
            indices,
            ranges,
            capacity,
            fixed: fixed_pairs.is_some(),
            max_capacity,
            layout,
            bind_group,
            readback,
            readback_state: Arc::new(AtomicU8::new(IDLE)),
            label,
        })
    }

    /// True when a frame of `num_lights` lights could find 2^32 (list, light) pairs or more:
    /// the kernels then check the counter before adding to it, so it cannot wrap around
    /// onto stored lists (a second atomic round trip per list, so only when needed).
    pub fn needs_guard(&self, num_lights: u32) -> bool {
        self.list_count() as u64 * num_lights as u64 >= 1 << 32
    }

    /// Number of lists.
    pub fn list_count(&self) -> usize {
        self.tiles.tile_count() * self.lists_per_tile as usize
    }

    /// Indices the index buffer holds now.
    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    /// The index buffer (re-created by [`Self::grow`]: bind it again after growing).
    pub fn indices(&self) -> &wgpu::Buffer {
        &self.indices
    }

    /// Layout of the culling kernels' group: 0 grid, 1 indices, 2 ranges (half-z), all
    /// read-write.
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    /// The culling kernels' group (re-created by [`Self::grow`]).
    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.bind_group
    }

    /// Bytes allocated, by category.
    pub fn memory(&self) -> MemoryReport {
        let mut m = MemoryReport::default();
        m.add(&format!("{}.lists", self.label), self.grid.size());
        m.add(&format!("{}.indices", self.label), self.indices.size());
        if let Some(r) = &self.ranges {
            m.add(&format!("{}.ranges", self.label), r.size());
        }
        m
    }

    /// Records the clearing of the frame's counters (before the culling kernel).
    pub fn record_clear(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.clear_buffer(&self.grid, 0, Some(COUNTER_BYTES));
    }

    /// Records a copy of the header for [`Self::poll_status`] (after the culling kernel),
    /// unless the previous copy has not been read yet.
    pub fn record_readback(&self, encoder: &mut wgpu::CommandEncoder) {
        if self.readback_state.compare_exchange(IDLE, COPIED, Ordering::AcqRel, Ordering::Acquire).is_ok() {
            encoder.copy_buffer_to_buffer(&self.grid, 0, &self.readback, 0, HEADER_BYTES);
        }
    }

    /// The header of the latest finished frame whose copy has arrived, without waiting
    /// (None while none has); call it between frames, after submitting.
    pub fn poll_status(&self) -> Option<GridStatus> {
        match self.readback_state.load(Ordering::Acquire) {
            COPIED => {
                self.readback_state.store(MAPPING, Ordering::Release);
                let state = self.readback_state.clone();
                self.readback.slice(..).map_async(wgpu::MapMode::Read, move |r| {
                    // A failed map leaves the buffer unmapped: start over.
                    state.store(if r.is_ok() { MAPPED } else { IDLE }, Ordering::Release);
                });
                None
            }
            MAPPED => {
                let header = self
                    .readback
                    .slice(..)
                    .get_mapped_range()
                    .ok()
                    .map(|bytes| *bytemuck::from_bytes::<LightGridHeader>(&bytes[..HEADER_BYTES as usize]));
                self.readback.unmap();
                self.readback_state.store(IDLE, Ordering::Release);
                header.map(GridStatus::from_gpu)
            }
            _ => None,
        }
    }

    /// The header of the last frame (stalls the GPU: tests, single renders).
    pub fn status(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<GridStatus, GpuError> {
        let words: Vec<u32> = read_buffer_range(device, queue, &self.grid, 0, HEADER_BYTES)?;
        Ok(GridStatus::from_gpu(*bytemuck::from_bytes(bytemuck::cast_slice(&words))))
    }

    /// The index count to grow to after a frame that needed `pairs` indices ([`GridStatus::needed`]), or None when the grid
    /// holds them already, its budget is fixed, or the device cannot bind more.
    pub fn growth(&self, pairs: u32) -> Option<u32> {
        if self.fixed || pairs <= self.capacity || self.capacity >= self.max_capacity {
            return None;
        }
        // A quarter more than needed, so a camera moving a little does not regrow each frame.
        let want = pairs as u64 + pairs as u64 / 4;
        Some(want.min(self.max_capacity as u64) as u32)
    }

    /// Re-creates the index buffer with `capacity` indices and the culling group that
    /// holds it; the caller rebinds its other groups reading [`Self::indices`].
    pub fn grow(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, capacity: u32) {
        self.capacity = capacity.clamp(1, self.max_capacity);
        self.indices = index_buffer(device, self.label, self.capacity);
        self.bind_group =
            compute_group(device, self.label, &self.layout, &self.grid, &self.indices, self.ranges.as_ref());
        queue.write_buffer(&self.grid, COUNTER_BYTES, bytemuck::bytes_of(&self.capacity));
    }

    /// Reads the last frame's lists back (tests, statistics; stalls the GPU).
    pub fn read_lists(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<GpuTileLists, GpuError> {
        let grid: Vec<u32> = read_buffer(device, queue, &self.grid)?;
        let indices: Vec<u32> = read_buffer(device, queue, &self.indices)?;
        let words = (HEADER_BYTES / 4) as usize;
        let header = GridStatus::from_gpu(*bytemuck::from_bytes(bytemuck::cast_slice(&grid[..words]))).header;
        let n = self.list_count();
        let entries = &grid[words..];
        if entries.len() < 2 * n {
            return Err(GpuError::Readback(format!("{} list entries read back for {n} lists", entries.len() / 2)));
        }
        let cap = header.capacity.min(indices.len() as u32);
        let mut counts = Vec::with_capacity(n);
        let mut lists = Vec::with_capacity(n);
        for l in 0..n {
            let (first, count) = (entries[2 * l], entries[2 * l + 1]);
            // The same clipping as common/light_grid.wgsl's light_list.
            let first = first.min(cap);
            let stored = count.min(cap - first);
            counts.push(count);
            lists.push(indices[first as usize..(first + stored) as usize].to_vec());
        }
        Ok(GpuTileLists {
            counts,
            lists,
            overflowing: header.dropped_lists,
            pairs: header.pairs,
            status: GridStatus::from_gpu(header),
        })
    }

    /// Reads the per-list true counts of the last frame (heat map statistics; stalls).
    pub fn read_counts(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Vec<u32>, GpuError> {
        let grid: Vec<u32> = read_buffer(device, queue, &self.grid)?;
        Ok(grid[(HEADER_BYTES / 4) as usize..].chunks_exact(2).map(|e| e[1]).take(self.list_count()).collect())
    }
}

/// The automatic first size: [`INITIAL_PER_TILE`] indices a tile (fewer when there are
/// fewer lights), at least 1,024.
pub fn initial_capacity(tiles: u64, num_lights: u32) -> u64 {
    (tiles * num_lights.clamp(1, INITIAL_PER_TILE) as u64).max(1024)
}

fn index_buffer(device: &wgpu::Device, label: &str, capacity: u32) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(&format!("{label}.indices")),
        size: capacity as u64 * 4,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

fn compute_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    grid: &wgpu::Buffer,
    indices: &wgpu::Buffer,
    ranges: Option<&wgpu::Buffer>,
) -> wgpu::BindGroup {
    let mut entries = vec![
        wgpu::BindGroupEntry { binding: 0, resource: grid.as_entire_binding() },
        wgpu::BindGroupEntry { binding: 1, resource: indices.as_entire_binding() },
    ];
    if let Some(r) = ranges {
        entries.push(wgpu::BindGroupEntry { binding: 2, resource: r.as_entire_binding() });
    }
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(&format!("{label}.group")),
        layout,
        entries: &entries,
    })
}

/// Layouts of this module's GPU structs, for the xtask layout check.
pub fn layouts() -> Vec<tiledlight_cull::layout::StructLayout> {
    vec![tiledlight_cull::struct_layout!(
        LightGridHeader,
        "LightGridHeader",
        "common/light_grid.wgsl",
        [
            allocated,
            pairs,
            dropped_pairs,
            dropped_lists,
            spilled_lists,
            capacity,
            tiles,
            tile_size,
            lists_per_tile,
            list_capacity,
            slice_first,
            slice_scale,
            _pad0
        ]
    )]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_is_56_bytes_and_counters_precede_capacity() {
        assert_eq!(HEADER_BYTES, 56);
        assert_eq!(std::mem::offset_of!(LightGridHeader, capacity) as u64, COUNTER_BYTES);
    }

    #[test]
    fn first_size_follows_tiles_and_lights() {
        // 1080p, 16 px tiles: 8,160 tiles.
        assert_eq!(initial_capacity(8160, 1024), 8160 * 32);
        assert_eq!(initial_capacity(8160, 4), 8160 * 4);
        assert_eq!(initial_capacity(1, 1), 1024);
    }
}
