//! Image bytes through Penumbra's decoders: textures (PNG, JPEG via zune-jpeg or the image
//! crate, WebP lossless and lossy, KTX2 (Basis Universal or plain) checked and then every level
//! delivered as the renderer would ask: in each of its block formats and as RGBA8) under the
//! import limits, and environment maps
//! (Radiance .hdr, OpenEXR). The first byte picks the path.
#![no_main]

use libfuzzer_sys::fuzz_target;
use penumbra_engine::compressed_image::Format;
use penumbra_engine::environment::EnvironmentImage;
use penumbra_engine::import::{ImportOptions, decode_texture};

fuzz_target!(|data: &[u8]| {
    let Some((&pick, bytes)) = data.split_first() else { return };
    if pick & 1 == 0 {
        let mut options = ImportOptions::default();
        options.limits.image_bytes = 64 << 20;
        if let Ok(image) = decode_texture(bytes, "fuzz.png", &options)
            && let Some(c) = &image.compressed
        {
            for format in c.block_formats().into_iter().chain([Format::Rgba8]) {
                let _ = c.levels_as(0..c.levels, format);
            }
        }
    } else {
        let _ = EnvironmentImage::from_bytes(bytes, "fuzz.hdr");
    }
});
