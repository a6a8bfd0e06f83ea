// Tiled Deferred's compact G-buffer texel: a surface sample in one Rgba16Uint texel.
// CPU twin and bit layout: crates/cull/src/gbuffer.rs (keep the two in step).
//   x: metallic bits 1-0 in 15-14, the octahedral normal's u code (14 bits, offset) in 13-0
//   y: metallic bits 3-2 in 15-14, the v code in 13-0
//   z: base red (sRGB, 8 bits) in 15-8, green in 7-0
//   w: base blue in 15-8, perceptual roughness (8 bits) in 7-0

#include "common/srgb.wgsl"
#include "common/octahedral.wgsl"

const GB_NORMAL_MAX: f32 = 8191.0;   // 2^13 - 1
const GB_NORMAL_OFFSET: i32 = 8192;  // 2^13
const GB_METALLIC_MAX: f32 = 15.0;   // 4 bits

struct GTexel {
    base: vec3<f32>,
    metallic: f32,
    normal: vec3<f32>,
    roughness: f32,
}

fn unorm_code(c: f32, max_code: f32) -> u32 {
    return u32(floor(0.5 + max_code * saturate(c)));
}

fn pack_gtexel(t: GTexel) -> vec4<u32> {
    let o = oct_map(t.normal);
    let q = vec2<u32>(vec2<i32>(floor(0.5 + GB_NORMAL_MAX * clamp(o, vec2<f32>(-1.0), vec2<f32>(1.0)))) + GB_NORMAL_OFFSET);
    let m = unorm_code(t.metallic, GB_METALLIC_MAX);
    let srgb = linear_to_srgb(t.base);
    let c = vec3<u32>(floor(0.5 + 255.0 * srgb));
    return vec4<u32>(q.x | ((m & 3u) << 14u), q.y | ((m >> 2u) << 14u), (c.r << 8u) | c.g, (c.b << 8u) | unorm_code(t.roughness, 255.0));
}

// The base colour's three 8-bit sRGB codes (the Tiled Deferred shading decodes them through
// a table the texture unit reads, common/deferred_shade.wgsl).
fn gtexel_base_codes(p: vec4<u32>) -> vec3<u32> {
    return vec3<u32>(p.z >> 8u, p.z, p.w >> 8u) & vec3<u32>(0xffu);
}

// The texel's fields, the base colour decoded by the sRGB formula.
fn unpack_gtexel(p: vec4<u32>) -> GTexel {
    let q = vec2<f32>(vec2<i32>(p.xy & vec2<u32>(0x3fffu)) - GB_NORMAL_OFFSET);
    var t: GTexel;
    t.normal = oct_unmap(max(q / GB_NORMAL_MAX, vec2<f32>(-1.0)));
    t.metallic = f32(((p.x >> 14u) & 3u) | (((p.y >> 14u) & 3u) << 2u)) / GB_METALLIC_MAX;
    let c = vec3<f32>(gtexel_base_codes(p)) / 255.0;
    t.base = srgb_to_linear(c);
    t.roughness = f32(p.w & 0xffu) / 255.0;
    return t;
}
