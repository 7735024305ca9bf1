//! Mip chains made on the CPU, where images are decoded: each texel of level N+1 is the mean of
//! the 2×2 block of level N it covers (clamped at an odd edge, level sizes halving as the GPU's
//! do), in linear light for sRGB images, rounded to the nearest stored byte.
//!
//! Import builds the chain on the decoding thread for the colour space the image's material
//! slots read it in ([`StandardMaterial::SRGB_SLOTS`](crate::material::StandardMaterial)), and
//! the renderer uploads it with level 0. Only images without one (made at run time, or edited
//! since: `Assets::get_mut` drops it), and the texture of an image read in both colour spaces
//! whose chain was made for the other one, have their chain rendered on the GPU
//! (`shaders/mipmap.wgsl`, the same means). Why on the CPU: on a software rasteriser the GPU
//! *is* the CPU, and there the shader costs several times the plain loop below, after decoding
//! had already finished; on a GPU machine the chain adds a small share to the decoding threads'
//! work (docs/performance.md, "A headless screenshot").
//!
//! sRGB means are exact in integers: each stored byte's linear value is held as a 24-bit
//! fraction, four of them summed, and the sum compared with the sums at which the sRGB curve
//! crosses each half byte (a coarse table picks the byte, one comparison settles it).

use std::sync::OnceLock;

/// Levels 1.. of an image (level 0 is the image), for one colour space.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MipChain {
    /// Averaged in linear light (the image is read as sRGB) or as stored.
    pub srgb: bool,
    /// RGBA8 texels of each level from 1 down to 1×1, with its width and height.
    pub levels: Vec<MipLevel>,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MipLevel {
    pub width: u32,
    pub height: u32,
    pub rgba8: Vec<u8>,
}

/// Levels down to 1×1, level 0 included: ⌊log2(max side)⌋ + 1.
pub fn mip_level_count(width: u32, height: u32) -> u32 {
    32 - width.max(height).max(1).leading_zeros()
}

/// Bytes of levels 1.. of a `width`×`height` RGBA8 image: what a chain adds to the image (about
/// a third of it).
pub fn chain_bytes(width: u32, height: u32) -> u64 {
    (1..mip_level_count(width, height)).map(|l| (width >> l).max(1) as u64 * (height >> l).max(1) as u64 * 4).sum()
}

impl MipChain {
    /// The chain below level 0 of a `width`×`height` RGBA8 image of `rgba8`.
    pub fn build(width: u32, height: u32, rgba8: &[u8], srgb: bool) -> Self {
        let mut levels: Vec<MipLevel> = Vec::new();
        let (mut w, mut h) = (width as usize, height as usize);
        for _ in 1..mip_level_count(width, height) {
            let above = levels.last().map_or(rgba8, |l| l.rgba8.as_slice());
            let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
            let rgba8 = if srgb { halve::<true>(above, w, h, nw, nh) } else { halve::<false>(above, w, h, nw, nh) };
            levels.push(MipLevel { width: nw as u32, height: nh as u32, rgba8 });
            (w, h) = (nw, nh);
        }
        Self { srgb, levels }
    }

    /// Whether this chain belongs below a `width`×`height` image (its level 1 is half of it).
    pub fn fits(&self, width: u32, height: u32) -> bool {
        let expected = mip_level_count(width, height) as usize - 1;
        self.levels.len() == expected
            && self.levels.first().is_none_or(|l| (l.width, l.height) == ((width / 2).max(1), (height / 2).max(1)))
    }
}

/// One level from the one above (`w`×`h`), texel by texel.
fn halve<const SRGB: bool>(above: &[u8], w: usize, h: usize, nw: usize, nh: usize) -> Vec<u8> {
    let tables = SRGB.then(SrgbTables::get);
    let mut out = vec![0u8; nw * nh * 4];
    for y in 0..nh {
        let row0 = &above[(2 * y).min(h - 1) * w * 4..][..w * 4];
        let row1 = &above[(2 * y + 1).min(h - 1) * w * 4..][..w * 4];
        let out_row = &mut out[y * nw * 4..][..nw * 4];
        for x in 0..nw {
            let (x0, x1) = ((2 * x).min(w - 1) * 4, (2 * x + 1).min(w - 1) * 4);
            for c in 0..4 {
                let texels = [row0[x0 + c], row0[x1 + c], row1[x0 + c], row1[x1 + c]];
                out_row[x * 4 + c] = match tables {
                    Some(t) if c < 3 => t.mean(texels),
                    _ => ((texels.iter().map(|&b| b as u32).sum::<u32>() + 2) / 4) as u8,
                };
            }
        }
    }
    out
}

/// Fraction bits of a stored byte's linear value; four summed stay below 2^26.
const LINEAR_BITS: u32 = 24;
/// The coarse table's step in the sum of four.
const BUCKET_SHIFT: u32 = 14;

struct SrgbTables {
    /// Linear value of each stored byte, ×2^24.
    linear: [u32; 256],
    /// `threshold[k]`: the smallest sum of four linear values whose mean encodes to byte k or
    /// more (k − ½ in stored units); `threshold[256]` is out of reach.
    threshold: [u32; 257],
    /// The byte for the sum at each bucket's start.
    coarse: Vec<u8>,
}

