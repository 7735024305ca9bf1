//! `EXT_meshopt_compression` and `KHR_meshopt_compression`: buffer views stored in
//! meshoptimizer's vertex and index codecs, decoded at import by meshoptimizer's own decoders.
//!
//! The extension sits on a bufferView: its compressed bytes live in another buffer, and the
//! view's own buffer is usually a *fallback* buffer with no data (`"fallback": true`), there only
//! for loaders without the extension. [`is_fallback`] tells the buffer loader to skip those;
//! [`decode_views`] decodes every compressed view once, checked and charged to the import's
//! limits, and the accessor reader ([`super::accessor::Buffers::view`]) reads a decoded view in
//! place of its buffer's bytes. Accessors, skins, animations and instancing then read compressed
//! data the way they read plain data, with the same bounds checks.

use std::collections::HashMap;

use gltf::json::Value;

use crate::import::{ImportErrorKind, ImportLimits, Limit};

/// The two names of the extension: the vendor one and the ratified one (which adds version 1 of
/// the vertex codec and the COLOR filter; meshoptimizer's decoder reads both versions).
pub(crate) const EXTENSIONS: [&str; 2] = ["KHR_meshopt_compression", "EXT_meshopt_compression"];

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Attributes,
    Triangles,
    Indices,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Filter {
    None,
    Octahedral,
    Quaternion,
    Exponential,
    Color,
}

/// Whether a buffer is a meshopt fallback buffer: its data is never read by a loader that
/// decodes the extension (it may have no URI at all), so it is not loaded.
pub(crate) fn is_fallback(buffer: &gltf::Buffer) -> bool {
    EXTENSIONS.iter().any(|name| {
        buffer.extension_value(name).and_then(|e| e.get("fallback")).and_then(Value::as_bool).unwrap_or(false)
    })
}

/// Decodes every compressed bufferView of the document: view index to its decoded bytes.
pub(crate) fn decode_views(
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    limits: &ImportLimits,
) -> Result<HashMap<usize, Vec<u8>>, ImportErrorKind> {
    let mut decoded = HashMap::new();
    let mut total = 0u64;
    for view in document.views() {
        let Some((name, ext)) = EXTENSIONS.iter().find_map(|&n| view.extension_value(n).map(|e| (n, e))) else {
            continue;
        };
        let index = view.index();
        let err = |reason: String| ImportErrorKind::BufferView { index, reason: format!("{name}: {reason}") };
        let bytes = decode_view(name, ext, (view.length(), view.stride()), buffers, limits, &mut total).map_err(
            |e| match e {
                ViewError::Bad(reason) => err(reason),
                ViewError::Limit(kind) => kind,
            },
        )?;
        decoded.insert(index, bytes);
    }
    Ok(decoded)
}

enum ViewError {
    Bad(String),
    Limit(ImportErrorKind),
}

impl From<String> for ViewError {
    fn from(reason: String) -> Self {
        ViewError::Bad(reason)
    }
}

