// Tonemapping for display: exposure, the ACES filmic fit (Narkowicz 2015), and the sRGB
// encoding done by the Rgba8UnormSrgb target. A full-screen triangle reads the HDR image.
// The pass's own parameters (crates/gpu/src/tonemap.rs, TonemapUniforms): written when
// they change, so changing the exposure rebuilds nothing.
struct Tonemap {
    exposure: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

// With AUTO_EXPOSURE the exposure is exposure.wgsl's, computed from this frame's image.
// variants: AUTO_EXPOSURE
@group(0) @binding(0) var hdr: texture_2d<f32>;
@group(0) @binding(1) var<uniform> params: Tonemap;
#ifdef AUTO_EXPOSURE
@group(0) @binding(2) var<storage, read> auto_exposure: array<f32>;
#endif

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

fn aces(x: vec3<f32>) -> vec3<f32> {
    let a = 2.51;
    let b = 0.03;
    let c = 2.43;
    let d = 0.59;
    let e = 0.14;
    return saturate((x * (a * x + b)) / (x * (c * x + d) + e));
}

@fragment
fn fs_tonemap(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let c = textureLoad(hdr, vec2<i32>(pos.xy), 0).rgb;
#ifdef AUTO_EXPOSURE
    let e = auto_exposure[0];
#else
    let e = params.exposure;
#endif
    return vec4<f32>(aces(c * e), 1.0);
}
