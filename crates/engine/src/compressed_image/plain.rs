//! KTX2 files of ordinary Vulkan formats ("plain" KTX2, what `ktx create` and asset pipelines
//! write besides Basis Universal): 8-bit texels (R, RG, RGB, RGBA, BGR, BGRA) and the block
//! formats GPUs sample (BC1-5 and BC7, ETC2 and EAC, ASTC LDR of every block size), each level
//! stored as it is or supercompressed with zstd (ruzstd) or zlib (miniz_oxide).
//!
//! Levels are inflated and checked at import (each must hold exactly its size in the format), so
//! a corrupt file is an import error naming the image, and held inflated: what the GPU gets
//! where it samples the format. Where it does not (ASTC and ETC2 on desktop GPUs, BC on mobile
//! ones, any block format on a size that is not whole blocks), or for 8-bit texels, a level is
//! expanded to RGBA8 on request (block decoding by texture2ddecoder, pure Rust).
//!
//! Whether a file says sRGB or UNORM does not matter here: as for every image, the material slot
//! that samples it decides the colour space.

use std::io::Read;
use std::ops::Range;

use super::Format;
use super::header::{Header, SCHEME_BASIS_LZ, SCHEME_NONE, SCHEME_ZLIB, SCHEME_ZSTD};

/// How a level's bytes are laid out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Layout {
    /// `channels` bytes per texel, in R, G, B, A order, or B, G, R(, A) when `bgr`.
    Texels { channels: u8, bgr: bool },
    /// Blocks of a GPU format. `opaque`: BC1 read as RGB (its one transparent index is black
    /// with alpha 1).
    Blocks { format: Format, opaque: bool },
}

impl Layout {
    pub fn level_bytes(self, (width, height): (u32, u32)) -> u64 {
        match self {
            Layout::Texels { channels, .. } => {
                (width as u64).saturating_mul(height as u64).saturating_mul(channels as u64)
            }
            Layout::Blocks { format, .. } => format.level_bytes(width, height),
        }
    }
}

/// The layout of a `VkFormat` (its name for messages), or why it is refused.
pub(super) fn layout(vk_format: u32) -> Result<(Layout, &'static str), String> {
    use Format as F;
    let texels = |channels, bgr| Layout::Texels { channels, bgr };
    let blocks = |format| Layout::Blocks { format, opaque: false };
    let astc = |w, h| blocks(F::Astc { w, h });
    Ok(match vk_format {
        9 | 15 => (texels(1, false), "R8"),
        16 | 22 => (texels(2, false), "R8G8"),
        23 | 29 => (texels(3, false), "R8G8B8"),
        30 | 36 => (texels(3, true), "B8G8R8"),
        37 | 43 => (texels(4, false), "R8G8B8A8"),
        44 | 50 => (texels(4, true), "B8G8R8A8"),
        131 | 132 => (Layout::Blocks { format: F::Bc1, opaque: true }, "BC1_RGB"),
        133 | 134 => (blocks(F::Bc1), "BC1_RGBA"),
        135 | 136 => (blocks(F::Bc2), "BC2"),
        137 | 138 => (blocks(F::Bc3), "BC3"),
        139 => (blocks(F::Bc4), "BC4_UNORM"),
        141 => (blocks(F::Bc5), "BC5_UNORM"),
        145 | 146 => (blocks(F::Bc7), "BC7"),
        147 | 148 => (blocks(F::Etc2Rgb), "ETC2_R8G8B8"),
        149 | 150 => (blocks(F::Etc2RgbA1), "ETC2_R8G8B8A1"),
        151 | 152 => (blocks(F::Etc2Rgba), "ETC2_R8G8B8A8"),
        153 => (blocks(F::EacR11), "EAC_R11_UNORM"),
        155 => (blocks(F::EacRg11), "EAC_R11G11_UNORM"),
        157 | 158 => (astc(4, 4), "ASTC_4x4"),
        159 | 160 => (astc(5, 4), "ASTC_5x4"),
        161 | 162 => (astc(5, 5), "ASTC_5x5"),
        163 | 164 => (astc(6, 5), "ASTC_6x5"),
        165 | 166 => (astc(6, 6), "ASTC_6x6"),
        167 | 168 => (astc(8, 5), "ASTC_8x5"),
        169 | 170 => (astc(8, 6), "ASTC_8x6"),
        171 | 172 => (astc(8, 8), "ASTC_8x8"),
        173 | 174 => (astc(10, 5), "ASTC_10x5"),
        175 | 176 => (astc(10, 6), "ASTC_10x6"),
        177 | 178 => (astc(10, 8), "ASTC_10x8"),
        179 | 180 => (astc(10, 10), "ASTC_10x10"),
        181 | 182 => (astc(12, 10), "ASTC_12x10"),
        183 | 184 => (astc(12, 12), "ASTC_12x12"),
        140 | 142 | 154 | 156 => {
            return Err(format!(
                "is a KTX2 file of vkFormat {vk_format}, a signed format (glTF textures are unsigned)"
            ));
        }
        143 | 144 => {
            return Err(format!(
                "is a KTX2 file of vkFormat {vk_format} (BC6H, high dynamic range: glTF textures are 8-bit)"
            ));
        }
        _ => {
            return Err(format!(
                "is a KTX2 file of vkFormat {vk_format}, which Penumbra does not read (it reads Basis Universal, 8-bit \
                 UNORM/sRGB texels, BC1-5, BC7, ETC2, EAC and ASTC LDR)"
            ));
        }
    })
}

