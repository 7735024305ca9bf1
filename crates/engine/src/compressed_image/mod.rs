//! `CompressedImage`: a KTX2 texture kept in a GPU-ready form until the renderer uploads it.
//!
//! A KTX2 file is read at import ([`CompressedImage::parse`]: the container in `header`, then
//! its payload): Basis Universal (`KHR_texture_basisu`: ETC1S or UASTC; `basis`, held as the
//! file and transcoded on request) or an ordinary Vulkan format (`plain`: 8-bit texels, BC, ETC2,
//! EAC or ASTC blocks; held as its inflated levels). The renderer's texture cache picks the first
//! of [`CompressedImage::block_formats`] the device samples and asks for the levels in it
//! ([`CompressedImage::levels_as`]), so a texture costs its block size in GPU memory (1 byte per
//! texel for BC7, ASTC 4×4 and ETC2 RGBA, against 4 for RGBA8) and the host never holds RGBA8
//! texels; RGBA8 serves devices with none of them. Import-time code that must read texels
//! (specular-glossiness conversion) gets them from [`CompressedImage::decode_rgba8`]; occlusion
//! packing leaves compressed images apart.

mod basis;
mod header;
mod plain;

use std::ops::Range;

pub use header::KTX2_MAGIC;

/// Whether `bytes` are a KTX2 file (by its magic).
pub fn is_ktx2(bytes: &[u8]) -> bool {
    bytes.starts_with(&KTX2_MAGIC)
}

/// What importing a KTX2 file will hold on the host, from its header alone (`None` when the
/// header does not read; parsing then says why): the file for Basis Universal, the levels'
/// inflated sizes for an ordinary format.
pub fn held_size(bytes: &[u8]) -> Option<u64> {
    let header = header::read(bytes).ok()?;
    match plain::layout(header.vk_format) {
        Ok((layout, _)) => Some(
            (0..header.levels.len()).fold(0u64, |sum, l| sum.saturating_add(layout.level_bytes(header.level_size(l)))),
        ),
        _ => Some(bytes.len() as u64),
    }
}

/// The base level's size a KTX2 file's header declares (`None` when the header does not read),
/// for checking it against the import limits before anything is inflated or decoded.
pub fn dimensions(bytes: &[u8]) -> Option<(u32, u32)> {
    header::read(bytes).ok().map(|h| (h.width, h.height))
}

/// The Basis Universal codec a file was encoded with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Codec {
    /// Small, lower quality: an ETC1 subset with BasisLZ supercompression.
    Etc1s,
    /// High quality: ASTC-like 4×4 blocks (optionally zstd-supercompressed).
    Uastc,
}

/// A layout a mip level can be delivered in: the block formats GPUs sample directly, and RGBA8
/// for the rest.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// Uncompressed RGBA8: 4 bytes per texel.
    Rgba8,
    /// BC1 (DXT1) RGB with 1-bit alpha: 8 bytes per 4×4 block.
    Bc1,
    /// BC2 (DXT3): explicit 4-bit alpha, 16 bytes per block.
    Bc2,
    /// BC3 (DXT5): interpolated alpha, 16 bytes per block.
    Bc3,
    /// BC4: one channel, 8 bytes per block.
    Bc4,
    /// BC5: two channels, 16 bytes per block.
    Bc5,
    /// BC7 (desktop GPUs): 16 bytes per 4×4 block.
    Bc7,
    /// ETC2 RGB: 8 bytes per block.
    Etc2Rgb,
    /// ETC2 RGB with punch-through alpha: 8 bytes per block.
    Etc2RgbA1,
    /// ETC2 RGBA8 (EAC alpha; mobile GPUs): 16 bytes per 4×4 block.
    Etc2Rgba,
    /// EAC R11: one channel, 8 bytes per block.
    EacR11,
    /// EAC RG11: two channels, 16 bytes per block.
    EacRg11,
    /// ASTC LDR of a `w`×`h` block (4×4 to 12×12): 16 bytes per block.
    Astc { w: u8, h: u8 },
}

