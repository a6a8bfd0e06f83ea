// Material textures: every image in one of eight 2D-array textures (group 2), each slot of
// a material naming its array, layer, size and sampler (TextureSlot), texels read with
// textureLoad and filtered here. The layout is tiledlight_gpu::texture_arrays's; the CPU
// twin, step for step, is tiledlight_cull::texture (mip chain, level, wrap, filter).
// Included by common/scene.wgsl with TEXTURES only.
//
// Why filter by hand: a material's textures are then a per-pixel value, not a binding, so
// one draw or dispatch shades every material (the visibility buffer's single material
// pass), no sampler is bound, no array is indexed non-uniformly (lavapipe and WebGPU have
// no such indexing), and every adapter computes the same texel weights.

@group(2) @binding(0) var material_array_0: texture_2d_array<f32>;
@group(2) @binding(1) var material_array_1: texture_2d_array<f32>;
@group(2) @binding(2) var material_array_2: texture_2d_array<f32>;
@group(2) @binding(3) var material_array_3: texture_2d_array<f32>;
@group(2) @binding(4) var material_array_4: texture_2d_array<f32>;
@group(2) @binding(5) var material_array_5: texture_2d_array<f32>;
@group(2) @binding(6) var material_array_6: texture_2d_array<f32>;
@group(2) @binding(7) var material_array_7: texture_2d_array<f32>;

const WRAP_REPEAT: u32 = 0u;
const WRAP_MIRROR: u32 = 1u;
const MIPMAP_NEAREST: u32 = 1u;
const MIPMAP_LINEAR: u32 = 2u;

// Texel `p` of `level`, layer `layer` of array `a`: the switch names each binding
// statically, so the array is never indexed by a non-uniform value.
fn material_texel(a: u32, layer: u32, p: vec2<i32>, level: u32) -> vec4<f32> {
    switch a {
        case 0u: { return textureLoad(material_array_0, p, layer, level); }
        case 1u: { return textureLoad(material_array_1, p, layer, level); }
        case 2u: { return textureLoad(material_array_2, p, layer, level); }
        case 3u: { return textureLoad(material_array_3, p, layer, level); }
        case 4u: { return textureLoad(material_array_4, p, layer, level); }
        case 5u: { return textureLoad(material_array_5, p, layer, level); }
        case 6u: { return textureLoad(material_array_6, p, layer, level); }
        default: { return textureLoad(material_array_7, p, layer, level); }
    }
}

// Texel index `i` wrapped into 0..n (twin: wrap_texel).
fn wrap_texel(i: i32, n: i32, mode: u32) -> i32 {
    if mode == WRAP_REPEAT {
        return ((i % n) + n) % n;
    }
    if mode == WRAP_MIRROR {
        let p = 2 * n;
        let t = ((i % p) + p) % p;
        return select(t, p - 1 - t, t >= n);
    }
    return clamp(i, 0, n - 1);
}

// A coordinate reduced to one period of its wrap mode; 0 when it is not a number (twin:
// reduce).
fn reduce_coordinate(x: f32, mode: u32) -> f32 {
    var r = clamp(x, -1.0, 2.0);
    var lo = -1.0;
    var hi = 2.0;
    if mode == WRAP_REPEAT {
        r = x - floor(x);
        lo = 0.0;
        hi = 1.0;
    } else if mode == WRAP_MIRROR {
        r = x - 2.0 * floor(x * 0.5);
        lo = 0.0;
        hi = 2.0;
    }
    return select(0.0, r, r >= lo && r <= hi);
}

// Level `level` of slot `s` at `uv`, nearest or bilinear (twin: Mips::filter): the texels'
// weighted sum, one tap (nearest) or four, read at one call site (the kernel holds one copy
// of the loads).
fn filter_level(s: TextureSlot, uv: vec2<f32>, level: u32, linear: bool) -> vec4<f32> {
    let a = s.place & 15u;
    let layer = s.place >> 4u;
    let n = vec2<i32>(max(vec2<u32>(s.size & 0xffffu, s.size >> 16u) >> vec2<u32>(level), vec2<u32>(1u)));
    let size = vec2<f32>(n);
    let wu = s.sampling & 3u;
    let wv = (s.sampling >> 2u) & 3u;
    let u = vec2<f32>(reduce_coordinate(uv.x, wu), reduce_coordinate(uv.y, wv));
    // Nearest: the texel holding u; linear: the four around it, half a texel off.
    var p = u * size;
    var taps = 1u;
    if linear {
        p -= 0.5;
        taps = 4u;
    }
    let i0f = floor(p);
    let f = select(vec2<f32>(0.0), p - i0f, linear);
    let i0 = vec2<i32>(i0f);
    var sum = vec4<f32>(0.0);
    for (var k = 0u; k < taps; k++) {
        let o = vec2<u32>(k & 1u, k >> 1u);
        let w = select(1.0 - f.x, f.x, o.x == 1u) * select(1.0 - f.y, f.y, o.y == 1u);
        let t = vec2<i32>(wrap_texel(i0.x + i32(o.x), n.x, wu), wrap_texel(i0.y + i32(o.y), n.y, wv));
        sum += w * material_texel(a, layer, t, level);
    }
    return sum;
}

// Slot `s` at `uv` with screen-space gradients `dx`, `dy` (twin: Mips::sample): the level
// from the longer gradient, the sampler's filters and mipmap mode; one or two levels read at
// one call site.
fn sample_texture(s: TextureSlot, uv: vec2<f32>, dx: vec2<f32>, dy: vec2<f32>) -> vec4<f32> {
    let size = vec2<f32>(f32(s.size & 0xffffu), f32(s.size >> 16u));
    let rho = max(length(dx * size), length(dy * size));
    let lambda = log2(rho);
    let last = f32(((s.sampling >> 8u) & 31u) - 1u);
    let mipmap = (s.sampling >> 6u) & 3u;
    // Magnified (or not a number): level 0 with the magnification filter.
    var linear = ((s.sampling >> 4u) & 1u) != 0u;
    var l0 = 0.0;
    var t = 0.0;
    if lambda > 0.0 {
        linear = ((s.sampling >> 5u) & 1u) != 0u;
        if mipmap == MIPMAP_NEAREST {
            l0 = clamp(ceil(lambda + 0.5) - 1.0, 0.0, last);
        } else if mipmap == MIPMAP_LINEAR {
            let d = min(lambda, last);
            l0 = floor(d);
            t = d - l0;
        }
    }
    var sum = vec4<f32>(0.0);
    let levels = select(1u, 2u, t > 0.0);
    for (var j = 0u; j < levels; j++) {
        let w = select(1.0 - t, t, j == 1u);
        sum += w * filter_level(s, uv, u32(min(l0 + f32(j), last)), linear);
    }
    return sum;
}
