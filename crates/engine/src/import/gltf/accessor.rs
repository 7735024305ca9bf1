//! Accessor decoding with every range checked before it is read.
//!
//! The gltf crate's own readers slice buffers without bounds checks (a malformed file panics),
//! so Penumbra decodes accessors itself: element size, stride, view and buffer extents are
//! checked with overflow-safe arithmetic, then components are converted to `f32` (normalised
//! integers per the glTF spec: signed `max(c / MAX, −1)`, unsigned `c / MAX`) and sparse
//! substitutions applied. Every decode is charged to the import's [`ImportLimits`] before its
//! output is allocated ([`Buffers::charge`]): per accessor and in total, so a file cannot make a
//! few bytes of JSON decode into gigabytes, nor decode one large accessor a thousand times.

use std::cell::Cell;
use std::collections::HashMap;

use gltf::accessor::{DataType, Dimensions};

use crate::import::{ImportErrorKind, ImportLimits, Limit};

/// A decoding failure: the file is wrong (reported as `accessor N: reason` or in the caller's
/// words), or it asks for more than the limits allow (reported as the limit).
#[derive(Debug)]
pub(crate) enum AccessorError {
    Bad(String),
    Limit(ImportErrorKind),
}

impl AccessorError {
    /// The import error, with a malformed accessor described by `make(reason)`.
    pub(crate) fn into_kind_with(self, make: impl FnOnce(String) -> ImportErrorKind) -> ImportErrorKind {
        match self {
            AccessorError::Bad(reason) => make(reason),
            AccessorError::Limit(kind) => kind,
        }
    }

    /// `accessor N: reason`.
    pub(crate) fn into_kind(self, index: usize) -> ImportErrorKind {
        self.into_kind_with(|reason| ImportErrorKind::Accessor { index, reason })
    }

    /// Prefixes a malformed accessor's reason with where it was used.
    pub(crate) fn context(self, prefix: impl std::fmt::Display) -> Self {
        match self {
            AccessorError::Bad(reason) => AccessorError::Bad(format!("{prefix}: {reason}")),
            limit => limit,
        }
    }
}

impl From<String> for AccessorError {
    fn from(reason: String) -> Self {
        AccessorError::Bad(reason)
    }
}

pub(crate) type AccessorResult<T> = Result<T, AccessorError>;

/// The file's buffers, its bufferViews that were stored compressed (decoded, by view index), and
/// what decoding accessors from them has allocated so far.
pub(crate) struct Buffers {
    data: Vec<Vec<u8>>,
    decoded_views: HashMap<usize, Vec<u8>>,
    limits: ImportLimits,
    decoded: Cell<u64>,
}

impl Buffers {
    /// The decoded views count against the decoded-data budget from the start.
    pub(crate) fn new(data: Vec<Vec<u8>>, decoded_views: HashMap<usize, Vec<u8>>, limits: ImportLimits) -> Self {
        let decoded = decoded_views.values().map(|v| v.len() as u64).sum();
        Self { data, decoded_views, limits, decoded: Cell::new(decoded) }
    }

    /// Bytes decoded so far (compressed views, accessors), of the `DecodedBytes` budget.
    pub(crate) fn decoded(&self) -> u64 {
        self.decoded.get()
    }

    /// The bytes of a bufferView: its decoded data when it was stored compressed
    /// (`EXT_meshopt_compression`), else its window of its buffer, checked to lie inside it.
    pub(crate) fn view(&self, view: &gltf::buffer::View) -> Result<&[u8], String> {
        if let Some(decoded) = self.decoded_views.get(&view.index()) {
            // decode_views checked that the view's byteLength fits in what it decodes to.
            return Ok(&decoded[..view.length()]);
        }
        let index = view.buffer().index();
        let buffer = self.data.get(index).ok_or_else(|| format!("buffer {index} does not exist"))?;
        view.offset().checked_add(view.length()).and_then(|end| buffer.get(view.offset()..end)).ok_or_else(|| {
            format!(
                "bufferView {} (offset {}, length {}) runs past the end of buffer {index} ({} bytes)",
                view.index(),
                view.offset(),
                view.length(),
                buffer.len()
            )
        })
    }

    pub(crate) fn limits(&self) -> &ImportLimits {
        &self.limits
    }

    /// Charges `count` elements of `elem_bytes` decoded bytes each, before they are allocated.
    pub(crate) fn charge(&self, count: usize, elem_bytes: usize) -> AccessorResult<()> {
        let lim = |e| AccessorError::Limit(e);
        self.limits.check(Limit::AccessorElements, "an accessor's element count", count as u64).map_err(lim)?;
        let total = self.decoded.get().saturating_add((count as u64).saturating_mul(elem_bytes as u64));
        self.limits.check(Limit::DecodedBytes, "decoded accessor data", total).map_err(lim)?;
        self.decoded.set(total);
        Ok(())
    }
}

