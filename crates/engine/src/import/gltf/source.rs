//! Bytes in: the file itself, its buffers and its images, from the GLB binary chunk, base64 data
//! URIs or files beside the scene. A relative URI may not leave the scene's folder (lexically
//! through `..`, or through a symlink) unless the caller allows it.

use std::path::{Component, Path, PathBuf};

use base64::Engine as _;

use super::ImportOptions;
use crate::import::{ImportErrorKind, Limit};

/// A GLB header is 12 bytes: magic, version, total length. The gltf crate subtracts 12 from the
/// declared length without checking it, so a truncated or hostile header is refused here first.
/// A GLB's header checked against the file: its version must be 2 (GLB 1 is glTF 1.0, another
/// format), and its length must not pass the end of the file. Returns the bytes the header
/// declares: bytes after them are not part of the GLB (a warning, not an error: the GLB itself
/// is whole).
pub(crate) fn check_glb_header<'a>(bytes: &'a [u8], warnings: &mut Vec<String>) -> Result<&'a [u8], ImportErrorKind> {
    if !bytes.starts_with(b"glTF") {
        return Ok(bytes);
    }
    if bytes.len() < 20 {
        return Err(ImportErrorKind::Malformed(format!(
            "GLB is truncated: {} bytes, the headers alone need 20",
            bytes.len()
        )));
    }
    let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
    let version = word(4);
    if version != 2 {
        return Err(ImportErrorKind::Malformed(format!(
            "GLB version {version}{}: Penumbra reads glTF 2.0 (GLB version 2) only",
            if version == 1 { " is glTF 1.0, a different format" } else { " is unknown" }
        )));
    }
    let declared = word(8) as usize;
    if declared < 20 || declared > bytes.len() {
        return Err(ImportErrorKind::Malformed(format!(
            "GLB header declares {declared} bytes but the file has {}{}",
            bytes.len(),
            if declared > bytes.len() { " (truncated?)" } else { "" }
        )));
    }
    if declared < bytes.len() {
        warnings.push(format!(
            "the GLB header declares {declared} bytes but the file has {}; the {} bytes after the GLB are ignored",
            bytes.len(),
            bytes.len() - declared
        ));
    }
    Ok(&bytes[..declared])
}

/// `asset.version` (and `minVersion`) must name glTF 2.x: glTF 1.0 files are another format
/// that would otherwise fail to parse in confusing terms, or parse and render wrongly.
pub(crate) fn check_version(version: &str, min_version: Option<&str>) -> Result<(), ImportErrorKind> {
    let major_minor = |v: &str| -> Option<(u32, u32)> {
        let (major, minor) = v.split_once('.')?;
        Some((major.parse().ok()?, minor.parse().ok()?))
    };
    match major_minor(version) {
        Some((2, _)) => {}
        Some((1, _)) => {
            return Err(ImportErrorKind::Malformed(format!(
                "asset.version \"{version}\" is glTF 1.0, a different format; Penumbra reads glTF 2.0 (convert it, \
                 for example with Blender or gltf-pipeline)"
            )));
        }
        _ => {
            return Err(ImportErrorKind::Malformed(format!(
                "asset.version \"{version}\" is not a glTF 2.x version; Penumbra reads glTF 2.0"
            )));
        }
    }
    if let Some(min) = min_version
        && major_minor(min).is_none_or(|v| v > (2, 0))
    {
        return Err(ImportErrorKind::Malformed(format!(
            "asset.minVersion \"{min}\": the file needs a glTF version newer than the 2.0 Penumbra reads"
        )));
    }
    Ok(())
}

/// The `asset` of a file that did not parse as glTF 2.0: enough to tell a glTF 1.0 file (whose
/// JSON has another shape) from a broken one.
pub(crate) fn probe_version(bytes: &[u8]) -> Option<String> {
    let json = if bytes.starts_with(b"glTF") {
        // GLB 1 has its content chunk after a 20-byte header; GLB 2 its JSON chunk after 20 too
        // (12 of header, 8 of chunk header), both with the length at byte 12.
        let len = u32::from_le_bytes(bytes.get(12..16)?.try_into().ok()?) as usize;
        bytes.get(20..20usize.checked_add(len)?)?
    } else {
        bytes
    };
    let root: gltf::json::Value = gltf::json::deserialize::from_slice(json).ok()?;
    match root.get("asset")?.get("version")? {
        gltf::json::Value::String(s) => Some(s.clone()),
        v => Some(v.to_string()),
    }
}

