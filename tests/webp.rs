//! EXT_texture_webp: textures whose image is WebP (lossless and lossy), with no PNG fallback
//! (the file requires the extension), draw as their PNG originals do; a bad WebP reference is an
//! error naming it, a texture with no image at all a warning.
//!
//! tests/assets/BoxTexturedWebp is BoxTextured with its PNG texture converted to WebP
//! (ImageMagick `convert`, `-define webp:lossless=true` and `-quality 92`).

mod common;

use common::golden_scenes::THREE_QUARTER;
use common::{Tolerance, asset, check_golden, flip_mean, render_asset, scratch_dir};
use penumbra::engine::import::{GltfScene, ImportErrorKind, ImportOptions};
use penumbra::render::RenderSettings;
use penumbra::render::headless::ShotSettings;

fn shot() -> ShotSettings {
    ShotSettings { size: Some((128, 128)), camera: THREE_QUARTER, exposure_ev100: Some(0.0), ..Default::default() }
}

#[test]
fn webp_textures_draw_as_their_png_originals() {
    let settings = || RenderSettings { max_anisotropy: Some(1), ..Default::default() };
    let png = render_asset("BoxTextured/BoxTextured.glb", &shot(), settings());
    let lossless = render_asset("BoxTexturedWebp/BoxTextured-webp.gltf", &shot(), settings());
    let lossy = render_asset("BoxTexturedWebp/BoxTextured-webp-lossy.gltf", &shot(), settings());
    assert_eq!(lossless.rgba8, png.rgba8, "a lossless WebP texture draws exactly as its PNG");
    let error = flip_mean(&lossy.rgba8, &png.rgba8, 128, 128);
    assert!(error > 0.0 && error < 0.01, "lossy WebP against PNG: FLIP mean {error}");
    check_golden("BoxTextured-webp", &lossless, Tolerance::default());
    for rel in ["BoxTexturedWebp/BoxTextured-webp.gltf", "BoxTexturedWebp/BoxTextured-webp-lossy.gltf"] {
        let scene = GltfScene::load(&asset(rel), &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        assert!(scene.warnings.is_empty(), "{rel}: {:?}", scene.warnings);
    }
}

/// The WebP file with its JSON changed by `edit`, written to a scratch folder beside copies of
/// its buffer and images.
fn variant(name: &str, edit: impl FnOnce(&mut serde_json::Value)) -> std::path::PathBuf {
    let dir = scratch_dir(name);
    let from = asset("BoxTexturedWebp/BoxTextured-webp.gltf");
    for f in ["BoxTextured.bin", "CesiumLogoFlat.webp"] {
        std::fs::copy(from.with_file_name(f), dir.join(f)).unwrap();
    }
    let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&from).unwrap()).unwrap();
    edit(&mut json);
    let path = dir.join("scene.gltf");
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    path
}

#[test]
fn bad_webp_references_and_data_are_named() {
    // A WebP source the file does not have.
    let path = variant("webp-index", |j| j["textures"][0]["extensions"]["EXT_texture_webp"]["source"] = 7.into());
    let err = GltfScene::load(&path, &ImportOptions::default()).expect_err("must fail");
    assert!(matches!(err.kind, ImportErrorKind::Invalid(_)), "{err}");
    assert!(
        err.to_string().contains("textures[0].extensions.EXT_texture_webp.source is 7, but the file has 1 images"),
        "{err}"
    );
    // Bytes that are not WebP behind a .webp name.
    let path = variant("webp-corrupt", |_| {});
    let bytes = std::fs::read(path.with_file_name("CesiumLogoFlat.webp")).unwrap();
    std::fs::write(path.with_file_name("CesiumLogoFlat.webp"), &bytes[..bytes.len() / 3]).unwrap();
    let err = GltfScene::load(&path, &ImportOptions::default()).expect_err("must fail");
    assert!(matches!(err.kind, ImportErrorKind::Image { .. }), "{err}");
    assert!(err.to_string().contains("CesiumLogoFlat.webp"), "{err}");
    // A texture with neither a source nor a WebP image: drawn untextured, with a warning.
    let path = variant("webp-none", |j| {
        j["textures"][0].as_object_mut().unwrap().remove("extensions");
    });
    let scene = GltfScene::load(&path, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.iter().any(|w| w.contains("texture 0 has no image")), "{:?}", scene.warnings);
}
