//! Comparing a renderer's image with a reference, as the lab does: FLIP (perceptual, on the
//! tonemapped sRGB images: mean, 99th percentile, maximum) and the HDR errors (PSNR
//! against the reference's 99.9th-percentile value, the largest error and where, the
//! energy lost). Here the "renderer" darkens one corner of a gradient.
//!
//! Run with `cargo run -p tiledlight-metrics --example compare_images`.

use tiledlight_metrics::{flip, HdrError};

fn main() {
    let (w, h) = (64u32, 64u32);
    let reference: Vec<[f32; 4]> =
        (0..w * h).map(|i| [(i % w) as f32 / w as f32, (i / w) as f32 / h as f32, 0.5, 1.0]).collect();
    // The approximation: the top-left 16x16 pixels lose half their light.
    let test: Vec<[f32; 4]> = reference
        .iter()
        .enumerate()
        .map(
            |(i, p)| {
                if i as u32 % w < 16 && (i as u32) / w < 16 {
                    [p[0] * 0.5, p[1] * 0.5, p[2] * 0.5, 1.0]
                } else {
                    *p
                }
            },
        )
        .collect();
    let e = HdrError::of(&reference, &test);
    println!(
        "HDR: PSNR {:.2} dB, largest error {:.3} at pixel {:?}, energy lost {:.2}%",
        e.psnr_db,
        e.max_error,
        e.worst_pixel.map(|p| (p as u32 % w, p as u32 / w)),
        100.0 * e.energy_lost
    );
    // FLIP compares display images: tonemap (here a plain clamp) and encode as sRGB.
    let srgb = |img: &[[f32; 4]]| -> Vec<u8> {
        img.iter()
            .flat_map(|p| {
                let enc = |c: f32| {
                    let c = c.clamp(0.0, 1.0);
                    let s = if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
                    (s * 255.0).round() as u8
                };
                [enc(p[0]), enc(p[1]), enc(p[2]), 255]
            })
            .collect()
    };
    let f = flip(w, h, &srgb(&reference), &srgb(&test)).summary(0.99);
    println!("FLIP: mean {:.4}, p99 {:.4}, max {:.4}", f.mean, f.percentile, f.max);
}
