// VPL generation (crates/vpl/src/generate.rs): one thread per block x block texels of each
// reflective-shadow-map face (crates/vpl/src/rsm.rs). The block's texels are summed into one
// VPL: flux summed, position and tint the solid-angle-weighted means, normal the normalised
// weighted sum; it is kept when a channel of its normalised tint reaches the colour
// threshold and its tint's length exceeds the brightness threshold (TiledLighting11's two
// sliders), then appended with an atomic counter. The counter counts every candidate: the
// VPLs are the first min(count, cap) slots, and count - cap were refused by the cap. The CPU
// twin is tiledlight_cull::vpl (texel_light, block_vpl, passes_thresholds): keep in step.
#include "common/lights.wgsl"
#include "common/vpl.wgsl"

// One RSM face (crates/cull/src/vpl.rs, GpuRsmFace).
struct RsmFace {
    clip_to_world: mat4x4<f32>,
    light_position: vec3<f32>,
    light_radius: f32,
    radiance: vec3<f32>,
    // Squared world size of a texel per unit of view depth.
    texel_sq: f32,
    axis: vec3<f32>,
    vpl_radius: f32,
    spot_direction: vec3<f32>,
    spot_scale: f32,
    spot_offset: f32,
    is_spot: u32,
    // Top-left texel of the face's tile in the RSM textures.
    origin: vec2<u32>,
}

// crates/cull/src/vpl.rs, GpuVplParams.
struct VplParams {
    rsm_size: u32,
    block: u32,
    cap: u32,
    faces: u32,
    colour_threshold: f32,
    brightness_threshold: f32,
    _pad: vec2<u32>,
}

@group(0) @binding(0) var<uniform> params: VplParams;
@group(0) @binding(1) var<storage, read> faces: array<RsmFace>;
@group(0) @binding(2) var rsm_depth: texture_depth_2d;
@group(0) @binding(3) var rsm_albedo: texture_2d<f32>;
@group(0) @binding(4) var rsm_normal: texture_2d<f32>;
@group(0) @binding(5) var<storage, read_write> vpls: array<Vpl>;
@group(0) @binding(6) var<storage, read_write> vpl_cull: array<CullLight>;
@group(0) @binding(7) var<storage, read_write> vpl_count: atomic<u32>;
// The VPLs' `Lighting` uniform (common/lights.wgsl) as words, for the culling pass: word 3
// is num_lights, which becomes min(count, cap) as the largest stored index + 1 (zeroed with
// the counter before the dispatch).
@group(0) @binding(8) var<storage, read_write> vpl_lighting: array<atomic<u32>, 12>;

struct TexelLight {
    flux: vec3<f32>,
    tint: vec3<f32>,
    solid_angle: f32,
}

// What the texel at p with diffuse albedo reflects (tiledlight_cull::vpl::texel_light).
fn texel_light(face: RsmFace, p: vec3<f32>, albedo: vec3<f32>) -> TexelLight {
    let to = p - face.light_position;
    let d2 = dot(to, to);
    var dir = vec3<f32>(0.0);
    if (d2 > 0.0) {
        dir = to * inverseSqrt(d2);
    }
    let cos_axis = max(dot(face.axis, dir), 0.0);
    let solid_angle = face.texel_sq * cos_axis * cos_axis * cos_axis;
    let x = d2 / (face.light_radius * face.light_radius);
    let w = saturate(1.0 - x * x);
    var spot = 1.0;
    if (face.is_spot != 0u) {
        spot = spot_falloff(dot(face.spot_direction, dir), face.spot_scale, face.spot_offset);
    }
    let peak = max(max(max(face.radiance.x, face.radiance.y), face.radiance.z), 1.17549435e-38);
    let tint = albedo * (face.radiance / peak) * (w * w * spot);
    return TexelLight(albedo * face.radiance * (w * w * spot * solid_angle), tint, solid_angle);
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let blocks = params.rsm_size / params.block;
    if (id.x >= blocks || id.y >= blocks || id.z >= params.faces) {
        return;
    }
    let face = faces[id.z];
    let size = f32(params.rsm_size);
    var flux = vec3<f32>(0.0);
    var tint = vec3<f32>(0.0);
    var pos = vec3<f32>(0.0);
    var normal = vec3<f32>(0.0);
    var omega = 0.0;
    for (var y = 0u; y < params.block; y++) {
        for (var x = 0u; x < params.block; x++) {
            let t = vec2<u32>(id.x * params.block + x, id.y * params.block + y);
            let texel = vec2<i32>(face.origin + t);
            let depth = textureLoad(rsm_depth, texel, 0);
            if (depth <= 0.0) {
                continue; // nothing drawn (cleared to 0, the far plane of reversed-Z)
            }
            let ndc = vec2<f32>((f32(t.x) + 0.5) / size * 2.0 - 1.0, 1.0 - (f32(t.y) + 0.5) / size * 2.0);
            let h = face.clip_to_world * vec4<f32>(ndc, depth, 1.0);
            let p = h.xyz / h.w;
            let am = textureLoad(rsm_albedo, texel, 0);
            let n = textureLoad(rsm_normal, texel, 0).xyz;
            let l = texel_light(face, p, am.rgb * (1.0 - am.a));
            flux += l.flux;
            tint += l.tint * l.solid_angle;
            pos += p * l.solid_angle;
            normal += n * l.solid_angle;
            omega += l.solid_angle;
        }
    }
    if (omega <= 0.0 || dot(normal, normal) <= 1e-12 * omega * omega) {
        return;
    }
    let mean_tint = tint / omega;
    let len = length(mean_tint);
    let normalised = mean_tint / max(len, 1.17549435e-38);
    if (max(max(normalised.x, normalised.y), normalised.z) < params.colour_threshold || len <= params.brightness_threshold) {
        return;
    }
    let i = atomicAdd(&vpl_count, 1u);
    if (i >= params.cap) {
        return; // refused: counted, not stored
    }
    atomicMax(&vpl_lighting[3], i + 1u);
    let position = pos / omega;
    vpls[i] = Vpl(position, face.vpl_radius, normalize(normal), 0.0, flux, 0.0);
    vpl_cull[i] = CullLight(position, face.vpl_radius);
}
