// Heat map of lights per tile over the tonemapped image: a log-scale palette from 1 light
// (blue) to the workgroup list capacity (red, also for longer lists); tiles that lost lights
// because the light grid was full are magenta; tiles with no light keep the image. With
// half-z the two lists' counts are summed, with clusters the fullest slice's is shown.
// Reads the light grid's lists (true counts).
// No view: the grid header says the tiling (a pass that only needs the grid).
@group(0) @binding(0) var<storage, read> light_grid: LightGrid;
#include "common/light_grid.wgsl"

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

// Blue -> cyan -> green -> yellow -> red for t in [0, 1].
fn palette(t: f32) -> vec3<f32> {
    let x = saturate(t) * 4.0;
    let r = saturate(x - 2.0);
    let g = select(saturate(x - 0.0), saturate(4.0 - x), x > 2.0);
    let b = saturate(2.0 - x);
    return vec3<f32>(r, g, b);
}

@fragment
fn fs_heatmap(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let h = light_grid.header;
    let tile = vec2<u32>(pos.xy) / h.tile_size;
    let t = tile.y * h.tiles.x + tile.x;
    var count = 0u;
    var overflow = false;
    for (var k = 0u; k < h.lists_per_tile; k++) {
        let l = t * h.lists_per_tile + k;
        let c = light_grid.lists[l].y;
        // Half-z: the two halves' sum (the tile's lights); clusters: the fullest slice
        // (summing the slices would count a light once per slice it spans).
        count = select(count + c, max(count, c), h.lists_per_tile > 2u);
        overflow = overflow || light_list(light_grid.lists[l], h.capacity).count < c;
    }
    if count == 0u {
        return vec4<f32>(0.0);
    }
    if overflow {
        return vec4<f32>(1.0, 0.0, 1.0, 0.75);
    }
    let t_log = log2(f32(count)) / log2(f32(max(h.list_capacity, 2u)));
    return vec4<f32>(palette(t_log), 0.6);
}
