// Debug readback: copies every sample of a multisampled reversed-Z depth buffer into a
// storage buffer, pixel-major (pixel (x, y) sample s at (y * width + x) * samples + s), since
// multisampled textures cannot be copied to buffers. Used by tests and statistics, never per
// frame; the CPU reference reads the same layout (tiledlight_cull::tiles::tile_depth_bounds_samples).

@group(0) @binding(0) var depth_texture: texture_depth_multisampled_2d;
@group(0) @binding(1) var<storage, read_write> out_samples: array<f32>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth_texture);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let n = textureNumSamples(depth_texture);
    let first = (id.y * size.x + id.x) * n;
    for (var s = 0u; s < n; s++) {
        out_samples[first + s] = textureLoad(depth_texture, id.xy, s);
    }
}
