//! Image bytes through Penumbra's decoders: textures (PNG, JPEG via zune-jpeg or the image
//! crate, WebP lossless and lossy, KTX2 + Basis Universal checked and then every level
//! transcoded as the renderer would: BC7 and RGBA8) under the import limits, and environment maps
//! (Radiance .hdr, OpenEXR). The first byte picks the path.
#![no_main]

use libfuzzer_sys::fuzz_target;
use penumbra_engine::compressed_image::Target;
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
            for level in 0..c.levels {
                let _ = c.transcode(level, Target::Bc7);
                let _ = c.transcode(level, Target::Rgba8);
            }
        }
    } else {
        let _ = EnvironmentImage::from_bytes(bytes, "fuzz.hdr");
    }
});
