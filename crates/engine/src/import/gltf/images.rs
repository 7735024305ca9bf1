//! Image bytes to RGBA8, decoded in parallel across the machine's cores: on a 2-core machine the
//! JPEG/PNG decode of a textured model is the largest part of load time, and images are
//! independent.

use std::io::Cursor;
use std::path::Path;

use super::ImportOptions;
use super::accessor::Buffers;
use super::source::{ReadBudget, ReadLimit, read_uri};
use crate::compressed_image::CompressedImage;
use crate::image::Image;
use crate::import::{ImportErrorKind, Limit};

/// Where an image's encoded bytes live.
pub(crate) enum ImageBytes<'a> {
    Slice(&'a [u8]),
    Owned(Vec<u8>),
}

/// Encoded bytes of glTF image `index`, from a buffer view or a URI.
pub(crate) fn image_bytes<'a>(
    image: &gltf::Image,
    buffers: &'a Buffers,
    base_dir: &Path,
    options: &ImportOptions,
    reads: &ReadBudget,
) -> Result<ImageBytes<'a>, ImportErrorKind> {
    let index = image.index();
    match image.source() {
        gltf::image::Source::View { view, .. } => buffers
            .view(&view)
            .map(ImageBytes::Slice)
            .map_err(|reason| ImportErrorKind::Image { index, uri: format!("bufferView {}", view.index()), reason }),
        gltf::image::Source::Uri { uri, .. } => read_uri(base_dir, uri, options, ReadLimit::image(options), reads)
            .map(ImageBytes::Owned)
            .map_err(|e| e.into_kind(uri, |reason| ImportErrorKind::Image { index, uri: uri.to_owned(), reason })),
    }
}

/// The RGBA8 size an encoded image will decode to, from its header alone (`None` when the header
/// cannot be read; decoding then reports why).
pub(crate) fn decoded_size(bytes: &[u8]) -> Option<u64> {
    let (w, h) = dimensions(bytes)?;
    Some(w as u64 * h as u64 * 4)
}

/// What importing the encoded image holds once decoded: level 0 and the mip chain import makes
/// (`TotalImageBytes` counts this), from the header alone.
pub(crate) fn held_size(bytes: &[u8]) -> Option<u64> {
    if crate::compressed_image::is_ktx2(bytes) {
        // Held as the file or its inflated levels; the RGBA8 size bounds what decoding it for the
        // CPU can take.
        return crate::compressed_image::held_size(bytes);
    }
    let (w, h) = dimensions(bytes)?;
    Some(w as u64 * h as u64 * 4 + crate::mip_chain::chain_bytes(w, h))
}

fn dimensions(bytes: &[u8]) -> Option<(u32, u32)> {
    image::ImageReader::new(Cursor::new(bytes)).with_guessed_format().ok()?.into_dimensions().ok()
}

pub(crate) fn decode(
    bytes: &[u8],
    index: usize,
    uri: &str,
    label: String,
    options: &ImportOptions,
) -> Result<Image, ImportErrorKind> {
    let err = |reason: String| ImportErrorKind::Image { index, uri: uri.to_owned(), reason };
    if crate::compressed_image::is_ktx2(bytes) {
        // Checked from the header, before any level is inflated or decoded.
        if let Some((w, h)) = crate::compressed_image::dimensions(bytes) {
            let rgba = crate::compressed_image::Format::Rgba8.level_bytes(w, h);
            options.limits.check(Limit::ImageBytes, "an image's decoded RGBA size", rgba)?;
        }
        let image = CompressedImage::parse(bytes.to_vec(), options.limits.image_dimension).map_err(err)?;
        return Ok(Image::compressed(image, label));
    }
    // JPEG straight to RGBA with zune-jpeg: the image crate decodes to RGB and then converts,
    // which for a 2048² texture is 12 MiB more memory to fault in and one more pass over it.
    if bytes.starts_with(&[0xff, 0xd8, 0xff])
        && let Some(image) = decode_jpeg_rgba(bytes, &label, options).map_err(err)?
    {
        return Ok(image);
    }
    let mut reader = image::ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| err(format!("cannot read: {e}")))?;
    if reader.format().is_none() {
        return Err(err("unknown image format (Penumbra decodes PNG, JPEG, WebP and KTX2)".into()));
    }
    // The RGBA8 copy made after decoding is outside the decoder's own allocation limit: check
    // its size from the header first.
    if let Some(size) = decoded_size(bytes) {
        options.limits.check(Limit::ImageBytes, "an image's decoded RGBA size", size)?;
    }
    let (max_side, max_bytes) = (options.limits.image_dimension, options.limits.image_bytes);
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(max_side.min(u32::MAX as u64) as u32);
    limits.max_image_height = Some(max_side.min(u32::MAX as u64) as u32);
    limits.max_alloc = Some(max_bytes);
    reader.limits(limits);
    let decoded = reader.decode().map_err(|e| match e {
        image::ImageError::Limits(l) => err(format!(
            "{l} (limits: {max_side}×{max_side} pixels, {max_bytes} bytes; raise them with \
             `--limit image-dimension=N` / `--limit image-bytes=N`, or ImportLimits in code)"
        )),
        other => err(format!("cannot decode: {other}")),
    })?;
    let rgba = decoded.into_rgba8();
    Ok(Image::rgba8(rgba.width(), rgba.height(), rgba.into_raw(), label))
}

/// `Ok(None)`: a JPEG zune-jpeg cannot turn into RGBA (CMYK, say); the caller falls back to the
/// image crate.
fn decode_jpeg_rgba(bytes: &[u8], label: &str, options: &ImportOptions) -> Result<Option<Image>, String> {
    use zune_core::bytestream::ZCursor;
    use zune_core::colorspace::ColorSpace;
    use zune_core::options::DecoderOptions;
    let max = options.limits.image_dimension.min(u32::MAX as u64) as usize;
    let opts =
        DecoderOptions::default().jpeg_set_out_colorspace(ColorSpace::RGBA).set_max_width(max).set_max_height(max);
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(ZCursor::new(bytes), opts);
    decoder.decode_headers().map_err(|e| format!("cannot decode JPEG: {e}"))?;
    let Some((w, h)) = decoder.dimensions() else { return Ok(None) };
    if decoder.output_colorspace() != Some(ColorSpace::RGBA) {
        return Ok(None);
    }
    let size = w as u64 * h as u64 * 4;
    if size > options.limits.image_bytes {
        return Err(format!(
            "{w}×{h} decodes to {size} bytes, over the limit of {} (raise it with `--limit image-bytes=N`, or \
             ImportLimits in code)",
            options.limits.image_bytes
        ));
    }
    let mut rgba8 = vec![0u8; size as usize];
    decoder.decode_into(&mut rgba8).map_err(|e| format!("cannot decode JPEG: {e}"))?;
    Ok(Some(Image::rgba8(w as u32, h as u32, rgba8, label)))
}
