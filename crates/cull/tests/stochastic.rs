//! The stochastic sampler's twin (`tiledlight_cull::stochastic`, issue 48) is unbiased: on
//! a floor with a box and a wall between it and 40 lights (points and spots, some in the
//! box's shadow), the mean of many independent one-sample-per-pixel estimates (no reuse, no
//! denoising) converges to the truth, every light's contribution times its shadow ray
//! (`raycast::Triangles`), within a bound derived from the sample variance; so do merged
//! reservoirs. The negative test: a sampler that draws its candidates from another pdf than
//! the one it weights them by is rejected by the same test.
//!
//! The statistic: per pixel `z = (mean - truth) / sqrt(var / K)` over `K` frames. An
//! unbiased estimator gives `z` about standard normal: every `|z| <= 4.5` (a false alarm
//! under 1e-5 a pixel) and the mean of `z^2` within 1 +- 6 sqrt(2 / N) over `N` pixels. The
//! estimate of a pixel with zero variance (no light reaches it, or one light only) must
//! equal the truth to f32 rounding.

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use tiledlight_cull::brdf::Surface;
use tiledlight_cull::light::{Light, LightKind};
use tiledlight_cull::light_tree::LightTree;
use tiledlight_cull::raycast::Triangles;
use tiledlight_cull::stochastic::{
    estimate, luminance, near_draw, rand01, reaches, resample, resample_near_far, resample_near_far_rays, unshadowed,
    FarSource, Reservoir,
};

/// A surface point: position, normal, direction to the eye, material.
struct Pixel {
    p: Vec3,
    n: Vec3,
    v: Vec3,
    s: Surface,
}

/// Two triangles of an axis-aligned quad from its four corners.
fn quad(tris: &mut Vec<[Vec3; 3]>, a: Vec3, b: Vec3, c: Vec3, d: Vec3) {
    tris.push([a, b, c]);
    tris.push([a, c, d]);
}

/// The scene (lights of threshold 0.02): a floor of 8 x 8 m at y = 0, a 1 m box at the centre, a 3 m wall 2 m high at
/// z = -1.5; 32 point lights and 8 spots pointing down, 0.3 to 2.5 m up.
fn scene() -> (Triangles, Vec<Light>, Vec<Pixel>) {
    scene_at(0.02)
}

