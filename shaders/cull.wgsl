// Tiled light culling: one workgroup per tile. Min/max depth of the tile's non-sky pixels
// reduced in workgroup memory, the tile's view volume built, every light tested in parallel,
// survivors appended to a workgroup list and written to the tile's region of the global
// list buffer with the true count (never more than CAPACITY indices: overflow is counted).
// The CPU reference is crates/cull/src/reference.rs (cull_tiles).
// With COARSE, each tile tests only the lights of its 64x64-pixel cell (cull_coarse.wgsl),
// or every light when the cell overflowed.
// variants: AABB HALF_Z SPOT_CONE COARSE
#include "common/cull_tests.wgsl"
#include "common/lights.wgsl"

// Tile side in pixels; the workgroup is WG x WG threads, each reducing (TILE_SIZE / WG)^2 pixels.
override TILE_SIZE: u32 = 16u;
override WG: u32 = 16u;
// Indices stored per list.
override CAPACITY: u32 = 512u;

@group(1) @binding(0) var depth_texture: texture_depth_2d;
@group(1) @binding(1) var<storage, read> cull_lights: array<CullLight>;
// Per list: the number of lights found (may exceed CAPACITY).
@group(1) @binding(2) var<storage, read_write> tile_counts: array<u32>;
// Per list: CAPACITY light indices.
@group(1) @binding(3) var<storage, read_write> tile_indices: array<u32>;
// [0]: lists that overflowed, [1]: (tile, light) pairs found.
@group(1) @binding(4) var<storage, read_write> cull_stats: array<atomic<u32>, 2>;
#ifdef HALF_Z
// Per tile: near and far view distance of its surfaces (the pixel picks its half).
@group(1) @binding(5) var<storage, read_write> tile_ranges: array<vec2<f32>>;
#endif
#ifdef COARSE
override CELL: u32 = 64u;
override COARSE_CAPACITY: u32 = 8192u;
// Cell counts, then COARSE_CAPACITY indices per cell (see cull_coarse.wgsl).
@group(1) @binding(8) var<storage, read> cell_lists: array<u32>;
#endif
#ifdef SPOT_CONE
@group(1) @binding(6) var<storage, read> shading_lights: array<ShadingLight>;
@group(1) @binding(7) var<storage, read> spot_lights: array<SpotLight>;
#endif

var<workgroup> wg_min_depth: atomic<u32>;
var<workgroup> wg_max_depth: atomic<u32>;
var<workgroup> wg_count: array<atomic<u32>, 2>;
var<workgroup> wg_list: array<u32, CAPACITY>;
#ifdef HALF_Z
var<workgroup> wg_list_far: array<u32, CAPACITY>;
#endif

fn append(list: u32, light: u32) {
    let slot = atomicAdd(&wg_count[list], 1u);
    if slot < CAPACITY {
#ifdef HALF_Z
        if list == 1u {
            wg_list_far[slot] = light;
            return;
        }
#endif
        wg_list[slot] = light;
    }
}

// The light's tests beyond the sphere/planes one (AABB, spot cone); `c` is the view-space centre.
fn extra_tests(v: TileVolume, light: u32, c: vec3<f32>, r: f32) -> bool {
#ifdef AABB
    let b = volume_aabb(v);
    if !sphere_vs_aabb(b, c, r) {
        return false;
    }
#endif
#ifdef SPOT_CONE
    if light >= frame.num_point_lights {
#ifndef AABB
        let b = volume_aabb(v);
#endif
        let s = spot_lights[light - frame.num_point_lights];
        let sh = shading_lights[light];
        let apex = (frame.view * vec4<f32>(sh.position, 1.0)).xyz;
        let axis = (frame.view * vec4<f32>(s.direction, 0.0)).xyz;
        let sc = (b.lo + b.hi) * 0.5;
        let sr = length(b.hi - b.lo) * 0.5;
        if !cone_vs_sphere(apex, axis, sh.radius, s.cos_outer, s.sin_outer, sc, sr) {
            return false;
        }
    }
#endif
    return true;
}

