//! Import errors: every failure names the file it came from and says what is wrong in terms of
//! the file (which buffer, which accessor, which extension), never in terms of our code.

use std::fmt;
use std::path::PathBuf;

use crate::mesh::MeshError;

/// A failed import. Display reads `path: problem`.
#[derive(Debug, thiserror::Error)]
pub struct ImportError {
    pub path: PathBuf,
    pub kind: ImportErrorKind,
}

impl fmt::Display for ImportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.kind)
    }
}

impl ImportError {
    pub fn new(path: impl Into<PathBuf>, kind: ImportErrorKind) -> Self {
        Self { path: path.into(), kind }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ImportErrorKind {
    #[error("cannot read the file: {0}")]
    Io(#[source] std::io::Error),
    #[error("unsupported file type (expected .gltf, .glb or .obj)")]
    UnknownFormat,
    #[error("not a valid glTF file: {0}")]
    Malformed(String),
    #[error("invalid glTF: {0}")]
    Invalid(String),
    #[error("requires extension {name}, which Penumbra does not support")]
    UnsupportedExtension { name: String },
    #[error("buffer {index} ({uri}): {reason}")]
    Buffer { index: usize, uri: String, reason: String },
    #[error("image {index} ({uri}): {reason}")]
    Image { index: usize, uri: String, reason: String },
    #[error("URI {uri:?} points outside the scene's folder (pass --allow-outside-folder to permit it)")]
    UriOutsideFolder { uri: String },
    #[error("bufferView {index}: {reason}")]
    BufferView { index: usize, reason: String },
    #[error("accessor {index}: {reason}")]
    Accessor { index: usize, reason: String },
    #[error("mesh {mesh} primitive {primitive}: {reason}")]
    Primitive { mesh: usize, primitive: usize, reason: String },
    #[error("mesh {mesh} primitive {primitive}: {source}")]
    Mesh {
        mesh: usize,
        primitive: usize,
        #[source]
        source: MeshError,
    },
    #[error("IES profile {index} ({uri}): {reason}")]
    IesProfile { index: usize, uri: String, reason: String },
    #[error("{}{reason}", line.map_or_else(String::new, |l| format!("line {l}: ")))]
    Obj { line: Option<usize>, reason: String },
    #[error("camera {index} (\"{name}\"): {reason}")]
    Camera { index: usize, name: String, reason: String },
    #[error("it is {what}, not a regular file")]
    NotAFile { what: &'static str },
    #[error("skin {index}: {reason}")]
    Skin { index: usize, reason: String },
    #[error("animation {index}: {reason}")]
    Animation { index: usize, reason: String },
    #[error("node hierarchy: {0}")]
    Hierarchy(String),
    #[error("scene {index} does not exist (the file has {count})")]
    NoSuchScene { index: usize, count: usize },
    #[error("{what} is {value}, over the limit of {limit} (raise it with `--limit {name}=N`, or ImportLimits in code)")]
    LimitExceeded { what: &'static str, value: u64, limit: u64, name: super::Limit },
}
