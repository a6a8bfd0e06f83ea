//! The bytes behind a glTF file: its buffers (GLB binary chunk, external files, base64
//! data URIs), the URI decoding they need, and the rules for which files a glTF may name
//! ([`Files`]): only regular files, only inside the model's folder unless allowed, never
//! more bytes than asked for. Written here rather than taken from the gltf crate's
//! importer because that one panics on malformed percent-encoding, reads any path
//! (`/dev/zero` without end) and its errors do not say which file was missing. Depends on
//! std and the gltf crate.

use std::io::Read;
use std::path::{Component, Path, PathBuf};

/// Where a URI points.
pub(crate) enum UriTarget {
    /// Inline data (already decoded).
    Data(Vec<u8>),
    /// A file, resolved against the glTF file's directory.
    File(PathBuf),
}

/// Resolves a glTF URI relative to `base` (the glTF file's directory); a data URI is
/// decoded if it holds at most `max_data` bytes. Errors are plain messages; the caller
/// adds which buffer or image and which file.
pub(crate) fn resolve_uri(base: &Path, uri: &str, max_data: u64) -> Result<UriTarget, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, payload)) = rest.split_once(";base64,") else {
            return Err("data URI is not base64-encoded (expected ';base64,')".to_owned());
        };
        // Every 4 base64 characters hold 3 bytes: check before decoding anything.
        let size = payload.trim_end_matches('=').len() as u64 * 3 / 4;
        if size > max_data {
            return Err(format!("data URI holds {size} bytes, more than the {} allowed", bytes_text(max_data)));
        }
        return decode_base64(payload).map(UriTarget::Data);
    }
    let path = if let Some(rest) = uri.strip_prefix("file://") {
        percent_decode(rest)?
    } else if uri.contains("://")
        || uri.split_once(':').is_some_and(|(scheme, _)| scheme.len() > 1 && !scheme.contains('/'))
    {
        // A single letter before ':' is a Windows drive, not a scheme.
        return Err(format!(
            "URI '{uri}' uses an unsupported scheme (only relative paths, file:// and data: are read)"
        ));
    } else {
        percent_decode(uri)?
    };
    Ok(UriTarget::File(base.join(path)))
}

/// "268435456 bytes (256 MiB)": a byte count with its binary-megabyte rounding.
pub(crate) fn bytes_text(n: u64) -> String {
    if n >= 1 << 20 {
        format!("{n} bytes ({} MiB)", n >> 20)
    } else {
        format!("{n} bytes")
    }
}

/// Why a file a URI names was not read.
#[derive(Clone, Debug)]
pub(crate) enum ReadError {
    /// Refused by the rules on which files may be read (outside the model's folder, not a
    /// regular file): always an error, whatever the file is for.
    Refused(String),
    /// Missing, unreadable or too large: a texture may be left out with a warning.
    Failed(String),
    /// The file does not exist (`path`): a texture may be left out with a warning, grouped
    /// with the other images missing from its folder.
    Missing(String, std::path::PathBuf),
}

impl ReadError {
    /// The message.
    pub(crate) fn message(self) -> String {
        match self {
            Self::Refused(m) | Self::Failed(m) | Self::Missing(m, _) => m,
        }
    }
}

/// What to do with a file larger than the byte limit given to [`Files::read`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Larger {
    /// Read the first `limit` bytes (a buffer: the rest is beyond its `byteLength`).
    Truncate,
    /// Fail (an image: it must be read whole).
    Fail,
}

/// The files a glTF file may name: those inside its folder (`base`), checked lexically
/// (absolute paths, `..` leading out) and after resolving symbolic links; anywhere when
/// `allow_any_path`. Only regular files are read, whatever the setting: a device such as
/// `/dev/zero` never ends and a pipe may block forever.
pub(crate) struct Files {
    base: PathBuf,
    allow_any_path: bool,
}

impl Files {
    /// The rules for a glTF file in folder `base`.
    pub(crate) fn new(base: &Path, allow_any_path: bool) -> Self {
        // `Path::parent` of a bare file name is "": that is the current folder.
        let base = if base.as_os_str().is_empty() { PathBuf::from(".") } else { base.to_owned() };
        Self { base, allow_any_path }
    }

    /// The folder URIs are resolved against.
    pub(crate) fn base(&self) -> &Path {
        &self.base
    }

    fn outside(&self, uri: &str, path: &Path, how: &str) -> ReadError {
        ReadError::Refused(format!(
            "URI '{uri}' names '{}'{how}, outside the model's folder '{}': not read (files outside it are read only when allowed: --allow-any-path)",
            path.display(),
            self.base.display()
        ))
    }