fn decode_view(
    name: &str,
    ext: &Value,
    (view_length, view_stride): (usize, Option<usize>),
    buffers: &[Vec<u8>],
    limits: &ImportLimits,
    total: &mut u64,
) -> Result<Vec<u8>, ViewError> {
    let uint = |key: &str, default: Option<u64>| -> Result<u64, String> {
        match ext.get(key) {
            Some(v) => v.as_u64().ok_or_else(|| format!("\"{key}\" must be a non-negative integer, found {v}")),
            None => default.ok_or_else(|| format!("\"{key}\" is required")),
        }
    };
    let buffer_index = uint("buffer", None)? as usize;
    let offset = uint("byteOffset", Some(0))?;
    let length = uint("byteLength", None)?;
    let stride = uint("byteStride", None)?;
    let count = uint("count", None)?;
    let mode = match ext.get("mode").and_then(Value::as_str) {
        Some("ATTRIBUTES") => Mode::Attributes,
        Some("TRIANGLES") => Mode::Triangles,
        Some("INDICES") => Mode::Indices,
        other => return Err(format!("\"mode\" must be ATTRIBUTES, TRIANGLES or INDICES, found {other:?}").into()),
    };
    let filter = match ext.get("filter").map(|f| f.as_str()) {
        None | Some(Some("NONE")) => Filter::None,
        Some(Some("OCTAHEDRAL")) => Filter::Octahedral,
        Some(Some("QUATERNION")) => Filter::Quaternion,
        Some(Some("EXPONENTIAL")) => Filter::Exponential,
        // The ratified extension's addition; the vendor extension has no COLOR filter.
        Some(Some("COLOR")) if name == "KHR_meshopt_compression" => Filter::Color,
        Some(other) => return Err(format!("unknown \"filter\" {other:?}").into()),
    };

    // The extension's own rules on strides, per mode and filter.
    let stride_ok = match (mode, filter) {
        (Mode::Attributes, Filter::None | Filter::Exponential) => {
            stride.is_multiple_of(4) && (4..=256).contains(&stride)
        }
        (Mode::Attributes, Filter::Octahedral | Filter::Color) => stride == 4 || stride == 8,
        (Mode::Attributes, Filter::Quaternion) => stride == 8,
        (Mode::Triangles | Mode::Indices, Filter::None) => stride == 2 || stride == 4,
        (Mode::Triangles | Mode::Indices, _) => {
            return Err(format!("filter {filter:?} applies only to ATTRIBUTES").into());
        }
    };
    if !stride_ok {
        return Err(format!("byteStride {stride} is not allowed for mode {mode:?} with filter {filter:?}").into());
    }
    if let Some(own) = view_stride.filter(|&own| mode == Mode::Attributes && own as u64 != stride) {
        return Err(format!(
            "the bufferView's byteStride {own} differs from the extension's {stride} (the extension requires them equal)"
        )
        .into());
    }
    if mode == Mode::Triangles && !count.is_multiple_of(3) {
        return Err(format!("TRIANGLES needs a count that is a multiple of 3, found {count}").into());
    }

    let size = count.checked_mul(stride).ok_or_else(|| format!("count {count} x byteStride {stride} overflows"))?;
    let limit = |e| ViewError::Limit(e);
    limits.check(Limit::BufferBytes, "a compressed bufferView's decoded size", size).map_err(limit)?;
    *total = total.saturating_add(size);
    limits.check(Limit::DecodedBytes, "decoded data", *total).map_err(limit)?;
    if (view_length as u64) > size {
        return Err(
            format!("the bufferView's byteLength {view_length} is more than the {size} bytes it decodes to").into()
        );
    }

    let buffer = buffers.get(buffer_index).ok_or_else(|| format!("buffer {buffer_index} does not exist"))?;
    let source = usize::try_from(offset)
        .ok()
        .zip(usize::try_from(length).ok())
        .and_then(|(o, l)| buffer.get(o..o.checked_add(l)?))
        .ok_or_else(|| {
            format!(
                "byteOffset {offset} + byteLength {length} runs past the end of buffer {buffer_index} ({} bytes)",
                buffer.len()
            )
        })?;

    let (count, stride) = (count as usize, stride as usize);
    let mut out = vec![0u8; size as usize];
    // SAFETY: meshoptimizer's decoders write exactly `count * stride` bytes into `out`, which has
    // that length, and read at most `source.len()` bytes; they are documented as safe on
    // untrusted input (malformed data decodes to garbage or returns an error, never out of bounds).
    let code = unsafe {
        match mode {
            Mode::Attributes => meshopt::ffi::meshopt_decodeVertexBuffer(
                out.as_mut_ptr().cast(),
                count,
                stride,
                source.as_ptr(),
                source.len(),
            ),
            Mode::Triangles => meshopt::ffi::meshopt_decodeIndexBuffer(
                out.as_mut_ptr().cast(),
                count,
                stride,
                source.as_ptr(),
                source.len(),
            ),
            Mode::Indices => meshopt::ffi::meshopt_decodeIndexSequence(
                out.as_mut_ptr().cast(),
                count,
                stride,
                source.as_ptr(),
                source.len(),
            ),
        }
    };
    if code != 0 {
        return Err(format!(
            "the {mode:?} data does not decode (meshoptimizer error {code}: truncated or corrupt, or an unknown codec version)"
        )
        .into());
    }
    // SAFETY: each filter reads and writes `count` elements of `stride` bytes in place, within `out`;
    // the strides were checked above against what each filter accepts.
    unsafe {
        let ptr = out.as_mut_ptr().cast();
        match filter {
            Filter::None => {}
            Filter::Octahedral => meshopt::ffi::meshopt_decodeFilterOct(ptr, count, stride),
            Filter::Quaternion => meshopt::ffi::meshopt_decodeFilterQuat(ptr, count, stride),
            Filter::Exponential => meshopt::ffi::meshopt_decodeFilterExp(ptr, count, stride),
            Filter::Color => meshopt::ffi::meshopt_decodeFilterColor(ptr, count, stride),
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn decode(ext: Value, buffers: &[Vec<u8>], view_length: usize) -> Result<Vec<u8>, String> {
        let mut total = 0;
        decode_view("EXT_meshopt_compression", &ext, (view_length, None), buffers, &ImportLimits::default(), &mut total)
            .map_err(|e| match e {
                ViewError::Bad(r) => r,
                ViewError::Limit(k) => k.to_string(),
            })
    }

    #[test]
    fn vertices_and_indices_round_trip_through_the_codecs() {
        let vertices: Vec<[u16; 4]> = (0..100u16).map(|i| [i, i * 2, 7, i ^ 3]).collect();
        let encoded = meshopt::encode_vertex_buffer(&vertices).unwrap();
        let ext =
            json!({"buffer": 0, "byteLength": encoded.len(), "byteStride": 8, "count": 100, "mode": "ATTRIBUTES"});
        let out = decode(ext, &[encoded], 800).unwrap();
        assert_eq!(out, bytemuck::cast_slice::<[u16; 4], u8>(&vertices));

        let indices: Vec<u32> = vec![0, 1, 2, 2, 1, 3, 3, 1, 4];
        let encoded = meshopt::encode_index_buffer(&indices, 5).unwrap();
        let ext = json!({"buffer": 0, "byteLength": encoded.len(), "byteStride": 4, "count": 9, "mode": "TRIANGLES"});
        let out = decode(ext, &[encoded], 36).unwrap();
        assert_eq!(out, bytemuck::cast_slice::<u32, u8>(&indices));
    }

    #[test]
    fn bad_extensions_and_data_are_named() {
        let vertices: Vec<[f32; 3]> = (0..64).map(|i| [i as f32, 1.0, -2.0]).collect();
        let encoded = meshopt::encode_vertex_buffer(&vertices).unwrap();
        let n = encoded.len();
        let base = json!({"buffer": 0, "byteLength": n, "byteStride": 12, "count": 64, "mode": "ATTRIBUTES"});
        let with = |k: &str, v: Value| {
            let mut e = base.clone();
            e[k] = v;
            e
        };
        let buffers = [encoded.clone()];
        assert!(decode(base.clone(), &buffers, 768).is_ok());
        let cases = [
            (with("byteLength", json!(n / 2)), "does not decode"),
            (with("byteLength", json!(n + 1)), "runs past the end of buffer 0"),
            (with("byteStride", json!(6)), "byteStride 6 is not allowed"),
            (with("filter", json!("QUATERNION")), "byteStride 12 is not allowed"),
            (with("filter", json!("COLOR")), "unknown \"filter\""),
            (with("mode", json!("STRIPS")), "\"mode\" must be"),
            (with("count", json!(u64::MAX)), "overflows"),
            (with("count", json!(1u64 << 40)), "over the limit"),
            (with("buffer", json!(3)), "buffer 3 does not exist"),
        ];
        for (ext, expected) in cases {
            let e = decode(ext.clone(), &buffers, 768).unwrap_err();
            assert!(e.contains(expected), "{ext}: {e}");
        }
        assert!(decode(base.clone(), &buffers, 769).unwrap_err().contains("more than the 768 bytes"));
        let mut corrupt = encoded;
        corrupt[0] = 0xff; // header byte: an unknown codec version
        assert!(decode(base, &[corrupt], 768).unwrap_err().contains("does not decode"));
    }
}
