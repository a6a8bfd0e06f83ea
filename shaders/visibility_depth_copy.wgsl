// The visibility buffer's compute raster in a scene with blended geometry: its R32Float
// depth copied into the frame's Depth32Float attachment, which the blended passes test
// against (a compute pass cannot write a depth texture, nor a copy fill one). A full-screen
// triangle writing @builtin(frag_depth); only such scenes have this pass.
// Bindings: crates/visibility/src/raster.rs (DEPTH_COPY_BINDINGS).

@group(0) @binding(0) var source: texture_2d<f32>;

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn fs_main(@builtin(position) p: vec4<f32>) -> @builtin(frag_depth) f32 {
    return textureLoad(source, vec2<u32>(p.xy), 0).x;
}