/// [`scene`] with the lights' radii set by `threshold` (their intensity there).
fn scene_at(threshold: f32) -> (Triangles, Vec<Light>, Vec<Pixel>) {
    let mut tris = Vec::new();
    let v = Vec3::new;
    quad(&mut tris, v(-4.0, 0.0, -4.0), v(4.0, 0.0, -4.0), v(4.0, 0.0, 4.0), v(-4.0, 0.0, 4.0));
    let (lo, hi) = (v(-0.5, 0.0, -0.5), v(0.5, 1.0, 0.5));
    for (a, b, c, d) in [
        (v(lo.x, hi.y, lo.z), v(hi.x, hi.y, lo.z), v(hi.x, hi.y, hi.z), v(lo.x, hi.y, hi.z)),
        (v(lo.x, lo.y, lo.z), v(hi.x, lo.y, lo.z), v(hi.x, hi.y, lo.z), v(lo.x, hi.y, lo.z)),
        (v(lo.x, lo.y, hi.z), v(hi.x, lo.y, hi.z), v(hi.x, hi.y, hi.z), v(lo.x, hi.y, hi.z)),
        (v(lo.x, lo.y, lo.z), v(lo.x, lo.y, hi.z), v(lo.x, hi.y, hi.z), v(lo.x, hi.y, lo.z)),
        (v(hi.x, lo.y, lo.z), v(hi.x, lo.y, hi.z), v(hi.x, hi.y, hi.z), v(hi.x, hi.y, lo.z)),
    ] {
        quad(&mut tris, a, b, c, d);
    }
    quad(&mut tris, v(-1.5, 0.0, -1.5), v(1.5, 0.0, -1.5), v(1.5, 2.0, -1.5), v(-1.5, 2.0, -1.5));
    let mut rng = Pcg64::seed_from_u64(48);
    let mut lights = Vec::new();
    for k in 0..40 {
        let position = v(rng.random_range(-3.5..3.5), rng.random_range(0.3..2.5), rng.random_range(-3.5..3.5));
        let color = v(rng.random_range(0.2..1.0), rng.random_range(0.2..1.0), rng.random_range(0.2..1.0));
        let intensity = rng.random_range(0.5..4.0);
        let light = if k < 32 {
            Light::point(position, color, intensity, threshold).unwrap()
        } else {
            let kind = Light::spot_kind(v(rng.random_range(-0.3..0.3), -1.0, 0.0), 0.4, 0.7).unwrap();
            Light { kind, ..Light::point(position, color, intensity, threshold).unwrap() }
        };
        assert!(matches!(light.kind, LightKind::Point) == (k < 32));
        lights.push(light);
    }
    let eye = v(0.0, 5.0, 8.0);
    let mut pixels = Vec::new();
    for i in 0..12 {
        for j in 0..12 {
            let p = v(-3.3 + 0.6 * i as f32, 0.0, -3.3 + 0.6 * j as f32);
            let inside_box = p.x.abs() < 0.5 && p.z.abs() < 0.5;
            let p = if inside_box { v(p.x, 1.0, p.z) } else { p };
            let s = Surface {
                albedo: v(0.7, 0.6, 0.5),
                roughness: if (i + j) % 3 == 0 { 0.25 } else { 0.7 },
                metallic: if (i + j) % 5 == 0 { 1.0 } else { 0.0 },
            };
            pixels.push(Pixel { p, n: Vec3::Y, v: (eye - p).normalize(), s });
        }
    }
    (Triangles::new(tris), lights, pixels)
}

fn visible(bvh: &Triangles, px: &Pixel, light: &Light) -> bool {
    !bvh.occluded(px.p + px.n * 1e-3, light.position, 1e-4)
}

/// The truth at `px`: every light's contribution times its shadow ray (luminance).
fn truth(bvh: &Triangles, lights: &[Light], px: &Pixel, cutoff: bool) -> f64 {
    lights
        .iter()
        .filter(|l| visible(bvh, px, l))
        .map(|l| f64::from(luminance(unshadowed(l, (px.p, px.n, px.v), &px.s, cutoff))))
        .sum()
}

/// The verdict of the statistic over `K` frames of `sample(pixel, frame)` (luminance).
fn unbiased(
    what: &str,
    (bvh, lights, pixels): (&Triangles, &[Light], &[Pixel]),
    cutoff: bool,
    frames: u32,
    sample: impl Fn(u32, &Pixel, u32) -> f32,
) -> Result<(), String> {
    unbiased_against(what, (bvh, pixels), |px| truth(bvh, lights, px, cutoff), frames, sample)
}

/// [`unbiased`] against the truth `truth(pixel)`.
fn unbiased_against(
    what: &str,
    (_bvh, pixels): (&Triangles, &[Pixel]),
    truth: impl Fn(&Pixel) -> f64,
    frames: u32,
    sample: impl Fn(u32, &Pixel, u32) -> f32,
) -> Result<(), String> {
    let (mut z2_sum, mut n_z) = (0.0f64, 0usize);
    let mut worst = (0.0f64, 0usize);
    for (i, px) in pixels.iter().enumerate() {
        let t = truth(px);
        let xs: Vec<f64> = (0..frames).map(|f| f64::from(sample(i as u32, px, f))).collect();
        let k = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / k;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (k - 1.0);
        if var <= 1e-18 * mean.abs().max(1.0) {
            if (mean - t).abs() > 1e-5 * t.abs().max(1e-6) {
                return Err(format!("{what}: pixel {i} has no variance but its estimate {mean} is not the truth {t}"));
            }
            continue;
        }
        let z = (mean - t) / (var / k).sqrt();
        z2_sum += z * z;
        n_z += 1;
        if z.abs() > worst.0 {
            worst = (z.abs(), i);
        }
    }
    let n = n_z as f64;
    let mean_z2 = z2_sum / n;
    let band = 6.0 * (2.0 / n).sqrt();
    eprintln!(
        "{what}: {n_z} pixels with variance, mean z^2 {mean_z2:.3} (1 +- {band:.3}), worst |z| {:.2} at pixel {}",
        worst.0, worst.1
    );
    if n_z < pixels.len() / 2 {
        return Err(format!("{what}: only {n_z} pixels vary: the scene tests too little"));
    }
    if worst.0 > 4.5 || (mean_z2 - 1.0).abs() > band {
        return Err(format!("{what}: biased: worst |z| {:.2} at pixel {}, mean z^2 {mean_z2:.3}", worst.0, worst.1));
    }
    Ok(())
}