impl SrgbTables {
    fn get() -> &'static Self {
        static TABLES: OnceLock<SrgbTables> = OnceLock::new();
        TABLES.get_or_init(|| {
            let scale = (1u64 << LINEAR_BITS) as f64;
            let linear = std::array::from_fn(|b| (srgb_to_linear_f64(b as f64 / 255.0) * scale).round() as u32);
            let mut threshold = [u32::MAX; 257];
            threshold[0] = 0;
            for (k, t) in threshold.iter_mut().enumerate().take(256).skip(1) {
                *t = (srgb_to_linear_f64((k as f64 - 0.5) / 255.0) * 4.0 * scale).ceil() as u32;
            }
            let buckets = ((4u64 << LINEAR_BITS) >> BUCKET_SHIFT) as usize + 1;
            let coarse = (0..buckets)
                .map(|i| {
                    let sum = (i as u64) << BUCKET_SHIFT;
                    (threshold[..256].partition_point(|&t| t as u64 <= sum) - 1) as u8
                })
                .collect();
            SrgbTables { linear, threshold, coarse }
        })
    }

    /// The stored byte nearest to the linear mean of four stored bytes.
    #[inline]
    fn mean(&self, texels: [u8; 4]) -> u8 {
        let sum: u32 = texels.iter().map(|&b| self.linear[b as usize]).sum();
        let mut byte = self.coarse[(sum >> BUCKET_SHIFT) as usize] as usize;
        // A bucket is narrower than the curve's smallest step (1/255/12.92 in linear light), so
        // at most one threshold lies inside it.
        if sum >= self.threshold[byte + 1] {
            byte += 1;
        }
        byte as u8
    }
}

/// `srgb_to_linear` in f64, for the tables.
fn srgb_to_linear_f64(c: f64) -> f64 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn linear_to_srgb_f64(l: f64) -> f64 {
        if l <= 0.0031308 { l * 12.92 } else { 1.055 * l.powf(1.0 / 2.4) - 0.055 }
    }

    /// The mean by the definition, in f64.
    fn reference_mean(texels: [u8; 4]) -> u8 {
        let mean = texels.iter().map(|&b| srgb_to_linear_f64(b as f64 / 255.0)).sum::<f64>() / 4.0;
        (linear_to_srgb_f64(mean) * 255.0).round() as u8
    }

    #[test]
    fn srgb_means_equal_the_definition_for_every_pair_and_spread() {
        let t = SrgbTables::get();
        for a in 0..=255u8 {
            for b in 0..=255u8 {
                for texels in [[a, a, a, a], [a, b, a, b], [a, a, a, b], [a, b, b, b], [a, b, 0, 255]] {
                    let (got, want) = (t.mean(texels), reference_mean(texels));
                    // Ties in f64 are not ties in the integers: allow a step only where the
                    // exact mean sits within 1e-4 of a half byte.
                    if got != want {
                        let mean = texels.iter().map(|&v| srgb_to_linear_f64(v as f64 / 255.0)).sum::<f64>() / 4.0;
                        let stored = linear_to_srgb_f64(mean) * 255.0;
                        assert!((stored.fract() - 0.5).abs() < 1e-4, "{texels:?}: {got} vs {want} ({stored})");
                    }
                }
            }
        }
        // The same curve as the rest of the engine's.
        for b in 0..=255u8 {
            let f32_curve = crate::color::srgb_to_linear(b as f32 / 255.0) as f64;
            assert!((f32_curve - srgb_to_linear_f64(b as f64 / 255.0)).abs() < 1e-6);
        }
    }

    #[test]
    fn an_srgb_checker_averages_in_linear_light_and_alpha_as_stored() {
        // Black and white: the linear mean 0.5 is stored as 188, not 128.
        let rgba8 = [[0, 0, 0, 0], [255, 255, 255, 255], [255, 255, 255, 255], [0, 0, 0, 0]].concat();
        let srgb = MipChain::build(2, 2, &rgba8, true);
        assert_eq!(srgb.levels, vec![MipLevel { width: 1, height: 1, rgba8: vec![188, 188, 188, 128] }]);
        let linear = MipChain::build(2, 2, &rgba8, false);
        assert_eq!(linear.levels[0].rgba8, vec![128, 128, 128, 128]);
        assert!(srgb.fits(2, 2));
    }

    #[test]
    fn chain_bytes_count_every_level_below_the_image() {
        assert_eq!(chain_bytes(2048, 2048), (1..=11).map(|l| (2048u64 >> l).pow(2) * 4).sum::<u64>());
        // 5×3: 2×1 and 1×1.
        assert_eq!(chain_bytes(5, 3), 12);
        assert_eq!(chain_bytes(1, 1), 0);
        for (w, h) in [(5, 3), (1, 8), (8, 1), (7, 2), (1, 1), (64, 16)] {
            let texels = vec![0; (w * h * 4) as usize];
            let built: usize = MipChain::build(w, h, &texels, false).levels.iter().map(|l| l.rgba8.len()).sum();
            assert_eq!(chain_bytes(w, h), built as u64, "{w}×{h}");
        }
    }

    #[test]
    fn levels_halve_down_to_one_texel_clamping_odd_edges() {
        // 5×3: levels 2×1 and 1×1, as the GPU sizes them (the fifth column is never read).
        let rgba8: Vec<u8> = (0..15u8).flat_map(|i| [i * 10, 0, 0, 255]).collect();
        let chain = MipChain::build(5, 3, &rgba8, false);
        let sizes: Vec<_> = chain.levels.iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, vec![(2, 1), (1, 1)]);
        // Level 1, texel (1, 0): columns 2 and 3 of rows 0 and 1: (20 + 30 + 70 + 80) / 4 = 50.
        assert_eq!(chain.levels[0].rgba8[4], 50);
        // 1×3 → 1×1 clamps the missing column and row to the last ones.
        let tall = [[10u8, 0, 0, 0], [30, 0, 0, 0], [90, 0, 0, 0]].concat();
        let chain = MipChain::build(1, 3, &tall, false);
        assert_eq!(chain.levels[0].rgba8, vec![20, 0, 0, 0]);
        assert_eq!(mip_level_count(2048, 2048), 12);
        assert_eq!(mip_level_count(1, 1), 1);
    }
}