/// A plain KTX2 texture: its layout and its levels, inflated.
#[derive(PartialEq, Eq)]
pub(super) struct Plain {
    pub layout: Layout,
    pub vk_format: u32,
    pub name: &'static str,
    levels: Vec<Vec<u8>>,
}

impl Plain {
    /// Reads the levels of `file` (its header `header`, vkFormat not 0).
    pub fn parse(file: &[u8], header: &Header) -> Result<Self, String> {
        let (layout, name) = layout(header.vk_format)?;
        let levels = header
            .levels
            .iter()
            .enumerate()
            .map(|(level, l)| {
                let (w, h) = header.level_size(level);
                let size = layout.level_bytes((w, h));
                let data = l.bytes(file);
                let wrong = |held: u64| {
                    format!("is corrupt: its mip level {level} holds {held} bytes, a {w}×{h} {name} level {size}")
                };
                match header.scheme {
                    SCHEME_NONE if data.len() as u64 == size => Ok(data.to_vec()),
                    SCHEME_NONE => Err(wrong(data.len() as u64)),
                    SCHEME_ZSTD | SCHEME_ZLIB if l.uncompressed != size => Err(wrong(l.uncompressed)),
                    SCHEME_ZSTD => inflate_zstd(data, size as usize).map_err(|e| level_error(level, "zstd", &e)),
                    SCHEME_ZLIB => inflate_zlib(data, size as usize).map_err(|e| level_error(level, "zlib", &e)),
                    SCHEME_BASIS_LZ => Err(format!(
                        "is a KTX2 file of vkFormat {} with BasisLZ, which only \
                         Basis Universal (vkFormat 0) uses",
                        header.vk_format
                    )),
                    other => Err(format!("has supercompression scheme {other}, which KTX2 does not define")),
                }
            })
            .collect::<Result<_, _>>()?;
        Ok(Self { layout, vk_format: header.vk_format, name, levels })
    }

    /// The block format this file can go to the GPU in as it is (none for texels, or for BC1
    /// read as RGB whose blocks use their transparent index: sampled as BC1 RGBA those texels
    /// would turn transparent).
    pub fn native(&self) -> Option<Format> {
        match self.layout {
            Layout::Blocks { format, opaque: false } => Some(format),
            Layout::Blocks { format, opaque: true } => {
                (!self.levels.iter().any(|l| uses_bc1_transparency(l))).then_some(format)
            }
            Layout::Texels { .. } => None,
        }
    }