const FRAMES: u32 = 3000;

/// Resampled importance sampling with 8 uniform candidates over every light, one shadow ray
/// a pixel, converges to the truth with and without the radius cutoff; so do two reservoirs
/// of 4 candidates merged into one.
#[test]
fn one_sample_a_pixel_converges_to_the_truth() {
    let (bvh, lights, pixels) = scene();
    let all: Vec<u32> = (0..lights.len() as u32).collect();
    for cutoff in [true, false] {
        let ris = |i: u32, px: &Pixel, f: u32| {
            let r = resample(&lights, &all, (px.p, px.n, px.v), &px.s, (8, cutoff), (i, f));
            luminance(estimate(&lights, &r, (px.p, px.n, px.v), &px.s, cutoff, |l| {
                visible(&bvh, px, &lights[l as usize])
            }))
        };
        unbiased(&format!("RIS M=8, cutoff {cutoff}"), (&bvh, &lights, &pixels), cutoff, FRAMES, ris).unwrap();
    }
    let merged = |i: u32, px: &Pixel, f: u32| {
        let at = (px.p, px.n, px.v);
        let mut a = resample(&lights, &all, at, &px.s, (4, true), (i, 2 * f));
        let b = resample(&lights, &all, at, &px.s, (4, true), (i, 2 * f + 1));
        a.merge(&b, rand01(i, f, 1_000_000));
        luminance(estimate(&lights, &a, at, &px.s, true, |l| visible(&bvh, px, &lights[l as usize])))
    };
    unbiased("two reservoirs of 4 merged", (&bvh, &lights, &pixels), true, FRAMES, merged).unwrap();
}

/// The negative test: candidates drawn with probability growing with their index (`u^2`:
/// low indices favoured) but weighted as if uniform, the bug of a source pdf that does not
/// match the draw, is rejected by the same statistic.
#[test]
fn a_sampler_with_the_wrong_pdf_is_rejected() {
    let (bvh, lights, pixels) = scene();
    let n = lights.len() as u32;
    let wrong = |i: u32, px: &Pixel, f: u32| {
        let at = (px.p, px.n, px.v);
        let mut r = Reservoir::default();
        for k in 0..8 {
            let u = rand01(i, f, 2 * k);
            let light = ((u * u * n as f32) as u32).min(n - 1);
            let p_hat = luminance(unshadowed(&lights[light as usize], at, &px.s, true));
            r.update(light, (p_hat * n as f32, p_hat), rand01(i, f, 2 * k + 1));
        }
        luminance(estimate(&lights, &r, at, &px.s, true, |l| visible(&bvh, px, &lights[l as usize])))
    };
    let verdict = unbiased("wrong pdf", (&bvh, &lights, &pixels), true, FRAMES, wrong);
    assert!(verdict.is_err(), "a sampler whose pdf does not match its draw passed as unbiased");
}

/// The lights' threshold of the two-source tests: radii of 1.3 to 3.7 m on the 8 m floor.
const NEAR_FAR_THRESHOLD: f32 = 0.3;

/// The pixel's list as the culling would give it: every light whose radius reaches the
/// point, and (conservatively, as a tile's list does) every third other light.
fn list_of(lights: &[Light], px: &Pixel) -> Vec<u32> {
    (0..lights.len() as u32).filter(|&l| reaches(&lights[l as usize], px.p) || l % 3 == 0).collect()
}

