//! Image error against a reference: FLIP (mean, 99th percentile of pixels, and nv_flip's
//! error-weighted 99th percentile) on the display-referred
//! images, PSNR on the linear HDR ones. The reference's display image is made here on the CPU
//! with the renderer's own CPU copy of the display transform (`features::tonemap::display_color`:
//! Khronos PBR Neutral, then sRGB), so both images reach FLIP through identical tonemapping; a
//! test holds it equal to the GPU's.

use penumbra_render::Tonemapper;
use penumbra_render::features::tonemap::display_color;

/// Linear exposed radiance to 8-bit RGB as Penumbra's neutral tonemap pass writes it.
pub fn display_rgb8(hdr: &[[f32; 3]]) -> Vec<u8> {
    hdr.iter()
        .flat_map(|&p| {
            let p = p.map(|v| if v.is_finite() { v.max(0.0) as f64 } else { 0.0 });
            display_color(Tonemapper::Neutral, p, true).map(|v| (v * 255.0 + 0.5) as u8)
        })
        .collect()
}

#[derive(Debug, Clone, PartialEq)]
pub struct ImageError {
    pub flip_mean: f32,
    /// The 99th percentile of the pixels' FLIP values: 1 % of the pixels are worse.
    pub flip_p99: f32,
    /// nv_flip's error-weighted 99th percentile (`get_percentile(0.99, true)`): the FLIP value
    /// below which 99 % of the image's summed error lies. Far higher than `flip_p99` where a few
    /// pixels hold most of the error (DamagedHelmet: 0.839 against 0.244).
    pub flip_weighted_p99: f32,
    /// 10·log10(1 / MSE) over linear RGB, unclamped, with radiance 1 as the peak (display white
    /// at the references' exposure); `inf` for identical images.
    pub psnr_db: f64,
    /// Where the error is: FLIP's per-pixel error in magma colours, RGB8.
    pub flip_map: Vec<u8>,
}

/// FLIP between two RGB8 images of `size` (the reference first): mean, 99th percentile of the
/// pixels, error-weighted 99th percentile, and the error map in FLIP's magma colours (RGB8).
pub fn flip(reference: &[u8], test: &[u8], size: (u32, u32)) -> (f32, f32, f32, Vec<u8>) {
    let r = nv_flip::FlipImageRgb8::with_data(size.0, size.1, reference);
    let t = nv_flip::FlipImageRgb8::with_data(size.0, size.1, test);
    let error = nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let mut pool = nv_flip::FlipPool::from_image(&error);
    let map = error.apply_color_lut(&nv_flip::magma_lut()).to_vec();
    (pool.mean(), pool.get_percentile(0.99, false), pool.get_percentile(0.99, true), map)
}

pub fn psnr(reference: &[[f32; 3]], test: &[[f32; 3]]) -> f64 {
    let mut sum = 0.0f64;
    for (r, t) in reference.iter().zip(test) {
        for k in 0..3 {
            let d = (r[k] as f64) - (t[k] as f64);
            sum += if d.is_finite() { d * d } else { 1e30 };
        }
    }
    let mse = sum / (reference.len() * 3).max(1) as f64;
    10.0 * (1.0 / mse).log10()
}

pub fn compare(reference: &[[f32; 3]], test_hdr: &[[f32; 3]], test_rgb8: &[u8], size: (u32, u32)) -> ImageError {
    let (flip_mean, flip_p99, flip_weighted_p99, flip_map) = flip(&display_rgb8(reference), test_rgb8, size);
    ImageError { flip_mean, flip_p99, flip_weighted_p99, psnr_db: psnr(reference, test_hdr), flip_map }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_have_no_error_and_noise_has_some() {
        let img: Vec<[f32; 3]> = (0..64 * 64).map(|i| [(i % 64) as f32 / 64.0, 0.5, (i / 64) as f32 / 32.0]).collect();
        let rgb = display_rgb8(&img);
        let e = compare(&img, &img, &rgb, (64, 64));
        assert_eq!(e.flip_mean, 0.0);
        assert!(e.psnr_db.is_infinite());
        let noisy: Vec<[f32; 3]> =
            img.iter().enumerate().map(|(i, p)| p.map(|v| v + if i % 2 == 0 { 0.1 } else { -0.1 })).collect();
        let e = compare(&img, &noisy, &display_rgb8(&noisy), (64, 64));
        assert!(e.flip_mean > 0.01 && e.flip_p99 >= e.flip_mean, "{e:?}");
        assert!((e.psnr_db - 20.0).abs() < 0.5, "an error of 0.1 everywhere is 20 dB: {e:?}");
    }

    /// Where a few pixels hold most of the error, the plain 99th percentile of pixels is what 1 %
    /// of the pixels exceed, and the error-weighted one is far higher: they are two measures.
    #[test]
    fn the_pixel_percentile_and_the_error_weighted_one_differ() {
        let img: Vec<[f32; 3]> = vec![[0.2, 0.2, 0.2]; 64 * 64];
        let mut spot = img.clone();
        for y in 30..34 {
            for x in 30..34 {
                spot[y * 64 + x] = [1.0, 0.0, 0.0];
            }
        }
        let e = compare(&img, &spot, &display_rgb8(&spot), (64, 64));
        // 16 of 4096 pixels changed (0.4 %): FLIP spreads them over a few dozen more.
        assert!(e.flip_p99 < 0.5 * e.flip_weighted_p99, "{e:?}");
        assert!(e.flip_weighted_p99 > 0.5, "{e:?}");
    }
}
