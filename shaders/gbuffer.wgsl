// Tiled Deferred's G-buffer pass: what the shared BRDF needs, per pixel.
//   target 0, Rgba16Uint: the packed surface (common/gbuffer_texel.wgsl: octahedral normal
//     already facing the viewer, sRGB base colour, roughness, metallic; 8 bytes)
//   targets 1-3 (the stress knob: 0 to 3 of them), Rgba8Unorm: written white, and
//     multiplied into the albedo when shading, so their bandwidth is real and the image unchanged.
//   location 4, with EMISSION only (a scene with emissive or occlusion-mapped materials):
//     linear emission in rgb, the occlusion factor in alpha (Rg11b10Ufloat, no alpha, when
//     nothing is occlusion-mapped: tiledlight_deferred::gbuffer says which); the deferred
//     pass adds ambient x albedo x occlusion + emission.
// Normal maps and metallic-roughness textures change only what target 0 holds.
// Alpha-masked materials discard below their cutoff (common/scene.wgsl material_sample).
// With EXTRA_TEST_VALUES (tests only, tiledlight_deferred::DeferredSettings::test_gbuffer_values)
// the extra targets hold known colours instead of white (crates/deferred/src/gbuffer.rs
// EXTRA_TEST_VALUES: keep in step), so tests can prove each one is read and multiplied in.
// variants: ALPHA_MASK TEXTURES EXTRA_TEST_VALUES EMISSION
// variants: NORMAL_MAP UV1
#include "common/scene.wgsl"
#include "common/gbuffer_texel.wgsl"

#ifdef EXTRA_TEST_VALUES
const EXTRA0 = vec4<f32>(204.0, 153.0, 230.0, 255.0) / 255.0;
const EXTRA1 = vec4<f32>(179.0, 230.0, 128.0, 255.0) / 255.0;
const EXTRA2 = vec4<f32>(230.0, 204.0, 153.0, 255.0) / 255.0;
#else
const EXTRA0 = vec4<f32>(1.0);
const EXTRA1 = vec4<f32>(1.0);
const EXTRA2 = vec4<f32>(1.0);
#endif

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    return transform_vertex(v);
}

struct Surfel {
    surface: vec4<u32>,
    emission_occlusion: vec4<f32>,
}

fn surfel(in: VertexOut, front: bool) -> Surfel {
    let ms = material_sample(in, front);
    let t = GTexel(ms.base, ms.metallic, ms.normal, ms.roughness);
    return Surfel(pack_gtexel(t), vec4<f32>(ms.emission, ms.occlusion));
}

struct Out2 {
    @location(0) surface: vec4<u32>,
#ifdef EMISSION
    @location(4) emission_occlusion: vec4<f32>,
#endif
}

struct Out3 {
    @location(0) surface: vec4<u32>,
    @location(1) extra0: vec4<f32>,
#ifdef EMISSION
    @location(4) emission_occlusion: vec4<f32>,
#endif
}

struct Out4 {
    @location(0) surface: vec4<u32>,
    @location(1) extra0: vec4<f32>,
    @location(2) extra1: vec4<f32>,
#ifdef EMISSION
    @location(4) emission_occlusion: vec4<f32>,
#endif
}

struct Out5 {
    @location(0) surface: vec4<u32>,
    @location(1) extra0: vec4<f32>,
    @location(2) extra1: vec4<f32>,
    @location(3) extra2: vec4<f32>,
#ifdef EMISSION
    @location(4) emission_occlusion: vec4<f32>,
#endif
}

@fragment
fn fs_gbuffer2(in: VertexOut, @builtin(front_facing) front: bool) -> Out2 {
    let s = surfel(in, front);
#ifdef EMISSION
    return Out2(s.surface, s.emission_occlusion);
#else
    return Out2(s.surface);
#endif
}

@fragment
fn fs_gbuffer3(in: VertexOut, @builtin(front_facing) front: bool) -> Out3 {
    let s = surfel(in, front);
#ifdef EMISSION
    return Out3(s.surface, EXTRA0, s.emission_occlusion);
#else
    return Out3(s.surface, EXTRA0);
#endif
}

@fragment
fn fs_gbuffer4(in: VertexOut, @builtin(front_facing) front: bool) -> Out4 {
    let s = surfel(in, front);
#ifdef EMISSION
    return Out4(s.surface, EXTRA0, EXTRA1, s.emission_occlusion);
#else
    return Out4(s.surface, EXTRA0, EXTRA1);
#endif
}

@fragment
fn fs_gbuffer5(in: VertexOut, @builtin(front_facing) front: bool) -> Out5 {
    let s = surfel(in, front);
#ifdef EMISSION
    return Out5(s.surface, EXTRA0, EXTRA1, EXTRA2, s.emission_occlusion);
#else
    return Out5(s.surface, EXTRA0, EXTRA1, EXTRA2);
#endif
}

// The reflective shadow map's texel (tiledlight_vpl::rsm): the same material sample,
// unpacked, into its two float targets (albedo + metallic, normal + roughness), since the
// VPL generation pass filters and sums them rather than shading them once.
struct RsmOut {
    @location(0) albedo_metallic: vec4<f32>,
    @location(1) normal_roughness: vec4<f32>,
}

@fragment
fn fs_rsm(in: VertexOut, @builtin(front_facing) front: bool) -> RsmOut {
    let ms = material_sample(in, front);
    return RsmOut(vec4<f32>(ms.base, ms.metallic), vec4<f32>(ms.normal, ms.roughness));
}
