//! References kept on disk (`tiledlight accuracy --reference-cache DIR`): a reference
//! image that took minutes (the traced truth of a million lights: 10^12 shadow rays at
//! 1080p) is rendered once and read back by every later run that asks for the same one.
//!
//! 1. The key names everything the image depends on: the reference's own settings key
//!    (scene, lights, seed, screen, exposure, shadows: what the in-memory cache of one run
//!    is keyed by), its kind, the prepared scene's description (triangles, instances,
//!    camera, light counts), a hash of the packed lights as uploaded, and a fingerprint of
//!    every WGSL source the binary embeds (a changed shader renders another truth).
//! 2. The file is `DIR/reference-<64-bit FNV-1a of the key, hex>.bin`: a text header (a
//!    magic line, the key, the size, the exposure, the original render's time and passes)
//!    and then the HDR image (RGBA f32, little-endian) and the tonemapped one (RGBA8).
//! 3. A file whose key differs (a hash collision) is a miss; a file that is truncated or
//!    malformed is an error naming it (delete it to render again), never a wrong image.
//! 4. Written to a temporary name and renamed, so an interrupted run leaves no half file.
//!
//! What the key cannot see: a change of the Rust code that places lights or builds the
//! scene's geometry without changing the counts in the description. Clear the directory
//! after such a change. Depends on std and the shader table of tiledlight-gpu only.

use std::fmt::Write as _;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};

use anyhow::{bail, ensure, Context, Result};

/// The first line of every cache file (its format version).
const MAGIC: &str = "tiledlight reference cache 1";

/// 64-bit FNV-1a over `bytes`, continuing from `h` (start with [`FNV_OFFSET`]).
fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// FNV-1a's offset basis.
const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// A hash of byte slices, in order (each one's length is hashed too, so ["ab", "c"] and
/// ["a", "bc"] differ).
pub fn hash_parts<'a>(parts: impl IntoIterator<Item = &'a [u8]>) -> u64 {
    parts.into_iter().fold(FNV_OFFSET, |h, p| fnv1a(fnv1a(h, &(p.len() as u64).to_le_bytes()), p))
}

/// The fingerprint of every WGSL file the binary embeds (path and text).
pub fn shader_fingerprint() -> u64 {
    let files = tiledlight_gpu::shader::SHADER_FILES;
    hash_parts(files.iter().flat_map(|(path, text)| [path.as_bytes(), text.as_bytes()]))
}

/// One cached reference: the images and what its first render measured.
#[derive(Clone, Debug, PartialEq)]
pub struct CachedReference {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The automatic exposure the reference got (None: fixed).
    pub exposure: Option<f32>,
    /// The HDR image, row-major.
    pub hdr: Vec<[f32; 4]>,
    /// The tonemapped image, RGBA8 row-major.
    pub ldr: Vec<u8>,
    /// The render's GPU time when it was made (ms).
    pub total_ms: f64,
    /// Its passes' times, as the accuracy CSV writes them.
    pub passes: String,
}

/// A directory of cached references.
#[derive(Clone, Debug)]
pub struct ReferenceCache {
    dir: PathBuf,
}

impl ReferenceCache {
    /// The cache in `dir` (created on the first store).
    pub fn new(dir: &Path) -> Self {
        Self { dir: dir.to_path_buf() }
    }

    /// The file that holds the reference of `key`.
    pub fn path(&self, key: &str) -> PathBuf {
        self.dir.join(format!("reference-{:016x}.bin", hash_parts([key.as_bytes()])))
    }

