// First level of two-level culling: one 16x16 workgroup per 64x64-pixel cell. Min/max depth
// of the cell's non-sky pixels, then every light's bounding sphere against the cell's side
// planes and depth range; survivors are written to the cell's region of a global list with
// the true count. The per-tile kernel (cull.wgsl with COARSE) then tests only those.
// The CPU reference is crates/cull/src/reference.rs (coarse_cells).
#include "common/cull_tests.wgsl"
#include "common/lights.wgsl"

// Cell side in pixels and the indices a cell stores (keep in step with
// tiledlight_cull::reference::{COARSE_SIZE, COARSE_CAPACITY}: set by the pipeline).
override CELL: u32 = 64u;
override COARSE_CAPACITY: u32 = 8192u;
const WG: u32 = 16u;

@group(1) @binding(0) var depth_texture: texture_depth_2d;
@group(1) @binding(1) var<storage, read> cull_lights: array<CullLight>;
// One buffer (a storage-buffer binding is scarce: 8 per stage): the cells' true counts,
// then COARSE_CAPACITY indices per cell.
@group(1) @binding(2) var<storage, read_write> cell_lists: array<u32>;

var<workgroup> wg_min_depth: atomic<u32>;
var<workgroup> wg_max_depth: atomic<u32>;
var<workgroup> wg_count: atomic<u32>;

@compute @workgroup_size(16, 16)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>, @builtin(local_invocation_index) lidx: u32) {
    if lidx == 0u {
        atomicStore(&wg_min_depth, 0x7f800000u);
        atomicStore(&wg_max_depth, 0u);
        atomicStore(&wg_count, 0u);
    }
    workgroupBarrier();
    let cell = wid.xy;
    let origin = cell * CELL;
    var lo = 3.4e38;
    var hi = 0.0;
    let steps = CELL / WG;
    for (var j = 0u; j < steps; j++) {
        for (var i = 0u; i < steps; i++) {
            let p = origin + lid.xy + vec2<u32>(i, j) * WG;
            if p.x < frame.screen.x && p.y < frame.screen.y {
                let d = textureLoad(depth_texture, p, 0);
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
    let cells = (frame.screen + CELL - 1u) / CELL;
    let cell_index = cell.y * cells.x + cell.x;
    let first = cells.x * cells.y + cell_index * COARSE_CAPACITY;
    let max_depth = bitcast<f32>(atomicLoad(&wg_max_depth));
    let min_depth = bitcast<f32>(atomicLoad(&wg_min_depth));
    if max_depth > 0.0 {
        let v = tile_volume(tile_ndc(cell, CELL), view_distance(max_depth), view_distance(min_depth));
        for (var light = lidx; light < frame.num_lights; light += WG * WG) {
            let cl = cull_lights[light];
            let c = (frame.view * vec4<f32>(cl.center, 1.0)).xyz;
            if cl.radius > 0.0 && sphere_vs_frustum(v, c, cl.radius) {
                let slot = atomicAdd(&wg_count, 1u);
                if slot < COARSE_CAPACITY {
                    cell_lists[first + slot] = light;
                }
            }
        }
    }
    workgroupBarrier();
    if lidx == 0u {
        cell_lists[cell_index] = atomicLoad(&wg_count);
    }
}
