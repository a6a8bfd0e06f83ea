//! The bytes behind a glTF file: its buffers (GLB binary chunk, external files, base64
//! data URIs) and the URI decoding they need. Written here rather than taken from the
//! gltf crate's importer because that one panics on malformed percent-encoding and its
//! errors do not say which file was missing. Depends on std and the gltf crate.

use std::path::{Path, PathBuf};

/// Where a URI points.
pub(crate) enum UriTarget {
    /// Inline data (already decoded).
    Data(Vec<u8>),
    /// A file, resolved against the glTF file's directory.
    File(PathBuf),
}

/// Resolves a glTF URI relative to `base` (the glTF file's directory). Errors are
/// plain messages; the caller adds which buffer or image and which file.
pub(crate) fn resolve_uri(base: &Path, uri: &str) -> Result<UriTarget, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, payload)) = rest.split_once(";base64,") else {
            return Err("data URI is not base64-encoded (expected ';base64,')".to_owned());
        };
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

/// Loads every buffer of `doc`: the GLB binary chunk, data URIs and external files,
/// each checked to hold at least the declared `byteLength`.
pub(crate) fn load_buffers(
    doc: &gltf::Document,
    base: &Path,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, String> {
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let i = buffer.index();
        let (data, from) = match buffer.source() {
            gltf::buffer::Source::Bin => {
                let data = blob
                    .take()
                    .ok_or_else(|| format!("buffer {i} refers to the GLB binary chunk, but the file has none"))?;
                (data, "the GLB binary chunk".to_owned())
            }
            gltf::buffer::Source::Uri(uri) => match resolve_uri(base, uri).map_err(|e| format!("buffer {i}: {e}"))? {
                UriTarget::Data(data) => (data, "its data URI".to_owned()),
                UriTarget::File(path) => {
                    let data = std::fs::read(&path)
                        .map_err(|e| format!("buffer {i}: cannot read '{}': {e}", path.display()))?;
                    (data, format!("'{}'", path.display()))
                }
            },
        };
        if data.len() < buffer.length() {
            return Err(format!(
                "buffer {i} is too short: byteLength is {} but {from} holds {} bytes",
                buffer.length(),
                data.len()
            ));
        }
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
            matches!(resolve_uri(base, "a%20b.bin").unwrap(), UriTarget::File(p) if p == Path::new("/models/a b.bin"))
        );
        assert!(
            matches!(resolve_uri(base, "data:application/octet-stream;base64,AAE=").unwrap(), UriTarget::Data(d) if d == [0, 1])
        );
        assert!(resolve_uri(base, "http://example.com/x.bin").is_err());
        assert!(resolve_uri(base, "bad%zz.bin").is_err());
        assert!(resolve_uri(base, "bad%ff.bin").is_err(), "not UTF-8");
        assert!(resolve_uri(base, "data:text/plain,hello").is_err());
    }
}
