// Scene geometry bindings and the shared vertex transform.
// Keep in sync with crates/gpu/src/scene_gpu.rs (GpuInstance, GpuMaterial).
#include "common/view.wgsl"

struct Instance {
    model: mat4x4<f32>,
    normal_matrix: mat3x3<f32>,
    material: u32,
}

struct Material {
    base_color: vec4<f32>,
    roughness: f32,
    metallic: f32,
    alpha_cutoff: f32,
    has_texture: u32,
}

@group(1) @binding(0) var<storage, read> instances: array<Instance>;
@group(1) @binding(1) var<storage, read> materials: array<Material>;

#ifdef TEXTURES
@group(2) @binding(0) var base_color_texture: texture_2d<f32>;
@group(2) @binding(1) var base_color_sampler: sampler;
#endif

// Base colour and alpha of a material at `uv`.
fn material_color(m: Material, uv: vec2<f32>) -> vec4<f32> {
    var c = m.base_color;
#ifdef TEXTURES
    // Sampled unconditionally: textureSample needs uniform control flow (derivatives).
    let t = textureSample(base_color_texture, base_color_sampler, uv);
    c *= select(vec4<f32>(1.0), t, m.has_texture != 0u);
#endif
    return c;
}

struct VertexOut {
    // Invariant: the shading pass tests depth Equal against the pre-pass.
    @invariant @builtin(position) clip: vec4<f32>,
    // Centroid: with MSAA a pixel whose centre lies outside the triangle is shaded at a
    // covered point, not extrapolated off the surface (no change without MSAA).
    @location(0) @interpolate(perspective, centroid) world_pos: vec3<f32>,
    @location(1) @interpolate(perspective, centroid) normal: vec3<f32>,
    @location(2) @interpolate(perspective, centroid) uv: vec2<f32>,
    @location(3) @interpolate(flat) material: u32,
}

fn transform_vertex(instance_index: u32, position: vec3<f32>, normal: vec3<f32>, uv: vec2<f32>) -> VertexOut {
    let inst = instances[instance_index];
    let world = inst.model * vec4<f32>(position, 1.0);
    var out: VertexOut;
    out.clip = view.world_to_clip * world;
    out.world_pos = world.xyz;
    out.normal = inst.normal_matrix * normal;
    out.uv = uv;
    out.material = inst.material;
    return out;
}

// Clip position only: the same arithmetic as transform_vertex so depths match exactly.
fn transform_position(instance_index: u32, position: vec3<f32>) -> vec4<f32> {
    let world = instances[instance_index].model * vec4<f32>(position, 1.0);
    return view.world_to_clip * world;
}

// The material seen by a rasterised fragment, for the shading pass and the G-buffer alike.
struct MaterialSample {
    base: vec3<f32>,
    roughness: f32,
    metallic: f32,
    // Unit normal facing the viewer: double-sided surfaces seen from behind are lit on
    // their back.
    normal: vec3<f32>,
}

// The material at fragment `in`. With ALPHA_MASK it discards below the material's cutoff,
// as the depth pre-pass does: call it only from fragment entry points.
fn material_sample(in: VertexOut, front: bool) -> MaterialSample {
    let m = materials[in.material];
    let base = material_color(m, in.uv);
#ifdef ALPHA_MASK
    if base.a < m.alpha_cutoff {
        discard;
    }
#endif
    let n = normalize(in.normal);
    return MaterialSample(base.rgb, m.roughness, m.metallic, select(-n, n, front));
}
