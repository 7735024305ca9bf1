//! Image bytes to RGBA8, decoded in parallel across the machine's cores: on a 2-core machine the
//! JPEG/PNG decode of a textured model is the largest part of load time, and images are
//! independent.

use std::io::Cursor;
use std::path::Path;

use super::ImportOptions;
use super::source::read_uri;
use crate::image::Image;
use crate::import::ImportErrorKind;

/// Where an image's encoded bytes live.
pub(crate) enum ImageBytes<'a> {
    Slice(&'a [u8]),
    Owned(Vec<u8>),
}

/// Encoded bytes of glTF image `index`, from a buffer view or a URI.
pub(crate) fn image_bytes<'a>(
    image: &gltf::Image,
    buffers: &'a [Vec<u8>],
    base_dir: &Path,
    options: &ImportOptions,
) -> Result<ImageBytes<'a>, ImportErrorKind> {
    let index = image.index();
    match image.source() {
        gltf::image::Source::View { view, .. } => {
            let err = |reason: String| ImportErrorKind::Image {
                index,
                uri: format!("bufferView {}", view.index()),
                reason,
            };
            let buffer = buffers
                .get(view.buffer().index())
                .ok_or_else(|| err("buffer missing".into()))?;
            let end = view
                .offset()
                .checked_add(view.length())
                .filter(|&e| e <= buffer.len())
                .ok_or_else(|| {
                    err(format!(
                        "bufferView runs past the end of buffer {} ({} bytes)",
                        view.buffer().index(),
                        buffer.len()
                    ))
                })?;
            Ok(ImageBytes::Slice(&buffer[view.offset()..end]))
        }
        gltf::image::Source::Uri { uri, .. } => read_uri(base_dir, uri, options)
            .map(ImageBytes::Owned)
            .map_err(|e| {
                e.into_kind(uri, |reason| ImportErrorKind::Image {
                    index,
                    uri: uri.to_owned(),
                    reason,
                })
            }),
    }
}

pub(crate) fn decode(
    bytes: &[u8],
    index: usize,
    uri: &str,
    label: String,
    options: &ImportOptions,
) -> Result<Image, ImportErrorKind> {
    let err = |reason: String| ImportErrorKind::Image {
        index,
        uri: uri.to_owned(),
        reason,
    };
    let mut reader = image::ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| err(format!("cannot read: {e}")))?;
    if reader.format().is_none() {
        return Err(err(
            "unknown image format (Penumbra decodes PNG and JPEG)".into()
        ));
    }
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(options.max_image_dimension);
    limits.max_image_height = Some(options.max_image_dimension);
    limits.max_alloc = Some(options.max_image_bytes);
    reader.limits(limits);
    let decoded = reader.decode().map_err(|e| match e {
        image::ImageError::Limits(l) => err(format!(
            "{l} (limits: {0}×{0} pixels, {1} bytes; raise ImportOptions::max_image_dimension / max_image_bytes)",
            options.max_image_dimension, options.max_image_bytes
        )),
        other => err(format!("cannot decode: {other}")),
    })?;
    let rgba = decoded.into_rgba8();
    Ok(Image {
        width: rgba.width(),
        height: rgba.height(),
        rgba8: rgba.into_raw(),
        label,
    })
}

/// Runs `jobs` on up to `available_parallelism` threads, keeping their order.
pub(crate) fn parallel_map<T: Sync, R: Send>(jobs: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(jobs.len())
        .max(1);
    if threads == 1 {
        return jobs.iter().map(f).collect();
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut results: Vec<Option<R>> = (0..jobs.len()).map(|_| None).collect();
    let slots = std::sync::Mutex::new(&mut results);
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(job) = jobs.get(i) else { break };
                    let r = f(job);
                    slots.lock().expect("no panics while holding the lock")[i] = Some(r);
                }
            });
        }
    });
    results
        .into_iter()
        .map(|r| r.expect("every job ran"))
        .collect()
}
