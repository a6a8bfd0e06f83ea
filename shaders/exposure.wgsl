// Automatic exposure (crates/gpu/src/tonemap.rs, AutoExposure), before the tonemap reads
// it. CPU twin: tiledlight_cull::exposure::auto_exposure.
// 1. reduce: a workgroup per 16 x 16 pixels sums log2 of the luminance of its lit pixels
//    (luminance >= MIN_LUMINANCE; the sky and unlit corners are left out) and counts them
//    into its slot of `partials`.
// 2. finish: one workgroup adds the partial sums and writes the exposure that maps the
//    log-average luminance to KEY (clamped to [1 / MAX_EXPOSURE, MAX_EXPOSURE]; 1 when no
//    pixel is lit) to `exposure[0]`.
// Sums are f32 per workgroup (256 values of at most ~128 in magnitude) and f32 over the
// partials: the CPU twin sums in f64; the tests allow for the difference.

override KEY: f32 = 0.25;
override MIN_LUMINANCE: f32 = 1e-4;
override MAX_EXPOSURE: f32 = 1e6;

@group(0) @binding(0) var hdr: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> partials: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read_write> exposure: array<f32>;

var<workgroup> wg_sum: array<vec2<f32>, 256>;

#include "common/luminance.wgsl"

// Tree sum of wg_sum into wg_sum[0].
fn workgroup_sum(lidx: u32) {
    for (var o = 128u; o > 0u; o >>= 1u) {
        workgroupBarrier();
        if lidx < o {
            wg_sum[lidx] += wg_sum[lidx + o];
        }
    }
    workgroupBarrier();
}

@compute @workgroup_size(16, 16)
fn reduce(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lidx: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let size = textureDimensions(hdr);
    var v = vec2<f32>(0.0);
    if gid.x < size.x && gid.y < size.y {
        let l = luminance(textureLoad(hdr, vec2<i32>(gid.xy), 0).rgb);
        // NaN fails every comparison, infinity the second: left out, as on the CPU.
        if l >= MIN_LUMINANCE && l <= 3.4e38 {
            v = vec2<f32>(log2(l), 1.0);
        }
    }
    wg_sum[lidx] = v;
    workgroup_sum(lidx);
    if lidx == 0u {
        partials[wid.y * nwg.x + wid.x] = wg_sum[0];
    }
}

@compute @workgroup_size(256)
fn finish(@builtin(local_invocation_index) lidx: u32) {
    var v = vec2<f32>(0.0);
    for (var i = lidx; i < arrayLength(&partials); i += 256u) {
        v += partials[i];
    }
    wg_sum[lidx] = v;
    workgroup_sum(lidx);
    if lidx == 0u {
        let s = wg_sum[0];
        var e = 1.0;
        if s.y > 0.0 {
            e = clamp(KEY / exp2(s.x / s.y), 1.0 / MAX_EXPOSURE, MAX_EXPOSURE);
        }
        exposure[0] = e;
    }
}
