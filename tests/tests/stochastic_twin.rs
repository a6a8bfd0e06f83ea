//! The stochastic sampler's WGSL (`shaders/common/stochastic.wgsl`) against its CPU twin
//! (`tiledlight_cull::stochastic`, issue 48): for fixed seeds the same random numbers (bit
//! for bit), the same picks and counts, and the same weights within rounding.
//!
//! Each case is a pixel and a frame with 8 candidates' targets (zeros among them, one
//! case all zeros, targets from 1e-30 to 1e30): the kernel resamples 8 uniform draws into
//! one reservoir, 8 more into a second, merges them, and writes the first random number,
//! both reservoirs and the merged one's weight. The GPU may fuse the weight's product into
//! its sum (an FMA), so sums and weights may differ in the last bits, and a pick may differ
//! where the CPU's decision `u w_sum < w` was within 1e-5 of a tie; any other difference
//! fails. The negative test: a twin that draws with the draw index off by one is rejected.

use tiledlight_cull::stochastic::{rand01, Reservoir};
use tiledlight_tests::gpu;
use tiledlight_tests::kernels::{run_cases, Rng};

const SRC: &str = r#"
#include "common/stochastic.wgsl"
@group(0) @binding(0) var<storage, read> cases: array<array<f32, 10>>;
@group(0) @binding(1) var<storage, read_write> out: array<array<u32, 10>>;

fn resample8(c: array<f32, 10>, pixel: u32, frame: u32) -> Reservoir {
    var r = reservoir_empty();
    for (var k = 0u; k < 8u; k++) {
        let i = min(u32(rand01(pixel, frame, 2u * k) * 8.0), 7u);
        let p_hat = c[2u + i];
        reservoir_update(&r, i, p_hat * 8.0, p_hat, rand01(pixel, frame, 2u * k + 1u));
    }
    return r;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&cases) { return; }
    let c = cases[i];
    let pixel = bitcast<u32>(c[0]);
    let frame = bitcast<u32>(c[1]);
    var a = resample8(c, pixel, frame);
    let b = resample8(c, pixel, frame + 1000u);
    let first = a;
    reservoir_merge(&a, b, rand01(pixel, frame, 999u));
    out[i] = array<u32, 10>(bitcast<u32>(rand01(pixel, frame, 0u)), first.light, bitcast<u32>(first.w_sum), first.m,
        b.light, bitcast<u32>(b.w_sum), a.light, bitcast<u32>(a.w_sum), a.m, bitcast<u32>(reservoir_weight(a)));
}
"#;

/// A case: pixel, frame, 8 targets.
type Case = (u32, u32, [f32; 8]);

fn cases() -> Vec<Case> {
    let mut rng = Rng(48);
    let mut v: Vec<Case> = vec![
        (0, 0, [0.0; 8]),
        (1, 0, [1.0; 8]),
        (2, 7, [1e-30, 1e30, 0.0, 1.0, 0.0, 0.0, 1e-30, 2.0]),
        (u32::MAX, u32::MAX, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 5.0]),
    ];
    for n in 0..4000u32 {
        let mut t = [0.0f32; 8];
        for x in &mut t {
            // A quarter zeros (lights out of range), the rest over eight decades.
            *x = if rng.unit() < 0.25 { 0.0 } else { rng.log(1e-4, 1e4) };
        }
        v.push((n * 7919 + 13, n / 64, t));
    }
    v
}

/// What the CPU twin gives for a case, with the smallest relative margin of its decisions
/// `u w_sum < w` (how near a tie a pick was). `offset` shifts the draw index (the negative
/// test's broken twin).
struct Twin {
    rand: u32,
    a: Reservoir,
    b: Reservoir,
    merged: Reservoir,
    margin: f32,
}

fn twin(&(pixel, frame, t): &Case, offset: u32) -> Twin {
    let mut margin = f32::INFINITY;
    let mut resample = |frame: u32| {
        let mut r = Reservoir::default();
        for k in 0..8u32 {
            let i = ((rand01(pixel, frame, 2 * k + offset) * 8.0) as u32).min(7);
            let (p_hat, u) = (t[i as usize], rand01(pixel, frame, 2 * k + 1 + offset));
            let w = p_hat * 8.0;
            let sum = r.w_sum + w;
            if w > 0.0 {
                margin = margin.min((u * sum - w).abs() / w);
            }
            r.update(i, (w, p_hat), u);
        }
        r
    };
    let a = resample(frame);
    let b = resample(frame.wrapping_add(1000));
    let mut merged = a;
    merged.merge(&b, rand01(pixel, frame, 999));
    Twin { rand: rand01(pixel, frame, offset).to_bits(), a, b, merged, margin }
}

fn close(g: u32, c: f32) -> bool {
    let g = f32::from_bits(g);
    g == c || (g - c).abs() <= 1e-6 * c.abs().max(g.abs())
}

/// The cases whose GPU row differs from the twin beyond rounding and near-ties.
fn mismatches(cases: &[Case], rows: &[u32], offset: u32) -> Vec<String> {
    let mut bad = Vec::new();
    for (i, (case, row)) in cases.iter().zip(rows.chunks_exact(10)).enumerate() {
        let c = twin(case, offset);
        if row[0] != c.rand {
            bad.push(format!("case {i}: random number {:#x} on the GPU, {:#x} on the CPU", row[0], c.rand));
            continue;
        }
        let counts_ok = row[3] == c.a.m && row[8] == c.merged.m;
        let sums_ok = close(row[2], c.a.w_sum) && close(row[5], c.b.w_sum) && close(row[7], c.merged.w_sum);
        let picks_ok = row[1] == c.a.light && row[4] == c.b.light && row[6] == c.merged.light;
        let weight_ok = close(row[9], c.merged.weight());
        if !counts_ok || !sums_ok || (!picks_ok && c.margin > 1e-5) || (picks_ok && !weight_ok) {
            bad.push(format!(
                "case {i} {case:?}: GPU {row:?}, CPU a {:?} b {:?} merged {:?} weight {} (margin {:e})",
                c.a,
                c.b,
                c.merged,
                c.merged.weight(),
                c.margin
            ));
        }
    }
    bad
}

fn run(cases: &[Case]) -> Vec<u32> {
    let input: Vec<u32> =
        cases.iter().flat_map(|(p, f, t)| [*p, *f].into_iter().chain(t.iter().map(|x| x.to_bits()))).collect();
    let out = run_cases(
        gpu(),
        "test.stochastic",
        SRC,
        bytemuck::cast_slice(&input),
        cases.len() as u32,
        cases.len() as u64 * 40,
    );
    out.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn the_gpu_sampler_matches_its_cpu_twin() {
    let cases = cases();
    let rows = run(&cases);
    let bad = mismatches(&cases, &rows, 0);
    let kept = rows.chunks_exact(10).filter(|r| r[8] > 0 && f32::from_bits(r[9]) > 0.0).count();
    eprintln!("{} cases, {kept} with a light kept, {} mismatches", cases.len(), bad.len());
    assert!(kept * 2 > cases.len(), "too few cases keep a light ({kept}): the picks are barely tested");
    assert!(bad.is_empty(), "{} of {} cases differ:\n{}", bad.len(), cases.len(), bad[..bad.len().min(10)].join("\n"));
}

#[test]
fn the_comparison_rejects_a_twin_that_draws_otherwise() {
    let cases = cases();
    let rows = run(&cases);
    let bad = mismatches(&cases, &rows, 1);
    assert!(bad.len() * 10 > cases.len() * 9, "only {} of {} cases caught", bad.len(), cases.len());
}
