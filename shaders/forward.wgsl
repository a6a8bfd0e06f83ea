// Forward shading: each fragment loops over its tile's light list (Forward+), or over every
// light (BRUTE_FORCE, the reference renderer), with the shared BRDF, into linear HDR.
// The depth test is Equal against the pre-pass, so each pixel is shaded once.
// Alpha-masked draws (ALPHA_MASK) discard as the pre-pass did: depth Equal alone would let a
// masked-out texel shade a coplanar surface behind it.
// variants: SPOT_LIGHTS TEXTURES HALF_Z BRUTE_FORCE NO_CUTOFF ALPHA_MASK
#include "common/scene.wgsl"
#include "common/shade.wgsl"

@group(3) @binding(0) var<storage, read> shading_lights: array<ShadingLight>;
#ifdef SPOT_LIGHTS
@group(3) @binding(1) var<storage, read> spot_lights: array<SpotLight>;
#endif
#ifndef BRUTE_FORCE
@group(3) @binding(2) var<storage, read> tile_counts: array<u32>;
@group(3) @binding(3) var<storage, read> tile_indices: array<u32>;
#ifdef HALF_Z
@group(3) @binding(4) var<storage, read> tile_ranges: array<vec2<f32>>;
#endif
#endif

@vertex
fn vs_main(
    @builtin(instance_index) instance: u32,
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
) -> VertexOut {
    return transform_vertex(instance, position, normal, uv);
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    let ms = material_sample(in, front);
    let n = ms.normal;
    let v = view_vector(in.world_pos);
    let s = Surface(ms.base, ms.roughness, ms.metallic);
    var color = frame.ambient * ms.base;
#ifdef BRUTE_FORCE
    for (var i = 0u; i < frame.num_lights; i++) {
        color += shade_light(i, in.world_pos, n, v, s);
    }
#else
    let tile = vec2<u32>(in.clip.xy) / frame.tile_size;
    let tile_index = tile.y * frame.tiles.x + tile.x;
    var list = tile_index;
#ifdef HALF_Z
    let range = tile_ranges[tile_index];
    let dist = view_distance(in.clip.z);
    list = tile_index * 2u + select(0u, 1u, dist > 0.5 * (range.x + range.y));
#endif
    let count = min(tile_counts[list], frame.capacity);
    let first = list * frame.capacity;
    for (var i = 0u; i < count; i++) {
        color += shade_light(tile_indices[first + i], in.world_pos, n, v, s);
    }
#endif
    return vec4<f32>(color, 1.0);
}
