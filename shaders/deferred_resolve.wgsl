// Tiled Deferred MSAA resolve: for each edge pixel the shading pass listed (deferred.wgsl),
// the mean of its SAMPLES shaded samples from the oversized sample texture, written to the
// HDR image. Non-edge pixels were written there directly. Dispatched indirectly, 64 edge
// pixels a workgroup, with the size the shading pass computed.

override SAMPLES: u32 = 4u;
override SAMPLES_X: u32 = 2u;

@group(0) @binding(0) var samples_in: texture_2d<f32>;
@group(0) @binding(1) var<storage, read> edge_list: array<u32>;
@group(0) @binding(2) var<storage, read> edge_args: array<u32, 4>;
@group(0) @binding(3) var output: texture_storage_2d<rgba16float, write>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= edge_args[3] {
        return;
    }
    let packed = edge_list[id.x];
    let p = vec2<u32>(packed & 0xffffu, packed >> 16u);
    let base = p * vec2<u32>(SAMPLES_X, SAMPLES / SAMPLES_X);
    var sum = vec3<f32>(0.0);
    for (var s = 0u; s < SAMPLES; s++) {
        sum += textureLoad(samples_in, base + vec2<u32>(s % SAMPLES_X, s / SAMPLES_X), 0).rgb;
    }
    textureStore(output, p, vec4<f32>(sum / f32(SAMPLES), 1.0));
}
