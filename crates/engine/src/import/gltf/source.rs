//! Bytes in: the file itself, its buffers and its images, from the GLB binary chunk, base64 data
//! URIs or files beside the scene. A relative URI may not leave the scene's folder (lexically
//! through `..`, or through a symlink) unless the caller allows it.

use std::path::{Component, Path, PathBuf};

use base64::Engine as _;

use super::ImportOptions;
use crate::import::ImportErrorKind;

/// A GLB header is 12 bytes: magic, version, total length. The gltf crate subtracts 12 from the
/// declared length without checking it, so a truncated or hostile header is refused here first.
pub(crate) fn check_glb_header(bytes: &[u8]) -> Result<(), ImportErrorKind> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    if bytes.len() < 20 {
        return Err(ImportErrorKind::Malformed(format!(
            "GLB is truncated: {} bytes, the headers alone need 20",
            bytes.len()
        )));
    }
    let declared = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes")) as usize;
    if declared < 20 || declared > bytes.len() {
        return Err(ImportErrorKind::Malformed(format!(
            "GLB header declares {declared} bytes but the file has {}{}",
            bytes.len(),
            if declared > bytes.len() { " (truncated?)" } else { "" }
        )));
    }
    Ok(())
}

#[derive(Debug)]
pub(crate) enum UriError {
    OutsideFolder,
    Unsupported(String),
    Read(String),
    TooLarge { size: u64, limit: u64 },
}

impl UriError {
    /// Maps to the import error for a buffer or image at `index`.
    pub(crate) fn into_kind(self, uri: &str, make: impl FnOnce(String) -> ImportErrorKind) -> ImportErrorKind {
        match self {
            UriError::OutsideFolder => ImportErrorKind::UriOutsideFolder { uri: uri.to_owned() },
            UriError::Unsupported(r) | UriError::Read(r) => make(r),
            UriError::TooLarge { size, limit } => ImportErrorKind::LimitExceeded {
                what: "a data URI's decoded size",
                value: size,
                limit,
                how_to_raise: "ImportOptions::max_data_uri_bytes",
            },
        }
    }
}

/// Reads what `uri` names, relative to `base_dir`.
pub(crate) fn read_uri(base_dir: &Path, uri: &str, options: &ImportOptions) -> Result<Vec<u8>, UriError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        return decode_data_uri(rest, options.max_data_uri_bytes);
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
    std::fs::read(&path).map_err(|e| UriError::Read(format!("cannot read {}: {e}", path.display())))
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

fn decode_data_uri(rest: &str, limit: u64) -> Result<Vec<u8>, UriError> {
    let (header, payload) =
        rest.split_once(',').ok_or_else(|| UriError::Read("data URI has no ',' before its payload".into()))?;
    if !header.ends_with(";base64") {
        return Err(UriError::Unsupported("data URI is not base64-encoded".into()));
    }
    // Base64 expands 3 bytes to 4: check the bound before allocating.
    let size = payload.len() as u64 / 4 * 3;
    if size > limit {
        return Err(UriError::TooLarge { size, limit });
    }
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
    // Then symlinks: the real path must still be under the real folder.
    if let (Ok(real), Ok(real_base)) = (joined.canonicalize(), base_dir.canonicalize()) {
        if !real.starts_with(&real_base) {
            return Err(UriError::OutsideFolder);
        }
        return Ok(real);
    }
    Ok(joined)
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
        assert!(resolve_inside(base, "a/../b.bin", false).is_ok());
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
        assert_eq!(read_uri(Path::new("."), "data:application/octet-stream;base64,AAEC", &opts).unwrap(), [0, 1, 2]);
        assert!(matches!(decode_data_uri(";base64,AAAAAAAA", 3), Err(UriError::TooLarge { .. })));
    }

    #[test]
    fn truncated_glb_headers_are_refused() {
        let mut glb = b"glTF\x02\0\0\0".to_vec();
        glb.extend_from_slice(&5u32.to_le_bytes());
        glb.extend_from_slice(&[0; 8]);
        assert!(check_glb_header(&glb).is_err());
        assert!(check_glb_header(b"glTF").is_err());
        assert!(check_glb_header(b"{\"asset\":{}}").is_ok());
    }
}