/// The families of block formats a device samples or not as a whole (wgpu's
/// `TEXTURE_COMPRESSION_BC`, `_ETC2`, `_ASTC` features).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    Bc,
    Etc2,
    Astc,
}

impl Format {
    /// Texels of one block, across and down (1×1 for RGBA8).
    pub fn block(self) -> (u32, u32) {
        match self {
            Format::Rgba8 => (1, 1),
            Format::Astc { w, h } => (w as u32, h as u32),
            _ => (4, 4),
        }
    }

    /// Bytes of one block (of one texel for RGBA8).
    pub fn block_bytes(self) -> u32 {
        match self {
            Format::Rgba8 => 4,
            Format::Bc1 | Format::Bc4 | Format::Etc2Rgb | Format::Etc2RgbA1 | Format::EacR11 => 8,
            _ => 16,
        }
    }

    /// Bytes of one mip level of `width` × `height` in this format (partial blocks whole).
    pub fn level_bytes(self, width: u32, height: u32) -> u64 {
        let (bw, bh) = self.block();
        (width.div_ceil(bw) as u64).saturating_mul(height.div_ceil(bh) as u64).saturating_mul(self.block_bytes() as u64)
    }

    /// The device feature it needs; none for RGBA8.
    pub fn family(self) -> Option<Family> {
        match self {
            Format::Rgba8 => None,
            Format::Bc1 | Format::Bc2 | Format::Bc3 | Format::Bc4 | Format::Bc5 | Format::Bc7 => Some(Family::Bc),
            Format::Etc2Rgb | Format::Etc2RgbA1 | Format::Etc2Rgba | Format::EacR11 | Format::EacRg11 => {
                Some(Family::Etc2)
            }
            Format::Astc { .. } => Some(Family::Astc),
        }
    }
}

/// What a KTX2 file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// Basis Universal, transcoded to the device's block format.
    Basis(Codec),
    /// An ordinary Vulkan format (`vk_format`), named as the KTX specification does without its
    /// UNORM / SRGB suffix where the two share a layout.
    Plain { vk_format: u32, name: &'static str },
}

/// A KTX2 texture, checked.
#[derive(PartialEq, Eq)]
pub struct CompressedImage {
    pub width: u32,
    pub height: u32,
    /// Mip levels in the file (1 when it has no chain).
    pub levels: u32,
    payload: Payload,
}

#[derive(PartialEq, Eq)]
enum Payload {
    Basis(basis::Basis),
    Plain(plain::Plain),
}

impl std::fmt::Debug for CompressedImage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CompressedImage")
            .field("source", &self.source())
            .field("held_bytes", &self.held_bytes())
            .field("width", &self.width)
            .field("height", &self.height)
            .field("levels", &self.levels)
            .finish()
    }
}

impl CompressedImage {
    /// Checks a KTX2 file and keeps it. Errors say what is wrong in words for
    /// `image N (uri): ...`. `max_side` bounds the base level's width and height.
    pub fn parse(bytes: Vec<u8>, max_side: u64) -> Result<Self, String> {
        let header = header::read(&bytes)?;
        header.check_2d()?;
        header.check_side(max_side)?;
        let (width, height, levels) = (header.width, header.height, header.levels.len() as u32);
        // A KTX2 file's vkFormat is 0 exactly when its data is Basis Universal.
        let payload = if header.vk_format == 0 {
            Payload::Basis(basis::Basis::parse(bytes, &header)?)
        } else {
            Payload::Plain(plain::Plain::parse(&bytes, &header)?)
        };
        Ok(Self { width, height, levels, payload })
    }

    /// What the file holds.
    pub fn source(&self) -> Source {
        match &self.payload {
            Payload::Basis(b) => Source::Basis(b.codec),
            Payload::Plain(p) => Source::Plain { vk_format: p.vk_format, name: p.name },
        }
    }

