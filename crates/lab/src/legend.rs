//! The heat map's legend, drawn on the CPU onto the PNG: a horizontal colour bar with the
//! same log-scale palette as `shaders/heatmap.wgsl` (blue at 1 light per tile, red at
//! the list capacity), ticks labelled 1, capacity^(1/4), capacity^(1/2), capacity^(3/4)
//! and capacity, and a magenta "overflow" swatch. Text uses a hand-made 5x7 bitmap font
//! (digits and the few capitals needed) scaled 1x to 3x with the image, so no font crate
//! is needed.
//!
//! Depends on `image` only; the palette is `tiledlight_gpu::heatmap::heatmap_palette`, the shader's CPU twin.

use image::{Rgb, RgbImage};

pub use tiledlight_gpu::heatmap::{heatmap_palette as palette, heatmap_t as palette_t, HEATMAP_OVERFLOW as OVERFLOW};

/// sRGB encoding of a linear value, as the `Rgba8UnormSrgb` target the heat map is drawn
/// into applies it.
pub fn srgb_encode(c: f32) -> u8 {
    let c = c.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

fn srgb(c: [f32; 3]) -> Rgb<u8> {
    Rgb([srgb_encode(c[0]), srgb_encode(c[1]), srgb_encode(c[2])])
}

/// The tick labels: 1 and capacity^(k/4) for k = 1..4, rounded, without duplicates.
pub fn label_values(capacity: u32) -> Vec<u32> {
    let cap = capacity.max(1);
    let mut v: Vec<u32> = (0..=4).map(|k| ((cap as f64).powf(k as f64 / 4.0).round() as u32).clamp(1, cap)).collect();
    v.dedup();
    v
}

/// A 5x7 glyph: seven rows, top first, bit 4 the leftmost pixel. Unknown characters are
/// blank.
fn glyph(c: char) -> [u8; 7] {
    match c.to_ascii_uppercase() {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        'A' => [0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'C' => [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        'F' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10],
        'G' => [0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F],
        'H' => [0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'I' => [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F],
        'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
        'O' => [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'P' => [0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10],
        'R' => [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11],
        'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
        'T' => [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'V' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'W' => [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A],
        '>' => [0x08, 0x04, 0x02, 0x01, 0x02, 0x04, 0x08],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        _ => [0; 7],
    }
}

/// Glyph cell: 5 pixels wide plus 1 of spacing, 7 tall.
const GLYPH_W: u32 = 5;
const GLYPH_H: u32 = 7;
const ADVANCE: u32 = GLYPH_W + 1;

/// Width in pixels of `text` at `scale` (no trailing spacing).
fn text_width(text: &str, scale: u32) -> u32 {
    (text.chars().count() as u32 * ADVANCE).saturating_sub(1) * scale
}

/// Draws `text` with its top-left corner at (x, y); pixels outside the image are skipped.
fn draw_text(img: &mut RgbImage, x: u32, y: u32, text: &str, scale: u32, color: Rgb<u8>) {
    for (i, c) in text.chars().enumerate() {
        let g = glyph(c);
        let gx = x + i as u32 * ADVANCE * scale;
        for (row, bits) in g.iter().enumerate() {
            for col in 0..GLYPH_W {
                if bits & (1 << (GLYPH_W - 1 - col)) != 0 {
                    fill(img, gx + col * scale, y + row as u32 * scale, scale, scale, color);
                }
            }
        }
    }
}

fn fill(img: &mut RgbImage, x: u32, y: u32, w: u32, h: u32, color: Rgb<u8>) {
    for py in y..(y + h).min(img.height()) {
        for px in x..(x + w).min(img.width()) {
            img.put_pixel(px, py, color);
        }
    }
}

/// Legend layout in glyph-pixel units (multiplied by the scale).
const PAD: u32 = 4;
const MARGIN: u32 = 4;
const BAR_W: u32 = 120;
const BAR_H: u32 = 8;
const TICK_H: u32 = 2;
const TITLE: &str = "LIGHTS PER TILE";
const OVERFLOW_TEXT: &str = "OVERFLOW";

/// The glyph scale for an image: 1 up to ~720p, 2 at ~1280x720, 3 from ~1920x1080.
pub fn scale_for(width: u32, height: u32) -> u32 {
    (width.min(height.saturating_mul(16) / 9) / 640).clamp(1, 3)
}

/// Draws the legend for a heat map of list capacity `capacity` in the bottom-right corner
/// of `img`, over a darkened panel. Returns false (and leaves the image alone) when the
/// image is too small to hold it.
pub fn draw_legend(img: &mut RgbImage, capacity: u32) -> bool {
    let s = scale_for(img.width(), img.height());
    let swatch_gap = 8;
    let panel_w = PAD + BAR_W + swatch_gap + BAR_H + 3 + text_width(OVERFLOW_TEXT, 1) + PAD;
    let panel_h = PAD + GLYPH_H + 4 + BAR_H + TICK_H + 1 + GLYPH_H + PAD;
    let (pw, ph) = (panel_w * s, panel_h * s);
    if pw + 2 * MARGIN * s > img.width() || ph + 2 * MARGIN * s > img.height() {
        return false;
    }
    let x0 = img.width() - MARGIN * s - pw;
    let y0 = img.height() - MARGIN * s - ph;

    // Darken rather than blank the panel, so the tiles beneath stay faintly visible.
    for py in y0..y0 + ph {
        for px in x0..x0 + pw {
            let p = img.get_pixel_mut(px, py);
            for c in p.0.iter_mut() {
                *c /= 5;
            }
        }
    }
    let white = Rgb([255, 255, 255]);
    let title_y = y0 + PAD * s;
    draw_text(img, x0 + PAD * s, title_y, TITLE, s, white);

    let bar_x = x0 + PAD * s;
    let bar_y = title_y + (GLYPH_H + 4) * s;
    let bar_w = BAR_W * s;
    for i in 0..bar_w {
        let t = i as f32 / (bar_w - 1) as f32;
        fill(img, bar_x + i, bar_y, 1, BAR_H * s, srgb(palette(t)));
    }

    // Ticks and labels at the exact palette positions of the rounded values.
    let label_y = bar_y + (BAR_H + TICK_H + 1) * s;
    let mut placed: Vec<(u32, u32, String)> = Vec::new();
    for v in label_values(capacity) {
        let tx = bar_x + (palette_t(v, capacity) * (bar_w - 1) as f32).round() as u32;
        let text = v.to_string();
        let w = text_width(&text, s);
        let lx = tx.saturating_sub(w / 2).min((x0 + pw).saturating_sub(s + w)).max(x0 + s);
        // Drop earlier labels that the next one would overlap (the capacity label wins).
        while placed.last().is_some_and(|(px, pw_, _)| px + pw_ + 2 * s > lx) {
            placed.pop();
        }
        fill(img, tx.min(bar_x + bar_w - s), bar_y + BAR_H * s, s, TICK_H * s, white);
        placed.push((lx, w, text));
    }
    for (lx, _, text) in &placed {
        draw_text(img, *lx, label_y, text, s, white);
    }

    let sw_x = bar_x + bar_w + swatch_gap * s;
    fill(img, sw_x, bar_y, BAR_H * s, BAR_H * s, srgb(OVERFLOW));
    draw_text(img, sw_x + (BAR_H + 3) * s, bar_y + s / 2, OVERFLOW_TEXT, s, white);
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn palette_matches_the_shader() {
        assert_eq!(palette(0.0), [0.0, 0.0, 1.0]);
        assert_eq!(palette(0.25), [0.0, 1.0, 1.0]);
        assert_eq!(palette(0.5), [0.0, 1.0, 0.0]);
        assert_eq!(palette(0.75), [1.0, 1.0, 0.0]);
        assert_eq!(palette(1.0), [1.0, 0.0, 0.0]);
        assert_eq!(palette(2.0), palette(1.0));
        assert_eq!(palette_t(1, 512), 0.0);
        assert_eq!(palette_t(512, 512), 1.0);
        assert_eq!(palette_t(1, 1), 0.0);
    }

    #[test]
    fn srgb_endpoints() {
        assert_eq!(srgb_encode(0.0), 0);
        assert_eq!(srgb_encode(1.0), 255);
        assert_eq!(srgb_encode(0.5), 188);
    }

    #[test]
    fn labels_are_quarter_powers() {
        assert_eq!(label_values(512), vec![1, 5, 23, 108, 512]);
        assert_eq!(label_values(16), vec![1, 2, 4, 8, 16]);
        assert_eq!(label_values(1), vec![1]);
        assert_eq!(label_values(2), vec![1, 2]);
    }

    #[test]
    fn every_legend_character_has_a_glyph() {
        for c in TITLE.chars().chain(OVERFLOW_TEXT.chars()).chain("0123456789".chars()) {
            assert!(c == ' ' || glyph(c) != [0; 7], "no glyph for {c:?}");
        }
    }

    #[test]
    fn drawn_in_the_corner_or_not_at_all() {
        let mut img = RgbImage::from_pixel(320, 180, Rgb([100, 100, 100]));
        assert!(draw_legend(&mut img, 512));
        assert_eq!(img.get_pixel(0, 0), &Rgb([100, 100, 100]));
        let changed = img.pixels().filter(|p| **p != Rgb([100, 100, 100])).count();
        assert!(changed > 1000, "{changed}");
        assert!(img.pixels().any(|p| *p == Rgb([255, 0, 255])), "overflow swatch");
        assert!(img.pixels().any(|p| *p == Rgb([0, 0, 255])), "bar start");
        assert!(img.pixels().any(|p| *p == Rgb([255, 0, 0])), "bar end");

        let mut tiny = RgbImage::from_pixel(64, 36, Rgb([1, 2, 3]));
        assert!(!draw_legend(&mut tiny, 512));
        assert!(tiny.pixels().all(|p| *p == Rgb([1, 2, 3])));

        for (w, h) in [(1280, 720), (1920, 1080), (3840, 2160), (210, 1000)] {
            let mut img = RgbImage::new(w, h);
            assert!(draw_legend(&mut img, 2048), "{w}x{h}");
        }
    }
}