#[derive(Debug)]
pub(crate) enum UriError {
    OutsideFolder,
    Unsupported(String),
    Read(String),
    TooLarge { size: u64, max: u64, limit: Limit, what: &'static str },
}

impl std::fmt::Display for UriError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            UriError::OutsideFolder => f.write_str("the URI points outside the scene's folder"),
            UriError::Unsupported(r) | UriError::Read(r) => f.write_str(r),
            UriError::TooLarge { size, max, limit, what } => {
                write!(f, "{what} is {size}, over the limit of {max} (raise it with `--limit {limit}=N`)")
            }
        }
    }
}

/// Bytes one import has read from files and data URIs, against `--limit read-bytes`: per-file
/// limits alone would let a file name one large file a thousand times.
#[derive(Debug)]
pub(crate) struct ReadBudget {
    used: std::cell::Cell<u64>,
    max: u64,
}

impl ReadBudget {
    pub(crate) fn new(options: &ImportOptions) -> Self {
        Self { used: std::cell::Cell::new(0), max: options.limits.read_bytes }
    }

    fn charge(&self, bytes: u64) -> Result<(), UriError> {
        let total = self.used.get().saturating_add(bytes);
        if total > self.max {
            let what = "the bytes read from files and data URIs";
            return Err(UriError::TooLarge { size: total, max: self.max, limit: Limit::ReadBytes, what });
        }
        self.used.set(total);
        Ok(())
    }
}

/// How much a URI may bring in, checked before the bytes are allocated.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ReadLimit {
    bytes: u64,
    /// Read only the first `bytes` of a longer file rather than refusing it.
    truncate: bool,
    limit: Limit,
    what: &'static str,
}

impl ReadLimit {
    /// A glTF buffer: its byteLength, already checked against `--limit buffer-bytes`. A longer
    /// file is legal; the rest is never used, so never read.
    pub(crate) fn buffer(byte_length: u64) -> Self {
        Self { bytes: byte_length, truncate: true, limit: Limit::BufferBytes, what: "a buffer's size" }
    }

    /// An encoded image file.
    pub(crate) fn image(options: &ImportOptions) -> Self {
        let bytes = options.limits.image_bytes;
        Self { bytes, truncate: false, limit: Limit::ImageBytes, what: "an image file's size" }
    }

    /// Any other referenced file (an IES profile).
    pub(crate) fn file(options: &ImportOptions, what: &'static str) -> Self {
        Self { bytes: options.limits.buffer_bytes, truncate: false, limit: Limit::BufferBytes, what }
    }
}

impl UriError {
    /// Maps to the import error for a buffer or image at `index`.
    pub(crate) fn into_kind(self, uri: &str, make: impl FnOnce(String) -> ImportErrorKind) -> ImportErrorKind {
        match self {
            UriError::OutsideFolder => ImportErrorKind::UriOutsideFolder { uri: uri.to_owned() },
            UriError::Unsupported(r) | UriError::Read(r) => make(r),
            UriError::TooLarge { size, max, limit, what } => {
                ImportErrorKind::LimitExceeded { what, value: size, limit: max, name: limit }
            }
        }
    }
}

/// Reads what `uri` names, relative to `base_dir`.
pub(crate) fn read_uri(
    base_dir: &Path,
    uri: &str,
    options: &ImportOptions,
    read_limit: ReadLimit,
    budget: &ReadBudget,
) -> Result<Vec<u8>, UriError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        return decode_data_uri(rest, options.limits.data_uri_bytes, budget);
    }
    if has_scheme(uri) {
        return Err(UriError::Unsupported(format!(
            "URI scheme of {uri:?} is not supported (only relative paths and data URIs)"
        )));
    }
    let decoded = percent_encoding::percent_decode_str(uri)
        .decode_utf8()
        .map_err(|_| UriError::Read("URI is not valid UTF-8 after percent-decoding".into()))?;
    let path = resolve_inside(base_dir, &decoded, options.allow_outside_folder)?;
    read_file(&path, read_limit, budget)
}

/// Reads at most `limit.bytes` of `path` (a device or a 100 GB file must not be read whole).
pub(crate) fn read_file(path: &Path, limit: ReadLimit, budget: &ReadBudget) -> Result<Vec<u8>, UriError> {
    use std::io::Read;
    let read_err = |e: std::io::Error| UriError::Read(format!("cannot read {}: {e}", path.display()));
    // Opening a FIFO or a device would block or never end: only regular files.
    let meta = std::fs::metadata(path).map_err(read_err)?;
    if !meta.is_file() {
        return Err(UriError::Read(format!("{} is not a regular file", path.display())));
    }
    let size = meta.len();
    if !limit.truncate && size > limit.bytes {
        return Err(UriError::TooLarge { size, max: limit.bytes, limit: limit.limit, what: limit.what });
    }
    budget.charge(size.min(limit.bytes))?;
    let file = std::fs::File::open(path).map_err(read_err)?;
    let mut out = Vec::new();
    // `+ 1` notices a file that grew, or a device whose metadata says 0 bytes.
    let cap = if limit.truncate { limit.bytes } else { limit.bytes.saturating_add(1) };
    file.take(cap).read_to_end(&mut out).map_err(read_err)?;
    if out.len() as u64 > limit.bytes {
        return Err(UriError::TooLarge {
            size: out.len() as u64,
            max: limit.bytes,
            limit: limit.limit,
            what: limit.what,
        });
    }
    Ok(out)
}

