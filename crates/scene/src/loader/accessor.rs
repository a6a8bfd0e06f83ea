//! Reading glTF accessors into plain vectors, with every offset, stride and count
//! checked against the real buffer sizes (the gltf crate's reader trusts them, and
//! panics or silently truncates on bad files). Handles strided views, normalised and
//! quantised (`KHR_mesh_quantization`) integer components and sparse accessors. Every read
//! is charged to a byte budget before anything is allocated, so a hostile count cannot
//! exhaust memory. Depends on the gltf crate only.

use gltf::accessor::{DataType, Dimensions};

/// What an attribute holds, which decides the component types it may have: glTF's core
/// types plus `KHR_mesh_quantization`'s (integers dequantised here, so the rest of the
/// loader sees `f32`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Attr {
    /// POSITION: float, or (quantised) any 8/16-bit integer, normalised or not.
    Position,
    /// NORMAL, TANGENT: float, or (quantised) normalised signed 8/16-bit integers.
    Direction,
    /// TEXCOORD_n: float, normalised unsigned 8/16-bit integers (core), or (quantised)
    /// any 8/16-bit integer, normalised or not.
    TexCoord,
}

/// Reads `accessor` as `f32` values, `dims` per element, flattened. Integer components
/// allowed for `attr` are converted as the specification says: normalised unsigned to
/// `c / max`, normalised signed to `max(c / max, -1)`, others to their value. Errors
/// are plain messages naming the accessor. The values' bytes are taken from `budget` (an
/// error when they do not fit).
pub(crate) fn read_f32(
    accessor: &gltf::Accessor<'_>,
    buffers: &[Vec<u8>],
    dims: Dimensions,
    attr: Attr,
    budget: &mut u64,
) -> Result<Vec<f32>, String> {
    let a = accessor.index();
    if accessor.dimensions() != dims {
        return Err(format!("accessor {a} has type {:?}, expected {dims:?}", accessor.dimensions()));
    }
    let ty = accessor.data_type();
    let norm = accessor.normalized();
    let small_int = matches!(ty, DataType::I8 | DataType::U8 | DataType::I16 | DataType::U16);
    let ok = ty == DataType::F32
        || match attr {
            Attr::Position | Attr::TexCoord => small_int,
            Attr::Direction => norm && matches!(ty, DataType::I8 | DataType::I16),
        };
    if !ok {
        let n = if norm { "normalized " } else { "" };
        return Err(format!("accessor {a} has {n}component type {ty:?}, which is not supported here"));
    }
    read_components(accessor, buffers, budget, |b| match (ty, norm) {
        (DataType::F32, _) => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        (DataType::U8, true) => f32::from(b[0]) / 255.0,
        (DataType::U8, false) => f32::from(b[0]),
        (DataType::I8, true) => (f32::from(b[0] as i8) / 127.0).max(-1.0),
        (DataType::I8, false) => f32::from(b[0] as i8),
        (DataType::U16, true) => f32::from(u16::from_le_bytes([b[0], b[1]])) / 65535.0,
        (DataType::U16, false) => f32::from(u16::from_le_bytes([b[0], b[1]])),
        (DataType::I16, true) => (f32::from(i16::from_le_bytes([b[0], b[1]])) / 32767.0).max(-1.0),
        (DataType::I16, false) => f32::from(i16::from_le_bytes([b[0], b[1]])),
        // Rejected above.
        (DataType::U32, _) => f32::NAN,
    })
}

/// Reads a scalar unsigned-integer accessor (vertex indices).
pub(crate) fn read_indices(
    accessor: &gltf::Accessor<'_>,
    buffers: &[Vec<u8>],
    budget: &mut u64,
) -> Result<Vec<u32>, String> {
    let a = accessor.index();
    if accessor.dimensions() != Dimensions::Scalar {
        return Err(format!("index accessor {a} has type {:?}, expected Scalar", accessor.dimensions()));
    }
    let ty = accessor.data_type();
    if !matches!(ty, DataType::U8 | DataType::U16 | DataType::U32) {
        return Err(format!("index accessor {a} has component type {ty:?}, expected an unsigned integer"));
    }
    read_components(accessor, buffers, budget, |bytes| match ty {
        DataType::U8 => u32::from(bytes[0]),
        DataType::U16 => u32::from(u16::from_le_bytes([bytes[0], bytes[1]])),
        _ => u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
    })
}

/// Accessors without a buffer view are zeros (patched by sparse values): nothing but
/// this bounds their count, so a hostile count cannot exhaust memory.
const MAX_VIEWLESS_ELEMENTS: usize = 1 << 24;

