// The viewer's present pass: draws the renderer's tonemapped image (already sRGB-encoded
// in an Rgba8UnormSrgb texture) onto the window's surface, whatever its format. One
// full-screen triangle; the image is sampled with normalised coordinates so a window that
// was just resized (image still at the old size) shows it stretched, never garbage.

struct VertexOut {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@group(0) @binding(0) var image: texture_2d<f32>;
@group(0) @binding(1) var image_sampler: sampler;

@vertex
fn vs_blit(@builtin(vertex_index) i: u32) -> VertexOut {
    // Vertices (0,0), (2,0), (0,2) in uv cover the screen with one triangle.
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    var out: VertexOut;
    out.position = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
    out.uv = uv;
    return out;
}

@fragment
fn fs_blit(in: VertexOut) -> @location(0) vec4<f32> {
    return vec4<f32>(textureSample(image, image_sampler, in.uv).rgb, 1.0);
}