fn has_scheme(uri: &str) -> bool {
    // RFC 3986: scheme = ALPHA *( ALPHA / DIGIT / "+" / "-" / "." ) ":". One letter before the
    // colon is a Windows drive, which is an absolute path, refused by `resolve_inside`.
    match uri.find(':') {
        Some(i) if i > 1 => {
            let scheme = &uri[..i];
            scheme.starts_with(|c: char| c.is_ascii_alphabetic())
                && scheme.chars().all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
        }
        _ => false,
    }
}

fn decode_data_uri(rest: &str, limit: u64, budget: &ReadBudget) -> Result<Vec<u8>, UriError> {
    let (header, payload) =
        rest.split_once(',').ok_or_else(|| UriError::Read("data URI has no ',' before its payload".into()))?;
    if !header.ends_with(";base64") {
        return Err(UriError::Unsupported("data URI is not base64-encoded".into()));
    }
    // Base64 expands 3 bytes to 4: check the bound before allocating.
    let size = payload.len() as u64 / 4 * 3;
    if size > limit {
        return Err(UriError::TooLarge {
            size,
            max: limit,
            limit: Limit::DataUriBytes,
            what: "a data URI's decoded size",
        });
    }
    budget.charge(size)?;
    base64::engine::general_purpose::STANDARD
        .decode(payload.trim_end())
        .map_err(|e| UriError::Read(format!("invalid base64 in data URI: {e}")))
}

