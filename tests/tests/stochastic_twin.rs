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
//! skips the similarity test is rejected. The temporal reuse's (`tiledlight_cull::temporal`)
//! on tables of reservoirs and history records (`TEMPORAL_SRC`) and of points seen through
//! random cameras (`REPROJECT_SRC`); their negative tests: a twin without the cap, and one
//! whose rows run upwards, are rejected.

use glam::Vec3;
use tiledlight_cull::reuse::{self, Record};
use tiledlight_cull::stochastic::{rand01, Reservoir};
use tiledlight_cull::temporal;
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

// The near candidates' stratified draw (tiledlight_cull::stochastic::near_draw,
// `near_draw` in shaders/common/stochastic.wgsl): each case is (k, m, count, u) and the
// kernel writes the entry and the stratum's size; integers, so equal bit for bit. With
// them the number pick `m % rays` of `rays = 1 + k % 8` decides with (`ray_number`: 24-bit
// integers, so equal bit for bit too).
const NEAR_SRC: &str = r#"
#include "common/stochastic.wgsl"
@group(0) @binding(0) var<storage, read> cases: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read_write> out: array<vec4<u32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&cases) { return; }
    let c = cases[i];
    let u = bitcast<f32>(c.w);
    let rays = 1u + c.x % 8u;
    out[i] = vec4<u32>(near_draw(c.x, c.y, c.z, u), bitcast<u32>(ray_number(u, c.y % rays, rays)), 0u);
}
"#;

/// Near-draw cases: short lists cut in every way, long ones (a million lights) and the
/// integer limits (`u32::MAX` entries in 65,536 strata: a 64-bit product otherwise), `u`
/// from 0 to the largest below 1.
fn near_cases() -> Vec<[u32; 4]> {
    let mut rng = Rng(49);
    let top = f32::from_bits(1.0f32.to_bits() - 1);
    let mut v = Vec::new();
    for count in 1..=24u32 {
        for m in 1..=count {
            for k in 0..m {
                v.push([k, m, count, rng.unit().to_bits()]);
            }
        }
    }
    for (m, count) in [(65_536u32, u32::MAX), (4096, 1_000_000), (4095, 1_048_577), (7, 3_000_001)] {
        for k in [0, 1, m / 2, m - 2, m - 1] {
            for u in [0.0, 0.5, top, rng.unit()] {
                v.push([k, m, count, f32::to_bits(u)]);
            }
        }
    }
    v
}

fn run_near(cases: &[[u32; 4]]) -> Vec<[u32; 3]> {
    let out = run_cases(
        gpu(),
        "test.near_draw",
        NEAR_SRC,
        bytemuck::cast_slice(cases),
        cases.len() as u32,
        cases.len() as u64 * 16,
    );
    out.chunks_exact(4).map(|c| [c[0].to_bits(), c[1].to_bits(), c[2].to_bits()]).collect()
}

/// The twin's pick number for a case (the kernel's `rays` and `j`).
fn ray_twin(k: u32, m: u32, u: f32) -> u32 {
    let rays = 1 + k % 8;
    tiledlight_cull::stochastic::ray_number(u, m % rays, rays).to_bits()
}

/// The cases where the GPU's row differs from `twin`'s near draw or from the pick number.
fn near_mismatches(
    cases: &[[u32; 4]],
    rows: &[[u32; 3]],
    twin: impl Fn(u32, u32, u32, f32) -> (u32, u32),
) -> Vec<String> {
    cases
        .iter()
        .zip(rows)
        .filter_map(|(&[k, m, count, u], &[i, size, number])| {
            let u = f32::from_bits(u);
            let c = (twin(k, m, count, u), ray_twin(k, m, u));
            (c != ((i, size), number))
                .then(|| format!("k {k} m {m} count {count} u {u}: GPU ({i}, {size}), {number:#x}, CPU {c:?}"))
        })
        .collect()
}

#[test]
fn the_gpu_near_draw_matches_its_cpu_twin() {
    let cases = near_cases();
    let rows = run_near(&cases);
    let bad = near_mismatches(&cases, &rows, tiledlight_cull::stochastic::near_draw);
    let wrapped = rows.iter().zip(&cases).filter(|(r, c)| f32::from_bits(r[2]) < f32::from_bits(c[3])).count();
    eprintln!("{} near draws, {} mismatches, {wrapped} pick numbers wrapped", cases.len(), bad.len());
    assert!(wrapped > cases.len() / 10, "few pick numbers wrap past 1 ({wrapped}): the wrap is barely tested");
    assert!(bad.is_empty(), "{} of {} differ:\n{}", bad.len(), cases.len(), bad[..bad.len().min(10)].join("\n"));
}