    /// Reads the file `path` that `uri` resolved to: at most `limit` bytes, what happens
    /// beyond that being `larger`'s choice. Refuses files outside the model's folder
    /// (unless allowed) and anything but regular files.
    pub(crate) fn read(&self, uri: &str, path: &Path, limit: u64, larger: Larger) -> Result<Vec<u8>, ReadError> {
        if !self.allow_any_path && !lexically_inside(&self.base, path) {
            return Err(self.outside(uri, path, ""));
        }
        // Follows symbolic links: what counts is the file read.
        let meta = std::fs::metadata(path).map_err(|e| {
            let m = format!("cannot read '{}' (URI '{uri}'): {e}", path.display());
            if e.kind() == std::io::ErrorKind::NotFound {
                ReadError::Missing(m, path.to_path_buf())
            } else {
                ReadError::Failed(m)
            }
        })?;
        if !self.allow_any_path {
            let canonical = |p: &Path| {
                p.canonicalize()
                    .map_err(|e| ReadError::Failed(format!("cannot resolve '{}' (URI '{uri}'): {e}", p.display())))
            };
            let (file, base) = (canonical(path)?, canonical(&self.base)?);
            if !file.starts_with(&base) {
                return Err(self.outside(uri, path, &format!(" (which leads to '{}')", file.display())));
            }
        }
        if !meta.is_file() {
            return Err(ReadError::Refused(format!(
                "URI '{uri}' names '{}', which is not a regular file (devices, pipes and folders are never read)",
                path.display()
            )));
        }
        if larger == Larger::Fail && meta.len() > limit {
            return Err(ReadError::Failed(format!(
                "'{}' (URI '{uri}') is {} bytes, more than the {} allowed",
                path.display(),
                meta.len(),
                bytes_text(limit)
            )));
        }
        let failed =
            |e: std::io::Error| ReadError::Failed(format!("cannot read '{}' (URI '{uri}'): {e}", path.display()));
        let file = std::fs::File::open(path).map_err(failed)?;
        let mut data = Vec::new();
        // The size seen is only a hint (the file may change); `take` is the bound.
        let expected = usize::try_from(meta.len().min(limit)).unwrap_or(usize::MAX);
        data.try_reserve_exact(expected).map_err(|_| {
            ReadError::Failed(format!("'{}' (URI '{uri}'): no memory for {expected} bytes", path.display()))
        })?;
        file.take(limit).read_to_end(&mut data).map_err(failed)?;
        Ok(data)
    }
}

/// True when `path` lies inside `base` by its components alone: it starts with `base`,
/// and the rest is relative and never climbs above it with `..`.
fn lexically_inside(base: &Path, path: &Path) -> bool {
    let Ok(rest) = path.strip_prefix(base) else {
        return false;
    };
    let mut depth = 0usize;
    for c in rest.components() {
        match c {
            Component::Normal(_) => depth += 1,
            Component::CurDir => {}
            Component::ParentDir => match depth.checked_sub(1) {
                Some(d) => depth = d,
                None => return false,
            },
            Component::RootDir | Component::Prefix(_) => return false,
        }
    }
    true
}

/// Decodes `%XX` escapes (URIs in glTF are percent-encoded, e.g. spaces as `%20`).
fn percent_decode(s: &str) -> Result<String, String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes.get(i + 1..i + 3).and_then(|h| std::str::from_utf8(h).ok());
            let value = hex.and_then(|h| u8::from_str_radix(h, 16).ok());
            let Some(v) = value else {
                return Err(format!("URI '{s}' has a malformed %-escape at byte {i}"));
            };
            out.push(v);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| format!("URI '{s}' does not decode to UTF-8"))
}

fn base64_value(c: u8) -> Option<u32> {
    match c {
        b'A'..=b'Z' => Some(u32::from(c - b'A')),
        b'a'..=b'z' => Some(u32::from(c - b'a') + 26),
        b'0'..=b'9' => Some(u32::from(c - b'0') + 52),
        b'+' | b'-' => Some(62),
        b'/' | b'_' => Some(63),
        _ => None,
    }
}

