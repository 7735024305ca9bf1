//! Golden images of the sample models, rendered headless on lavapipe and compared with FLIP.
//! Each golden was looked at before it was committed; docs/testing.md says how to regenerate them.
//! The frames are built in `common::golden_scenes` (tests/backend_parity.rs draws them on GL too).

mod common;
use common::Tolerance;
use common::golden_scenes::{SAMPLE_MODELS, check_golden_frame, sample_model};

fn golden(name: &str) {
    check_golden_frame(&|| sample_model(name), Tolerance::default());
}

#[test]
fn every_sample_golden_has_its_test() {
    let tested = [
        "DamagedHelmet",
        "BoxTextured",
        "MetalRoughSpheresNoTextures",
        "NormalTangentMirrorTest",
        "NormalTangentTest",
        "AlphaBlendModeTest",
        "OrientationTest",
        "TextureCoordinateTest",
        "TextureSettingsTest",
        "VertexColorTest",
        "CesiumMilkTruck",
        "LightsPunctualLamp",
        "Cameras-0",
        "Cameras-1",
        "MultiUVTest",
        "UnlitTest",
        "MeshPrimitiveModes",
        "TextureTransformTest",
        "EmissiveStrengthTest",
        "BoxWithSpaces",
        "SimpleInstancing",
    ];
    let listed: Vec<&str> = SAMPLE_MODELS.iter().map(|(name, ..)| *name).collect();
    assert_eq!(listed, tested);
}

#[test]
fn damaged_helmet() {
    golden("DamagedHelmet");
}

#[test]
fn box_textured() {
    golden("BoxTextured");
}

#[test]
fn metal_rough_spheres_no_textures() {
    golden("MetalRoughSpheresNoTextures");
}

#[test]
fn normal_tangent_mirror_test() {
    golden("NormalTangentMirrorTest");
}

#[test]
fn normal_tangent_test() {
    golden("NormalTangentTest");
}

#[test]
fn alpha_blend_mode_test() {
    golden("AlphaBlendModeTest");
}

#[test]
fn orientation_test() {
    golden("OrientationTest");
}

#[test]
fn texture_coordinate_test() {
    golden("TextureCoordinateTest");
}

#[test]
fn texture_settings_test() {
    golden("TextureSettingsTest");
}

#[test]
fn vertex_color_test() {
    golden("VertexColorTest");
}

#[test]
fn cesium_milk_truck() {
    golden("CesiumMilkTruck");
}

#[test]
fn lights_punctual_lamp() {
    golden("LightsPunctualLamp");
}

#[test]
fn cameras_perspective() {
    golden("Cameras-0");
}

#[test]
fn cameras_orthographic() {
    golden("Cameras-1");
}

#[test]
fn multi_uv_test() {
    golden("MultiUVTest");
}

#[test]
fn unlit_test() {
    golden("UnlitTest");
}

#[test]
fn mesh_primitive_modes() {
    golden("MeshPrimitiveModes");
}

#[test]
fn texture_transform_test() {
    golden("TextureTransformTest");
}

#[test]
fn emissive_strength_test() {
    golden("EmissiveStrengthTest");
}

#[test]
fn box_with_spaces() {
    golden("BoxWithSpaces");
}

/// EXT_mesh_gpu_instancing: 125 instances of one cube in a 5×5×5 grid, turned and scaled one
/// by one (before the extension was read, one cube).
#[test]
fn simple_instancing() {
    golden("SimpleInstancing");
}
