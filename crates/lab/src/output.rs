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
    let verbose = VERBOSE.load(std::sync::atomic::Ordering::Relaxed);
    for w in warnings {
        match w.strip_prefix(tiledlight_scene::DETAIL) {
            // A grouped warning's per-image list: only with --verbose.
            Some(detail) if verbose => eprintln!("warning:   - {detail}"),
            Some(_) => {}
            None => eprintln!("warning: {w}"),
        }
    }
}

/// `--verbose`: the load warnings' details too ([`print_load_warnings`]).
static VERBOSE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Prints the details of grouped load warnings from now on (`--verbose`) or not.
pub fn set_verbose(verbose: bool) {
    VERBOSE.store(verbose, std::sync::atomic::Ordering::Relaxed);
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

/// Checks, before any work, that output file `path` (given by `flag`) can be written: not
/// a folder, its folder exists or can be made, a file can be made in that folder, and an
/// existing file can be opened for writing (it is not changed). A command calls it for
/// every output before it renders, so a bad path costs no time and loses no report.
pub fn check_output(flag: &str, path: &Path) -> Result<()> {
    let shown = path.display();
    ensure!(!path.is_dir(), "{flag} {shown}: is a folder, not a file");
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    check_folder(flag, &shown.to_string(), dir)?;
    if path.exists() {
        std::fs::OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(|e| anyhow::anyhow!("{flag} {shown}: the file cannot be written: {e}"))?;
    }
    Ok(())
}

/// [`check_output`] for an output folder (`--diff-dir`): it exists or can be made, and a
/// file can be made in it.
pub fn check_output_dir(flag: &str, dir: &Path) -> Result<()> {
    let shown = dir.display().to_string();
    ensure!(!dir.is_file(), "{flag} {shown}: is a file, not a folder");
    check_folder(flag, &shown, dir)
}

/// Makes `dir` if needed and proves a file can be made in it (made and removed again).
fn check_folder(flag: &str, shown: &str, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .map_err(|e| anyhow::anyhow!("{flag} {shown}: its folder {} cannot be made: {e}", dir.display()))?;
    let probe = dir.join(format!(".tiledlight-write-check-{}", std::process::id()));
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .map_err(|e| anyhow::anyhow!("{flag} {shown}: nothing can be written in {}: {e}", dir.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A writable path passes and leaves nothing behind; a folder, a path under a file and a
    /// folder nothing can be written in are refused naming the flag and the path. (A
    /// read-only file is not tried: the tests may run as root, whom permissions do not stop.)
    #[test]
    fn outputs_are_checked_before_the_work() {
        let dir = std::env::temp_dir().join(format!("tiledlight-check-output-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let file = dir.join("new/sub/out.png");
        check_output("--out", &file).unwrap();
        assert!(!file.exists(), "the check writes no output");
        assert_eq!(std::fs::read_dir(file.parent().unwrap()).unwrap().count(), 0, "the probe is removed");
        let e = check_output("--out", &dir).unwrap_err().to_string();
        assert!(e.starts_with(&format!("--out {}: is a folder", dir.display())), "{e}");
        std::fs::write(&file, b"kept").unwrap();
        let e = check_output("--json", &file.join("x.json")).unwrap_err().to_string();
        assert!(e.starts_with("--json ") && e.contains("cannot be made"), "{e}");
        check_output("--out", &file).unwrap();
        assert_eq!(std::fs::read(&file).unwrap(), b"kept", "an existing file is not changed");
        let e = check_output_dir("--diff-dir", &file).unwrap_err().to_string();
        assert!(e.contains("is a file, not a folder"), "{e}");
        check_output_dir("--diff-dir", &dir.join("flip")).unwrap();
        // /proc takes no new files, even from root (file permissions would not stop root).
        if Path::new("/proc/self").exists() {
            let e = check_output("--out", Path::new("/proc/tiledlight.png")).unwrap_err().to_string();
            assert!(e.starts_with("--out /proc/tiledlight.png: nothing can be written in /proc"), "{e}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn messages_become_one_line() {
        assert_eq!(one_line("a\n\n  b  \nc"), "a b c");
    }
}
