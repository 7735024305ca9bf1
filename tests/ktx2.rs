//! KHR_texture_basisu: KTX2 textures with Basis Universal data (ETC1S and UASTC) draw as their
//! PNG original, transcoded to the adapter's block format with their mip chains (or to RGBA8);
//! a texture without a chain gets one made on the GPU; broken files are errors naming the image.
//!
//! tests/assets/BoxTexturedKtx2 is BoxTextured with its PNG texture encoded by Basis Universal's
//! `basisu` tool (see its README.md for the commands): ETC1S with mips, UASTC with mips and zstd
//! supercompression, and UASTC without mips.

mod common;

use common::golden_scenes::THREE_QUARTER;
use common::{Shot, Tolerance, asset, check_golden, flip_mean, render_asset, scratch_dir};
use penumbra::engine::compressed_image::Codec;
use penumbra::engine::import::{GltfScene, ImportErrorKind, ImportOptions};
use penumbra::render::RenderSettings;
use penumbra::render::headless::ShotSettings;

fn shot() -> ShotSettings {
    ShotSettings { size: Some((128, 128)), camera: THREE_QUARTER, exposure_ev100: Some(0.0), ..Default::default() }
}

fn render(rel: &str) -> Shot {
    let scene = GltfScene::load(&asset(rel), &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{rel}: {:?}", scene.warnings);
    render_asset(rel, &shot(), RenderSettings { max_anisotropy: Some(1), ..Default::default() })
}

#[test]
fn basis_textures_draw_as_their_png_original() {
    let png = render("BoxTextured/BoxTextured.glb");
    for (rel, golden, codec, max) in [
        // ETC1S is the small codec (0.5 bits per texel here): colour bleeds at the logo's edges
        // and the encoder's own mip filter soften it.
        ("BoxTexturedKtx2/BoxTextured-etc1s.gltf", "BoxTextured-etc1s", Codec::Etc1s, 0.07),
        // UASTC keeps the texels (0.002 where the GPU makes the chain from level 0); the file's
        // own smaller levels, each encoded on its own, add the rest.
        ("BoxTexturedKtx2/BoxTextured-uastc.gltf", "BoxTextured-uastc", Codec::Uastc, 0.02),
        ("BoxTexturedKtx2/BoxTextured-uastc-nomips.gltf", "", Codec::Uastc, 0.005),
    ] {
        let scene = GltfScene::load(&asset(rel), &ImportOptions::default()).unwrap();
        let image = scene.images().next().expect("an image");
        let compressed = image.compressed.as_ref().expect("kept compressed");
        assert_eq!(compressed.codec, codec, "{rel}");
        assert!(image.rgba8.is_empty(), "{rel}: no texels on the host");
        let shot = render(rel);
        let error = flip_mean(&shot.rgba8, &png.rgba8, 128, 128);
        eprintln!("{rel} against the PNG: FLIP mean {error:.5}");
        assert!(error > 0.0 && error < max, "{rel} against the PNG: FLIP mean {error}");
        if !golden.is_empty() {
            check_golden(golden, &shot, Tolerance::default());
        }
    }
}

/// The KTX2 scene with its texture's bytes changed by `edit`, in a scratch folder.
fn variant(name: &str, gltf: &str, edit: impl FnOnce(&mut Vec<u8>)) -> std::path::PathBuf {
    let dir = scratch_dir(name);
    let from = asset("BoxTexturedKtx2").join(gltf);
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&from).unwrap()).unwrap();
    let uri = json["images"][0]["uri"].as_str().unwrap().to_owned();
    std::fs::copy(from.with_file_name("BoxTextured.bin"), dir.join("BoxTextured.bin")).unwrap();
    let mut bytes = std::fs::read(from.with_file_name(&uri)).unwrap();
    edit(&mut bytes);
    std::fs::write(dir.join(&uri), bytes).unwrap();
    std::fs::write(dir.join("scene.gltf"), serde_json::to_string(&json).unwrap()).unwrap();
    dir.join("scene.gltf")
}

#[test]
fn broken_ktx2_files_are_errors_naming_the_image() {
    let load = |path: &std::path::Path| GltfScene::load(path, &ImportOptions::default());
    for (gltf, image) in [
        ("BoxTextured-etc1s.gltf", "CesiumLogoFlat-etc1s.ktx2"),
        ("BoxTextured-uastc.gltf", "CesiumLogoFlat-uastc.ktx2"),
    ] {
        assert!(load(&variant("ktx2-fine", gltf, |_| {})).is_ok());
        // Cut short: the level index points past the end.
        let err = load(&variant("ktx2-header", gltf, |b| b.truncate(60))).expect_err("must fail");
        assert!(err.to_string().contains("truncated"), "{err}");
        let err = load(&variant("ktx2-truncated", gltf, |b| b.truncate(b.len() / 2))).expect_err("must fail");
        assert!(matches!(err.kind, ImportErrorKind::Image { .. }), "{err}");
        assert!(err.to_string().contains(image) && err.to_string().contains("scene.gltf"), "{err}");
        // A chain past 1×1: more levels than a 256×256 image has.
        let err = load(&variant("ktx2-levels", gltf, |b| b[40..44].copy_from_slice(&10u32.to_le_bytes())))
            .expect_err("must fail");
        assert!(err.to_string().contains("has 10 mip levels, more than the 9 a 256×256 image has"), "{err}");
        // Not Basis data: a vkFormat of RGBA8 in the header.
        let err = load(&variant("ktx2-vkformat", gltf, |b| b[12..16].copy_from_slice(&37u32.to_le_bytes())))
            .expect_err("must fail");
        assert!(err.to_string().contains("vkFormat 37, not Basis Universal"), "{err}");
    }
}

/// An OBJ material may name a KTX2 texture too: it is kept compressed like a glTF one.
#[test]
fn obj_materials_take_ktx2_textures() {
    let dir = scratch_dir("ktx2-obj");
    std::fs::copy(asset("BoxTexturedKtx2/CesiumLogoFlat-uastc.ktx2"), dir.join("logo.ktx2")).unwrap();
    std::fs::write(dir.join("quad.mtl"), "newmtl logo\nKd 1 1 1\nmap_Kd logo.ktx2\n").unwrap();
    std::fs::write(
        dir.join("quad.obj"),
        "mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl logo\nf 1/1 2/2 3/3 4/4\n",
    )
    .unwrap();
    let scene = penumbra::engine::import::ObjScene::load(&dir.join("quad.obj"), &ImportOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let mut app = common::scene_app();
    scene.spawn(&mut app.world);
    let images = app.world.resource::<penumbra::engine::Assets<penumbra::engine::image::Image>>();
    let image = images.iter().map(|(_, i)| i).next().expect("the texture");
    assert!(image.compressed.is_some() && image.rgba8.is_empty(), "kept compressed");
}