    /// The reference of `key`, if the cache holds it; an error names a file that is
    /// there but unreadable or malformed.
    pub fn load(&self, key: &str) -> Result<Option<CachedReference>> {
        let path = self.path(key);
        let file = match std::fs::File::open(&path) {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e).with_context(|| format!("opening the cached reference {}", path.display())),
        };
        read(&mut BufReader::new(file), key)
            .with_context(|| format!("reading the cached reference {} (delete it to render again)", path.display()))
    }

    /// Stores the reference of `key` (replacing any file of the same name).
    pub fn store(&self, key: &str, r: &CachedReference) -> Result<PathBuf> {
        std::fs::create_dir_all(&self.dir)
            .with_context(|| format!("--reference-cache {}: creating the directory", self.dir.display()))?;
        let path = self.path(key);
        let tmp = path.with_extension(format!("tmp{}", std::process::id()));
        let write = || -> Result<()> {
            let mut f = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
            write(&mut f, key, r)?;
            f.into_inner().map_err(|e| e.into_error())?.sync_all()?;
            std::fs::rename(&tmp, &path)?;
            Ok(())
        };
        write().with_context(|| format!("writing the cached reference {}", path.display()))?;
        Ok(path)
    }
}

/// One header line, with line breaks (which the format cannot hold) replaced.
fn line(s: &str) -> String {
    s.replace(['\n', '\r'], " ")
}

fn write(w: &mut impl Write, key: &str, r: &CachedReference) -> Result<()> {
    ensure!(
        r.hdr.len() == r.width as usize * r.height as usize && r.ldr.len() == r.hdr.len() * 4,
        "a {}x{} reference with {} HDR and {} LDR values",
        r.width,
        r.height,
        r.hdr.len(),
        r.ldr.len()
    );
    let exposure = r.exposure.map_or("fixed".to_string(), |e| e.to_bits().to_string());
    let mut head = String::new();
    writeln!(head, "{MAGIC}")?;
    writeln!(head, "{}", line(key))?;
    writeln!(head, "{} {} {exposure} {}", r.width, r.height, r.total_ms.to_bits())?;
    writeln!(head, "{}", line(&r.passes))?;
    w.write_all(head.as_bytes())?;
    let hdr: Vec<u8> = r.hdr.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    w.write_all(&hdr)?;
    w.write_all(&r.ldr)?;
    Ok(())
}

fn read_line(r: &mut impl BufRead, what: &str) -> Result<String> {
    let mut s = String::new();
    r.read_line(&mut s)?;
    ensure!(s.ends_with('\n'), "the file ends before its {what}");
    s.pop();
    Ok(s)
}

