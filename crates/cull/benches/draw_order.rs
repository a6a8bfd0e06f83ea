//! The CPU cost of sorting a frame's draws nearest first (`DrawOrder::front_to_back`),
//! which a frame pays whenever the eye moves: the Figure 9 scene's size (434 instances in
//! 16 draws, the largest of 280) and a large scene (100,000 instances in 1,000 draws of
//! 100). Instances are scattered through a 100 m cube, seeded.

use std::hint::black_box;
use std::ops::Range;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use tiledlight_cull::draw_order::DrawOrder;

/// `draws` draw ranges of the given sizes and one unit box a slot, scattered.
fn scene(sizes: &[u32]) -> (Vec<Range<u32>>, Vec<(Vec3, Vec3)>) {
    let mut rng = Pcg64::seed_from_u64(7);
    let mut ranges = Vec::new();
    let mut start = 0;
    for &n in sizes {
        ranges.push(start..start + n);
        start += n;
    }
    let bounds = (0..start)
        .map(|_| {
            let c =
                Vec3::new(rng.random_range(-50.0..50.0), rng.random_range(-50.0..50.0), rng.random_range(-50.0..50.0));
            (c - 0.5, c + 0.5)
        })
        .collect();
    (ranges, bounds)
}

fn bench(c: &mut Criterion) {
    let mut figure9 = vec![280u32];
    figure9.extend([1, 1, 1, 1, 10, 10, 20, 20, 8, 8, 4, 4, 6, 30, 30]);
    let large = vec![100u32; 1000];
    let mut g = c.benchmark_group("draw_order_front_to_back");
    for (name, sizes) in [("figure9_434", figure9), ("large_100000", large)] {
        let (ranges, bounds) = scene(&sizes);
        g.bench_with_input(BenchmarkId::from_parameter(name), &(ranges, bounds), |b, (r, bo)| {
            b.iter(|| DrawOrder::front_to_back(black_box(r), black_box(bo), black_box(Vec3::new(1.0, 2.0, 3.0))))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
