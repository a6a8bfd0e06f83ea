// Scene geometry bindings, the shared vertex transform and the material model.
// Keep in sync with crates/gpu/src/scene_gpu.rs (GpuInstance, GpuMaterial, MaterialFeatures);
// the CPU twin of the material maths is crates/cull/src/material.rs, of texture sampling
// crates/cull/src/texture.rs.
//
// Material defines, each set only when some material of the scene needs it
// (tiledlight_gpu::scene_gpu::MaterialFeatures):
//   TEXTURES    group 2 exists: every material's textures in eight texture arrays
//               (common/material_textures.wgsl), and the texture transforms
//   NORMAL_MAP  the tangent vertex attribute (needs TEXTURES)
//   UV1         the second texture coordinate set (needs TEXTURES)
// Which slots a material has textures in is a per-material bit (Material.textures), tested
// per pixel: the kernels' variants do not grow with the materials, and one draw or
// dispatch shades any mix of them. Without TEXTURES no texture is read and texture
// transforms are not applied (there is nothing to transform).
#include "common/view.wgsl"

struct Instance {
    model: mat4x4<f32>,
    normal_matrix: mat3x3<f32>,
    material: u32,
    // +1, or -1 when the model matrix mirrors: the bitangent flips with it.
    det_sign: f32,
    // Its mesh in the merged index and vertex buffers (the visibility buffer's compute pass
    // fetches a triangle's vertices with them).
    first_index: u32,
    base_vertex: i32,
}

// Texture slots: bit k of Material.textures and Material.uv1_sets, rows 2k and 2k+1 of
// Material.uv_rows.
const SLOT_BASE: u32 = 0u;
const SLOT_MR: u32 = 1u;
const SLOT_NORMAL: u32 = 2u;
const SLOT_OCCLUSION: u32 = 3u;
const SLOT_EMISSIVE: u32 = 4u;

struct Material {
    base_color: vec4<f32>,
    // Linear emitted radiance: factor times KHR_materials_emissive_strength.
    emissive: vec3<f32>,
    roughness: f32,
    metallic: f32,
    alpha_cutoff: f32,
    normal_scale: f32,
    occlusion_strength: f32,
    // Bit per slot: the material has a texture there.
    textures: u32,
    // Bit per slot: the slot reads texture coordinate set 1.
    uv1_sets: u32,
    // Per slot, KHR_texture_transform as two rows of a 2x3 matrix (xyz; w unused).
    uv_rows: array<vec4<f32>, 10>,
    // Per slot, where its texture lives and how it is sampled.
    slots: array<TextureSlot, 5>,
}

// A material slot's texture (tiledlight_gpu::texture_arrays::GpuTextureSlot). place: array
// (bits 0-3), layer (4-31); size: width (0-15), height (16-31); sampling: wrap u (0-1),
// wrap v (2-3: 0 repeat, 1 mirrored, 2 clamp), mag linear (4), min linear (5), mipmap (6-7:
// 0 none, 1 nearest, 2 linear), mip count (8-12).
struct TextureSlot {
    place: u32,
    size: u32,
    sampling: u32,
    pad: u32,
}

#ifdef VISIBILITY
// The visibility buffer's compute pass: its group 1 holds the lights, so the scene's
// buffers come after them (common/visibility_surface.wgsl).
@group(1) @binding(24) var<storage, read> instances: array<Instance>;
@group(1) @binding(25) var<storage, read> materials: array<Material>;
#else
@group(1) @binding(0) var<storage, read> instances: array<Instance>;
@group(1) @binding(1) var<storage, read> materials: array<Material>;
#endif

#ifdef TEXTURES
#include "common/material_textures.wgsl"
#endif

// A fragment's texture coordinate sets with their screen-space derivatives, taken from the
// interpolated varyings themselves (call uv_sets in uniform control flow). Textures are
// sampled with these gradients carried through each slot's transform (textureSampleGrad),
// not with implicit derivatives of the transformed coordinates: those would difference
// values read from the material buffer in helper invocations, which a GPU need not load
// (llvmpipe returns zeros there, and the mip level went wrong).
struct UvSets {
    uv0: vec2<f32>,
    dx0: vec2<f32>,
    dy0: vec2<f32>,
    uv1: vec2<f32>,
    dx1: vec2<f32>,
    dy1: vec2<f32>,
}

fn uv_sets(uv0: vec2<f32>, uv1: vec2<f32>) -> UvSets {
#ifdef UV1
    return UvSets(uv0, dpdx(uv0), dpdy(uv0), uv1, dpdx(uv1), dpdy(uv1));
#else
    let dx = dpdx(uv0);
    let dy = dpdy(uv0);
    return UvSets(uv0, dx, dy, uv0, dx, dy);
#endif
}

