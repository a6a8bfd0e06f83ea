// Composites the transparent layer (premultiplied colour and coverage, crates/gpu/src/
// blended.rs) over the opaque HDR image: the pipeline blends One, OneMinusSrcAlpha, so the
// result is layer.rgb + (1 - layer.a) * opaque.
// With WBOIT the layer is built here from the accumulation and revealage targets
// (McGuire and Bavoil 2013): colour = accum.rgb / accum.a, coverage = 1 - revealage.
// variants: WBOIT

@group(0) @binding(0) var layer: texture_2d<f32>;
#ifdef WBOIT
@group(0) @binding(1) var revealage: texture_2d<f32>;
#endif

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn fs_main(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let p = vec2<i32>(pos.xy);
#ifdef WBOIT
    let accum = textureLoad(layer, p, 0);
    let coverage = 1.0 - textureLoad(revealage, p, 0).r;
    return vec4<f32>(accum.rgb / max(accum.a, 1e-5) * coverage, coverage);
#else
    return textureLoad(layer, p, 0);
#endif
}