    /// Levels `levels` (of sizes `size(level)`) in `format`: the stored blocks when `format` is
    /// the file's own, else RGBA8.
    pub fn levels(
        &self,
        levels: Range<u32>,
        format: Format,
        size: impl Fn(u32) -> (u32, u32),
    ) -> Result<Vec<Vec<u8>>, String> {
        levels
            .map(|level| {
                let data = &self.levels[level as usize];
                let (w, h) = size(level);
                match (self.layout, format) {
                    (Layout::Blocks { format: own, .. }, f) if f == own => Ok(data.clone()),
                    (Layout::Texels { channels, bgr }, Format::Rgba8) => Ok(expand(data, channels, bgr)),
                    (Layout::Blocks { format: own, opaque }, Format::Rgba8) => decode_blocks(own, opaque, data, w, h)
                        .map_err(|e| format!("mip level {level} does not decode from {}: {e}", self.name)),
                    (_, f) => Err(format!("a {} KTX2 file does not go to the GPU as {f:?}", self.name)),
                }
            })
            .collect()
    }

    /// Bytes held (the inflated levels).
    pub fn held_bytes(&self) -> usize {
        self.levels.iter().map(Vec::len).sum()
    }
}

fn level_error(level: usize, scheme: &str, e: &str) -> String {
    format!("is corrupt: its mip level {level} does not inflate ({scheme}: {e})")
}

/// Inflates a zstd stream to exactly `size` bytes.
fn inflate_zstd(data: &[u8], size: usize) -> Result<Vec<u8>, String> {
    let mut decoder = ruzstd::StreamingDecoder::new(data).map_err(|e| e.to_string())?;
    let mut out = Vec::with_capacity(size);
    // One byte past the size tells a stream that holds more than the level from one that fits.
    (&mut decoder).take(size as u64 + 1).read_to_end(&mut out).map_err(|e| e.to_string())?;
    if out.len() != size {
        return Err(format!("it holds {}{} bytes, not {size}", out.len(), if out.len() > size { "+" } else { "" }));
    }
    Ok(out)
}

/// Inflates a zlib stream to exactly `size` bytes.
fn inflate_zlib(data: &[u8], size: usize) -> Result<Vec<u8>, String> {
    let out = miniz_oxide::inflate::decompress_to_vec_zlib_with_limit(data, size + 1).map_err(|e| match e.status {
        miniz_oxide::inflate::TINFLStatus::HasMoreOutput => format!("it holds more than {size} bytes"),
        status => format!("{status:?}"),
    })?;
    if out.len() != size {
        return Err(format!("it holds {} bytes, not {size}", out.len()));
    }
    Ok(out)
}

/// 8-bit texels of `channels` channels as RGBA8: missing colour channels 0 and alpha 1, as a GPU
/// samples R8 or RG8 textures.
fn expand(data: &[u8], channels: u8, bgr: bool) -> Vec<u8> {
    let mut out = Vec::with_capacity(data.len() / channels as usize * 4);
    for t in data.chunks_exact(channels as usize) {
        let mut rgba = [0, 0, 0, 255];
        rgba[..t.len()].copy_from_slice(t);
        if bgr {
            rgba.swap(0, 2);
        }
        out.extend_from_slice(&rgba);
    }
    out
}

/// Whether any BC1 block is in its three-colour mode (colour 0 ≤ colour 1) and uses index 3,
/// which BC1 RGBA decodes as transparent black and BC1 RGB as opaque black.
fn uses_bc1_transparency(blocks: &[u8]) -> bool {
    blocks.chunks_exact(8).any(|b| {
        let (c0, c1) = (u16::from_le_bytes([b[0], b[1]]), u16::from_le_bytes([b[2], b[3]]));
        let indices = u32::from_le_bytes([b[4], b[5], b[6], b[7]]);
        c0 <= c1 && (0..16).any(|i| (indices >> (2 * i)) & 3 == 3)
    })
}