// Whether material `mi` has a texture in slot `slot`.
fn has_slot(mi: u32, slot: u32) -> bool {
    return ((materials[mi].textures >> slot) & 1u) != 0u;
}

#ifdef TEXTURES
// Samples slot `slot` of material `mi` (which must have a texture there): its coordinate
// set, through its transform (the gradients through the transform's linear part).
fn sample_slot(mi: u32, slot: u32, sets: UvSets) -> vec4<f32> {
    var uv = sets.uv0;
    var dx = sets.dx0;
    var dy = sets.dy0;
#ifdef UV1
    if ((materials[mi].uv1_sets >> slot) & 1u) != 0u {
        uv = sets.uv1;
        dx = sets.dx1;
        dy = sets.dy1;
    }
#endif
    let r0 = materials[mi].uv_rows[2u * slot];
    let r1 = materials[mi].uv_rows[2u * slot + 1u];
    let tuv = vec2<f32>(dot(r0.xy, uv) + r0.z, dot(r1.xy, uv) + r1.z);
    let tdx = vec2<f32>(dot(r0.xy, dx), dot(r1.xy, dx));
    let tdy = vec2<f32>(dot(r0.xy, dy), dot(r1.xy, dy));
    return sample_texture(materials[mi].slots[slot], tuv, tdx, tdy);
}
#endif

// Base colour and alpha of material `mi` at a fragment's texture coordinates.
fn material_color(mi: u32, sets: UvSets) -> vec4<f32> {
    var c = materials[mi].base_color;
#ifdef TEXTURES
    if has_slot(mi, SLOT_BASE) {
        c *= sample_slot(mi, SLOT_BASE, sets);
    }
#endif
    return c;
}

// The vertex attributes of the scene's raster passes (crates/gpu/src/scene_gpu.rs
// vertex_layouts: one buffer each).
struct VertexIn {
    @builtin(instance_index) instance: u32,
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
#ifdef NORMAL_MAP
    @location(3) tangent: vec4<f32>,
#endif
#ifdef UV1
    @location(4) uv1: vec2<f32>,
#endif
}

struct VertexOut {
    // Invariant: the shading pass tests depth Equal against the pre-pass.
    @invariant @builtin(position) clip: vec4<f32>,
    // Every attribute at the pixel centre, also with MSAA, not at the centroid: where a
    // centroid lies is the implementation's choice ("inside both the pixel and the
    // primitive"), and lavapipe's is off the centre even in fully covered pixels (measured at
    // 4x on the many-material scene: brute force moved from its 1x image at 2,675 pixels,
    // the visibility buffer, shading at the centre, at none). Differencing centroids across
    // a quad also bent the texture gradients along every edge. A partly covered pixel whose
    // centre lies off the triangle is shaded with the triangle's attributes extrapolated to
    // the centre, as hardware MSAA does by default (and TiledLighting11 with it).
    @location(0) world_pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) @interpolate(flat) material: u32,
#ifdef NORMAL_MAP
    // World-space tangent, bitangent sign in w (mirroring instances flip it).
    @location(4) tangent: vec4<f32>,
#endif
#ifdef UV1
    @location(5) uv1: vec2<f32>,
#endif
}

fn transform_vertex(v: VertexIn) -> VertexOut {
    let inst = instances[v.instance];
    let world = inst.model * vec4<f32>(v.position, 1.0);
    var out: VertexOut;
    out.clip = view.world_to_clip * world;
    out.world_pos = world.xyz;
    out.normal = inst.normal_matrix * v.normal;
    out.uv = v.uv;
    out.material = inst.material;
#ifdef NORMAL_MAP
    out.tangent = vec4<f32>((inst.model * vec4<f32>(v.tangent.xyz, 0.0)).xyz, v.tangent.w * inst.det_sign);
#endif
#ifdef UV1
    out.uv1 = v.uv1;
#endif
    return out;
}

// Clip position only: the same arithmetic as transform_vertex so depths match exactly.
fn transform_position(instance_index: u32, position: vec3<f32>) -> vec4<f32> {
    let world = instances[instance_index].model * vec4<f32>(position, 1.0);
    return view.world_to_clip * world;
}

// The texture coordinates of set 1 at a fragment (set 0 without UV1: nothing reads them).
fn fragment_uv1(in: VertexOut) -> vec2<f32> {
#ifdef UV1
    return in.uv1;
#else
    return in.uv;
#endif
}