/// The negative test: a twin that finds the stratum's start in f32 (`k count / m` rounded
/// to 24 bits) is rejected on the long lists.
#[test]
fn the_near_draw_comparison_rejects_a_twin_in_floats() {
    let cases = near_cases();
    let rows = run_near(&cases);
    let bad = near_mismatches(&cases, &rows, |k, m, count, u| {
        let start = |k: u32| (k as f32 * count as f32 / m as f32) as u32;
        let (first, size) = (start(k), start(k + 1) - start(k));
        (first + ((u * size as f32) as u32).min(size.max(1) - 1), size)
    });
    assert!(bad.len() >= 20, "only {} of {} caught", bad.len(), cases.len());
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

// Not called here (the temporal kernels below test it).
fn temporal_proxy(light: u32, x: vec3<f32>, n: vec3<f32>, s: vec2<u32>) -> f32 {
    return 0.0;
}

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
    let c = ReuseParams(screen, head.z, head.w, REUSE_RADIUS, REUSE_NORMAL_COS, REUSE_DISTANCE_SHARE, REUSE_DRAW_BASE);
    let m = reuse_combine(vec2<u32>(i % screen.x, i / screen.x), c);
    out[i] = vec4<u32>(m.r.light, bitcast<u32>(m.r.w_sum), m.count, bitcast<u32>(reservoir_weight(m.r)));
}
"#;

const REUSE_SIZE: (u32, u32) = (48, 32);

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
            // A pixel's candidates, or with temporal reuse up to 21x them.
            let count = if rng.unit() < 0.5 { 20 } else { (rng.unit() * 420.0) as u32 };
            Record { light, count, weight, normal, dist, surface }
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
    let constants = reuse_constants();
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
    let offers = reuse::offers(records, ((x, y), REUSE_SIZE), (k, frame), &reuse_scene());
    let (mut w_sum, mut margin) = (0.0f32, f32::INFINITY);
    for (_, w, _, u, _) in offers {
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
        let (c, count) = reuse::combine(twin, ((x, y), REUSE_SIZE), (k, frame), &reuse_scene());
        let close = |g: u32, c: f32| {
            let g = f32::from_bits(g);
            g == c || (g - c).abs() <= 1e-5 * c.abs().max(g.abs())
        };
        let pick_ok = row[0] == c.light || reuse_margin(records, (x, y), (frame, k)) < 1e-5;
        if row[2] != count || !close(row[1], c.w_sum) || !pick_ok || (row[0] == c.light && !close(row[3], c.weight())) {
            bad.push(format!("pixel ({x}, {y}): GPU {row:?}, CPU {c:?} count {count} weight {}", c.weight()));
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
                rows[i][3] != 0 && reuse::offers(&records, ((x, y), REUSE_SIZE), (k, frame), &reuse_scene()).len() > 1
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

// Temporal reuse (tiledlight_cull::temporal, shaders/common/reuse.wgsl): each case is this
// frame's reservoir (light, p_hat, w_sum, count 0..64), a history record (the spatial
// table's mix: sky, empty, weights 1e-30..1e30, counts to 2,000), the point and normal this
// pixel sees and the distance the reprojection expects, and a cap (1, 20 or 64): the GPU
// decides whether the record shows the same surface and merges, the twin likewise. The
// history's proxy depends on the light, the point, the normal and the material.
const TEMPORAL_STUBS: &str = r#"
#include "common/reuse.wgsl"

fn reuse_record(index: u32) -> RecordWords {
    return RecordWords(vec4<u32>(0u), vec4<u32>(0u));
}

fn reuse_position(q: vec2<u32>, dist: f32) -> vec3<f32> {
    return vec3<f32>(0.0);
}

fn reuse_proxy(light: u32, x: vec3<f32>, n: vec3<f32>, s: vec2<u32>) -> f32 {
    return 0.0;
}

fn reuse_target(light: u32) -> f32 {
    return select(f32((light * 2654435761u) >> 16u) / 65536.0, 0.0, light % 5u == 0u);
}

fn temporal_proxy(light: u32, x: vec3<f32>, n: vec3<f32>, s: vec2<u32>) -> f32 {
    return (0.5 + f32(light % 6u)) * (1.25 + n.x) * (1.0 + 0.05 * x.z * f32(light % 4u)) * (1.0 + f32(s.x & 255u) / 255.0);
}
"#;

const TEMPORAL_SRC: &str = r#"
@group(0) @binding(0) var<storage, read> cases: array<array<u32, 24>>;
@group(0) @binding(1) var<storage, read_write> out: array<vec4<u32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&cases) { return; }
    let w = cases[i];
    let own = Reservoir(w[4], bitcast<f32>(w[5]), bitcast<f32>(w[6]), w[7]);
    let h = record_unpack(RecordWords(vec4<u32>(w[8], w[9], w[10], w[11]), vec4<u32>(w[12], w[13], w[14], w[15])));
    let x = vec3<f32>(bitcast<f32>(w[16]), bitcast<f32>(w[17]), bitcast<f32>(w[18]));
    let n = vec3<f32>(bitcast<f32>(w[19]), bitcast<f32>(w[20]), bitcast<f32>(w[21]));
    let c = ReuseParams(vec2<u32>(1u), w[1], 0u, REUSE_RADIUS, REUSE_NORMAL_COS, REUSE_DISTANCE_SHARE, REUSE_DRAW_BASE);
    let kept = temporal_same_surface(n, bitcast<f32>(w[3]), h, c);
    let m = temporal_merge(own, h, x, kept, w[0], c, w[2]);
    out[i] = vec4<u32>(m.r.light, bitcast<u32>(m.r.w_sum), m.count, bitcast<u32>(reservoir_weight(m.r)));
}
"#;