fn store_list(list_index: u32, list: u32, lidx: u32) {
    let count = atomicLoad(&wg_count[list]);
    let stored = min(count, CAPACITY);
    for (var i = lidx; i < stored; i += WG * WG) {
#ifdef HALF_Z
        if list == 1u {
            tile_indices[list_index * CAPACITY + i] = wg_list_far[i];
            continue;
        }
#endif
        tile_indices[list_index * CAPACITY + i] = wg_list[i];
    }
    if lidx == 0u {
        tile_counts[list_index] = count;
        atomicAdd(&cull_stats[1], count);
        if count > CAPACITY {
            atomicAdd(&cull_stats[0], 1u);
        }
    }
}

@compute @workgroup_size(WG, WG)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>, @builtin(local_invocation_index) lidx: u32) {
    if lidx == 0u {
        // Depth is in [0, 1]: non-negative floats order like their bit patterns.
        atomicStore(&wg_min_depth, 0x7f800000u);
        atomicStore(&wg_max_depth, 0u);
        atomicStore(&wg_count[0], 0u);
        atomicStore(&wg_count[1], 0u);
    }
    workgroupBarrier();

    let tile = wid.xy;
    let origin = tile * TILE_SIZE;
    var lo = 3.4e38;
    var hi = 0.0;
    let steps = TILE_SIZE / WG;
    for (var j = 0u; j < steps; j++) {
        for (var i = 0u; i < steps; i++) {
            let p = origin + lid.xy + vec2<u32>(i, j) * WG;
            if p.x < frame.screen.x && p.y < frame.screen.y {
                let d = textureLoad(depth_texture, p, 0);
                // Sky (depth 0, the clear value) is no surface.
                if d > 0.0 {
                    lo = min(lo, d);
                    hi = max(hi, d);
                }
            }
        }
    }
    if hi > 0.0 {
        atomicMin(&wg_min_depth, bitcast<u32>(lo));
        atomicMax(&wg_max_depth, bitcast<u32>(hi));
    }
    workgroupBarrier();

    let tile_index = tile.y * frame.tiles.x + tile.x;
    let max_depth = bitcast<f32>(atomicLoad(&wg_max_depth));
    let min_depth = bitcast<f32>(atomicLoad(&wg_min_depth));
    if max_depth > 0.0 {
        // Reversed-Z: the largest depth is the nearest surface.
        let near = view_distance(max_depth);
        let far = view_distance(min_depth);
        let ndc = tile_ndc(tile, TILE_SIZE);
#ifdef HALF_Z
        let mid = 0.5 * (near + far);
        let v0 = tile_volume(ndc, near, mid);
        let v1 = tile_volume(ndc, mid, far);
        if lidx == 0u {
            tile_ranges[tile_index] = vec2<f32>(near, far);
        }
#else
        let v0 = tile_volume(ndc, near, far);
#endif
        var candidates = frame.num_lights;
#ifdef COARSE
        let cells = (frame.screen + CELL - 1u) / CELL;
        let cell_index = (origin.y / CELL) * cells.x + origin.x / CELL;
        let cell_first = cells.x * cells.y + cell_index * COARSE_CAPACITY;
        let cell_count = cell_lists[cell_index];
        let from_cell = cell_count <= COARSE_CAPACITY;
        if from_cell {
            candidates = cell_count;
        }
#endif
        for (var k = lidx; k < candidates; k += WG * WG) {
            var light = k;
#ifdef COARSE
            if from_cell {
                light = cell_lists[cell_first + k];
            }
#endif
            let cl = cull_lights[light];
            let c = (frame.view * vec4<f32>(cl.center, 1.0)).xyz;
            let r = cl.radius;
            if r <= 0.0 {
                continue;
            }
            if sphere_vs_frustum(v0, c, r) && extra_tests(v0, light, c, r) {
                append(0u, light);
            }
#ifdef HALF_Z
            if sphere_vs_frustum(v1, c, r) && extra_tests(v1, light, c, r) {
                append(1u, light);
            }
#endif
        }
    }
#ifdef HALF_Z
    else if lidx == 0u {
        tile_ranges[tile_index] = vec2<f32>(0.0, 0.0);
    }
#endif
    workgroupBarrier();

    store_list(tile_index * frame.lists_per_tile, 0u, lidx);
#ifdef HALF_Z
    store_list(tile_index * 2u + 1u, 1u, lidx);
#endif
}