// A tangent-space normal-map texel (linear RGB) turned into a world-space unit normal around
// the interpolated normal `n_in` and tangent (CPU twin: tiledlight_cull::material::normal_from_map).
fn perturb_normal(n_in: vec3<f32>, tangent: vec4<f32>, texel: vec3<f32>, scale: f32) -> vec3<f32> {
    let n = normalize(n_in);
    // Re-orthogonalise: interpolation bends the tangent off the normal's plane.
    let t0 = tangent.xyz - n * dot(n, tangent.xyz);
    let tl = length(t0);
    if !(tl > 0.0) {
        return n;
    }
    let t = t0 / tl;
    let b = cross(n, t) * tangent.w;
    let m = (texel * 2.0 - 1.0) * vec3<f32>(scale, scale, 1.0);
    let p = t * m.x + b * m.y + n * m.z;
    let pl = length(p);
    if !(pl > 0.0) {
        return n;
    }
    return p / pl;
}

// The material seen by a rasterised fragment, for the shading pass and the G-buffer alike.
struct MaterialSample {
    base: vec3<f32>,
    alpha: f32,
    roughness: f32,
    metallic: f32,
    // Unit normal facing the viewer: double-sided surfaces seen from behind are lit on
    // their back.
    normal: vec3<f32>,
    // Scales the ambient term (1 without an occlusion map).
    occlusion: f32,
    // Linear emitted radiance (0 for materials that do not emit).
    emission: vec3<f32>,
}

// The material at fragment `in`. With ALPHA_MASK it discards below the material's cutoff,
// as the depth pre-pass does: call it only from fragment entry points.
fn material_sample(in: VertexOut, front: bool) -> MaterialSample {
    let mi = in.material;
    let sets = uv_sets(in.uv, fragment_uv1(in));
    let base = material_color(mi, sets);
#ifdef ALPHA_MASK
    if base.a < materials[mi].alpha_cutoff {
        discard;
    }
#endif
#ifdef NORMAL_MAP
    let tangent = in.tangent;
#else
    let tangent = vec4<f32>(0.0);
#endif
    return material_at(mi, sets, base, in.normal, tangent, front);
}

// Material `mi` at texture coordinates `sets` (with their screen-space gradients), whose
// base colour and alpha are `base` (material_color), around the interpolated normal `n_in`
// and, with NORMAL_MAP, tangent (bitangent sign in w), seen from the front or the back. The
// raster passes' fragments (material_sample) and the visibility buffer's compute pass
// (common/visibility_surface.wgsl) evaluate materials alike through it.
fn material_at(mi: u32, sets: UvSets, base: vec4<f32>, n_in: vec3<f32>, tangent: vec4<f32>, front: bool) -> MaterialSample {
    let m = materials[mi];
    var ms: MaterialSample;
    ms.base = base.rgb;
    ms.alpha = base.a;
    ms.roughness = m.roughness;
    ms.metallic = m.metallic;
    ms.occlusion = 1.0;
    var n = normalize(n_in);
    ms.emission = m.emissive;
#ifdef TEXTURES
    // Every map the material has (a per-material bit: one kernel serves every mix of maps),
    // sampled at one call site so the kernel holds one copy of the filter, not four; a
    // slot without a map reads white, which leaves its factor as it is.
    var maps = array<vec4<f32>, 5>(vec4<f32>(1.0), vec4<f32>(1.0), vec4<f32>(1.0), vec4<f32>(1.0), vec4<f32>(1.0));
    for (var slot = SLOT_MR; slot <= SLOT_EMISSIVE; slot++) {
        if has_slot(mi, slot) {
            maps[slot] = sample_slot(mi, slot, sets);
        }
    }
    // glTF: roughness in green, metalness in blue (linear).
    ms.roughness *= maps[SLOT_MR].g;
    ms.metallic *= maps[SLOT_MR].b;
#ifdef NORMAL_MAP
    if has_slot(mi, SLOT_NORMAL) {
        n = perturb_normal(n, tangent, maps[SLOT_NORMAL].rgb, m.normal_scale);
    }
#endif
    ms.occlusion = 1.0 + m.occlusion_strength * (maps[SLOT_OCCLUSION].r - 1.0);
    ms.emission *= maps[SLOT_EMISSIVE].rgb;
#endif
    ms.normal = select(-n, n, front);
    return ms;
}

// The part of a fragment's colour that no light adds: ambient light on the base colour,
// scaled by occlusion, plus emission (CPU twin: tiledlight_cull::material::unlit_term).
fn unlit_term(ambient: vec3<f32>, ms: MaterialSample) -> vec3<f32> {
    return ambient * ms.base * ms.occlusion + ms.emission;
}
