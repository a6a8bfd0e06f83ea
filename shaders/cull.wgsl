// Tiled light culling for Forward+: one workgroup per tile (common/tile_cull.wgsl). Min/max
// depth of the tile's non-sky pixels reduced in workgroup memory, the tile's view volume
// built, every light tested in parallel, survivors appended to a workgroup list, then the
// list written to the light grid (common/light_grid_write.wgsl): indices allocated from the
// frame's real number of pairs, a list longer than the workgroup list culled again straight
// into the grid, missing pairs counted when the grid is full (nothing written out of bounds).
// The CPU reference is crates/cull/src/reference.rs (cull_tiles).
// With COARSE, each tile tests only the lights of its 64x64-pixel cell (cull_coarse.wgsl),
// or every light when the cell overflowed.
// With MSAA the depth buffer is multisampled and the tile's range covers every sample.
// With BLENDED it culls for blended geometry (tiledlight_gpu::blended): the range runs from
// the nearest blended depth to the opaque depth behind it, over the samples with blended
// geometry in front (common/depth_range.wgsl); one list per tile, planes only, one level.
// With DEPTH_MASK (2.5D, Harada 2012) a light must also meet a depth bin of the tile that
// holds a surface (32 bins over the tile's range; one list per tile).
// variants: HALF_Z SPOT_CONE COARSE MSAA DROP_LIGHT BLENDED DEPTH_MASK
#include "common/tile_cull.wgsl"
#include "common/light_grid_write.wgsl"

@group(1) @binding(1) var<storage, read> cull_lights: array<CullLight>;
@group(1) @binding(9) var<uniform> lighting: Lighting;
#ifdef COARSE
// Cell counts, then COARSE_CAPACITY indices per cell (see cull_coarse.wgsl).
@group(1) @binding(8) var<storage, read> cell_lists: array<u32>;
#endif
#ifdef SPOT_CONE
@group(1) @binding(6) var<storage, read> shading_lights: array<ShadingLight>;
@group(1) @binding(7) var<storage, read> spot_lights: array<SpotLight>;
#endif
// The light grid (crates/gpu/src/light_grid.rs).
@group(2) @binding(0) var<storage, read_write> light_grid: LightGridRw;
@group(2) @binding(1) var<storage, read_write> light_indices: array<u32>;
#ifdef HALF_Z
// Per tile: near and far view distance of its surfaces (the pixel picks its half).
@group(2) @binding(2) var<storage, read_write> tile_ranges: array<vec2<f32>>;
#endif

@compute @workgroup_size(WG, WG)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>, @builtin(local_invocation_index) lidx: u32) {
    let t = cull_tile(wid.xy, lid.xy, lidx);
#ifdef HALF_Z
    if lidx == 0u {
        tile_ranges[t.index] = vec2<f32>(t.near, t.far);
    }
#endif
    write_lists(t, t.index * lists_per_tile(), lidx);
}
