//! `CompressedImage`: a texture kept in a GPU-transcodable form until the renderer uploads it.
//!
//! A KTX2 file with a Basis Universal payload (`KHR_texture_basisu`: ETC1S with BasisLZ, or
//! UASTC, optionally zstd-supercompressed) is checked at import ([`CompressedImage::parse`]:
//! header, codec, levels, sizes against the import limits) and held as its file bytes. The
//! renderer's texture cache asks for each mip level in the best format the adapter samples
//! ([`CompressedImage::transcode`] to BC7, ASTC 4×4, ETC2 or RGBA8), so a texture costs its
//! block size in GPU memory (1 byte per texel for BC7, ASTC 4×4 and ETC2 RGBA, against 4 for
//! RGBA8) and the host never holds its RGBA8 texels. Import-time code that must read texels
//! (specular-glossiness conversion) gets them from [`CompressedImage::decode_rgba8`]; occlusion
//! packing leaves compressed images apart. Transcoding is basisu's, a pure-Rust port of the reference
//! Basis Universal transcoder (bit-exact to it).

use basisu::{DecodeFlags, SourceFormat, TargetFormat, Transcoder};

/// The 12 bytes every KTX2 file starts with.
pub const KTX2_MAGIC: [u8; 12] = [0xab, 0x4b, 0x54, 0x58, 0x20, 0x32, 0x30, 0xbb, 0x0d, 0x0a, 0x1a, 0x0a];

/// Whether `bytes` are a KTX2 file (by its magic).
pub fn is_ktx2(bytes: &[u8]) -> bool {
    bytes.starts_with(&KTX2_MAGIC)
}

/// The Basis Universal codec a file was encoded with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Codec {
    /// Small, lower quality: an ETC1 subset with BasisLZ supercompression.
    Etc1s,
    /// High quality: ASTC-like 4×4 blocks (optionally zstd-supercompressed).
    Uastc,
}

/// What a mip level can be transcoded to: the block formats GPUs sample directly, and RGBA8 for
/// adapters with none of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Target {
    /// BC7 (desktop GPUs): 16 bytes per 4×4 block.
    Bc7,
    /// ASTC 4×4 LDR (mobile and some desktop GPUs): 16 bytes per 4×4 block.
    Astc4x4,
    /// ETC2 RGBA8 (EAC alpha; mobile GPUs): 16 bytes per 4×4 block.
    Etc2Rgba,
    /// Uncompressed RGBA8: 4 bytes per texel.
    Rgba8,
}

impl Target {
    /// Bytes of one mip level of `width` × `height` in this format.
    pub fn level_bytes(self, width: u32, height: u32) -> u64 {
        match self {
            Target::Rgba8 => width as u64 * height as u64 * 4,
            _ => width.div_ceil(4) as u64 * height.div_ceil(4) as u64 * 16,
        }
    }

    fn basis(self) -> TargetFormat {
        match self {
            Target::Bc7 => TargetFormat::Bc7Rgba,
            Target::Astc4x4 => TargetFormat::Astc4x4Rgba,
            Target::Etc2Rgba => TargetFormat::Etc2Rgba,
            Target::Rgba8 => TargetFormat::Rgba32,
        }
    }
}

/// A KTX2 + Basis Universal texture, checked, as its file bytes.
#[derive(Clone, PartialEq, Eq)]
pub struct CompressedImage {
    bytes: Vec<u8>,
    pub width: u32,
    pub height: u32,
    /// Mip levels in the file (1 when it has no chain).
    pub levels: u32,
    pub codec: Codec,
}

impl std::fmt::Debug for CompressedImage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CompressedImage")
            .field("file_bytes", &self.bytes.len())
            .field("width", &self.width)
            .field("height", &self.height)
            .field("levels", &self.levels)
            .field("codec", &self.codec)
            .finish()
    }
}

/// Checks that every range the KTX2 header's index names (data format descriptor, key/value
/// data, supercompression global data, each mip level) lies inside the file, and that no level
/// declares more uncompressed bytes than its size holds in 16-byte blocks: a truncated file is
/// refused here rather than found at upload, and a zstd level cannot make the transcoder allocate
/// what its header claims (the fuzzer found a 58 PB claim that aborted the process).
fn check_ranges(bytes: &[u8]) -> Result<(), String> {
    let u32_at = |at: usize| bytes.get(at..at + 4).map(|b| u32::from_le_bytes(b.try_into().unwrap()) as u64);
    let u64_at = |at: usize| bytes.get(at..at + 8).map(|b| u64::from_le_bytes(b.try_into().unwrap()));
    let truncated = || String::from("is truncated (its header is incomplete)");
    let levels = u32_at(40).ok_or_else(truncated)?.max(1);
    let len = bytes.len() as u64;
    let inside = |what: String, offset: u64, length: u64| {
        if offset.checked_add(length).is_none_or(|end| end > len) {
            Err(format!(
                "is truncated or corrupt: its {what} (bytes {offset}..+{length}) runs past the end of the file ({len} bytes)"
            ))
        } else {
            Ok(())
        }
    };
    inside("data format descriptor".into(), u32_at(48).ok_or_else(truncated)?, u32_at(52).ok_or_else(truncated)?)?;
    inside("key/value data".into(), u32_at(56).ok_or_else(truncated)?, u32_at(60).ok_or_else(truncated)?)?;
    inside("supercompression data".into(), u64_at(64).ok_or_else(truncated)?, u64_at(72).ok_or_else(truncated)?)?;
    let (width, height) = (u32_at(20).ok_or_else(truncated)?, u32_at(24).ok_or_else(truncated)?);
    for level in 0..levels.min(32) as usize {
        let at = 80 + level * 24;
        inside(format!("mip level {level}"), u64_at(at).ok_or_else(truncated)?, u64_at(at + 8).ok_or_else(truncated)?)?;
        let (w, h) = ((width >> level).max(1), (height >> level).max(1));
        let most = w.div_ceil(4).saturating_mul(h.div_ceil(4)).saturating_mul(16);
        let uncompressed = u64_at(at + 16).ok_or_else(truncated)?;
        if uncompressed > most {
            return Err(format!(
                "is corrupt: mip level {level} ({w}×{h}) declares {uncompressed} uncompressed bytes, more than its {most}"
            ));
        }
    }
    Ok(())
}

