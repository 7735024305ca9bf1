//! Basis Universal payloads (`KHR_texture_basisu`: ETC1S with BasisLZ, or UASTC, optionally
//! zstd-supercompressed), held as the file's bytes and transcoded on request by basisu, a
//! pure-Rust port of the reference Basis Universal transcoder (bit-exact to it).

use std::ops::Range;

use basisu::{DecodeFlags, SourceFormat, TargetFormat, Transcoder};

use super::header::Header;
use super::{Codec, Format};

/// The block formats a Basis Universal file transcodes to, best first: BC7 and ASTC 4×4 keep
/// UASTC's quality, ETC2 loses some.
pub(super) const BLOCK_FORMATS: [Format; 3] = [Format::Bc7, Format::Astc { w: 4, h: 4 }, Format::Etc2Rgba];

#[derive(PartialEq, Eq)]
pub(super) struct Basis {
    file: Vec<u8>,
    pub codec: Codec,
}

impl Basis {
    /// Checks the payload of a KTX2 file whose vkFormat is 0; `header` has been read from `file`.
    pub fn parse(file: Vec<u8>, header: &Header) -> Result<Self, String> {
        // No level may declare more uncompressed bytes than its size holds in 16-byte blocks: a
        // zstd level could otherwise make the transcoder allocate what its header claims (the
        // fuzzer found a 58 PB claim that aborted the process).
        for (level, l) in header.levels.iter().enumerate() {
            let (w, h) = header.level_size(level);
            let most = Format::Bc7.level_bytes(w, h);
            if l.uncompressed > most {
                return Err(format!(
                    "is corrupt: mip level {level} ({w}×{h}) declares {} uncompressed bytes, more than its {most}",
                    l.uncompressed
                ));
            }
        }
        let t = Transcoder::new(&file).map_err(|e| describe("is not a readable KTX2 / Basis Universal file", &e))?;
        let codec = match t.source_format() {
            SourceFormat::Etc1s => Codec::Etc1s,
            SourceFormat::UastcLdr => Codec::Uastc,
            other => return Err(format!("KTX2 with {other:?} data is not supported (only ETC1S and UASTC LDR 4x4)")),
        };
        if t.is_video() {
            return Err("KTX2 textures must be one 2D image for glTF (this one has video frames)".into());
        }
        drop(t);
        Ok(Self { file, codec })
    }

    /// Levels `levels` in `format`'s layout, through one transcoder (for ETC1S, opening one
    /// decodes the file's codebooks).
    pub fn levels(&self, levels: Range<u32>, format: Format) -> Result<Vec<Vec<u8>>, String> {
        let target = match format {
            Format::Bc7 => TargetFormat::Bc7Rgba,
            Format::Astc { w: 4, h: 4 } => TargetFormat::Astc4x4Rgba,
            Format::Etc2Rgba => TargetFormat::Etc2Rgba,
            Format::Rgba8 => TargetFormat::Rgba32,
            other => return Err(format!("Basis Universal does not transcode to {other:?}")),
        };
        let t = Transcoder::new(&self.file).map_err(|e| describe("does not read", &e))?;
        levels
            .map(|level| {
                t.transcode(level, target, DecodeFlags::NONE)
                    .map_err(|e| describe(&format!("mip level {level} does not transcode to {format:?}"), &e))
            })
            .collect()
    }

    pub fn file_bytes(&self) -> usize {
        self.file.len()
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
