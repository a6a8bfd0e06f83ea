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
//!
//! The spatial reuse's WGSL (`shaders/common/reuse.wgsl`) against `tiledlight_cull::reuse`
//! likewise, on a record image (below, at `REUSE_SRC`); its negative test: a twin that
//! skips the similarity test is rejected.

use glam::Vec3;
use tiledlight_cull::reuse::{self, Record};
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

// Spatial reuse (tiledlight_cull::reuse, shaders/common/reuse.wgsl): every pixel of a
// record image merged with its neighbours on the GPU and by the twin. The image has
// surfaces of three normals (0, 10 and 40 degrees from +Z) and three view distances (10,
// 10.5, 12) in blocks, sky pixels, records without a light (W 0), weights from 1e-30 to
// 1e30 and light indices up to the largest (2^20 - 1); no pair of surfaces is within 1e-3
// of the similarity test's thresholds, so rounding cannot flip a decision. The target is a
// table of the light index, exact in f32 on both sides (every fifth light 0).
const REUSE_SRC: &str = r#"
#include "common/reuse.wgsl"
@group(0) @binding(0) var<storage, read> records: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read_write> out: array<vec4<u32>>;

fn reuse_record(index: u32) -> RecordWords {
    return RecordWords(records[2u * index + 2u], records[2u * index + 3u]);
}

fn reuse_target(light: u32) -> f32 {
    return select(f32((light * 2654435761u) >> 16u) / 65536.0, 0.0, light % 5u == 0u);
}

fn reuse_position(q: vec2<u32>, dist: f32) -> vec3<f32> {
    return vec3<f32>(f32(q.x), f32(q.y), dist);
}

fn reuse_proxy(light: u32, x: vec3<f32>, n: vec3<f32>, s: vec2<u32>) -> f32 {
    return (0.25 + f32(light % 7u)) * (1.5 + n.x) / (1.0 + 0.01 * x.x * f32(light % 3u)) * (1.0 + f32(s.x & 255u) / 255.0);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let head = records[0];
    let screen = head.xy;
    let i = id.x;
    if i >= screen.x * screen.y { return; }
    let c = ReuseParams(screen, head.z, 4u, 16u, head.w, REUSE_RADIUS, REUSE_NORMAL_COS, REUSE_DISTANCE_SHARE,
        REUSE_DRAW_BASE);
    let r = reuse_combine(vec2<u32>(i % screen.x, i / screen.x), c);
    out[i] = vec4<u32>(r.light, bitcast<u32>(r.w_sum), r.m, bitcast<u32>(reservoir_weight(r)));
}
"#;

const REUSE_SIZE: (u32, u32) = (48, 32);
const REUSE_COUNTS: (u32, u32) = (4, 16);

fn reuse_target(light: u32) -> f32 {
    if light.is_multiple_of(5) {
        0.0
    } else {
        (light.wrapping_mul(2_654_435_761) >> 16) as f32 / 65536.0
    }
}

/// The test kernel's scene: pixel coordinates and distance as the point, a proxy that
/// depends on the light, the point and the normal (so neighbours' shares differ), the
/// target table.
fn reuse_scene() -> reuse::FnScene {
    reuse::Scene {
        position: |x: u32, y: u32, d: f32| Vec3::new(x as f32, y as f32, d),
        proxy: |l: u32, p: Vec3, n: Vec3, s: [u32; 2]| {
            (0.25 + (l % 7) as f32) * (1.5 + n.x) / (1.0 + 0.01 * p.x * (l % 3) as f32)
                * (1.0 + (s[0] & 255) as f32 / 255.0)
        },
        target: reuse_target as fn(u32) -> f32,
    }
}

fn reuse_records() -> Vec<Record> {
    let mut rng = Rng(4848);
    let normals = [0.0f32, 10.0, 40.0].map(|d| Vec3::new(d.to_radians().sin(), 0.0, d.to_radians().cos()));
    let dists = [10.0f32, 10.5, 12.0];
    (0..REUSE_SIZE.0 * REUSE_SIZE.1)
        .map(|i| {
            let (x, y) = (i % REUSE_SIZE.0, i / REUSE_SIZE.0);
            // Blocks of 8x8 of one normal and distance, a fifth of the pixels another.
            let block = ((x / 8) * 7 + (y / 8) * 3) as usize;
            let odd = rng.unit() < 0.2;
            let normal = normals[if odd { (rng.unit() * 3.0) as usize } else { block % 3 }];
            let dist = if rng.unit() < 0.05 {
                0.0
            } else {
                dists[if odd { (rng.unit() * 3.0) as usize } else { block / 3 % 3 }]
            };
            let light = if i == 5 { (1 << 20) - 1 } else { (rng.unit() * 4000.0) as u32 };
            let weight = if rng.unit() < 0.1 { 0.0 } else { rng.log(1e-30, 1e30) };
            let surface = [(rng.unit() * 65536.0) as u32, 0];
            Record { light, near: rng.unit() < 0.7, weight, normal, dist, surface }
        })
        .collect()
}