/// A level of `format` blocks decoded to RGBA8 texels.
fn decode_blocks(format: Format, opaque: bool, data: &[u8], w: u32, h: u32) -> Result<Vec<u8>, String> {
    use texture2ddecoder as t;
    let (wu, hu) = (w as usize, h as usize);
    let mut out = vec![0u32; wu * hu];
    match format {
        Format::Bc1 if opaque => t::decode_bc1(data, wu, hu, &mut out),
        Format::Bc1 => t::decode_bc1a(data, wu, hu, &mut out),
        Format::Bc2 => t::decode_bc2(data, wu, hu, &mut out),
        Format::Bc3 => t::decode_bc3(data, wu, hu, &mut out),
        Format::Bc4 => t::decode_bc4(data, wu, hu, &mut out),
        Format::Bc5 => t::decode_bc5(data, wu, hu, &mut out),
        Format::Bc7 => t::decode_bc7(data, wu, hu, &mut out),
        Format::Etc2Rgb => t::decode_etc2_rgb(data, wu, hu, &mut out),
        Format::Etc2RgbA1 => t::decode_etc2_rgba1(data, wu, hu, &mut out),
        Format::Etc2Rgba => t::decode_etc2_rgba8(data, wu, hu, &mut out),
        Format::EacR11 => t::decode_eacr(data, wu, hu, &mut out),
        Format::EacRg11 => t::decode_eacrg(data, wu, hu, &mut out),
        Format::Astc { w: bw, h: bh } => t::decode_astc(data, wu, hu, bw as usize, bh as usize, &mut out),
        Format::Rgba8 => return Err("RGBA8 is not a block format".into()),
    }
    .map_err(str::to_owned)?;
    // texture2ddecoder writes each texel as a little-endian BGRA word.
    Ok(out
        .iter()
        .flat_map(|&p| {
            let [b, g, r, a] = p.to_le_bytes();
            [r, g, b, a]
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texels_expand_as_a_gpu_samples_them() {
        assert_eq!(expand(&[7, 8], 1, false), [7, 0, 0, 255, 8, 0, 0, 255]);
        assert_eq!(expand(&[1, 2, 3], 3, true), [3, 2, 1, 255]);
        assert_eq!(expand(&[1, 2, 3, 4], 4, true), [3, 2, 1, 4]);
    }

    #[test]
    fn bc1_transparency_is_found_only_in_three_colour_blocks_using_index_3() {
        // Four-colour mode (colour 0 > colour 1): index 3 is a colour.
        assert!(!uses_bc1_transparency(&[2, 0, 1, 0, 0xff, 0xff, 0xff, 0xff]));
        // Three-colour mode with indices 0..2 only.
        assert!(!uses_bc1_transparency(&[1, 0, 2, 0, 0x66, 0x66, 0x66, 0x66]));
        assert!(uses_bc1_transparency(&[1, 0, 2, 0, 0x00, 0x00, 0x00, 0xc0]));
    }

    #[test]
    fn decoded_blocks_are_rgba() {
        // A BC1 block of colour 0 = pure red (0xf800) in four-colour mode, every index 0.
        let block = [0x00, 0xf8, 0x00, 0x00, 0, 0, 0, 0];
        let rgba = decode_blocks(Format::Bc1, false, &block, 4, 4).unwrap();
        assert_eq!(&rgba[..4], &[255, 0, 0, 255]);
        // A level smaller than its block is cut from it.
        assert_eq!(decode_blocks(Format::Bc1, false, &block, 2, 1).unwrap().len(), 2 * 4);
        assert!(decode_blocks(Format::Bc7, false, &block, 4, 4).is_err(), "too short for BC7");
    }

    #[test]
    fn inflating_wants_the_exact_size() {
        let packed = miniz_oxide::deflate::compress_to_vec_zlib(&[5; 100], 6);
        assert_eq!(inflate_zlib(&packed, 100).unwrap(), vec![5; 100]);
        assert!(inflate_zlib(&packed, 99).unwrap_err().contains("holds 100 bytes, not 99"));
        assert!(inflate_zlib(&packed, 10).unwrap_err().contains("more than 10"));
        assert!(inflate_zlib(&packed, 101).unwrap_err().contains("holds 100 bytes, not 101"));
        assert!(inflate_zstd(&packed, 100).is_err(), "not zstd");
    }
}
