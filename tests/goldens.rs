//! Golden images of the sample models, rendered headless on lavapipe and compared with FLIP.
//! Each golden was looked at before it was committed; the README says how to regenerate them.

use penumbra::render::RenderSettings;
use penumbra::render::headless::{CameraChoice, ShotSettings};

mod common;
use common::{Tolerance, check_golden, render_asset};

const SIZE: (u32, u32) = (256, 256);

fn golden(name: &str, rel: &str, camera: CameraChoice) {
    let shot = ShotSettings { size: Some(SIZE), camera, exposure_ev100: None, animation: None };
    let image = render_asset(rel, &shot, RenderSettings::default());
    check_golden(name, &image, Tolerance::default());
}

fn front(name: &str, rel: &str) {
    golden(name, rel, CameraChoice::Auto);
}

/// From the front-right and above, so three faces of a model show.
const THREE_QUARTER: CameraChoice = CameraChoice::Orbit { yaw: 35.0, pitch: 25.0 };

#[test]
fn damaged_helmet() {
    front("DamagedHelmet", "DamagedHelmet/DamagedHelmet.glb");
}

#[test]
fn box_textured() {
    golden("BoxTextured", "BoxTextured/BoxTextured.glb", THREE_QUARTER);
}

#[test]
fn metal_rough_spheres_no_textures() {
    front("MetalRoughSpheresNoTextures", "MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.glb");
}

#[test]
fn normal_tangent_mirror_test() {
    front("NormalTangentMirrorTest", "NormalTangentMirrorTest/NormalTangentMirrorTest.glb");
}

#[test]
fn normal_tangent_test() {
    front("NormalTangentTest", "NormalTangentTest/NormalTangentTest.glb");
}

#[test]
fn alpha_blend_mode_test() {
    front("AlphaBlendModeTest", "AlphaBlendModeTest/AlphaBlendModeTest.glb");
}

#[test]
fn orientation_test() {
    golden("OrientationTest", "OrientationTest/OrientationTest.glb", THREE_QUARTER);
}

#[test]
fn texture_coordinate_test() {
    front("TextureCoordinateTest", "TextureCoordinateTest/TextureCoordinateTest.glb");
}

#[test]
fn texture_settings_test() {
    front("TextureSettingsTest", "TextureSettingsTest/TextureSettingsTest.glb");
}

#[test]
fn vertex_color_test() {
    front("VertexColorTest", "VertexColorTest/VertexColorTest.glb");
}

#[test]
fn cesium_milk_truck() {
    golden("CesiumMilkTruck", "CesiumMilkTruck/CesiumMilkTruck.glb", THREE_QUARTER);
}

#[test]
fn lights_punctual_lamp() {
    golden("LightsPunctualLamp", "LightsPunctualLamp/LightsPunctualLamp.gltf", THREE_QUARTER);
}

#[test]
fn cameras_perspective() {
    golden("Cameras-0", "Cameras/Cameras.gltf", CameraChoice::Gltf(0));
}

#[test]
fn cameras_orthographic() {
    golden("Cameras-1", "Cameras/Cameras.gltf", CameraChoice::Gltf(1));
}

#[test]
fn multi_uv_test() {
    front("MultiUVTest", "MultiUVTest/MultiUVTest.glb");
}

#[test]
fn unlit_test() {
    front("UnlitTest", "UnlitTest/UnlitTest.glb");
}

#[test]
fn mesh_primitive_modes() {
    front("MeshPrimitiveModes", "MeshPrimitiveModes/MeshPrimitiveModes.gltf");
}

#[test]
fn texture_transform_test() {
    front("TextureTransformTest", "TextureTransformTest/TextureTransformTest.gltf");
}

#[test]
fn emissive_strength_test() {
    front("EmissiveStrengthTest", "EmissiveStrengthTest/EmissiveStrengthTest.glb");
}

#[test]
fn box_with_spaces() {
    golden("BoxWithSpaces", "BoxWithSpaces/Box With Spaces.gltf", THREE_QUARTER);
}