/// `base_dir/relative`, refused when it escapes `base_dir` (unless `allow_outside`).
pub(crate) fn resolve_inside(base_dir: &Path, relative: &str, allow_outside: bool) -> Result<PathBuf, UriError> {
    let rel = Path::new(relative);
    let joined = base_dir.join(rel);
    if allow_outside {
        return Ok(joined);
    }
    // Lexical check first: it needs no file to exist, so "../secret" is reported as outside the
    // folder rather than as missing.
    let mut depth: i64 = 0;
    for c in rel.components() {
        match c {
            Component::Normal(_) => depth += 1,
            Component::CurDir => {}
            Component::ParentDir => depth -= 1,
            Component::RootDir | Component::Prefix(_) => return Err(UriError::OutsideFolder),
        }
        if depth < 0 {
            return Err(UriError::OutsideFolder);
        }
    }
    // Then symlinks: the real path must still be under the real folder. A scene named without a
    // folder (`penumbra view scene.gltf`) has the empty path as its folder: that is ".".
    let base = if base_dir.as_os_str().is_empty() { Path::new(".") } else { base_dir };
    let real_base = base
        .canonicalize()
        .map_err(|e| UriError::Read(format!("cannot resolve the folder {}: {e}", base.display())))?;
    let real =
        base.join(rel).canonicalize().map_err(|e| UriError::Read(format!("cannot read {}: {e}", joined.display())))?;
    if !real.starts_with(&real_base) {
        return Err(UriError::OutsideFolder);
    }
    Ok(real)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parent_and_absolute_uris_are_refused() {
        let base = Path::new("/tmp");
        assert!(matches!(resolve_inside(base, "../etc/passwd", false), Err(UriError::OutsideFolder)));
        assert!(matches!(resolve_inside(base, "a/../../b", false), Err(UriError::OutsideFolder)));
        assert!(matches!(resolve_inside(base, "/etc/passwd", false), Err(UriError::OutsideFolder)));
        assert!(matches!(resolve_inside(base, "a/../b.bin", false), Err(UriError::Read(_))), "missing, not outside");
    }

    #[test]
    fn symlinks_out_of_the_folder_are_refused() {
        let dir = std::env::temp_dir().join(format!("penumbra-symlink-{}", std::process::id()));
        let inner = dir.join("scene");
        std::fs::create_dir_all(&inner).unwrap();
        std::fs::write(dir.join("secret.bin"), b"secret").unwrap();
        std::fs::write(inner.join("ok.bin"), b"ok").unwrap();
        let _ = std::fs::remove_file(inner.join("link.bin"));
        std::os::unix::fs::symlink(dir.join("secret.bin"), inner.join("link.bin")).unwrap();
        assert!(matches!(resolve_inside(&inner, "link.bin", false), Err(UriError::OutsideFolder)));
        assert!(resolve_inside(&inner, "link.bin", true).is_ok(), "allowed by the flag");
        assert!(resolve_inside(&inner, "ok.bin", false).is_ok());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn reads_stop_at_the_limit() {
        let path = std::env::temp_dir().join(format!("penumbra-read-limit-{}", std::process::id()));
        std::fs::write(&path, [7u8; 100]).unwrap();
        let mut options = ImportOptions::default();
        let budget = ReadBudget::new(&options);
        assert_eq!(
            read_file(&path, ReadLimit::buffer(10), &budget).unwrap().len(),
            10,
            "a buffer reads its byteLength"
        );
        options.limits.image_bytes = 99;
        let err = read_file(&path, ReadLimit::image(&options), &budget);
        assert!(matches!(err, Err(UriError::TooLarge { size: 100, .. })));
        options.limits.image_bytes = 100;
        assert_eq!(read_file(&path, ReadLimit::image(&options), &budget).unwrap().len(), 100);
        // The running total: 10 + 100 read so far; 150 allowed in all.
        options.limits.read_bytes = 150;
        let budget = ReadBudget::new(&options);
        assert!(read_file(&path, ReadLimit::image(&options), &budget).is_ok());
        let err = read_file(&path, ReadLimit::image(&options), &budget);
        assert!(matches!(err, Err(UriError::TooLarge { limit: Limit::ReadBytes, size: 200, .. })), "{err:?}");
        let fifo = std::env::temp_dir().join(format!("penumbra-fifo-{}", std::process::id()));
        let _ = std::fs::remove_file(&fifo);
        if std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
            assert!(
                matches!(read_file(&fifo, ReadLimit::buffer(10), &budget), Err(UriError::Read(_))),
                "no blocking open"
            );
            std::fs::remove_file(&fifo).unwrap();
        }
        std::fs::remove_file(&path).unwrap();
    }

    #[test]
    fn schemes_are_detected_but_drive_letters_are_not_schemes() {
        assert!(has_scheme("http://example.com/a.bin"));
        assert!(has_scheme("file:///etc/passwd"));
        assert!(!has_scheme("C:/x.bin"));
        assert!(!has_scheme("textures/a.png"));
    }

    #[test]
    fn data_uris_decode_and_respect_the_limit() {
        let opts = ImportOptions::default();
        assert_eq!(
            read_uri(
                Path::new("."),
                "data:application/octet-stream;base64,AAEC",
                &opts,
                ReadLimit::buffer(3),
                &ReadBudget::new(&opts)
            )
            .unwrap(),
            [0, 1, 2]
        );
        assert!(matches!(
            decode_data_uri(";base64,AAAAAAAA", 3, &ReadBudget::new(&opts)),
            Err(UriError::TooLarge { .. })
        ));
    }

    #[test]
    fn truncated_glb_headers_are_refused() {
        let mut glb = b"glTF\x02\0\0\0".to_vec();
        glb.extend_from_slice(&5u32.to_le_bytes());
        glb.extend_from_slice(&[0; 8]);
        let w = &mut Vec::new();
        assert!(check_glb_header(&glb, w).is_err());
        assert!(check_glb_header(b"glTF", w).is_err());
        assert!(check_glb_header(b"{\"asset\":{}}", w).is_ok());
        assert!(w.is_empty());
    }

    #[test]
    fn glb_versions_and_lengths() {
        let glb = |version: u32, declared: u32, len: usize| {
            let mut b = b"glTF".to_vec();
            b.extend_from_slice(&version.to_le_bytes());
            b.extend_from_slice(&declared.to_le_bytes());
            b.resize(len, 0);
            b
        };
        let w = &mut Vec::new();
        let err = check_glb_header(&glb(1, 24, 24), w).unwrap_err().to_string();
        assert!(err.contains("glTF 1.0"), "{err}");
        assert_eq!(check_glb_header(&glb(2, 24, 24), w).unwrap().len(), 24);
        assert!(w.is_empty());
        assert_eq!(check_glb_header(&glb(2, 24, 40), w).unwrap().len(), 24);
        assert!(w[0].contains("16 bytes after the GLB are ignored"), "{w:?}");
    }

    #[test]
    fn only_gltf_2_versions_are_read() {
        assert!(check_version("2.0", None).is_ok());
        assert!(check_version("2.1", Some("2.0")).is_ok());
        assert!(check_version("1.0", None).unwrap_err().to_string().contains("glTF 1.0"));
        assert!(check_version("3.0", None).is_err());
        assert!(check_version("two", None).is_err());
        assert!(check_version("2.1", Some("2.1")).is_err());
        assert_eq!(probe_version(br#"{"asset": {"version": "1.0"}, "meshes": {}}"#).as_deref(), Some("1.0"));
    }
}
