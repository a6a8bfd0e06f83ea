// Tiled Deferred's G-buffer pass: what the shared BRDF needs, per pixel.
//   target 0, Rgba8UnormSrgb: base colour (sRGB-encoded like the textures it comes from), metallic in alpha
//   target 1, Rgba16Float:    unit normal (already facing the viewer), roughness in alpha
//   targets 2-4 (the stress knob, 3 to 5 targets in all), Rgba8Unorm: written white, and
//   multiplied into the albedo when shading, so their bandwidth is real and the image unchanged.
// Alpha-masked materials discard below their cutoff (common/scene.wgsl material_sample).
// With EXTRA_TEST_VALUES (tests only, tiledlight_deferred::DeferredSettings::test_gbuffer_values)
// the extra targets hold known colours instead of white (crates/deferred/src/gbuffer.rs
// EXTRA_TEST_VALUES: keep in step), so tests can prove each one is read and multiplied in.
// variants: ALPHA_MASK TEXTURES EXTRA_TEST_VALUES
#include "common/scene.wgsl"

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
fn vs_main(
    @builtin(instance_index) instance: u32,
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
) -> VertexOut {
    return transform_vertex(instance, position, normal, uv);
}

struct Surfel {
    albedo_metallic: vec4<f32>,
    normal_roughness: vec4<f32>,
}

fn surfel(in: VertexOut, front: bool) -> Surfel {
    let ms = material_sample(in, front);
    return Surfel(vec4<f32>(ms.base, ms.metallic), vec4<f32>(ms.normal, ms.roughness));
}

struct Out2 {
    @location(0) albedo_metallic: vec4<f32>,
    @location(1) normal_roughness: vec4<f32>,
}

struct Out3 {
    @location(0) albedo_metallic: vec4<f32>,
    @location(1) normal_roughness: vec4<f32>,
    @location(2) extra0: vec4<f32>,
}

struct Out4 {
    @location(0) albedo_metallic: vec4<f32>,
    @location(1) normal_roughness: vec4<f32>,
    @location(2) extra0: vec4<f32>,
    @location(3) extra1: vec4<f32>,
}

struct Out5 {
    @location(0) albedo_metallic: vec4<f32>,
    @location(1) normal_roughness: vec4<f32>,
    @location(2) extra0: vec4<f32>,
    @location(3) extra1: vec4<f32>,
    @location(4) extra2: vec4<f32>,
}

@fragment
fn fs_gbuffer2(in: VertexOut, @builtin(front_facing) front: bool) -> Out2 {
    let s = surfel(in, front);
    return Out2(s.albedo_metallic, s.normal_roughness);
}

@fragment
fn fs_gbuffer3(in: VertexOut, @builtin(front_facing) front: bool) -> Out3 {
    let s = surfel(in, front);
    return Out3(s.albedo_metallic, s.normal_roughness, EXTRA0);
}

@fragment
fn fs_gbuffer4(in: VertexOut, @builtin(front_facing) front: bool) -> Out4 {
    let s = surfel(in, front);
    return Out4(s.albedo_metallic, s.normal_roughness, EXTRA0, EXTRA1);
}

@fragment
fn fs_gbuffer5(in: VertexOut, @builtin(front_facing) front: bool) -> Out5 {
    let s = surfel(in, front);
    return Out5(s.albedo_metallic, s.normal_roughness, EXTRA0, EXTRA1, EXTRA2);
}
