//! Resource limits on untrusted scene files, checked before the memory they guard is allocated.
//!
//! A scene file is a few bytes that can ask for anything: an accessor of 2^32 elements without a
//! buffer behind it, a 1×10^6 image, a node chain a million deep. Every import stage asks
//! [`ImportLimits`] before it allocates on the file's word; going over is
//! [`ImportErrorKind::LimitExceeded`](super::ImportErrorKind), which names the limit and how to
//! raise it (`--limit NAME=N` on the command line, the field in code). The table of limits and
//! their defaults is [`Limit::ALL`]; `docs/reliability.md` explains each default.

use std::fmt;

/// One limit, by name. `Limit::ALL` lists them in the order the docs and `--help` show them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Limit {
    DataUriBytes,
    BufferBytes,
    ReadBytes,
    AccessorElements,
    DecodedBytes,
    Vertices,
    Indices,
    AnimationKeys,
    NodeDepth,
    Nodes,
    ImageDimension,
    ImageBytes,
    TotalImageBytes,
}

impl Limit {
    pub const ALL: [Limit; 13] = [
        Limit::DataUriBytes,
        Limit::BufferBytes,
        Limit::ReadBytes,
        Limit::AccessorElements,
        Limit::DecodedBytes,
        Limit::Vertices,
        Limit::Indices,
        Limit::AnimationKeys,
        Limit::NodeDepth,
        Limit::Nodes,
        Limit::ImageDimension,
        Limit::ImageBytes,
        Limit::TotalImageBytes,
    ];

    /// The command-line name (`--limit accessor-elements=100000000`).
    pub fn name(self) -> &'static str {
        match self {
            Limit::DataUriBytes => "data-uri-bytes",
            Limit::BufferBytes => "buffer-bytes",
            Limit::ReadBytes => "read-bytes",
            Limit::AccessorElements => "accessor-elements",
            Limit::DecodedBytes => "decoded-bytes",
            Limit::Vertices => "vertices",
            Limit::Indices => "indices",
            Limit::AnimationKeys => "animation-keys",
            Limit::NodeDepth => "node-depth",
            Limit::Nodes => "nodes",
            Limit::ImageDimension => "image-dimension",
            Limit::ImageBytes => "image-bytes",
            Limit::TotalImageBytes => "total-image-bytes",
        }
    }

    /// What the limit bounds, for `--help` and the docs.
    pub fn describe(self) -> &'static str {
        match self {
            Limit::DataUriBytes => "decoded size of one base64 data URI",
            Limit::BufferBytes => "byteLength of one glTF buffer (a GLB chunk, a data URI or a file)",
            Limit::ReadBytes => "bytes read from files and data URIs in one import",
            Limit::AccessorElements => "elements in one accessor",
            Limit::DecodedBytes => "bytes of vertex, index, skin and animation data decoded in one import",
            Limit::Vertices => "vertices over all primitives of a scene file",
            Limit::Indices => "indices over all primitives of a scene file",
            Limit::AnimationKeys => "keyframes over all animation channels",
            Limit::NodeDepth => "depth of the node hierarchy",
            Limit::Nodes => "nodes in a scene file",
            Limit::ImageDimension => "width or height of one image, in pixels",
            Limit::ImageBytes => "decoded size of one image, and the size of one image file",
            Limit::TotalImageBytes => "decoded size of all images of a scene file, with their mip chains",
        }
    }

    fn field(self, limits: &mut ImportLimits) -> &mut u64 {
        match self {
            Limit::DataUriBytes => &mut limits.data_uri_bytes,
            Limit::BufferBytes => &mut limits.buffer_bytes,
            Limit::ReadBytes => &mut limits.read_bytes,
            Limit::AccessorElements => &mut limits.accessor_elements,
            Limit::DecodedBytes => &mut limits.decoded_bytes,
            Limit::Vertices => &mut limits.vertices,
            Limit::Indices => &mut limits.indices,
            Limit::AnimationKeys => &mut limits.animation_keys,
            Limit::NodeDepth => &mut limits.node_depth,
            Limit::Nodes => &mut limits.nodes,
            Limit::ImageDimension => &mut limits.image_dimension,
            Limit::ImageBytes => &mut limits.image_bytes,
            Limit::TotalImageBytes => &mut limits.total_image_bytes,
        }
    }

    pub fn from_name(name: &str) -> Option<Limit> {
        Limit::ALL.into_iter().find(|l| l.name() == name)
    }
}

impl fmt::Display for Limit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The limits one import runs under. Fields are named as on the command line, with `_` for `-`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ImportLimits {
    pub data_uri_bytes: u64,
    pub buffer_bytes: u64,
    pub read_bytes: u64,
    pub accessor_elements: u64,
    pub decoded_bytes: u64,
    pub vertices: u64,
    pub indices: u64,
    pub animation_keys: u64,
    pub node_depth: u64,
    pub nodes: u64,
    pub image_dimension: u64,
    pub image_bytes: u64,
    pub total_image_bytes: u64,
}