/// The reuse's constants as WGSL, for the test kernels.
fn reuse_constants() -> String {
    format!(
        "const REUSE_RADIUS: i32 = {};\nconst REUSE_NORMAL_COS: f32 = {:?};\nconst REUSE_DISTANCE_SHARE: f32 = {:?};\nconst REUSE_DRAW_BASE: u32 = {}u;\n",
        reuse::RADIUS,
        reuse::NORMAL_COS,
        reuse::DISTANCE_SHARE,
        reuse::DRAW_BASE
    )
}

/// A temporal case: pixel, frame, cap, expected distance, this frame's reservoir, the
/// history's record, this pixel's point and normal.
struct TemporalCase {
    pixel: u32,
    frame: u32,
    cap: u32,
    dist: f32,
    own: Reservoir,
    history: Record,
    x: Vec3,
    normal: Vec3,
}

fn temporal_proxy(l: u32, x: Vec3, n: Vec3, s: [u32; 2]) -> f32 {
    (0.5 + (l % 6) as f32) * (1.25 + n.x) * (1.0 + 0.05 * x.z * (l % 4) as f32) * (1.0 + (s[0] & 255) as f32 / 255.0)
}

fn temporal_cases() -> Vec<TemporalCase> {
    let mut rng = Rng(4949);
    let records = reuse_records();
    let normals = [0.0f32, 10.0, 40.0].map(|d| Vec3::new(d.to_radians().sin(), 0.0, d.to_radians().cos()));
    let dists = [10.0f32, 10.5, 12.0];
    (0..4000u32)
        .map(|n| {
            let light = (rng.unit() * 4000.0) as u32;
            let m = if n % 50 == 0 { 0 } else { 1 + (rng.unit() * 64.0) as u32 };
            let p_hat = if rng.unit() < 0.1 { 0.0 } else { reuse_target(light) };
            let w = rng.log(1e-30, 1e30);
            let own = Reservoir { light, p_hat, w_sum: if p_hat > 0.0 { w * m as f32 * p_hat } else { 0.0 }, m };
            TemporalCase {
                pixel: n * 7919 + 5,
                frame: n / 7,
                cap: [1, temporal::DEFAULT_CAP, temporal::MAX_CAP][n as usize % 3],
                dist: dists[(rng.unit() * 3.0) as usize],
                own,
                history: records[n as usize % records.len()],
                x: Vec3::new(rng.unit(), rng.unit(), 10.0 * rng.unit()),
                normal: normals[(rng.unit() * 3.0) as usize],
            }
        })
        .collect()
}

