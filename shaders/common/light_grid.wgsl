// The light grid: which lights may touch a pixel. One contract for every culling layout and
// every shading path (crates/gpu/src/light_grid.rs, LightGrid):
//
// - `light_grid.lists[l]` = (first, count) of list l: list l's light indices are
//   `light_indices[first .. first + count]` (lists of a tile are consecutive: tile t's
//   lists are t * lists_per_tile + k; with half-z list 0 is the near half).
// - `count` is the true number of lights found. The culling pass allocates the indices
//   atomically from the frame's real number of pairs; when `light_indices` is too small for a
//   frame, a list keeps only the indices that fit (`first` past the end: none) and the
//   header counts the missing pairs, so the host can report them and grow the buffer.
//   `light_list` returns only stored indices: nothing is read out of bounds.
//
// This file only defines types and pure functions (the layout check compiles it alone).
//
// Readers bind `light_grid: LightGrid` (the culling kernels the writable LightGridRw of
// common/light_grid_write.wgsl) and shading paths `light_indices: array<u32>`, reading
// light i of a list as light_indices[first + i]. Lookups by pixel: common/light_grid_pixel.wgsl.
// Keep LightGridHeader in sync with crates/gpu/src/light_grid.rs (`cargo xtask
// validate-shaders` checks it).

struct LightGridHeader {
    // Indices allocated this frame (may pass `capacity`: the rest were not stored).
    allocated: u32,
    // (list, light) pairs found this frame, counted only with GRID_GUARD (without it the
    // allocation counter is the pair count; the host reads the larger of the two).
    pairs: u32,
    // Pairs and lists that did not fit in `light_indices`.
    dropped_pairs: u32,
    dropped_lists: u32,
    // Lists longer than the culling kernel's workgroup list (written by a second pass).
    spilled_lists: u32,
    // Length of `light_indices` (written by the host when it allocates the buffer).
    capacity: u32,
    // The layout, written by the host: tiles across and down, tile side in pixels, lists
    // per tile (2 with half-z, the slices when clustered), and the culling kernel's
    // workgroup list length.
    tiles: vec2<u32>,
    tile_size: u32,
    lists_per_tile: u32,
    list_capacity: u32,
    // Clustered layouts (lists_per_tile = slices): the far end of slice 0 and the scale of
    // the exponential slices (cluster_slice in common/tile_tests.wgsl); 0 otherwise.
    slice_first: f32,
    slice_scale: f32,
    _pad0: u32,
}

struct LightGrid {
    header: LightGridHeader,
    lists: array<vec2<u32>>,
}

// A list's stored lights: indices light_indices[first .. first + count].
struct LightList {
    first: u32,
    count: u32,
}

// A list entry `e` = (first, count), clipped to the indices a grid of `capacity` stored.
fn light_list(e: vec2<u32>, capacity: u32) -> LightList {
    let first = min(e.x, capacity);
    return LightList(first, min(e.y, capacity - first));
}

// Clustered shading: the depth slice of view distance `d` (tiledlight_cull
// ClusterConfig::slice_of), from the header's slice_first, slice_scale and lists_per_tile.
// Slice 0 is [0, first) (no logarithm near the eye: no NaN at near 0), slices 1 ..
// slices-1 are exponential from `first`, the last reaching to infinity; scale =
// (slices - 1) / ln(last / first). Monotone in `d`, so a light whose depth interval
// [dist - r, dist + r] spans slices lo..hi covers the slice of every point it reaches.
fn cluster_slice(d: f32, first: f32, scale: f32, slices: u32) -> u32 {
    if slices <= 1u || !(d >= first) {
        return 0u;
    }
    let x = log(d / first) * scale;
    return 1u + u32(min(max(x, 0.0), f32(slices - 2u)));
}
