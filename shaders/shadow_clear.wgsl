// Clears one shadow face: a triangle covering the viewport (the face's tile) at depth 0,
// the far plane of reversed-Z, written with compare Always. A render pass can only clear
// a whole layer, and the other faces of the layer may still be valid.

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}
