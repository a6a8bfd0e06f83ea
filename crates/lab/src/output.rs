//! What the lab's reports write besides their tables: one-line messages (every failure
//! and warning is one line), the scene's load warnings, and PNG images.
//!
//! May depend on image and anyhow only.

use std::path::Path;

use anyhow::{ensure, Context, Result};

/// Makes a possibly multi-line message (wgpu validation errors, clap's usage hints) one
/// line, so every failure is a single `error:` line.
pub fn one_line(msg: &str) -> String {
    msg.lines().map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(" ")
}

/// Prints each warning of a scene's loading (`SceneCpu::warnings`,
/// `Prepared::scene_warnings`) as a line starting `warning: ` on stderr.
pub fn print_load_warnings(warnings: &[String]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

/// An RGB image from tightly packed RGBA8 pixels.
pub fn rgb_image(width: u32, height: u32, rgba: &[u8]) -> Result<image::RgbImage> {
    ensure!(
        rgba.len() == width as usize * height as usize * 4,
        "image readback has {} bytes, expected {width}x{height}x4",
        rgba.len()
    );
    let rgb: Vec<u8> = rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
    image::RgbImage::from_raw(width, height, rgb).context("building the output image")
}

/// Saves `img` as PNG at `path` (which must end in .png), creating its directory.
pub fn save_png(path: &Path, img: &image::RgbImage) -> Result<()> {
    check_png_path(path)?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating directory {}", dir.display()))?;
    }
    img.save_with_format(path, image::ImageFormat::Png).with_context(|| format!("writing {}", path.display()))
}

/// Output paths must be PNG files: checked before rendering so a typo costs no time.
pub fn check_png_path(path: &Path) -> Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    ensure!(ext.as_deref() == Some("png"), "--out {}: only .png output is supported", path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_become_one_line() {
        assert_eq!(one_line("a\n\n  b  \nc"), "a b c");
    }
}
