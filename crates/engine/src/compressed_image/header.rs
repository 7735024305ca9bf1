//! The KTX2 container: the fixed header and the level index, read and checked against the file
//! before any payload is looked at. Every range the index names (data format descriptor,
//! key/value data, supercompression global data, each mip level) must lie inside the file, so a
//! truncated file is refused here rather than found at upload; the payload modules (`basis`,
//! `plain`) then check what each level holds against its size.

/// The 12 bytes every KTX2 file starts with.
pub const KTX2_MAGIC: [u8; 12] = [0xab, 0x4b, 0x54, 0x58, 0x20, 0x32, 0x30, 0xbb, 0x0d, 0x0a, 0x1a, 0x0a];

/// `supercompressionScheme` values KTX2 defines.
pub(super) const SCHEME_NONE: u32 = 0;
pub(super) const SCHEME_BASIS_LZ: u32 = 1;
pub(super) const SCHEME_ZSTD: u32 = 2;
pub(super) const SCHEME_ZLIB: u32 = 3;

/// The header fields Penumbra reads.
pub(super) struct Header {
    /// 0 for Basis Universal (its DFD says which codec); otherwise a `VkFormat`.
    pub vk_format: u32,
    pub width: u32,
    pub height: u32,
    /// 0 for a 2D texture.
    pub depth: u32,
    /// 0 when it is not an array.
    pub layers: u32,
    pub faces: u32,
    pub scheme: u32,
    /// Level 0 (the largest) first; one entry when the file has no chain (levelCount 0 or 1).
    pub levels: Vec<Level>,
}

/// One entry of the level index.
pub(super) struct Level {
    pub offset: u64,
    pub length: u64,
    /// The level's size before supercompression (0 for BasisLZ).
    pub uncompressed: u64,
}

impl Level {
    /// The level's bytes in `file` (inside it: [`read`] checked).
    pub fn bytes<'a>(&self, file: &'a [u8]) -> &'a [u8] {
        &file[self.offset as usize..(self.offset + self.length) as usize]
    }
}

/// Reads and checks the header of a KTX2 file (its magic already seen). Errors say what is wrong
/// in words for `image N (uri): ...`.
pub(super) fn read(bytes: &[u8]) -> Result<Header, String> {
    let u32_at = |at: usize| bytes.get(at..at + 4).map(|b| u32::from_le_bytes(b.try_into().unwrap()));
    let u64_at = |at: usize| bytes.get(at..at + 8).map(|b| u64::from_le_bytes(b.try_into().unwrap()));
    let truncated = || String::from("is truncated (its header is incomplete)");
    let field = |at: usize| u32_at(at).ok_or_else(truncated);
    let (width, height) = (field(20)?, field(24)?);
    let level_count = field(40)?;
    // More levels than the size has (a chain past 1×1) would be an invalid GPU texture.
    let most = crate::mip_chain::mip_level_count(width.max(1), height.max(1));
    if level_count > most {
        return Err(format!("has {level_count} mip levels, more than the {most} a {width}×{height} image has"));
    }
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
    inside("data format descriptor".into(), field(48)?.into(), field(52)?.into())?;
    inside("key/value data".into(), field(56)?.into(), field(60)?.into())?;
    let sgd = (u64_at(64).ok_or_else(truncated)?, u64_at(72).ok_or_else(truncated)?);
    inside("supercompression data".into(), sgd.0, sgd.1)?;
    let mut levels = Vec::new();
    for level in 0..level_count.max(1) as usize {
        let at = 80 + level * 24;
        let entry = |i: usize| u64_at(at + i * 8).ok_or_else(truncated);
        let l = Level { offset: entry(0)?, length: entry(1)?, uncompressed: entry(2)? };
        inside(format!("mip level {level}"), l.offset, l.length)?;
        levels.push(l);
    }
    if width == 0 || height == 0 {
        return Err(format!("has an empty base level ({width}×{height})"));
    }
    Ok(Header {
        vk_format: field(12)?,
        width,
        height,
        depth: field(28)?,
        layers: field(32)?,
        faces: field(36)?,
        scheme: field(44)?,
        levels,
    })
}

impl Header {
    /// Size of mip level `level` in texels.
    pub fn level_size(&self, level: usize) -> (u32, u32) {
        ((self.width >> level).max(1), (self.height >> level).max(1))
    }

    /// Refuses anything but one 2D image (what a glTF texture is).
    pub fn check_2d(&self) -> Result<(), String> {
        if self.depth > 1 || self.layers > 1 || self.faces != 1 {
            return Err(format!(
                "KTX2 textures must be one 2D image for glTF (this one has depth {}, {} layers, {} faces)",
                self.depth.max(1),
                self.layers.max(1),
                self.faces
            ));
        }
        Ok(())
    }

    /// Refuses a base level over `max_side` texels a side (the import limit).
    pub fn check_side(&self, max_side: u64) -> Result<(), String> {
        let (width, height) = (self.width, self.height);
        if width as u64 > max_side || height as u64 > max_side {
            return Err(format!(
                "is {width}×{height}, over the limit of {max_side} pixels a side (raise it with `--limit image-dimension=N`)"
            ));
        }
        Ok(())
    }
}