fn run_reuse(records: &[Record], (frame, k): (u32, u32)) -> Vec<[u32; 4]> {
    let mut words = vec![[REUSE_SIZE.0, REUSE_SIZE.1, frame, k], [0; 4]];
    for r in records {
        let w = r.pack();
        words.extend([[w[0], w[1], w[2], w[3]], [w[4], w[5], w[6], w[7]]]);
    }
    let n = records.len() as u32;
    let constants = format!(
        "const REUSE_RADIUS: i32 = {};\nconst REUSE_NORMAL_COS: f32 = {:?};\nconst REUSE_DISTANCE_SHARE: f32 = {:?};\nconst REUSE_DRAW_BASE: u32 = {}u;\n",
        reuse::RADIUS,
        reuse::NORMAL_COS,
        reuse::DISTANCE_SHARE,
        reuse::DRAW_BASE
    );
    let out = run_cases(
        gpu(),
        "test.stochastic.reuse",
        &(constants + REUSE_SRC),
        bytemuck::cast_slice(&words),
        n,
        u64::from(n) * 16,
    );
    out.chunks_exact(4).map(|c| [0, 1, 2, 3].map(|j| c[j].to_bits())).collect()
}

/// The smallest distance of one of pixel `(x, y)`'s keep-or-not decisions from a tie
/// (`|u w_sum - w| / w_sum`): where it is within rounding, the GPU may keep the other one.
fn reuse_margin(records: &[Record], (x, y): (u32, u32), (frame, k): (u32, u32)) -> f32 {
    let offers = reuse::offers(records, ((x, y), REUSE_SIZE), (k, REUSE_COUNTS, frame), &reuse_scene());
    let (mut w_sum, mut margin) = (0.0f32, f32::INFINITY);
    for (_, w, _, u) in offers {
        w_sum += w;
        if w > 0.0 {
            margin = margin.min((u * w_sum - w).abs() / w_sum);
        }
    }
    margin
}

/// The pixels whose GPU reservoir differs from `twin`'s beyond rounding and near-ties.
fn reuse_mismatches(records: &[Record], rows: &[[u32; 4]], twin: &[Record], (frame, k): (u32, u32)) -> Vec<String> {
    let mut bad = Vec::new();
    for (i, row) in rows.iter().enumerate() {
        let (x, y) = (i as u32 % REUSE_SIZE.0, i as u32 / REUSE_SIZE.0);
        let c = reuse::combine(twin, ((x, y), REUSE_SIZE), (k, REUSE_COUNTS, frame), &reuse_scene());
        let close = |g: u32, c: f32| {
            let g = f32::from_bits(g);
            g == c || (g - c).abs() <= 1e-5 * c.abs().max(g.abs())
        };
        let pick_ok = row[0] == c.light || reuse_margin(records, (x, y), (frame, k)) < 1e-5;
        if row[2] != c.m || !close(row[1], c.w_sum) || !pick_ok || (row[0] == c.light && !close(row[3], c.weight())) {
            bad.push(format!("pixel ({x}, {y}): GPU {row:?}, CPU {c:?} weight {}", c.weight()));
        }
    }
    bad
}

#[test]
fn the_gpu_reuse_matches_its_cpu_twin() {
    let records = reuse_records();
    for (frame, k) in [(0, 1), (7, 4), (u32::MAX, 16)] {
        let rows = run_reuse(&records, (frame, k));
        let bad = reuse_mismatches(&records, &rows, &records, (frame, k));
        // Pixels that merged a neighbour and kept a light.
        let merged = (0..rows.len())
            .filter(|&i| {
                let (x, y) = (i as u32 % REUSE_SIZE.0, i as u32 / REUSE_SIZE.0);
                rows[i][3] != 0
                    && reuse::offers(&records, ((x, y), REUSE_SIZE), (k, REUSE_COUNTS, frame), &reuse_scene()).len() > 1
            })
            .count();
        eprintln!(
            "frame {frame}, {k} neighbours: {merged} of {} pixels merged a neighbour, {} mismatches",
            rows.len(),
            bad.len()
        );
        assert!(merged * 8 > rows.len(), "too few pixels merged a neighbour ({merged}): the reuse is barely tested");
        assert!(
            bad.is_empty(),
            "{} of {} pixels differ:\n{}",
            bad.len(),
            rows.len(),
            bad[..bad.len().min(10)].join("\n")
        );
    }
}

/// The negative test: a twin that skips the similarity test (every surface alike) is
/// rejected on most pixels that have a dissimilar neighbour.
#[test]
fn the_reuse_comparison_rejects_a_twin_without_the_similarity_test() {
    let records = reuse_records();
    let alike: Vec<Record> = records.iter().map(|r| Record { normal: Vec3::Z, dist: 10.0, ..*r }).collect();
    let rows = run_reuse(&records, (7, 4));
    let bad = reuse_mismatches(&records, &rows, &alike, (7, 4));
    assert!(bad.len() * 2 > rows.len(), "only {} of {} pixels caught", bad.len(), rows.len());
}