impl Default for ImportLimits {
    fn default() -> Self {
        // Each default is several times the largest real asset we know of, so no honest file
        // meets one, and small enough that a hostile file cannot exhaust a 16 GiB machine.
        Self {
            // 20× the largest single buffer in the Khronos samples.
            data_uri_bytes: 256 << 20,
            buffer_bytes: 4 << 30,
            read_bytes: 8 << 30,
            // Four times the vertex count of the largest scanned meshes people view; 1 GiB for
            // one vec4 attribute.
            accessor_elements: 1 << 26,
            decoded_bytes: 8 << 30,
            vertices: 1 << 28,
            indices: 1 << 30,
            animation_keys: 1 << 26,
            // Transform propagation walks hierarchies recursively; 1024 levels fit a 2 MiB
            // worker-thread stack in a debug build with room to spare.
            node_depth: 1024,
            nodes: 1 << 22,
            // The largest 2D texture wgpu guarantees on desktop adapters.
            image_dimension: 16384,
            image_bytes: 1 << 30,
            total_image_bytes: 8 << 30,
        }
    }
}

impl ImportLimits {
    pub fn get(&self, limit: Limit) -> u64 {
        let mut copy = *self;
        *limit.field(&mut copy)
    }

    pub fn set(&mut self, limit: Limit, value: u64) {
        *limit.field(self) = value;
    }

    /// Applies one `NAME=N` setting (`N` may be written `1e9`, `4G`, `512M`, `64K`).
    pub fn apply(&mut self, setting: &str) -> Result<(), String> {
        let names = || Limit::ALL.map(Limit::name).join(", ");
        let (name, value) =
            setting.split_once('=').ok_or_else(|| format!("limit {setting:?} is not NAME=N (names: {})", names()))?;
        let limit = Limit::from_name(name.trim())
            .ok_or_else(|| format!("unknown limit {:?} (names: {})", name.trim(), names()))?;
        let value = parse_amount(value.trim()).ok_or_else(|| {
            format!("limit {name}: {value:?} is not a whole number (examples: 100000, 1e8, 512M, 4G)")
        })?;
        self.set(limit, value);
        Ok(())
    }

    /// `Err(LimitExceeded)` when `value` is over `limit`.
    pub(crate) fn check(&self, limit: Limit, what: &'static str, value: u64) -> Result<(), super::ImportErrorKind> {
        let max = self.get(limit);
        if value > max {
            return Err(super::ImportErrorKind::LimitExceeded { what, value, limit: max, name: limit });
        }
        Ok(())
    }
}

fn parse_amount(s: &str) -> Option<u64> {
    let (digits, scale) = match s.as_bytes().last()? {
        b'K' | b'k' => (&s[..s.len() - 1], 1u64 << 10),
        b'M' | b'm' => (&s[..s.len() - 1], 1 << 20),
        b'G' | b'g' => (&s[..s.len() - 1], 1 << 30),
        _ => (s, 1),
    };
    if let Ok(v) = digits.parse::<u64>() {
        return v.checked_mul(scale);
    }
    // `1e8`: exact for whole values up to 2^53, which covers every sensible limit.
    let f: f64 = digits.parse().ok()?;
    let v = f * scale as f64;
    (v.is_finite() && v >= 0.0 && v.fract() == 0.0 && v <= u64::MAX as f64).then_some(v as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_limit_has_a_distinct_name_and_round_trips() {
        let mut limits = ImportLimits::default();
        for (i, l) in Limit::ALL.into_iter().enumerate() {
            assert_eq!(Limit::from_name(l.name()), Some(l));
            limits.set(l, 1000 + i as u64);
        }
        for (i, l) in Limit::ALL.into_iter().enumerate() {
            assert_eq!(limits.get(l), 1000 + i as u64, "{l}");
        }
    }

    #[test]
    fn settings_parse_with_units_and_reject_nonsense() {
        let mut limits = ImportLimits::default();
        limits.apply("vertices=1e9").unwrap();
        limits.apply("image-bytes=512M").unwrap();
        limits.apply(" node-depth = 20 ").unwrap();
        assert_eq!((limits.vertices, limits.image_bytes, limits.node_depth), (1_000_000_000, 512 << 20, 20));
        for bad in
            ["vertices", "vertex=3", "vertices=-1", "vertices=1.5", "vertices=lots", "nodes=99999999999999999999G"]
        {
            let err = limits.apply(bad).unwrap_err();
            assert!(!err.is_empty(), "{bad}");
        }
        assert!(limits.apply("vertex=3").unwrap_err().contains("animation-keys"), "the error lists the names");
    }
}
