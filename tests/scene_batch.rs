//! `SceneBatch`: many scenes on one renderer draw what each draws on a fresh one, whatever came
//! before it (a scene with other textures, the same scene again, another environment), and a
//! scene that fails to stage leaves the batch working.

mod common;

use common::{asset, gpu};
use penumbra::engine::environment::{Background, Environment};
use penumbra::engine::import::{GltfScene, ImportOptions};
use penumbra::render::headless::{CameraChoice, SceneBatch, ShotError, ShotSettings, render_frames, stage_scene};
use penumbra::render::{RenderSettings, Renderer};

fn shot(environment: Option<Environment>) -> ShotSettings {
    ShotSettings {
        size: Some((64, 48)),
        camera: CameraChoice::Orbit { yaw: 30.0, pitch: 20.0 },
        environment,
        ..Default::default()
    }
}

fn fresh(scene: &GltfScene, shot: &ShotSettings) -> Vec<u8> {
    let (mut app, size) = stage_scene(scene, shot).unwrap();
    render_frames(&mut app, Renderer::new(gpu(), RenderSettings::default()).unwrap(), size, 1).unwrap()
}

#[test]
fn a_batch_draws_each_scene_as_a_fresh_renderer_does() {
    let load = |rel: &str| GltfScene::load(&asset(rel), &ImportOptions::default()).unwrap();
    let (boxed, truck) = (load("BoxTextured/BoxTextured.glb"), load("CesiumMilkTruckDraco/CesiumMilkTruck.gltf"));
    let colour = Environment { background: Background::Color([0.2, 0.3, 0.4]), ..Default::default() };
    let mut batch = SceneBatch::new(Renderer::new(gpu(), RenderSettings::default()).unwrap());
    for (name, scene, env) in [
        ("box", &boxed, None),
        ("truck", &truck, None),
        ("box again", &boxed, None),
        ("truck, another environment", &truck, Some(colour.clone())),
        ("box, back to the default", &boxed, None),
    ] {
        let shot = shot(env);
        let (pixels, size) = batch.render(scene, &shot, 1).unwrap();
        assert_eq!(size, (64, 48));
        let covered = pixels.chunks_exact(4).filter(|p| p[..3] != pixels[..3]).count();
        assert!(covered > 200, "{name}: the scene is in the frame ({covered} pixels unlike the corner)");
        assert!(pixels == fresh(scene, &shot), "{name}: the batch drew other pixels than a fresh renderer");
    }
    // A camera the scene does not have: an error, and the batch goes on.
    let missing = ShotSettings { camera: CameraChoice::Gltf(7), ..shot(None) };
    assert!(matches!(batch.render(&boxed, &missing, 1), Err(ShotError::NoSuchCamera { .. })));
    assert!(batch.render(&truck, &shot(None), 1).unwrap().0 == fresh(&truck, &shot(None)));
}

#[test]
fn automatic_exposure_starts_afresh_with_each_scene() {
    use penumbra::render::{AutoExposure, PostSettings};
    let settings = || RenderSettings {
        post: PostSettings { auto_exposure: Some(AutoExposure::default()), ..Default::default() },
        ..Default::default()
    };
    let load = |rel: &str| GltfScene::load(&asset(rel), &ImportOptions::default()).unwrap();
    // A bright scene, then a dark one: without a restart the dark one's first frame would start
    // from the bright one's adapted exposure.
    let (lit, dark) = (load("BoxTextured/BoxTextured.glb"), load("CesiumMilkTruckDraco/CesiumMilkTruck.gltf"));
    let bright = Environment { background: Background::Color([4.0, 4.0, 4.0]), ..Default::default() };
    let dim = Environment { background: Background::Color([0.01, 0.01, 0.01]), ..Default::default() };
    let fresh_auto = |scene: &GltfScene, shot: &ShotSettings| {
        let (mut app, size) = stage_scene(scene, shot).unwrap();
        render_frames(&mut app, Renderer::new(gpu(), settings()).unwrap(), size, 3).unwrap()
    };
    let mut batch = SceneBatch::new(Renderer::new(gpu(), settings()).unwrap());
    let first = shot(Some(bright));
    assert!(batch.render(&lit, &first, 3).unwrap().0 == fresh_auto(&lit, &first));
    let second = shot(Some(dim));
    assert!(batch.render(&dark, &second, 3).unwrap().0 == fresh_auto(&dark, &second), "the second scene's exposure");
}
