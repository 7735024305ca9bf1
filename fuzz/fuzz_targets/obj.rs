//! OBJ text through the OBJ importer (face-index checks, tobj, conversion to meshes). MTL
//! libraries and textures resolve against a folder that does not exist.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use penumbra_engine::import::{ImportOptions, ObjScene};

fuzz_target!(|data: &[u8]| {
    let _ = ObjScene::from_bytes(data, Path::new("/nonexistent-penumbra-fuzz/scene.obj"), &ImportOptions::default());
});
