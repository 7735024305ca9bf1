//! Files Penumbra writes (images from `render`, `gif` and `report`, screenshots, CSV tables):
//! whole or not at all.
//!
//! Every write goes to a temporary file in the destination's folder and is renamed over the
//! destination only once it is complete and flushed to disk, so a failed write (a full disk, a
//! file-size limit, an encoder error) leaves an existing file as it was and no partial file
//! behind, and is an error with the operating system's reason. A destination that exists but is
//! not a regular file (`/dev/stdout`, a FIFO) is written directly, as renaming over it would
//! replace the device with a file. Image formats are chosen by extension and checked with
//! [`image_format`] before anything is rendered.

use std::io::Write;
use std::path::{Path, PathBuf};

/// A write that did not happen.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}: {reason}", path.display())]
pub struct OutputError {
    pub path: PathBuf,
    pub reason: String,
}

impl OutputError {
    fn new(path: &Path, reason: impl std::fmt::Display) -> Self {
        Self { path: path.to_path_buf(), reason: reason.to_string() }
    }
}

/// The image formats Penumbra writes, by the destination's extension (PNG keeps alpha; JPEG
/// has none, so alpha is dropped); PNG for a device or pipe without one.
pub fn image_format(path: &Path) -> Result<image::ImageFormat, OutputError> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("png") => Ok(image::ImageFormat::Png),
        Some("jpg" | "jpeg") => Ok(image::ImageFormat::Jpeg),
        Some(other) => {
            Err(OutputError::new(path, format!(".{other} is not an image format Penumbra writes (.png or .jpg)")))
        }
        // A device or pipe (`/dev/stdout`) has no extension to go by: PNG.
        None if is_device(path) => Ok(image::ImageFormat::Png),
        None => Err(OutputError::new(path, "no file extension to choose the image format by (.png or .jpg)")),
    }
}