    /// Bytes the host holds for it: the file (Basis Universal) or its inflated levels.
    pub fn held_bytes(&self) -> usize {
        match &self.payload {
            Payload::Basis(b) => b.file_bytes(),
            Payload::Plain(p) => p.held_bytes(),
        }
    }

    /// Size of mip level `level` in texels.
    pub fn level_size(&self, level: u32) -> (u32, u32) {
        ((self.width >> level).max(1), (self.height >> level).max(1))
    }

    /// The block formats its levels can be delivered in, best first (RGBA8, always possible, is
    /// not listed): BC7, ASTC 4×4, ETC2 RGBA for Basis Universal; a plain file's own format.
    pub fn block_formats(&self) -> Vec<Format> {
        match &self.payload {
            Payload::Basis(_) => basis::BLOCK_FORMATS.to_vec(),
            Payload::Plain(p) => p.native().into_iter().collect(),
        }
    }

    /// Mip levels `levels` in `format`'s layout: blocks row by row (block formats, one of
    /// [`Self::block_formats`]), or texels row by row (RGBA8).
    pub fn levels_as(&self, levels: Range<u32>, format: Format) -> Result<Vec<Vec<u8>>, String> {
        if levels.end > self.levels {
            return Err(format!("has {} mip levels, not {}", self.levels, levels.end));
        }
        match &self.payload {
            Payload::Basis(b) => b.levels(levels, format),
            Payload::Plain(p) => p.levels(levels, format, |l| self.level_size(l)),
        }
    }

    /// Mip level `level` in `format`'s layout (see [`Self::levels_as`]).
    pub fn transcode(&self, level: u32, format: Format) -> Result<Vec<u8>, String> {
        self.levels_as(level..level + 1, format).map(|mut l| l.remove(0))
    }

    /// The base level as RGBA8 texels, for import-time code that reads texels.
    pub fn decode_rgba8(&self) -> Result<Vec<u8>, String> {
        self.transcode(0, Format::Rgba8)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_formats_cost_a_quarter_of_rgba8() {
        assert_eq!(Format::Bc7.level_bytes(1024, 512), 1024 * 512);
        assert_eq!(Format::Rgba8.level_bytes(1024, 512), 1024 * 512 * 4);
        // Partial blocks at the small end of a chain are whole blocks.
        assert_eq!(Format::Astc { w: 4, h: 4 }.level_bytes(2, 1), 16);
        assert_eq!(Format::Bc1.level_bytes(8, 8), 32);
        assert_eq!(Format::Astc { w: 12, h: 10 }.level_bytes(25, 21), 3 * 3 * 16);
    }

    #[test]
    fn sizes_from_hostile_headers_saturate() {
        // An RGBA8 file claiming 2³²−1 texels a side, one empty level inside the file.
        let mut bytes = KTX2_MAGIC.to_vec();
        for field in [37u32, 1, u32::MAX, u32::MAX, 0, 0, 1, 1, 0, 0, 0, 0, 0] {
            bytes.extend_from_slice(&field.to_le_bytes());
        }
        bytes.extend_from_slice(&[0; 16]);
        bytes.extend_from_slice(&[104, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(bytes.len(), 104);
        assert_eq!(dimensions(&bytes), Some((u32::MAX, u32::MAX)));
        assert_eq!(held_size(&bytes), Some(u64::MAX));
        assert!(CompressedImage::parse(bytes, 16384).unwrap_err().contains("over the limit"));
    }

    #[test]
    fn non_ktx2_bytes_are_refused() {
        assert!(!is_ktx2(b"\x89PNG\r\n\x1a\n"));
        let header = |zeros: usize| [KTX2_MAGIC.as_slice(), &vec![0; zeros]].concat();
        let e = CompressedImage::parse(header(64), 16384).unwrap_err();
        assert!(e.contains("is truncated (its header is incomplete)"), "{e}");
        let e = CompressedImage::parse(header(200), 16384).unwrap_err();
        assert!(e.contains("has an empty base level (0×0)"), "{e}");
    }
}