/// The twin's merge of a case with the history's count capped at `cap` (the case's own in
/// the positive test), and the smallest margin of its history decision from a tie.
fn temporal_twin(c: &TemporalCase, cap: u32) -> ((Reservoir, u32), f32) {
    // The record as the GPU reads it (the normal through its octahedral code).
    let h = Record::unpack(c.history.pack());
    let kept = temporal::same_surface(c.normal, c.dist, &h);
    let merged = temporal::merge(&c.own, kept.then_some(&h), (c.pixel, c.frame, cap), reuse_target, |l| {
        temporal_proxy(l, c.x, h.normal, h.surface)
    });
    // Offer the history alone to find its weight: the decision is `u w_sum < w`.
    let alone = temporal::merge(
        &Reservoir { m: c.own.m, ..Reservoir::default() },
        kept.then_some(&h),
        (c.pixel, c.frame, cap),
        reuse_target,
        |l| temporal_proxy(l, c.x, h.normal, h.surface),
    );
    let w = alone.0.w_sum;
    let u = rand01(c.pixel, c.frame, temporal::DRAW);
    let margin = if w > 0.0 && merged.0.w_sum > 0.0 { (u * merged.0.w_sum - w).abs() / merged.0.w_sum } else { 1.0 };
    (merged, margin)
}

fn run_temporal(cases: &[TemporalCase]) -> Vec<[u32; 4]> {
    let mut words: Vec<u32> = Vec::new();
    for c in cases {
        let r = c.history.pack();
        words.extend([c.pixel, c.frame, c.cap, c.dist.to_bits(), c.own.light, c.own.p_hat.to_bits()]);
        words.extend([c.own.w_sum.to_bits(), c.own.m]);
        words.extend(r);
        words.extend([c.x.x, c.x.y, c.x.z, c.normal.x, c.normal.y, c.normal.z].map(f32::to_bits));
        words.extend([0, 0]);
    }
    let n = cases.len() as u32;
    let src = reuse_constants() + TEMPORAL_STUBS + TEMPORAL_SRC;
    let out = run_cases(gpu(), "test.stochastic.temporal", &src, bytemuck::cast_slice(&words), n, u64::from(n) * 16);
    out.chunks_exact(4).map(|c| [0, 1, 2, 3].map(|j| c[j].to_bits())).collect()
}

fn temporal_mismatches(
    cases: &[TemporalCase],
    rows: &[[u32; 4]],
    cap_of: impl Fn(&TemporalCase) -> u32,
) -> Vec<String> {
    let mut bad = Vec::new();
    for (i, (c, row)) in cases.iter().zip(rows).enumerate() {
        let ((r, count), margin) = temporal_twin(c, cap_of(c));
        let close = |g: u32, c: f32| {
            let g = f32::from_bits(g);
            g == c || (g - c).abs() <= 1e-5 * c.abs().max(g.abs())
        };
        let pick_ok = row[0] == r.light || margin < 1e-5;
        if row[2] != count || !close(row[1], r.w_sum) || !pick_ok || (row[0] == r.light && !close(row[3], r.weight())) {
            bad.push(format!("case {i}: GPU {row:?}, CPU {r:?} count {count} weight {}", r.weight()));
        }
    }
    bad
}

#[test]
fn the_gpu_temporal_merge_matches_its_cpu_twin() {
    let cases = temporal_cases();
    let rows = run_temporal(&cases);
    let bad = temporal_mismatches(&cases, &rows, |c| c.cap);
    // Cases that kept the history's light: the merge is exercised, not just its own input.
    let history_kept =
        cases.iter().zip(&rows).filter(|(c, row)| row[0] == c.history.light && row[0] != c.own.light).count();
    let merged = cases.iter().filter(|c| temporal::same_surface(c.normal, c.dist, &c.history)).count();
    eprintln!(
        "{} cases, {merged} with the same surface, {history_kept} kept the history's light, {} mismatches",
        cases.len(),
        bad.len()
    );
    assert!(
        merged * 5 > cases.len() && history_kept * 20 > cases.len(),
        "the history is barely merged: {merged}, {history_kept}"
    );
    assert!(bad.is_empty(), "{} of {} cases differ:\n{}", bad.len(), cases.len(), bad[..bad.len().min(10)].join("\n"));
}

/// The negative test: a twin without the cap (the history's whole count) is rejected on
/// many of the cases that merged a history of more than the cap allows.
#[test]
fn the_temporal_comparison_rejects_a_twin_without_the_cap() {
    let cases = temporal_cases();
    let rows = run_temporal(&cases);
    let bad = temporal_mismatches(&cases, &rows, |_| u32::MAX);
    let capped = cases
        .iter()
        .filter(|c| {
            temporal::same_surface(c.normal, c.dist, &c.history) && c.history.count > c.own.m * c.cap && c.own.m > 0
        })
        .count();
    assert!(capped > 100, "few cases exceed the cap ({capped})");
    assert!(bad.len() * 2 > capped, "only {} of {capped} capped cases caught", bad.len());
}