/// The method's two sources (near: the pixel's list, for the lights whose radius reaches
/// it; far: every light, for the rest) converge to the truth without the cutoff; with no
/// far candidates, to the truth of the near lights alone (the cutoff's bias, by design). The
/// radii are small enough that both sources matter: some pixels reach a few lights, most
/// lights are far.
#[test]
fn near_and_far_candidates_converge_to_the_truth() {
    let (bvh, lights, pixels) = scene_at(NEAR_FAR_THRESHOLD);
    let near_share: usize = pixels.iter().map(|px| lights.iter().filter(|l| reaches(l, px.p)).count()).sum();
    assert!(
        near_share > pixels.len() && near_share < pixels.len() * lights.len() / 2,
        "both sources are exercised ({near_share} near pairs)"
    );
    let tree = LightTree::build(&lights);
    let near_far_from = |m: (u32, u32), from_tree: bool| {
        let (bvh, lights, tree) = (&bvh, &lights, from_tree.then_some(&tree as &dyn FarSource));
        move |i: u32, px: &Pixel, f: u32| {
            let at = (px.p, px.n, px.v);
            let r = resample_near_far(lights, &list_of(lights, px), at, &px.s, m, (i, f), tree);
            luminance(estimate(lights, &r, at, &px.s, false, |l| visible(bvh, px, &lights[l as usize])))
        }
    };
    let near_far = |m: (u32, u32)| near_far_from(m, false);
    unbiased("near 4 + far 2", (&bvh, &lights, &pixels), false, FRAMES, near_far((4, 2))).unwrap();
    // As many near candidates as the longest list: every list light once (stratified draws
    // with strata of one), the near lights' unshadowed sum exact.
    let longest = pixels.iter().map(|px| list_of(&lights, px).len()).max().unwrap() as u32;
    assert!(longest > 4 && longest < 40, "the lists are longer than 4 candidates ({longest})");
    unbiased("every list light + far 2", (&bvh, &lights, &pixels), false, FRAMES, near_far((longest, 2))).unwrap();
    // Three picks of the same candidates, a ray each, their mean.
    let rays = |i: u32, px: &Pixel, f: u32| {
        let at = (px.p, px.n, px.v);
        let picks = resample_near_far_rays(&lights, &list_of(&lights, px), at, &px.s, (4, 2), (i, f), (None, 3));
        let sum: f32 = picks
            .iter()
            .map(|r| luminance(estimate(&lights, r, at, &px.s, false, |l| visible(&bvh, px, &lights[l as usize]))))
            .sum();
        sum / 3.0
    };
    unbiased("near 4 + far 2, 3 rays", (&bvh, &lights, &pixels), false, FRAMES, rays).unwrap();
    // The far candidates from the light tree: unbiased too.
    unbiased("near 4 + far 2, light tree", (&bvh, &lights, &pixels), false, FRAMES, near_far_from((4, 2), true))
        .unwrap();
    // No far candidates: the near lights' truth (unwindowed), nothing of the far ones.
    let near_only: Vec<Vec<Light>> = pixels
        .iter()
        .map(|px| lights.iter().map(|l| if reaches(l, px.p) { *l } else { Light { intensity: 0.0, ..*l } }).collect())
        .collect();
    let index: std::collections::HashMap<[u32; 3], usize> =
        pixels.iter().enumerate().map(|(i, px)| (px.p.to_array().map(f32::to_bits), i)).collect();
    let near_only_truth = |px: &Pixel| &near_only[index[&px.p.to_array().map(f32::to_bits)]];
    let verdict = unbiased_against(
        "near 4, no far",
        (&bvh, &pixels),
        |px| truth(&bvh, near_only_truth(px), px, false),
        FRAMES,
        near_far((4, 0)),
    );
    verdict.unwrap();
    // And that truth is not the whole truth: the far lights' share is what `m_far` buys.
    let whole: f64 = pixels.iter().map(|px| truth(&bvh, &lights, px, false)).sum();
    let near: f64 = pixels.iter().map(|px| truth(&bvh, near_only_truth(px), px, false)).sum();
    assert!(near < 0.95 * whole, "the far lights carry light ({near} of {whole})");
}

