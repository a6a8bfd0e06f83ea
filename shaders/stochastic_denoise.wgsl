// The stochastic method's denoiser (issue 48, step 4): an edge-avoiding à-trous filter
// guided by each pixel's surface and by the variance of its estimate, on the light divided
// by the albedo. CPU twin: tiledlight_cull::denoise (the same steps, constants and order;
// tests/tests/stochastic_denoise.rs compares the two). Two entry points share group 0:
//
// 1. `demodulate`: the history (the mean of `frames` frames' light; a: the mean of their
//    squared luminance over the albedo) divided by the albedo, and the variance of that
//    mean: the history's own from SHORT_HISTORY frames on, else the spread of the 3x3
//    neighbours on the same surface.
// 2. `atrous`: one iteration at `step` pixels: 5x5 B3-spline taps weighted by the normals'
//    agreement (^128), the view distances against the local depth slope and the estimates
//    against the noise their variance predicts (the larger of the two pixels'
//    predictions); the variance filtered along.
// 3. The last iteration (`atrous` with LAST) writes the HDR image: the unlit term plus the
//    albedo times the filtered light.
//
// Sky pixels (distance 0) are neither filtered nor taps; the last step leaves them as the
// shading pass wrote them.

#include "common/luminance.wgsl"

// One dispatch's parameters.
struct DenoiseStep {
    width: u32,
    height: u32,
    // The taps' spacing in pixels (1, 2, 4, ...).
    step: u32,
    // Frames in the history's mean.
    frames: u32,
}

// What the shading pass left (binding 41 of its group), three planes of one vec4 a pixel:
// the surface (unit normal, view distance; 0: sky), then the albedo the light is divided
// by (each channel at least DEMOD_FLOOR), then the unlit term (ambient, emission). Planes,
// not one struct a pixel: a tap reads only the surface.
@group(0) @binding(0) var<storage, read> guide: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> src: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> dst: array<vec4<f32>>;
@group(0) @binding(3) var<uniform> params: DenoiseStep;
@group(0) @binding(4) var hdr: texture_storage_2d<rgba16float, write>;

override SHORT_HISTORY: u32;
override SIGMA_L: f32;
override SIGMA_Z: f32;
override EPS_L: f32;
override EPS_Z: f32;
// The last iteration: write the HDR image, not the next buffer.
override LAST: bool;

// The B3-spline kernel's weight at offset k (0, 1 or 2 pixels steps).
fn kernel(k: i32) -> f32 {
    return select(select(0.0625, 0.25, k == 1), 0.375, k == 0);
}

fn pixels() -> i32 {
    return i32(params.width * params.height);
}

fn surface(i: i32) -> vec4<f32> {
    return guide[i];
}

fn albedo(i: i32) -> vec3<f32> {
    return guide[pixels() + i].rgb;
}

fn unlit(i: i32) -> vec3<f32> {
    return guide[2 * pixels() + i].rgb;
}

// The index of pixel (x, y), or -1 outside the image or on the sky.
fn surface_at(x: i32, y: i32) -> i32 {
    if x < 0 || y < 0 || x >= i32(params.width) || y >= i32(params.height) {
        return -1;
    }
    let i = y * i32(params.width) + x;
    return select(-1, i, surface(i).w > 0.0);
}

fn pow128(x: f32) -> f32 {
    var v = x;
    for (var k = 0; k < 7; k++) {
        v *= v;
    }
    return v;
}

