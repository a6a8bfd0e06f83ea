// Tiled Deferred: one compute dispatch culls and shades. Each workgroup culls its tile with
// the same code as Forward+ (common/tile_cull.wgsl) into workgroup memory, then each thread
// shades its pixels from the G-buffer with that list (its half with HALF_Z) and the shared
// BRDF, writing linear HDR to a storage texture. Per-list counts are written for the heat
// map and for tests. With EXTRA_RTS the stress knob's extra G-buffer targets (NUM_EXTRA
// layers, all white) are read and multiplied into the albedo.
// variants: SPOT_LIGHTS HALF_Z AABB SPOT_CONE COARSE EXTRA_RTS
#include "common/tile_cull.wgsl"
#include "common/shade.wgsl"

@group(1) @binding(0) var depth_texture: texture_depth_2d;
@group(1) @binding(1) var<storage, read> cull_lights: array<CullLight>;
// Per list: the number of lights found (may exceed CAPACITY).
@group(1) @binding(2) var<storage, read_write> tile_counts: array<u32>;
@group(1) @binding(3) var gbuffer_albedo: texture_2d<f32>;
@group(1) @binding(4) var gbuffer_normal: texture_2d<f32>;
#ifdef EXTRA_RTS
override NUM_EXTRA: u32 = 1u;
@group(1) @binding(5) var gbuffer_extra: texture_2d_array<f32>;
#endif
@group(1) @binding(6) var<storage, read> shading_lights: array<ShadingLight>;
#ifdef SPOT_LIGHTS
@group(1) @binding(7) var<storage, read> spot_lights: array<SpotLight>;
#else
#ifdef SPOT_CONE
@group(1) @binding(7) var<storage, read> spot_lights: array<SpotLight>;
#endif
#endif
#ifdef COARSE
// Cell counts, then COARSE_CAPACITY indices per cell (see cull_coarse.wgsl).
@group(1) @binding(8) var<storage, read> cell_lists: array<u32>;
#endif
@group(1) @binding(9) var output: texture_storage_2d<rgba16float, write>;

fn shade_pixel(p: vec2<u32>, t: TileCull, counts: vec2<u32>) {
    let d = textureLoad(depth_texture, p, 0);
    if d <= 0.0 {
        // Sky: black, as the forward pass's clear.
        textureStore(output, p, vec4<f32>(0.0, 0.0, 0.0, 1.0));
        return;
    }
    let dist = view_distance(d);
    let view_pos = view_point_at(pixel_to_ndc(vec2<f32>(p) + 0.5), dist);
    let world = (frame.inv_view * vec4<f32>(view_pos, 1.0)).xyz;
    let am = textureLoad(gbuffer_albedo, p, 0);
    let nr = textureLoad(gbuffer_normal, p, 0);
    var albedo = am.rgb;
#ifdef EXTRA_RTS
    for (var k = 0u; k < NUM_EXTRA; k++) {
        albedo *= textureLoad(gbuffer_extra, p, k, 0).rgb;
    }
#endif
    let n = normalize(nr.xyz);
    let v = view_vector(world);
    let s = Surface(albedo, nr.w, am.a);
    var color = frame.ambient * albedo;
#ifdef HALF_Z
    if dist > half_z_split(t.near, t.far) {
        for (var i = 0u; i < counts.y; i++) {
            color += shade_light(wg_list_far[i], world, n, v, s);
        }
        textureStore(output, p, vec4<f32>(color, 1.0));
        return;
    }
#endif
    for (var i = 0u; i < counts.x; i++) {
        color += shade_light(wg_list[i], world, n, v, s);
    }
    textureStore(output, p, vec4<f32>(color, 1.0));
}

@compute @workgroup_size(WG, WG)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>, @builtin(local_invocation_index) lidx: u32) {
    let t = cull_tile(wid.xy, lid.xy, lidx);
    let found = vec2<u32>(atomicLoad(&wg_count[0]), atomicLoad(&wg_count[1]));
    if lidx == 0u {
        tile_counts[t.index * frame.lists_per_tile] = found.x;
#ifdef HALF_Z
        tile_counts[t.index * 2u + 1u] = found.y;
#endif
    }
    let counts = min(found, vec2<u32>(CAPACITY));
    let origin = wid.xy * TILE_SIZE;
    let steps = TILE_SIZE / WG;
    for (var j = 0u; j < steps; j++) {
        for (var i = 0u; i < steps; i++) {
            let p = origin + lid.xy + vec2<u32>(i, j) * WG;
            if p.x < frame.screen.x && p.y < frame.screen.y {
                shade_pixel(p, t, counts);
            }
        }
    }
}
