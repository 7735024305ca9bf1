//! KHR_materials_variants: the file's variants are listed on the scene's root, each mapped
//! primitive carries its materials per variant, and selecting a variant (a script setting
//! `SceneVariants::active`, `select_variant`, the viewer's menu or `--variant NAME`) switches
//! the primitives' materials; `VariantsTest` (written for these tests, CC0) maps a cube to three
//! materials and its ground to a second one in one variant only.

use penumbra::engine::environment::Environment;
use penumbra::engine::import::GltfScene;
use penumbra::engine::variants::VariantError;
use penumbra::prelude::*;
use penumbra::render::features::environment::EnvironmentSettings;
use penumbra::render::headless::{CameraChoice, ShotError, ShotSettings, render_frames, stage_scene};
use penumbra::render::{RenderSettings, Renderer};

mod common;
use common::{Shot, Tolerance, asset, check_golden, gpu, scratch_dir};

const FILE: &str = "VariantsTest/VariantsTest.gltf";

/// What each named entity draws with, told apart by the materials' parameters.
fn drawn(app: &mut App) -> Vec<(String, String)> {
    let mut q = app.world.query::<(&Name, &MeshMaterial3d)>();
    let handles: Vec<(String, Handle<StandardMaterial>)> =
        q.iter(&app.world).map(|(n, m)| (n.as_str().to_owned(), m.0)).collect();
    let materials = app.world.resource::<Assets<StandardMaterial>>();
    let mut out: Vec<(String, String)> = handles
        .into_iter()
        .map(|(n, h)| {
            let m = materials.get(h).expect("live");
            let what = if m.metallic == 1.0 {
                "blue metal"
            } else if m.has_sheen() {
                "green velvet"
            } else if m.base_color.x > 0.5 {
                "red plastic"
            } else if m.base_color.x > 0.3 {
                "grey ground"
            } else {
                "dark ground"
            };
            (n, what.to_owned())
        })
        .collect();
    out.sort();
    out
}

fn staged(variant: Option<&str>) -> Result<App, ShotError> {
    let scene = GltfScene::load(&asset(FILE), &Default::default()).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(scene.variant_names(), ["Red plastic", "Blue metal", "Green velvet"]);
    let shot = ShotSettings { size: Some((32, 32)), variant: variant.map(str::to_owned), ..Default::default() };
    stage_scene(&scene, &shot).map(|(app, _)| app)
}

fn pairs(v: &[(&str, &str)]) -> Vec<(String, String)> {
    v.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect()
}

#[test]
fn selecting_a_variant_switches_the_mapped_materials_and_back() {
    let mut app = staged(None).unwrap();
    let own = pairs(&[("cube", "red plastic"), ("ground", "grey ground")]);
    assert_eq!(drawn(&mut app), own, "no variant: each primitive's own material");
    let root = {
        let mut q = app.world.query_filtered::<Entity, With<SceneVariants>>();
        q.single(&app.world).expect("one scene with variants")
    };
    assert_eq!(app.world.get::<SceneVariants>(root).unwrap().names, ["Red plastic", "Blue metal", "Green velvet"]);

    select_variant(&mut app.world, root, "Blue metal").unwrap();
    app.update();
    assert_eq!(drawn(&mut app), pairs(&[("cube", "blue metal"), ("ground", "dark ground")]));

    // The ground has no mapping for this variant: it goes back to its own material.
    app.world.get_mut::<SceneVariants>(root).unwrap().active = Some("Green velvet".into());
    app.update();
    assert_eq!(drawn(&mut app), pairs(&[("cube", "green velvet"), ("ground", "grey ground")]));

    app.world.get_mut::<SceneVariants>(root).unwrap().active = None;
    app.update();
    assert_eq!(drawn(&mut app), own);
}

#[test]
fn an_unknown_variant_is_refused_naming_the_variants() {
    let err = staged(Some("Purple")).err().expect("refused");
    assert_eq!(
        err.to_string(),
        "--variant Purple: the scene has no variant of that name (its variants: Red plastic, Blue metal, Green velvet)"
    );
    let plain = GltfScene::load(&asset("BoxTextured/BoxTextured.glb"), &Default::default()).unwrap();
    let shot = ShotSettings { variant: Some("Blue metal".into()), ..Default::default() };
    let err = stage_scene(&plain, &shot).err().expect("refused");
    assert!(matches!(err, ShotError::Variant(VariantError::NoVariants { .. })), "{err}");
}

/// Mappings naming a variant or material the file lacks are dropped with a warning naming the
/// mesh and primitive; the rest of the file still loads.
#[test]
fn bad_mappings_are_named_and_dropped() {
    let json = std::fs::read_to_string(asset(FILE)).unwrap().replace(
        r#""mappings": [
        {
         "material": 4,"#,
        r#""mappings": [
        {"material": 9, "variants": [0]},
        {"material": 4, "variants": [7]},
        {
         "material": 4,"#,
    );
    assert!(json.contains("\"material\": 9"), "the edit applies");
    let dir = scratch_dir("variants");
    let path = dir.join("bad.gltf");
    std::fs::write(&path, json).unwrap();
    let scene = GltfScene::load(&path, &Default::default()).expect("loads");
    let warnings = scene.warnings.join("\n");
    assert!(
        warnings.contains("mesh 1 primitive 0: KHR_materials_variants mapping names no material of the file (9)"),
        "{warnings}"
    );
    assert!(warnings.contains("mapping names variant 7, which the file does not list"), "{warnings}");
}

/// The Blue metal variant as drawn under the studio environment: a blue metal cube on the dark
/// ground.
#[test]
fn golden_variants_test_in_its_blue_metal_variant() {
    let scene = GltfScene::load(&asset(FILE), &Default::default()).unwrap();
    let shot = ShotSettings {
        size: Some((128, 128)),
        camera: CameraChoice::Orbit { yaw: 30.0, pitch: 25.0 },
        variant: Some("Blue metal".into()),
        ..Default::default()
    };
    let (mut app, size) = stage_scene(&scene, &shot).unwrap();
    app.insert_resource(Environment::default());
    let settings = RenderSettings {
        max_anisotropy: Some(1),
        environment: EnvironmentSettings { cube_size: Some(128), ..Default::default() },
        ..Default::default()
    };
    let renderer = Renderer::new(gpu(), settings).unwrap();
    let rgba8 = render_frames(&mut app, renderer, size, 1).unwrap();
    check_golden("VariantsTest-blue-metal", &Shot { width: size.0, height: size.1, rgba8 }, Tolerance::default());
}