fn normals_dot(a: vec4<f32>, b: vec4<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn same_surface(p: vec4<f32>, q: vec4<f32>) -> bool {
    return normals_dot(p, q) > 0.8 && abs(p.w - q.w) < 0.1 * p.w;
}

fn demodulated(i: i32) -> vec3<f32> {
    return src[i].rgb / albedo(i);
}

// An invocation's pixel: its coordinates, its index (-1 outside the image) and its surface
// index (-1 outside or on the sky).
struct Pixel {
    x: i32,
    y: i32,
    k: i32,
    i: i32,
}

fn pixel_of(id: vec3<u32>) -> Pixel {
    let x = i32(id.x);
    let y = i32(id.y);
    if id.x >= params.width || id.y >= params.height {
        return Pixel(x, y, -1, -1);
    }
    return Pixel(x, y, y * i32(params.width) + x, surface_at(x, y));
}

@compute @workgroup_size(8, 8)
fn demodulate(@builtin(global_invocation_id) id: vec3<u32>) {
    let px = pixel_of(id);
    if px.k < 0 {
        return;
    }
    let i = px.i;
    if i < 0 {
        dst[px.k] = vec4<f32>(0.0);
        return;
    }
    let c = demodulated(i);
    let l = luminance(c);
    var spread = 0.0;
    if params.frames >= SHORT_HISTORY {
        spread = max(src[i].a - l * l, 0.0);
    } else {
        var s1 = 0.0;
        var s2 = 0.0;
        var k = 0.0;
        for (var dy = -1; dy <= 1; dy++) {
            for (var dx = -1; dx <= 1; dx++) {
                let j = surface_at(px.x + dx, px.y + dy);
                if j >= 0 && same_surface(surface(i), surface(j)) {
                    let lj = luminance(demodulated(j));
                    s1 += lj;
                    s2 += lj * lj;
                    k += 1.0;
                }
            }
        }
        spread = max(s2 / k - (s1 / k) * (s1 / k), 0.0);
    }
    dst[i] = vec4<f32>(c, spread / f32(max(params.frames, 1u)));
}

// The depth slope at (x, y) along (ax, ay): the smaller difference to its two neighbours
// there (0 without one on the surface).
fn slope(x: i32, y: i32, ax: i32, ay: i32, here: f32) -> f32 {
    let a = surface_at(x + ax, y + ay);
    let b = surface_at(x - ax, y - ay);
    let da = abs(surface(max(a, 0)).w - here);
    let db = abs(surface(max(b, 0)).w - here);
    if a >= 0 && b >= 0 {
        return min(da, db);
    }
    if a >= 0 {
        return da;
    }
    if b >= 0 {
        return db;
    }
    return 0.0;
}

// The filtered value of surface pixel i at (x, y).
fn filtered(x: i32, y: i32, i: i32) -> vec4<f32> {
    let s = i32(params.step);
    let p = surface(i);
    let gx = slope(x, y, 1, 0, p.w);
    let gy = slope(x, y, 0, 1, p.w);
    let l_p = luminance(src[i].rgb);
    var sum_w = 0.0;
    var sum_c = vec3<f32>(0.0);
    var sum_v = 0.0;
    for (var dy = -2; dy <= 2; dy++) {
        for (var dx = -2; dx <= 2; dx++) {
            let j = surface_at(x + dx * s, y + dy * s);
            if j < 0 {
                continue;
            }
            let h = kernel(abs(dx)) * kernel(abs(dy));
            var w = h;
            if dx != 0 || dy != 0 {
                let q = surface(j);
                let tol_z = SIGMA_Z * (gx * f32(abs(dx)) + gy * f32(abs(dy))) * f32(params.step) + EPS_Z * p.w;
                let l_q = luminance(src[j].rgb);
                // The larger of the two predicted deviations: a dark pixel next to a bright
                // sample takes its share as the bright one gives it away.
                let tol_l = SIGMA_L * sqrt(max(src[i].a, src[j].a)) + EPS_L;
                let e = abs(p.w - q.w) / tol_z + abs(l_p - l_q) / tol_l;
                w = h * pow128(max(normals_dot(p, q), 0.0)) * exp(-e);
            }
            sum_w += w;
            sum_c += w * src[j].rgb;
            sum_v += w * w * src[j].a;
        }
    }
    return vec4<f32>(sum_c / sum_w, sum_v / (sum_w * sum_w));
}

// Iterations before the last (LAST false) write the next buffer; the last (LAST true) the
// HDR image: one entry point, two pipelines.
@compute @workgroup_size(8, 8)
fn atrous(@builtin(global_invocation_id) id: vec3<u32>) {
    let px = pixel_of(id);
    if px.k < 0 {
        return;
    }
    let i = px.i;
    if i < 0 {
        if !LAST {
            dst[px.k] = src[px.k];
        }
        return;
    }
    let c = filtered(px.x, px.y, i);
    if LAST {
        textureStore(hdr, id.xy, vec4<f32>(unlit(i) + albedo(i) * c.rgb, 1.0));
    } else {
        dst[i] = c;
    }
}