/// Whether `path` exists and is neither a regular file nor a folder (a device, a pipe): written
/// in place, and named without an extension.
pub fn is_device(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// Checks, before any work, that `path` can be written as far as can be told without writing:
/// its folder exists and it is not a folder itself.
pub fn check_destination(path: &Path) -> Result<(), OutputError> {
    if path.is_dir() {
        return Err(OutputError::new(path, "it is a folder"));
    }
    let folder = folder_of(path);
    match std::fs::metadata(folder) {
        Ok(m) if m.is_dir() => Ok(()),
        Ok(_) => Err(OutputError::new(path, format!("{} is not a folder", folder.display()))),
        Err(e) => Err(OutputError::new(path, format!("its folder {}: {e}", folder.display()))),
    }
}

fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Writes `path` with `write`, through a temporary file renamed over it when complete.
pub fn write_file(path: &Path, write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>) -> Result<(), OutputError> {
    write_with(path, Replace::Yes, write)
}

/// As [`write_file`], but never replaces an existing file: an error if `path` exists (at the
/// moment of the rename, so two writers cannot both take one name).
pub fn write_new_file(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), OutputError> {
    write_with(path, Replace::No, write)
}

#[derive(PartialEq)]
enum Replace {
    Yes,
    No,
}

fn write_with(
    path: &Path,
    replace: Replace,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), OutputError> {
    // A symbolic link's target is what gets the new contents, not the link.
    let target = match std::fs::canonicalize(path) {
        Ok(real) => real,
        Err(_) => path.to_path_buf(),
    };
    if let Ok(meta) = std::fs::metadata(&target)
        && !meta.is_file()
    {
        if meta.is_dir() {
            return Err(OutputError::new(path, "it is a folder"));
        }
        if replace == Replace::No {
            return Err(OutputError::new(path, "it already exists"));
        }
        let file = std::fs::OpenOptions::new().write(true).open(&target).map_err(|e| OutputError::new(path, e))?;
        let mut out = std::io::BufWriter::new(file);
        return write(&mut out).and_then(|()| out.flush()).map_err(|e| OutputError::new(path, e));
    }
    let mut temp = tempfile::Builder::new()
        .prefix(&format!(".{}.", target.file_name().map_or_else(Default::default, |n| n.to_string_lossy())))
        .suffix(".partial")
        .tempfile_in(folder_of(&target))
        .map_err(|e| OutputError::new(path, format!("cannot create a file in its folder: {e}")))?;
    {
        let mut out = std::io::BufWriter::new(temp.as_file_mut());
        write(&mut out).and_then(|()| out.flush()).map_err(|e| OutputError::new(path, e))?;
    }
    temp.as_file().sync_all().map_err(|e| OutputError::new(path, e))?;
    // The temporary file is private (0600); what is written is an ordinary file, as the
    // process's umask would make it.
    set_default_permissions(temp.as_file());
    match replace {
        Replace::Yes => temp.persist(&target).map(drop).map_err(|e| OutputError::new(path, e.error)),
        Replace::No => temp.persist_noclobber(&target).map(drop).map_err(|e| OutputError::new(path, e.error)),
    }
}

#[cfg(unix)]
fn set_default_permissions(file: &std::fs::File) {
    use std::os::unix::fs::PermissionsExt;
    let mode = 0o666 & !current_umask();
    let _ = file.set_permissions(std::fs::Permissions::from_mode(mode));
}

#[cfg(unix)]
fn current_umask() -> u32 {
    // Read once: programs set their umask at start, if at all. /proc/self/status has it on
    // Linux without changing it; elsewhere assume the common 022.
    static UMASK: std::sync::OnceLock<u32> = std::sync::OnceLock::new();
    *UMASK.get_or_init(|| {
        std::fs::read_to_string("/proc/self/status")
            .ok()
            .and_then(|s| {
                let line = s.lines().find(|l| l.starts_with("Umask:"))?;
                u32::from_str_radix(line.trim_start_matches("Umask:").trim(), 8).ok()
            })
            .unwrap_or(0o022)
    })
}

#[cfg(not(unix))]
fn set_default_permissions(_: &std::fs::File) {}

/// Encodes 8-bit pixels (`color` RGBA8 or RGB8) in the format `path`'s extension names and
/// writes them with [`write_file`]; JPEG drops alpha.
pub fn save_image(
    path: &Path,
    pixels: &[u8],
    size: (u32, u32),
    color: image::ExtendedColorType,
) -> Result<(), OutputError> {
    save_image_with(path, Replace::Yes, pixels, size, color)
}

/// As [`save_image`] but never replacing an existing file ([`write_new_file`]).
pub fn save_new_image(
    path: &Path,
    pixels: &[u8],
    size: (u32, u32),
    color: image::ExtendedColorType,
) -> Result<(), OutputError> {
    save_image_with(path, Replace::No, pixels, size, color)
}

fn save_image_with(
    path: &Path,
    replace: Replace,
    pixels: &[u8],
    size: (u32, u32),
    color: image::ExtendedColorType,
) -> Result<(), OutputError> {
    let format = image_format(path)?;
    write_with(path, replace, |out| encode(out, format, pixels, size, color))
}

fn encode(
    out: &mut dyn Write,
    format: image::ImageFormat,
    pixels: &[u8],
    (w, h): (u32, u32),
    color: image::ExtendedColorType,
) -> std::io::Result<()> {
    use image::ImageEncoder;
    let rgb;
    let (pixels, color) = match (format, color) {
        (image::ImageFormat::Jpeg, image::ExtendedColorType::Rgba8) => {
            rgb = pixels.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect::<Vec<u8>>();
            (&rgb[..], image::ExtendedColorType::Rgb8)
        }
        _ => (pixels, color),
    };
    let result = match format {
        image::ImageFormat::Jpeg => {
            image::codecs::jpeg::JpegEncoder::new_with_quality(out, 95).write_image(pixels, w, h, color)
        }
        _ => image::codecs::png::PngEncoder::new(out).write_image(pixels, w, h, color),
    };
    result.map_err(|e| match e {
        image::ImageError::IoError(io) => io,
        other => std::io::Error::other(other),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("penumbra-output-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn entries(d: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    #[test]
    fn a_failed_write_leaves_the_old_file_and_nothing_else() {
        let d = dir("failed");
        let path = d.join("out.png");
        std::fs::write(&path, b"old contents").unwrap();
        let err = write_file(&path, |out| {
            out.write_all(b"half of a new file")?;
            Err(std::io::Error::other("the disk is full"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("the disk is full") && err.to_string().contains("out.png"), "{err}");
        assert_eq!(std::fs::read(&path).unwrap(), b"old contents");
        assert_eq!(entries(&d), ["out.png"]);
    }

    #[test]
    fn a_complete_write_replaces_the_file() {
        let d = dir("complete");
        let path = d.join("out.png");
        std::fs::write(&path, b"old").unwrap();
        save_image(&path, &[255, 0, 0, 255], (1, 1), image::ExtendedColorType::Rgba8).unwrap();
        assert_eq!(image::open(&path).unwrap().to_rgba8().into_raw(), [255, 0, 0, 255]);
        let jpeg = d.join("out.JPG");
        save_image(&jpeg, &[255, 0, 0, 255], (1, 1), image::ExtendedColorType::Rgba8).unwrap();
        assert_eq!(image::open(&jpeg).unwrap().width(), 1);
        assert_eq!(entries(&d), ["out.JPG", "out.png"]);
    }

    #[test]
    fn new_files_never_replace() {
        let d = dir("new");
        let path = d.join("shot.png");
        std::fs::write(&path, b"taken").unwrap();
        assert!(save_new_image(&path, &[0; 4], (1, 1), image::ExtendedColorType::Rgba8).is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"taken");
        assert_eq!(entries(&d), ["shot.png"]);
    }

    #[test]
    fn formats_and_destinations_are_checked_first() {
        let d = dir("check");
        assert!(image_format(Path::new("a.png")).is_ok());
        assert!(image_format(Path::new("a.jpeg")).is_ok());
        let err = image_format(Path::new("photo.webp")).unwrap_err().to_string();
        assert!(err.contains(".webp") && err.contains("photo.webp"), "{err}");
        assert!(image_format(Path::new("noext")).is_err());
        assert!(check_destination(&d.join("x.png")).is_ok());
        assert!(check_destination(&d).is_err());
        assert!(check_destination(&d.join("missing/x.png")).is_err());
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_device_is_written_in_place_and_its_errors_reported() {
        use std::os::unix::fs::FileTypeExt;
        let err = write_file(Path::new("/dev/full"), |out| out.write_all(&[0; 1 << 16])).unwrap_err();
        assert!(err.to_string().contains("/dev/full"), "{err}");
        assert!(std::fs::metadata("/dev/full").unwrap().file_type().is_char_device());
    }
}
