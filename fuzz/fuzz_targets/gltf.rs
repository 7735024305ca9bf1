//! glTF and GLB bytes through the whole importer (JSON, validation, limits, buffers, accessors,
//! primitives, images, skins, animations, lights). Relative URIs resolve against a folder that
//! does not exist, so only data URIs and the GLB chunk supply bytes. Limits are lowered so that
//! an input cannot spend the fuzzer's memory legitimately.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use penumbra_engine::import::{GltfScene, ImportOptions};

fuzz_target!(|data: &[u8]| {
    let mut options = ImportOptions::default();
    options.limits.decoded_bytes = 64 << 20;
    options.limits.image_bytes = 64 << 20;
    options.limits.total_image_bytes = 128 << 20;
    options.limits.data_uri_bytes = 16 << 20;
    let _ = GltfScene::from_bytes(data, Path::new("/nonexistent-penumbra-fuzz/scene.gltf"), &options);
});
