// The stochastic method's light loop (issue 48: every light shadowed), included by the
// traced kernel's body (common/traced_shade.wgsl) with STOCHASTIC in place of the traced
// reference's loop over every light:
//
// 1. M candidates (`traced_band.candidates`) drawn uniformly from every light, each with
//    the luminance of its unshadowed contribution as its target (common/shade.wgsl with
//    STOCHASTIC casts no ray), resampled into one reservoir (common/stochastic.wgsl; the
//    CPU twin is tiledlight_cull::stochastic::resample, draw k from rand01(pixel, frame,
//    2k) and 2k + 1).
// 2. One shadow ray to the kept light through the BVH (traced_visibility); the pixel's
//    light is f(y) V(y) W, unbiased for the sum over every light of f V.
// 3. Temporal accumulation: the running mean of the frames since the camera or the lights
//    last changed (`traced_band.accumulated` of them before this one, 0 after a change:
//    nothing of another view remains), kept per pixel in `stochastic_history`. The count
//    stops at the `accumulate` setting, where the mean becomes a moving average.

#include "common/stochastic.wgsl"

// The accumulated image: one linear HDR colour a pixel, row-major at the screen's width.
@group(1) @binding(40) var<storage, read_write> stochastic_history: array<vec4<f32>>;

fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}

// This frame's estimate of the pixel's light (steps 1 and 2), without the unlit term.
fn stochastic_estimate(g: GSample, pixel: u32) -> vec3<f32> {
    let n = lighting.num_lights;
    if n == 0u {
        return vec3<f32>(0.0);
    }
    let v = view_vector(g.world);
    let frame = traced_band.frame;
    let count = f32(n);
    var r = reservoir_empty();
    for (var k = 0u; k < traced_band.candidates; k++) {
        let light = min(u32(rand01(pixel, frame, 2u * k) * count), n - 1u);
        let p_hat = luminance(shade_light(light, g.world, g.normal, v, g.surface));
        // Source pdf 1 / n: the candidate's weight is p_hat n.
        reservoir_update(&r, light, p_hat * count, p_hat, rand01(pixel, frame, 2u * k + 1u));
    }
    let w = reservoir_weight(r);
    if w <= 0.0 {
        return vec3<f32>(0.0);
    }
    let f = shade_light(r.light, g.world, g.normal, v, g.surface);
    // p_hat > 0: the light is on the normal's side, as the ray assumes.
    return f * (w * traced_visibility(g.world, g.normal, shading_lights[r.light].position));
}

// Linear HDR of one surface sample: the unlit term and the accumulated estimate (step 3).
fn shade_lights_at(g: GSample, p: vec2<u32>) -> vec3<f32> {
    if g.sky {
        return vec3<f32>(0.0);
    }
    let pixel = p.y * view.screen.x + p.x;
    let c = stochastic_estimate(g, pixel);
    let n = traced_band.accumulated;
    var mean = c;
    if n > 0u {
        let h = stochastic_history[pixel].rgb;
        mean = h + (c - h) / f32(n + 1u);
    }
    stochastic_history[pixel] = vec4<f32>(mean, 1.0);
    return g.unlit + mean;
}
