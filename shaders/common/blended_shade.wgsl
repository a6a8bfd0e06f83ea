// The blended shading pass's body, shared by its entry files (one per light loop:
// blended.wgsl, blended_brute_force.wgsl).
// Alpha-blended geometry (crates/gpu/src/blended.rs): each blended surface shaded forward
// with the shared BRDF, lit from both sides (the normal faces the viewer), over the lights
// of its tile's blended list (or every light with BRUTE_FORCE), and written with
// premultiplied alpha into the transparent layer, instances drawn back to front. The layer
// is composited over the opaque image afterwards (blended_composite.wgsl). Depth is tested
// against the opaque depth and not written.
// With WBOIT (weighted blended order-independent transparency, McGuire and Bavoil, JCGT
// 2(2) 2013) nothing is sorted: each fragment adds its premultiplied colour and coverage,
// weighted by its depth, to an accumulation target and multiplies the revealage target by
// (1 - alpha); blended_composite.wgsl turns the two into the layer.
// With CLUSTERED the list is the frame's own clustered grid's, at the fragment's depth slice
// (clusters of the whole frustum list every light of their volume, surface or not).
// Materials as in the opaque passes (common/scene.wgsl material_sample, with its defines);
// emission is part of the surface's colour, so it is weighted by coverage like the rest.
#include "common/scene.wgsl"
#include "common/lights_group.wgsl"

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    return transform_vertex(v);
}

#ifdef WBOIT
struct WboitOut {
    @location(0) accum: vec4<f32>,
    @location(1) revealage: vec4<f32>,
}

// McGuire and Bavoil's weight (their equation 9, view depth in metres): nearer and more
// opaque fragments weigh more; clamped so f16 accumulation neither overflows nor vanishes.
fn wboit_weight(alpha: f32, view_depth: f32) -> f32 {
    let d = view_depth / 200.0;
    return alpha * clamp(0.03 / (1e-5 + d * d * d * d), 1e-2, 3e3);
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front: bool) -> WboitOut {
    let c = shade_blended(in, front);
    let w = wboit_weight(c.a, view_distance(in.clip.z));
    return WboitOut(vec4<f32>(c.rgb * w, c.a * w), vec4<f32>(c.a));
}
#else
@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    return shade_blended(in, front);
}
#endif

// The blended surface's premultiplied colour and coverage.
fn shade_blended(in: VertexOut, front: bool) -> vec4<f32> {
    let ms = material_sample(in, front);
    let n = ms.normal;
    let v = view_vector(in.world_pos);
    let s = Surface(ms.base, ms.roughness, ms.metallic);
    var color = unlit_term(lighting.ambient, ms);
#ifdef BRUTE_FORCE
    for (var i = 0u; i < lighting.num_lights; i++) {
        color += shade_light(i, in.world_pos, n, v, s);
    }
#else
#ifdef CLUSTERED
    let list = pixel_list(vec2<u32>(in.clip.xy), view_distance(in.clip.z));
#else
    let list = pixel_list(vec2<u32>(in.clip.xy), 0.0);
#endif
    for (var i = 0u; i < list.count; i++) {
        color += shade_light(light_indices[list.first + i], in.world_pos, n, v, s);
    }
#endif
    return vec4<f32>(color * ms.alpha, ms.alpha);
}
