// First level of two-level culling: one 16x16 workgroup per 64x64-pixel cell. Min/max depth
// of the cell's non-sky pixels, then every light's bounding sphere against the cell's side
// planes and depth range; survivors are written to the cell's region of a global list with
// the true count. The per-tile kernel (cull.wgsl with COARSE) then tests only those.
// The CPU reference is crates/cull/src/reference.rs (coarse_cells).
// variants: MSAA
#include "common/cull_tests.wgsl"
#include "common/lights.wgsl"
#include "common/depth_range.wgsl"

// Cell side in pixels and the indices a cell stores (keep in step with
// tiledlight_cull::lists::{COARSE_SIZE, COARSE_CAPACITY}: set by the pipeline).
override CELL: u32 = 64u;
override COARSE_CAPACITY: u32 = 8192u;
const WG: u32 = 16u;

@group(1) @binding(1) var<storage, read> cull_lights: array<CullLight>;
// One buffer (a storage-buffer binding is scarce: 8 per stage): the cells' true counts,
// then COARSE_CAPACITY indices per cell.
@group(1) @binding(2) var<storage, read_write> cell_lists: array<u32>;
@group(1) @binding(3) var<uniform> lighting: Lighting;

var<workgroup> wg_count: atomic<u32>;

@compute @workgroup_size(16, 16)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>, @builtin(local_invocation_index) lidx: u32) {
    if lidx == 0u {
        atomicStore(&wg_count, 0u);
    }
    let cell = wid.xy;
    let range = region_depth_range(cell * CELL, CELL, WG, lid.xy, lidx);
    let cells = (view.screen + CELL - 1u) / CELL;
    let cell_index = cell.y * cells.x + cell.x;
    let first = cells.x * cells.y + cell_index * COARSE_CAPACITY;
    if range.y > 0.0 {
        let v = tile_volume(tile_ndc(cell, CELL), view_distance(range.y), view_distance(range.x));
        for (var light = lidx; light < lighting.num_lights; light += WG * WG) {
            let cl = cull_lights[light];
            let c = (view.world_to_view * vec4<f32>(cl.center, 1.0)).xyz;
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