fn component_size(t: DataType) -> usize {
    match t {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

fn dimensions_len(d: Dimensions) -> usize {
    match d {
        Dimensions::Scalar => 1,
        Dimensions::Vec2 => 2,
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 => 4,
        Dimensions::Mat2 => 4,
        Dimensions::Mat3 => 9,
        Dimensions::Mat4 => 16,
    }
}

pub(crate) fn read_component(bytes: &[u8], t: DataType, normalized: bool) -> f32 {
    match t {
        DataType::F32 => f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
        DataType::I8 => {
            let v = bytes[0] as i8 as f32;
            if normalized { (v / 127.0).max(-1.0) } else { v }
        }
        DataType::U8 => {
            let v = bytes[0] as f32;
            if normalized { v / 255.0 } else { v }
        }
        DataType::I16 => {
            let v = i16::from_le_bytes([bytes[0], bytes[1]]) as f32;
            if normalized { (v / 32767.0).max(-1.0) } else { v }
        }
        DataType::U16 => {
            let v = u16::from_le_bytes([bytes[0], bytes[1]]) as f32;
            if normalized { v / 65535.0 } else { v }
        }
        DataType::U32 => {
            let v = u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
            if normalized { v as f32 / u32::MAX as f32 } else { v as f32 }
        }
    }
}

/// The byte window `[start, start + stride·(count−1) + elem)` inside a view.
fn strided_window<'b>(
    buffers: &'b Buffers,
    view: &gltf::buffer::View,
    offset_in_view: usize,
    count: usize,
    elem_size: usize,
    stride_override: Option<usize>,
) -> Result<(&'b [u8], usize), String> {
    let stride = stride_override.unwrap_or(view.stride().unwrap_or(elem_size));
    if stride < elem_size {
        return Err(format!("byteStride {stride} is smaller than the element size {elem_size}"));
    }
    let bytes = buffers.view(view)?;
    if count == 0 {
        return Ok((&[], stride));
    }
    let needed = stride
        .checked_mul(count - 1)
        .and_then(|n| n.checked_add(elem_size))
        .and_then(|n| n.checked_add(offset_in_view))
        .filter(|&n| n <= bytes.len())
        .ok_or_else(|| {
            format!(
                "{count} elements of {elem_size} bytes at stride {stride} from offset {offset_in_view} do not fit in bufferView {} ({} bytes)",
                view.index(),
                bytes.len()
            )
        })?;
    Ok((&bytes[offset_in_view..needed], stride))
}

/// Decodes an accessor of `N` components per element to `f32`.
pub(crate) fn read_f32<const N: usize>(accessor: &gltf::Accessor, buffers: &Buffers) -> AccessorResult<Vec<[f32; N]>> {
    let dims = dimensions_len(accessor.dimensions());
    if dims != N {
        return Err(format!("expected {N} components per element, found {:?}", accessor.dimensions()).into());
    }
    let ty = accessor.data_type();
    let csize = component_size(ty);
    let elem = csize * N;
    let count = accessor.count();
    let normalized = accessor.normalized();
    buffers.charge(count, N * 4)?;
    let decode =
        |bytes: &[u8]| -> [f32; N] { std::array::from_fn(|c| read_component(&bytes[c * csize..], ty, normalized)) };

    let mut out: Vec<[f32; N]> = match accessor.view() {
        Some(view) => {
            let (window, stride) = strided_window(buffers, &view, accessor.offset(), count, elem, None)?;
            (0..count).map(|i| decode(&window[i * stride..i * stride + elem])).collect()
        }
        None => vec![[0.0; N]; count],
    };

    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        if n > count {
            return Err(format!("sparse count {n} exceeds the accessor count {count}").into());
        }
        let indices = sparse.indices();
        let isize = match indices.index_type() {
            gltf::accessor::sparse::IndexType::U8 => 1,
            gltf::accessor::sparse::IndexType::U16 => 2,
            gltf::accessor::sparse::IndexType::U32 => 4,
        };
        let (iwin, _) = strided_window(buffers, &indices.view(), indices.offset(), n, isize, Some(isize))
            .map_err(|e| format!("sparse indices: {e}"))?;
        let values = sparse.values();
        let (vwin, _) = strided_window(buffers, &values.view(), values.offset(), n, elem, Some(elem))
            .map_err(|e| format!("sparse values: {e}"))?;
        for k in 0..n {
            let b = &iwin[k * isize..];
            let target = match isize {
                1 => b[0] as usize,
                2 => u16::from_le_bytes([b[0], b[1]]) as usize,
                _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize,
            };
            let slot = out
                .get_mut(target)
                .ok_or_else(|| format!("sparse index {target} is out of range for {count} elements"))?;
            *slot = decode(&vwin[k * elem..(k + 1) * elem]);
        }
    }
    Ok(out)
}

/// Decodes an index accessor (unsigned scalar).
pub(crate) fn read_indices(accessor: &gltf::Accessor, buffers: &Buffers) -> AccessorResult<Vec<u32>> {
    if accessor.dimensions() != Dimensions::Scalar {
        return Err(format!("indices must be scalars, found {:?}", accessor.dimensions()).into());
    }
    match accessor.data_type() {
        DataType::U8 | DataType::U16 | DataType::U32 => {}
        other => {
            return Err(format!("indices must be unsigned integers, found {other:?}").into());
        }
    }
    if accessor.normalized() {
        return Err(String::from("indices must not be normalized").into());
    }
    // Through f32 would lose integers above 2^24: decode the integers directly.
    let ty = accessor.data_type();
    let csize = component_size(ty);
    let count = accessor.count();
    let decode = |b: &[u8]| -> u32 {
        match csize {
            1 => b[0] as u32,
            2 => u16::from_le_bytes([b[0], b[1]]) as u32,
            _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        }
    };
    if accessor.sparse().is_some() {
        // Sparse index buffers are legal but unseen in practice; the float path is exact for
        // the values an index buffer can address on any GPU we target (< 2^24 vertices).
        return Ok(read_f32::<1>(accessor, buffers)?.into_iter().map(|[v]| v as u32).collect());
    }
    buffers.charge(count, 4)?;
    let Some(view) = accessor.view() else {
        return Ok(vec![0; count]);
    };
    let (window, stride) = strided_window(buffers, &view, accessor.offset(), count, csize, None)?;
    Ok((0..count).map(|i| decode(&window[i * stride..])).collect())
}
