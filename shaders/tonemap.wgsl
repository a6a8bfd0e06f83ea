// Tonemapping for display: exposure, the ACES filmic fit (Narkowicz 2015), and the sRGB
// encoding, in a compute pass (a thread a pixel): the display image is Rgba8Unorm (sRGB
// formats cannot be storage textures), so the shader encodes and the bytes are sRGB.
// The pass's own parameters (crates/gpu/src/tonemap.rs, TonemapUniforms): written when
// they change, so changing the exposure rebuilds nothing.
struct Tonemap {
    exposure: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

#include "common/srgb.wgsl"

// With AUTO_EXPOSURE the exposure is exposure.wgsl's, computed from this frame's image.
// variants: AUTO_EXPOSURE
@group(0) @binding(0) var hdr: texture_2d<f32>;
@group(0) @binding(1) var<uniform> params: Tonemap;
#ifdef AUTO_EXPOSURE
@group(0) @binding(2) var<storage, read> auto_exposure: array<f32>;
#endif
@group(0) @binding(3) var ldr: texture_storage_2d<rgba8unorm, write>;

fn aces(x: vec3<f32>) -> vec3<f32> {
    let a = 2.51;
    let b = 0.03;
    let c = 2.43;
    let d = 0.59;
    let e = 0.14;
    return saturate((x * (a * x + b)) / (x * (c * x + d) + e));
}

@compute @workgroup_size(8, 8)
fn cs_tonemap(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(hdr);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let c = textureLoad(hdr, id.xy, 0).rgb;
#ifdef AUTO_EXPOSURE
    let e = auto_exposure[0];
#else
    let e = params.exposure;
#endif
    textureStore(ldr, id.xy, vec4<f32>(linear_to_srgb(aces(c * e)), 1.0));
}