// Reprojection (tiledlight_cull::temporal::reproject): points near and around the target of
// random perspective cameras (some behind the eye, some beside the frustum), on screens of
// odd and even sizes.
const REPROJECT_SRC: &str = r#"
@group(0) @binding(0) var<storage, read> cases: array<array<f32, 40>>;
@group(0) @binding(1) var<storage, read_write> out: array<vec4<u32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&cases) { return; }
    let c = cases[i];
    let clip = mat4x4<f32>(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9], c[10], c[11], c[12], c[13],
        c[14], c[15]);
    let view = mat4x4<f32>(c[16], c[17], c[18], c[19], c[20], c[21], c[22], c[23], c[24], c[25], c[26], c[27],
        c[28], c[29], c[30], c[31]);
    let q = temporal_reproject(vec3<f32>(c[32], c[33], c[34]), clip, view, vec2<u32>(bitcast<u32>(c[35]), bitcast<u32>(c[36])));
    out[i] = vec4<u32>(bitcast<u32>(q.pixel.x), bitcast<u32>(q.pixel.y), bitcast<u32>(q.dist), 0u);
}
"#;

struct ReprojectCase {
    clip: glam::Mat4,
    view: glam::Mat4,
    point: Vec3,
    screen: (u32, u32),
}

fn reproject_cases() -> Vec<ReprojectCase> {
    let mut rng = Rng(5050);
    (0..3000)
        .map(|n| {
            let eye = Vec3::new(rng.unit() * 20.0 - 10.0, rng.unit() * 8.0 + 0.5, rng.unit() * 20.0 - 10.0);
            let target = Vec3::new(rng.unit() * 4.0 - 2.0, rng.unit(), rng.unit() * 4.0 - 2.0);
            let screen = [(320, 180), (161, 91), (1920, 1080)][n % 3];
            let camera = tiledlight_cull::Camera::perspective(
                eye,
                target,
                Vec3::Y,
                (30.0 + 60.0 * rng.unit()).to_radians(),
                screen.0 as f32 / screen.1 as f32,
                0.1,
                None,
            )
            .expect("camera");
            let spread = if n % 4 == 0 { 40.0 } else { 6.0 };
            let point = target + Vec3::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5) * spread;
            ReprojectCase { clip: camera.view_proj(), view: camera.view(), point, screen }
        })
        .collect()
}

fn run_reproject(cases: &[ReprojectCase]) -> Vec<[u32; 4]> {
    let mut words: Vec<u32> = Vec::new();
    for c in cases {
        words.extend(c.clip.to_cols_array().map(f32::to_bits));
        words.extend(c.view.to_cols_array().map(f32::to_bits));
        words.extend([c.point.x, c.point.y, c.point.z].map(f32::to_bits));
        words.extend([c.screen.0, c.screen.1, 0, 0, 0]);
    }
    let n = cases.len() as u32;
    let src = reuse_constants() + TEMPORAL_STUBS + REPROJECT_SRC;
    let out = run_cases(gpu(), "test.stochastic.reproject", &src, bytemuck::cast_slice(&words), n, u64::from(n) * 16);
    out.chunks_exact(4).map(|c| [0, 1, 2, 3].map(|j| c[j].to_bits())).collect()
}

/// Cases the GPU reprojects otherwise than `twin`, beyond a pixel boundary within rounding
/// (the point's screen coordinate within 1e-3 of an integer).
fn reproject_mismatches(
    cases: &[ReprojectCase],
    rows: &[[u32; 4]],
    twin: impl Fn(&ReprojectCase) -> Option<((u32, u32), f32)>,
) -> Vec<String> {
    let mut bad = Vec::new();
    for (i, (c, row)) in cases.iter().zip(rows).enumerate() {
        let clip = c.clip * c.point.extend(1.0);
        let f = [(clip.x / clip.w + 1.0) * 0.5 * c.screen.0 as f32, (1.0 - clip.y / clip.w) * 0.5 * c.screen.1 as f32];
        let near_edge = f.iter().any(|v| (v - v.round()).abs() < 1e-3) || clip.w.abs() < 1e-4;
        let (gx, gy, gd) = (row[0] as i32, row[1] as i32, f32::from_bits(row[2]));
        let ok = match twin(c) {
            Some(((x, y), d)) => (gx, gy) == (x as i32, y as i32) && (gd - d).abs() <= 1e-5 * d.abs().max(1.0),
            None => (gx, gy) == (-1, -1),
        };
        if !ok && !near_edge {
            bad.push(format!("case {i}: GPU ({gx}, {gy}) {gd}, CPU {:?}", twin(c)));
        }
    }
    bad
}