/// The negative test of the two sources: a far source that does not leave out the near
/// lights counts them twice (once from each source), and the same statistic rejects it.
#[test]
fn near_and_far_sources_that_overlap_are_rejected() {
    let (bvh, lights, pixels) = scene_at(NEAR_FAR_THRESHOLD);
    let n = lights.len() as u32;
    let overlapping = |i: u32, px: &Pixel, f: u32| {
        let at = (px.p, px.n, px.v);
        let list = list_of(&lights, px);
        let mut r = Reservoir::default();
        let (m_near, m_far) = (4u32, 2u32);
        for k in 0..m_near + m_far {
            let near = k < m_near;
            let count = if near { list.len() as u32 } else { n };
            let j = ((rand01(i, f, 2 * k) * count as f32) as u32).min(count - 1);
            let light = if near { list[j as usize] } else { j };
            let l = &lights[light as usize];
            // The bug: the far source keeps the near lights too.
            let p_hat = if !near || reaches(l, px.p) { luminance(unshadowed(l, at, &px.s, false)) } else { 0.0 };
            let m = if near { m_near } else { m_far };
            r.update(light, (p_hat * count as f32 * 6.0 / m as f32, p_hat), rand01(i, f, 2 * k + 1));
        }
        luminance(estimate(&lights, &r, at, &px.s, false, |l| visible(&bvh, px, &lights[l as usize])))
    };
    let verdict = unbiased("overlapping sources", (&bvh, &lights, &pixels), false, FRAMES, overlapping);
    assert!(verdict.is_err(), "two sources that both make the near lights passed as unbiased");
}

/// The negative test of the stratified near draws: strata of `count / m` entries each, the
/// remainder at the list's end never drawn (the bug integer division invites), weighted as
/// if they covered the list, are rejected by the same statistic; the lists' lengths are
/// not multiples of 4, so every pixel misses some lights.
#[test]
fn near_strata_that_miss_the_lists_end_are_rejected() {
    let (bvh, lights, pixels) = scene_at(NEAR_FAR_THRESHOLD);
    let m = 4u32;
    let short = pixels.iter().filter(|px| !(list_of(&lights, px).len() as u32).is_multiple_of(m)).count();
    assert!(short > pixels.len() / 2, "most lists leave a remainder ({short} of {})", pixels.len());
    let missing = |i: u32, px: &Pixel, f: u32| {
        let at = (px.p, px.n, px.v);
        let list = list_of(&lights, px);
        let count = list.len() as u32;
        let mut r = Reservoir::default();
        for k in 0..m {
            let size = count / m;
            let u = rand01(i, f, 2 * k);
            let j = k * size + ((u * size as f32) as u32).min(size - 1);
            // The right draw's light lies in the same stratum when the sizes agree.
            assert!(!count.is_multiple_of(m) || j / size == near_draw(k, m, count, u).0 / size);
            let l = &lights[list[j as usize] as usize];
            let p_hat = if reaches(l, px.p) { luminance(unshadowed(l, at, &px.s, false)) } else { 0.0 };
            r.update(list[j as usize], (p_hat * count as f32, p_hat), rand01(i, f, 2 * k + 1));
        }
        luminance(estimate(&lights, &r, at, &px.s, false, |l| visible(&bvh, px, &lights[l as usize])))
    };
    // The truth of the near lights alone (no far candidates here).
    let near_truth = |px: &Pixel| {
        let near: Vec<Light> =
            lights.iter().map(|l| if reaches(l, px.p) { *l } else { Light { intensity: 0.0, ..*l } }).collect();
        truth(&bvh, &near, px, false)
    };
    let verdict = unbiased_against("strata missing the end", (&bvh, &pixels), near_truth, FRAMES, missing);
    assert!(verdict.is_err(), "near draws that never reach the list's end passed as unbiased");
}