/// Decodes standard (or URL-safe) base64, with or without `=` padding.
pub(crate) fn decode_base64(s: &str) -> Result<Vec<u8>, String> {
    let trimmed = s.trim_end_matches('=');
    let mut out = Vec::with_capacity(trimmed.len() * 3 / 4);
    let (mut acc, mut bits) = (0u32, 0u32);
    for (i, c) in trimmed.bytes().enumerate() {
        let Some(v) = base64_value(c) else {
            return Err(format!("invalid base64 character {:?} at offset {i}", c as char));
        };
        acc = (acc << 6) | v;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    if bits >= 6 {
        return Err("truncated base64 data".to_owned());
    }
    Ok(out)
}

/// Loads every buffer of `doc`: the GLB binary chunk, data URIs and external files (by
/// `files`' rules, at most `byteLength` bytes read), each checked to hold at least the
/// declared `byteLength` and cut to it.
pub(crate) fn load_buffers(
    doc: &gltf::Document,
    files: &Files,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, String> {
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let i = buffer.index();
        let length = buffer.length();
        let (mut data, from) = match buffer.source() {
            gltf::buffer::Source::Bin => {
                let data = blob
                    .take()
                    .ok_or_else(|| format!("buffer {i} refers to the GLB binary chunk, but the file has none"))?;
                (data, "the GLB binary chunk".to_owned())
            }
            gltf::buffer::Source::Uri(uri) => {
                // A data URI is already in memory; its size only needs a sane bound.
                match resolve_uri(files.base(), uri, u64::MAX).map_err(|e| format!("buffer {i}: {e}"))? {
                    UriTarget::Data(data) => (data, "its data URI".to_owned()),
                    UriTarget::File(path) => {
                        let data = files
                            .read(uri, &path, length as u64, Larger::Truncate)
                            .map_err(|e| format!("buffer {i}: {}", e.message()))?;
                        (data, format!("'{}'", path.display()))
                    }
                }
            }
        };
        if data.len() < length {
            return Err(format!(
                "buffer {i} is too short: byteLength is {length} but {from} holds {} bytes",
                data.len()
            ));
        }
        // Accessors and views must lie within byteLength; whatever follows is padding.
        data.truncate(length);
        out.push(data);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_roundtrips_known_vectors() {
        assert_eq!(decode_base64("").unwrap(), b"");
        assert_eq!(decode_base64("Zg==").unwrap(), b"f");
        assert_eq!(decode_base64("Zm8=").unwrap(), b"fo");
        assert_eq!(decode_base64("Zm9v").unwrap(), b"foo");
        assert_eq!(decode_base64("Zm9vYmFy").unwrap(), b"foobar");
        assert_eq!(decode_base64("AAECAwQF/w").unwrap(), [0, 1, 2, 3, 4, 5, 255]);
        assert!(decode_base64("Zm9v!").is_err());
        assert!(decode_base64("Z").is_err());
    }

    #[test]
    fn uris_resolve() {
        let base = Path::new("/models");
        assert!(
            matches!(resolve_uri(base, "a%20b.bin", u64::MAX).unwrap(), UriTarget::File(p) if p == Path::new("/models/a b.bin"))
        );
        assert!(
            matches!(resolve_uri(base, "data:application/octet-stream;base64,AAE=", u64::MAX).unwrap(), UriTarget::Data(d) if d == [0, 1])
        );
        assert!(resolve_uri(base, "http://example.com/x.bin", u64::MAX).is_err());
        assert!(resolve_uri(base, "bad%zz.bin", u64::MAX).is_err());
        assert!(resolve_uri(base, "bad%ff.bin", u64::MAX).is_err(), "not UTF-8");
        assert!(resolve_uri(base, "data:text/plain,hello", u64::MAX).is_err());
        // 8 base64 characters hold 6 bytes: refused before decoding when the limit is 5.
        let e = resolve_uri(base, "data:image/png;base64,AAAAAAAA", 5).err().unwrap();
        assert_eq!(e, "data URI holds 6 bytes, more than the 5 bytes allowed");
        assert!(resolve_uri(base, "data:image/png;base64,AAAAAAAA", 6).is_ok());
    }

    #[test]
    fn lexical_confinement() {
        let b = Path::new("/m");
        assert!(lexically_inside(b, Path::new("/m/a.bin")));
        assert!(lexically_inside(b, Path::new("/m/sub/../a.bin")));
        assert!(lexically_inside(b, Path::new("/m/./sub/a.bin")));
        assert!(!lexically_inside(b, Path::new("/m/../a.bin")));
        assert!(!lexically_inside(b, Path::new("/m/sub/../../a.bin")));
        assert!(!lexically_inside(b, Path::new("/dev/zero")));
        assert!(!lexically_inside(b, Path::new("/mm/a.bin")), "a sibling sharing the prefix is outside");
        let here = Path::new(".");
        assert!(lexically_inside(here, &here.join("a/b.bin")));
        // What `resolve_uri` builds for an absolute URI: the join replaces the base.
        let absolute = Path::new("/etc/passwd");
        assert!(!lexically_inside(here, &here.join(absolute)));
        assert!(!lexically_inside(here, &here.join("../x.bin")));
    }
}