#[test]
fn the_gpu_reprojection_matches_its_cpu_twin() {
    let cases = reproject_cases();
    let rows = run_reproject(&cases);
    let twin = |c: &ReprojectCase| temporal::reproject(c.point, (&c.clip, &c.view), c.screen);
    let bad = reproject_mismatches(&cases, &rows, twin);
    let on = cases.iter().filter(|c| twin(c).is_some()).count();
    eprintln!("{} cases, {on} on the screen, {} mismatches", cases.len(), bad.len());
    assert!(on * 2 > cases.len() && on * 20 < cases.len() * 19, "both outcomes must be common ({on} on the screen)");
    assert!(bad.is_empty(), "{} of {} cases differ:\n{}", bad.len(), cases.len(), bad[..bad.len().min(10)].join("\n"));
}

/// The negative test: a twin whose rows run upwards (no flip of NDC's y) is rejected on
/// most cases on the screen.
#[test]
fn the_reprojection_comparison_rejects_a_twin_with_rows_upwards() {
    let cases = reproject_cases();
    let rows = run_reproject(&cases);
    let flipped = |c: &ReprojectCase| {
        temporal::reproject(c.point, (&c.clip, &c.view), c.screen).map(|((x, y), d)| ((x, c.screen.1 - 1 - y), d))
    };
    let bad = reproject_mismatches(&cases, &rows, flipped);
    let on = cases.iter().filter(|c| flipped(c).is_some()).count();
    assert!(bad.len() * 10 > on * 9, "only {} of {on} cases caught", bad.len());
}

// The light tree (tiledlight_cull::light_tree, shaders/common/light_tree.wgsl): a tree of
// 3,000 lights (clusters, a line of lights at one point, powers over four decades, some
// dark; a third of them the list's) descended at 4,096 points on the GPU and by the twin. Each case's point, pixel,
// frame and draw come from its index, the same on both sides; a choice may differ only
// where the twin's number was within 1e-5 of the share (rounding of the importances).
const TREE_SRC: &str = r#"
@group(0) @binding(0) var<storage, read> light_tree: array<LightNode>;
@group(0) @binding(1) var<storage, read_write> out: array<vec2<u32>>;
#include "common/light_tree.wgsl"

// A third of the lights are the list's (left out where their sibling is not).
fn tree_reaches(light: u32, p: vec3<f32>) -> bool {
    return light % 3u == 0u;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= 4096u { return; }
    let p = vec3<f32>(f32(i % 37u) * 0.75 - 13.0, f32(i % 11u) * 0.5, f32((i / 37u) % 29u) * 0.875 - 12.0);
    out[i] = tree_sample(p, i * 7919u, i / 64u, i % 5u);
}
"#;

const TREE_CASES: u32 = 4096;

fn tree_point(i: u32) -> Vec3 {
    Vec3::new((i % 37) as f32 * 0.75 - 13.0, (i % 11) as f32 * 0.5, ((i / 37) % 29) as f32 * 0.875 - 12.0)
}

fn tree_lights() -> Vec<tiledlight_cull::light_tree::TreeLight> {
    let mut rng = Rng(777);
    (0..3000)
        .map(|i| {
            let p = match i % 10 {
                0 => Vec3::new(2.0, 1.0, -3.0),
                1..=3 => Vec3::new(rng.unit() * 2.0 - 8.0, rng.unit(), rng.unit() * 2.0 + 4.0),
                _ => Vec3::new(rng.unit() * 30.0 - 15.0, rng.unit() * 6.0, rng.unit() * 30.0 - 15.0),
            };
            let power = if i % 17 == 0 { 0.0 } else { rng.log(1e-2, 1e2) };
            // Radii of 0.5 to 3 m: whole boxes around some points are the list's.
            (p, power, 0.5 + 2.5 * rng.unit())
        })
        .collect()
}