impl CompressedImage {
    /// Checks a KTX2 file and keeps it. Errors say what is wrong in words for
    /// `image N (uri): ...`. `max_side` bounds the base level's width and height.
    pub fn parse(bytes: Vec<u8>, max_side: u64) -> Result<Self, String> {
        // A KTX2 file's vkFormat is 0 exactly when its data is Basis Universal.
        let vk_format = bytes.get(12..16).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        if let Some(vk) = vk_format.filter(|&vk| vk != 0) {
            return Err(format!(
                "is a KTX2 file of vkFormat {vk}, not Basis Universal (KHR_texture_basisu textures are ETC1S or UASTC)"
            ));
        }
        // More levels than the size has (a chain past 1×1) would be an invalid GPU texture.
        let header = |at: usize| bytes.get(at..at + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        if let (Some(w), Some(h), Some(levels)) = (header(20), header(24), header(40)) {
            let most = crate::mip_chain::mip_level_count(w.max(1), h.max(1));
            if levels > most {
                return Err(format!("has {levels} mip levels, more than the {most} a {w}×{h} image has"));
            }
        }
        check_ranges(&bytes)?;
        let t = Transcoder::new(&bytes).map_err(|e| describe("is not a readable KTX2 / Basis Universal file", &e))?;
        let codec = match t.source_format() {
            SourceFormat::Etc1s => Codec::Etc1s,
            SourceFormat::UastcLdr => Codec::Uastc,
            other => return Err(format!("KTX2 with {other:?} data is not supported (only ETC1S and UASTC LDR 4x4)")),
        };
        if t.is_video() || t.layer_count() > 1 || t.face_count() != 1 {
            return Err(format!(
                "KTX2 textures must be one 2D image for glTF (this one has {} layers, {} faces{})",
                t.layer_count().max(1),
                t.face_count(),
                if t.is_video() { ", video frames" } else { "" }
            ));
        }
        let (width, height) = t.base_dimensions();
        if width == 0 || height == 0 {
            return Err(format!("has an empty base level ({width}×{height})"));
        }
        if width as u64 > max_side || height as u64 > max_side {
            return Err(format!(
                "is {width}×{height}, over the limit of {max_side} pixels a side (raise it with `--limit image-dimension=N`)"
            ));
        }
        // A chain may stop early (KTX2 allows it); past 1×1 was refused above.
        let levels = t.level_count().max(1);
        drop(t);
        Ok(Self { bytes, width, height, levels, codec })
    }

    /// Size of mip level `level` in texels.
    pub fn level_size(&self, level: u32) -> (u32, u32) {
        ((self.width >> level).max(1), (self.height >> level).max(1))
    }

    /// Mip level `level` in `target`'s layout: blocks row by row (block formats), or texels row
    /// by row (RGBA8).
    pub fn transcode(&self, level: u32, target: Target) -> Result<Vec<u8>, String> {
        let t = Transcoder::new(&self.bytes).map_err(|e| describe("does not read", &e))?;
        t.transcode(level, target.basis(), DecodeFlags::NONE)
            .map_err(|e| describe(&format!("mip level {level} does not transcode to {target:?}"), &e))
    }

    /// The base level as RGBA8 texels, for import-time code that reads texels.
    pub fn decode_rgba8(&self) -> Result<Vec<u8>, String> {
        self.transcode(0, Target::Rgba8)
    }
}

fn describe(what: &str, e: &basisu::Error) -> String {
    let why = match e {
        basisu::Error::Truncated => "truncated".to_owned(),
        basisu::Error::InvalidData => "corrupt".to_owned(),
        other => format!("{other:?}"),
    };
    format!("{what} ({why})")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_formats_cost_a_quarter_of_rgba8() {
        assert_eq!(Target::Bc7.level_bytes(1024, 512), 1024 * 512);
        assert_eq!(Target::Rgba8.level_bytes(1024, 512), 1024 * 512 * 4);
        // Partial blocks at the small end of a chain are whole blocks.
        assert_eq!(Target::Astc4x4.level_bytes(2, 1), 16);
    }

    #[test]
    fn non_ktx2_bytes_are_refused() {
        assert!(!is_ktx2(b"\x89PNG\r\n\x1a\n"));
        let header = |zeros: usize| [KTX2_MAGIC.as_slice(), &vec![0; zeros]].concat();
        let e = CompressedImage::parse(header(64), 16384).unwrap_err();
        assert!(e.contains("is truncated (its header is incomplete)"), "{e}");
        let e = CompressedImage::parse(header(200), 16384).unwrap_err();
        assert!(e.contains("is not a readable KTX2"), "{e}");
    }
}
