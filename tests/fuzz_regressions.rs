//! Inputs the fuzzers (fuzz/, see docs/reliability.md) found crashing, each fed again through
//! the same entry point as its fuzz target: it must now return (an error or a scene), not panic.
//! Files live in tests/fuzz_regressions/<target>/, named after what they exercise; the `.min`
//! files are the fuzzers' crashers cut down by hand to the field that crashed (each still panics
//! the gltf crate's accessor when fed to it directly).

use std::path::Path;

use penumbra::engine::compressed_image::Format;
use penumbra::engine::environment::EnvironmentImage;
use penumbra::engine::ies::IesProfile;
use penumbra::engine::import::{GltfScene, ImportOptions, ObjScene, decode_texture};
use penumbra::render::pipelines::shader_library::{EMBEDDED, ShaderDefs, ShaderLibrary};

fn inputs(target: &str) -> Vec<(String, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions").join(target);
    let Ok(entries) = std::fs::read_dir(&dir) else { return Vec::new() };
    let mut out: Vec<_> = entries
        .flatten()
        .map(|e| (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).unwrap()))
        .collect();
    out.sort();
    out
}

/// Runs `f` on every input of `target`, naming the input that panics.
fn replay(target: &str, f: impl Fn(&[u8])) -> usize {
    let all = inputs(target);
    for (name, bytes) in &all {
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(bytes)));
        assert!(result.is_ok(), "tests/fuzz_regressions/{target}/{name} panics again");
    }
    all.len()
}

#[test]
fn gltf_crashers_are_errors_now() {
    // Each is invalid glTF: it must be refused with an error, not panic and not load.
    let n = replay("gltf", |b| {
        let loaded =
            GltfScene::from_bytes(b, Path::new("/nonexistent-penumbra-fuzz/scene.gltf"), &ImportOptions::default());
        assert!(loaded.is_err(), "an invalid file loaded");
    });
    assert!(n >= 3, "the glTF crasher files are present");
}

#[test]
fn obj_ies_shader_and_image_crashers_are_errors_now() {
    // The OBJ importer turns a panic inside tobj into an error of its own ("the OBJ parser
    // failed"); a crasher must be refused before tobj gets that far.
    let n = replay("obj", |b| {
        let loaded =
            ObjScene::from_bytes(b, Path::new("/nonexistent-penumbra-fuzz/scene.obj"), &ImportOptions::default());
        let err = loaded.expect_err("an invalid file loaded").to_string();
        assert!(!err.contains("the OBJ parser failed"), "tobj panicked (caught): {err}");
    });
    assert!(n >= 1, "the OBJ crasher files are present");
    replay("ies", |b| {
        let _ = IesProfile::parse(&String::from_utf8_lossy(b), "fuzz.ies");
    });
    replay("shader", |b| {
        let Some((&pick, rest)) = b.split_first() else { return };
        let Ok(source) = std::str::from_utf8(rest) else { return };
        let file = EMBEDDED[pick as usize % EMBEDDED.len()].0;
        if let Ok(mut library) = ShaderLibrary::embedded_with(file, source) {
            let _ = library.compose("forward.wgsl", &ShaderDefs::default());
            let _ = library.compose(file, &ShaderDefs::default());
        }
    });
    replay("image", |b| {
        let Some((&pick, bytes)) = b.split_first() else { return };
        if pick & 1 == 0 {
            // As the fuzz target: a KTX2 texture that loads is transcoded level by level.
            if let Ok(image) = decode_texture(bytes, "fuzz.png", &ImportOptions::default())
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
}