/// How far one level's share may be from the twin's, in units of 2^-24 of it: each
/// child's importance is a few rounded operations (a squared distance the GPU may contract
/// into FMAs, a division WGSL allows 2.5 ulps), within about 6 ulps; their share within 16.
const SHARE_ULPS: f32 = 16.0;

/// The twin's descent for case `i` with level numbers taken `shift` levels on (0: the
/// GPU's): the light, its probability, the smallest distance of a choice's number from its
/// share, and the relative error the probability may carry from the shares' rounding.
/// Taking the second child multiplies by `1 - share`, whose relative error is the share's
/// times `share / (1 - share)`: a choice of a child the tree weighs little (measured on
/// the H100: one descent of 4,096 at 1.3e-5) carries more than the rest.
fn tree_twin(t: &tiledlight_cull::light_tree::LightTree, i: u32, shift: u32) -> (u32, f32, f32, f32) {
    use tiledlight_cull::light_tree::{child_importance, first_share, level_rand, LEAF};
    let reaches = |l: u32, _: Vec3| l.is_multiple_of(3);
    let p = tree_point(i);
    let (mut node, mut pdf, mut margin, mut error) = (t.nodes[0], 1.0f32, f32::INFINITY, 0.0f32);
    let ulp = SHARE_ULPS * f32::powi(2.0, -24);
    for level in 0.. {
        if node.link & LEAF != 0 {
            return (node.link & !LEAF, pdf, margin, error);
        }
        let (a, b) = (t.nodes[node.link as usize], t.nodes[node.link as usize + 1]);
        let share = first_share(child_importance(&a, p, &reaches), child_importance(&b, p, &reaches));
        let u = level_rand(i * 7919, i / 64, i % 5, level + shift);
        margin = margin.min((u - share).abs());
        (node, pdf, error) = if u < share {
            (a, pdf * share, error + ulp)
        } else {
            (b, pdf * (1.0 - share), error + ulp * share.max(1.0 - share) / (1.0 - share))
        };
    }
    unreachable!()
}

fn run_tree(t: &tiledlight_cull::light_tree::LightTree) -> Vec<(u32, f32)> {
    let out = run_cases(
        gpu(),
        "test.light_tree",
        TREE_SRC,
        bytemuck::cast_slice(&t.nodes),
        TREE_CASES,
        u64::from(TREE_CASES) * 8,
    );
    out.chunks_exact(2).map(|c| (c[0].to_bits(), c[1])).collect()
}

fn tree_mismatches(t: &tiledlight_cull::light_tree::LightTree, rows: &[(u32, f32)], shift: u32) -> Vec<String> {
    let mut bad = Vec::new();
    for (i, &(light, pdf)) in rows.iter().enumerate() {
        let (l, q, margin, error) = tree_twin(t, i as u32, shift);
        let same = light == l && (pdf - q).abs() <= error * q.max(pdf);
        if !same && margin > 1e-5 {
            bad.push(format!("case {i}: GPU light {light} p {pdf:e}, CPU light {l} p {q:e}"));
        }
    }
    bad
}

#[test]
fn the_gpu_light_tree_draws_as_its_cpu_twin() {
    let t = tiledlight_cull::light_tree::LightTree::from_points(&tree_lights());
    let rows = run_tree(&t);
    let bad = tree_mismatches(&t, &rows, 0);
    let distinct: std::collections::HashSet<u32> = rows.iter().map(|r| r.0).collect();
    eprintln!("{TREE_CASES} descents, {} distinct lights drawn, {} mismatches", distinct.len(), bad.len());
    assert!(distinct.len() > 500, "the descents reach few lights ({})", distinct.len());
    assert!(rows.iter().all(|r| r.1 > 0.0), "a descent without a probability");
    assert!(bad.is_empty(), "{} of {TREE_CASES} descents differ:\n{}", bad.len(), bad[..bad.len().min(10)].join("\n"));
}

/// The negative test: a twin that takes each level's number from the next level is
/// rejected on most descents.
#[test]
fn the_light_tree_comparison_rejects_a_twin_with_other_numbers() {
    let t = tiledlight_cull::light_tree::LightTree::from_points(&tree_lights());
    let rows = run_tree(&t);
    let bad = tree_mismatches(&t, &rows, 1);
    assert!(bad.len() * 10 > TREE_CASES as usize * 8, "only {} of {TREE_CASES} descents caught", bad.len());
}