fn component_size(ty: DataType) -> usize {
    match ty {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

/// The bytes of `count` elements of `elem_size` bytes spaced `stride` apart, starting
/// `offset` bytes into buffer view `view`, all bounds checked.
fn view_elements<'b>(
    view: &gltf::buffer::View<'_>,
    buffers: &'b [Vec<u8>],
    offset: usize,
    count: usize,
    stride: usize,
    elem_size: usize,
    what: &str,
) -> Result<&'b [u8], String> {
    let b = view.buffer().index();
    let data = buffers.get(b).ok_or_else(|| format!("{what}: buffer {b} does not exist"))?;
    let view_end = view.offset().checked_add(view.length());
    let view_bytes = view_end.and_then(|end| data.get(view.offset()..end)).ok_or_else(|| {
        format!(
            "{what}: buffer view {} (offset {}, length {}) runs past the end of buffer {b} ({} bytes)",
            view.index(),
            view.offset(),
            view.length(),
            data.len()
        )
    })?;
    if count == 0 {
        return Ok(&view_bytes[..0]);
    }
    let needed =
        stride.checked_mul(count - 1).and_then(|n| n.checked_add(elem_size)).and_then(|n| n.checked_add(offset));
    match needed {
        Some(end) if end <= view_bytes.len() => Ok(&view_bytes[offset..end]),
        _ => Err(format!(
            "{what}: {count} elements of {elem_size} bytes (stride {stride}, offset {offset}) do not fit in buffer view {} ({} bytes)",
            view.index(),
            view_bytes.len()
        )),
    }
}

/// Decodes every component of `accessor` with `decode` (given the component's
/// little-endian bytes), applying sparse substitutions. The output's bytes are taken from
/// `budget` before it is allocated.
fn read_components<T: Copy + Default>(
    accessor: &gltf::Accessor<'_>,
    buffers: &[Vec<u8>],
    budget: &mut u64,
    decode: impl Fn(&[u8]) -> T,
) -> Result<Vec<T>, String> {
    let a = accessor.index();
    let what = format!("accessor {a}");
    let count = accessor.count();
    let comps = accessor.dimensions().multiplicity();
    let csize = component_size(accessor.data_type());
    let elem_size = comps * csize;
    let total = count.checked_mul(comps).ok_or_else(|| format!("{what}: count {count} is absurd"))?;
    // Check the data is there before the output is allocated: a count alone costs nothing
    // to write.
    let view_bytes = match accessor.view() {
        Some(view) => {
            let stride = view.stride().unwrap_or(elem_size);
            if stride < elem_size {
                return Err(format!("{what}: byteStride {stride} is smaller than the element size {elem_size}"));
            }
            Some((view_elements(&view, buffers, accessor.offset(), count, stride, elem_size, &what)?, stride))
        }
        None if count > MAX_VIEWLESS_ELEMENTS => {
            return Err(format!(
                "{what} has no buffer view and {count} elements (at most {MAX_VIEWLESS_ELEMENTS} are accepted)"
            ));
        }
        None => None,
    };
    let out_bytes = (total as u64).saturating_mul(std::mem::size_of::<T>() as u64);
    if out_bytes > *budget {
        return Err(format!(
            "{what}: {count} elements take {out_bytes} bytes, more than the {} bytes left of the scene's memory limit (LoadLimits::scene_bytes)",
            *budget
        ));
    }
    *budget -= out_bytes;
    let mut out = Vec::new();
    out.try_reserve_exact(total).map_err(|_| format!("{what}: count {count} is too large to load"))?;
    match view_bytes {
        Some((bytes, stride)) => {
            for e in 0..count {
                let elem = &bytes[e * stride..e * stride + elem_size];
                out.extend(elem.chunks_exact(csize).map(&decode));
            }
        }
        // No view: all zeros until sparse values replace some (glTF 3.6.2.3).
        None => out.resize(total, T::default()),
    }
    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        let indices = sparse.indices();
        let isize = match indices.index_type() {
            gltf::accessor::sparse::IndexType::U8 => 1,
            gltf::accessor::sparse::IndexType::U16 => 2,
            gltf::accessor::sparse::IndexType::U32 => 4,
        };
        let what_i = format!("{what} sparse indices");
        let ibytes = view_elements(&indices.view(), buffers, indices.offset(), n, isize, isize, &what_i)?;
        let values = sparse.values();
        let what_v = format!("{what} sparse values");
        let vbytes = view_elements(&values.view(), buffers, values.offset(), n, elem_size, elem_size, &what_v)?;
        for k in 0..n {
            let ib = &ibytes[k * isize..(k + 1) * isize];
            let target = match isize {
                1 => usize::from(ib[0]),
                2 => usize::from(u16::from_le_bytes([ib[0], ib[1]])),
                _ => u32::from_le_bytes([ib[0], ib[1], ib[2], ib[3]]) as usize,
            };
            if target >= count {
                return Err(format!("{what}: sparse index {target} is out of range ({count} elements)"));
            }
            let elem = &vbytes[k * elem_size..(k + 1) * elem_size];
            for (c, comp) in elem.chunks_exact(csize).enumerate() {
                out[target * comps + c] = decode(comp);
            }
        }
    }
    Ok(out)
}