fn read(r: &mut impl BufRead, key: &str) -> Result<Option<CachedReference>> {
    let magic = read_line(r, "first line")?;
    ensure!(magic == MAGIC, "its first line is {magic:?}, not {MAGIC:?}");
    if read_line(r, "key")? != line(key) {
        return Ok(None);
    }
    let size = read_line(r, "size")?;
    let fields: Vec<&str> = size.split(' ').collect();
    let [w, h, exposure, ms] = fields[..] else { bail!("its size line {size:?} does not hold four fields") };
    let num = |s: &str| s.parse::<u64>().with_context(|| format!("its size line {size:?}: {s:?} is not a number"));
    let (width, height) = (u32::try_from(num(w)?)?, u32::try_from(num(h)?)?);
    let exposure = if exposure == "fixed" { None } else { Some(f32::from_bits(u32::try_from(num(exposure)?)?)) };
    let total_ms = f64::from_bits(num(ms)?);
    let passes = read_line(r, "passes")?;
    let pixels = width as usize * height as usize;
    ensure!(pixels > 0, "it holds a {width}x{height} image");
    let mut hdr_bytes = vec![0u8; pixels * 16];
    r.read_exact(&mut hdr_bytes).context("the file ends inside its HDR image")?;
    let mut ldr = vec![0u8; pixels * 4];
    r.read_exact(&mut ldr).context("the file ends inside its tonemapped image")?;
    ensure!(r.read(&mut [0u8; 1])? == 0, "bytes follow its images");
    let hdr = hdr_bytes
        .chunks_exact(16)
        .map(|t| std::array::from_fn(|c| f32::from_le_bytes(t[c * 4..c * 4 + 4].try_into().expect("4 bytes"))))
        .collect();
    Ok(Some(CachedReference { width, height, exposure, hdr, ldr, total_ms, passes }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> CachedReference {
        CachedReference {
            width: 3,
            height: 2,
            exposure: Some(0.37),
            hdr: (0..6).map(|i| [i as f32, -0.5, f32::MAX, 1e-30]).collect(),
            ldr: (0..24).map(|i| i as u8 * 10).collect(),
            total_ms: 123.456,
            passes: "traced.shade=120.0;tonemap=3.456".into(),
        }
    }

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("tiledlight-refcache-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn a_stored_reference_reads_back_bit_for_bit() {
        let c = ReferenceCache::new(&scratch("roundtrip"));
        assert_eq!(c.load("k").unwrap(), None, "an empty cache holds nothing");
        let r = sample();
        c.store("k", &r).unwrap();
        assert_eq!(c.load("k").unwrap(), Some(r.clone()));
        let fixed = CachedReference { exposure: None, ..r };
        c.store("k2", &fixed).unwrap();
        assert_eq!(c.load("k2").unwrap(), Some(fixed));
    }

    #[test]
    fn another_key_in_the_same_file_is_a_miss() {
        let c = ReferenceCache::new(&scratch("collision"));
        c.store("one", &sample()).unwrap();
        // Force the collision: the second key's file holds the first key's reference.
        std::fs::rename(c.path("one"), c.path("two")).unwrap();
        assert_eq!(c.load("two").unwrap(), None);
    }

    #[test]
    fn a_truncated_or_foreign_file_is_an_error_naming_it() {
        let c = ReferenceCache::new(&scratch("broken"));
        let path = c.store("k", &sample()).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        for (cut, what) in [(bytes.len() - 1, "tonemapped image"), (bytes.len() - 30, "HDR image")] {
            std::fs::write(&path, &bytes[..cut]).unwrap();
            let e = format!("{:#}", c.load("k").unwrap_err());
            assert!(e.contains(&path.display().to_string()) && e.contains(what), "{e}");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        std::fs::write(&path, &longer).unwrap();
        assert!(format!("{:#}", c.load("k").unwrap_err()).contains("bytes follow"));
        std::fs::write(&path, b"PNG\n").unwrap();
        assert!(format!("{:#}", c.load("k").unwrap_err()).contains("first line"));
        let mut bad_size = bytes.clone();
        let at = bytes.iter().position(|&b| b == b'\n').unwrap() + 3; // "k\n" then the size line
        bad_size[at] = b'x';
        std::fs::write(&path, &bad_size).unwrap();
        assert!(format!("{:#}", c.load("k").unwrap_err()).contains("is not a number"));
    }

    #[test]
    fn a_reference_whose_sizes_disagree_is_not_stored() {
        let c = ReferenceCache::new(&scratch("sizes"));
        let r = CachedReference { width: 4, ..sample() };
        assert!(c.store("k", &r).is_err());
        assert_eq!(c.load("k").unwrap(), None, "nothing was left behind");
    }

    #[test]
    fn the_hash_separates_parts_and_follows_the_shaders() {
        assert_ne!(hash_parts([b"ab".as_slice(), b"c"]), hash_parts([b"a".as_slice(), b"bc"]));
        assert_ne!(hash_parts([b"a".as_slice()]), hash_parts([b"b".as_slice()]));
        // FNV-1a's published value for "a" (no length prefix): the arithmetic is the standard one.
        assert_eq!(fnv1a(FNV_OFFSET, b"a"), 0xaf63_dc4c_8601_ec8c);
        // Every file counts: the table without its last file is another fingerprint.
        let files = tiledlight_gpu::shader::SHADER_FILES;
        let fewer = hash_parts(files[..files.len() - 1].iter().flat_map(|(p, t)| [p.as_bytes(), t.as_bytes()]));
        assert_ne!(shader_fingerprint(), fewer);
    }
}
