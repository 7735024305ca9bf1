//! What a file gets with no settings at all: the default camera and the default exposure, on
//! the scenes of tests/assets/Defaults (written by tools/default_scenes.py), each a case the
//! old defaults failed:
//! - SunLit: a 6,830 lux sun (a Blender export's 10 W/m²) rendered 99.8 % white at EV100 0;
//!   metered, it shows its shadows and colours.
//! - DimLamp: a 12 cd lamp, a few lux: exposed near EV100 0, not darkened further.
//! - FlatPlane: a plane in the XZ plane was seen exactly edge-on from the front; the raised
//!   three-quarter view shows it.
//! - Sweep: a box an animation carries 6 m sideways left the frame framed on its rest pose;
//!   framing spans the clip.
//! - Cameras: a file with a camera is looked at through it, unless it sees none of the scene.
//!
//! Staged as `penumbra render FILE` stages them: the default environment (`--env auto`), no
//! exposure, camera `auto`.

mod common;

use common::{Shot, Tolerance, asset, check_golden, gpu};
use penumbra::engine::environment::{Background, Environment};
use penumbra::engine::import::{GltfScene, ImportOptions};
use penumbra::render::headless::{CameraChoice, ShotSettings, StagedView, ViewSource, render_frames, stage_scene};
use penumbra::render::metering::ExposureChoice;
use penumbra::render::{RenderSettings, Renderer};

const SIZE: (u32, u32) = (128, 128);

fn defaults() -> ShotSettings {
    ShotSettings { size: Some(SIZE), environment: Some(Environment::default()), ..Default::default() }
}

/// Stages `rel` with `shot`, renders `frames` frames; returns the last and how the view was
/// chosen.
fn render(rel: &str, shot: &ShotSettings, frames: u32) -> (Shot, StagedView) {
    let scene = GltfScene::load(&asset(rel), &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let (mut app, size) = stage_scene(&scene, shot).unwrap_or_else(|e| panic!("{e}"));
    let view = app.world.resource::<StagedView>().clone();
    let renderer = Renderer::new(gpu(), RenderSettings::default()).unwrap_or_else(|e| panic!("{e}"));
    let rgba8 = render_frames(&mut app, renderer, size, frames).unwrap_or_else(|e| panic!("{e}"));
    (Shot { width: size.0, height: size.1, rgba8 }, view)
}

/// Fraction of pixels whose every channel is at least `level`.
fn fraction_at_least(shot: &Shot, level: u8) -> f32 {
    let n = shot.rgba8.chunks_exact(4).filter(|p| p[..3].iter().all(|&c| c >= level)).count();
    n as f32 / (shot.width * shot.height) as f32
}

#[test]
fn a_sun_of_thousands_of_lux_is_exposed_for() {
    let (shot, view) = render("Defaults/SunLit.gltf", &defaults(), 1);
    let ExposureChoice::Metered(m) = view.exposure else { panic!("not metered: {:?}", view.exposure) };
    // The sun's 6,830 lux (less the cosine of nothing: a meter faces the light) plus the sky
    // made for it.
    assert!(m.lights_lux > 6000.0 && m.lights_lux <= 6830.0 * 1.001, "{m:?}");
    assert!((m.ev100 - (m.lux() / 2.5).log2()).abs() < 1e-4 && (11.0..12.5).contains(&m.ev100), "{m:?}");
    // At EV100 0 this frame was 99.8 % white; metered, no surface clips.
    assert!(fraction_at_least(&shot, 250) < 0.01, "{} of the frame is white", fraction_at_least(&shot, 250));
    let at_zero = render("Defaults/SunLit.gltf", &ShotSettings { exposure_ev100: Some(0.0), ..defaults() }, 1).0;
    assert!(fraction_at_least(&at_zero, 250) > 0.9, "EV100 0 no longer shows the bug this test is about");
    check_golden("Default-SunLit", &shot, Tolerance::default());
}

#[test]
fn a_dim_lamp_is_exposed_for_too() {
    let (shot, view) = render("Defaults/DimLamp.gltf", &defaults(), 1);
    let ExposureChoice::Metered(m) = view.exposure else { panic!("not metered: {:?}", view.exposure) };
    // A few lux from the lamp and about two from the studio environment: close to EV100 0.
    assert!(m.lights_lux > 0.5 && m.lights_lux < 10.0, "{m:?}");
    assert!((-1.0..1.5).contains(&m.ev100), "{m:?}");
    check_golden("Default-DimLamp", &shot, Tolerance::default());
}

#[test]
fn a_scene_without_lights_keeps_ev100_zero() {
    let (_, view) = render("Defaults/FlatPlane.gltf", &defaults(), 1);
    assert_eq!(view.exposure, ExposureChoice::Unlit);
    assert_eq!(view.exposure.ev100(), 0.0);
    // A given exposure wins over the meter.
    let (_, view) = render("Defaults/SunLit.gltf", &ShotSettings { exposure_ev100: Some(3.0), ..defaults() }, 1);
    assert_eq!(view.exposure, ExposureChoice::Given { ev100: 3.0 });
}

/// Fraction of pixels that differ from the background's colour (the frame's top-left pixel).
fn covered(shot: &Shot) -> f32 {
    let bg = &shot.rgba8[..3];
    let n = shot.rgba8.chunks_exact(4).filter(|p| p[..3].iter().zip(bg).any(|(a, b)| a.abs_diff(*b) > 24)).count();
    n as f32 / (shot.width * shot.height) as f32
}

#[test]
fn a_flat_plane_is_never_seen_edge_on() {
    let (shot, view) = render("Defaults/FlatPlane.gltf", &defaults(), 1);
    assert!(matches!(view.camera, ViewSource::Framed { yaw: 35.0, pitch: 25.0, .. }), "{:?}", view.camera);
    check_golden("Default-FlatPlane", &shot, Tolerance::default());
    // Measured against a plain background (the environment's gradient is not the plane).
    let plain = Environment { background: Background::Color([0.0, 0.0, 0.0]), ..Default::default() };
    let shot = render("Defaults/FlatPlane.gltf", &ShotSettings { environment: Some(plain.clone()), ..defaults() }, 1).0;
    assert!(covered(&shot) > 0.2, "the plane covers {} of the frame", covered(&shot));
    // From the front, as before, it was a line.
    let front = ShotSettings { camera: CameraChoice::FRONT, environment: Some(plain), ..defaults() };
    let front = render("Defaults/FlatPlane.gltf", &front, 1).0;
    assert!(covered(&front) < 0.02, "front view: {}", covered(&front));
}

/// The box's pixels (red) as (min x, min y, max x, max y), or `None` if none are in frame.
fn red_box(shot: &Shot) -> Option<(u32, u32, u32, u32)> {
    let mut b: Option<(u32, u32, u32, u32)> = None;
    for (i, p) in shot.rgba8.chunks_exact(4).enumerate() {
        if p[0] > 100 && p[0] as u32 > 2 * p[1] as u32 + 20 {
            let (x, y) = (i as u32 % shot.width, i as u32 / shot.width);
            b = Some(b.map_or((x, y, x, y), |(a, c, d, e)| (a.min(x), c.min(y), d.max(x), e.max(y))));
        }
    }
    b
}

#[test]
fn an_animated_scene_is_framed_over_its_whole_clip() {
    // Frames 1, 61 and 121 at 60 Hz: the start, the middle and the end of the 2 s sweep.
    for frames in [1, 61, 121] {
        let (shot, _) = render("Defaults/Sweep.gltf", &defaults(), frames);
        let (x0, y0, x1, y1) = red_box(&shot).unwrap_or_else(|| panic!("frame {frames}: the box left the frame"));
        assert!(
            x0 > 0 && y0 > 0 && x1 < SIZE.0 - 1 && y1 < SIZE.1 - 1,
            "frame {frames}: the box touches the border ({x0}, {y0})-({x1}, {y1})"
        );
        if frames == 1 {
            check_golden("Default-Sweep-start", &shot, Tolerance::default());
        }
    }
    // Framed on the rest pose alone (a pose given), the end of the sweep is out of the frame.
    let posed = ShotSettings {
        animation: Some(penumbra::render::headless::AnimationShot { clip: None, time: 0.0 }),
        ..defaults()
    };
    let scene = GltfScene::load(&asset("Defaults/Sweep.gltf"), &ImportOptions::default()).unwrap();
    let (mut app, size) = stage_scene(&scene, &posed).unwrap();
    let renderer = Renderer::new(gpu(), RenderSettings::default()).unwrap();
    render_frames(&mut app, renderer, size, 1).unwrap();
    let mut q = app.world.query::<&mut penumbra::engine::animation::AnimationPlayer>();
    q.single_mut(&mut app.world).unwrap().seek(2.0).unwrap();
    app.update();
    let end = app.world.resource::<Renderer>().read_frame().unwrap();
    assert!(
        red_box(&Shot { width: size.0, height: size.1, rgba8: end }).is_none(),
        "the rest-pose framing holds the end"
    );
}

#[test]
fn a_files_camera_is_looked_through_first() {
    let (shot, view) = render("Cameras/Cameras.gltf", &ShotSettings { size: Some((256, 256)), ..defaults() }, 1);
    assert!(matches!(&view.camera, ViewSource::File { index: 0, count: 2, asked: false, .. }), "{:?}", view.camera);
    let asked = render(
        "Cameras/Cameras.gltf",
        &ShotSettings { size: Some((256, 256)), camera: CameraChoice::Gltf(0), ..defaults() },
        1,
    );
    assert_eq!(shot.rgba8, asked.0.rgba8, "auto and --camera 0 differ");
    assert!(view.camera.to_string().contains("camera 0"), "{}", view.camera);
}

#[test]
fn a_file_camera_that_sees_nothing_is_passed_over() {
    // FlatPlane with a camera 5 m above it looking straight up.
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(asset("Defaults/FlatPlane.gltf")).unwrap()).unwrap();
    json["cameras"] = serde_json::json!([{ "type": "perspective", "perspective": { "yfov": 0.8, "znear": 0.1 } }]);
    // Rotated +90° about X: the camera's −Z view turns to +Y.
    let s = std::f64::consts::FRAC_1_SQRT_2;
    json["nodes"].as_array_mut().unwrap().push(serde_json::json!({
        "camera": 0, "translation": [0.0, 5.0, 0.0], "rotation": [s, 0.0, 0.0, s]
    }));
    json["scenes"][0]["nodes"].as_array_mut().unwrap().push(serde_json::json!(1));
    let dir = common::scratch_dir("defaults-camera-away");
    let path = dir.join("away.gltf");
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    let scene = GltfScene::load(&path, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let (app, _) = stage_scene(&scene, &defaults()).unwrap();
    let view = app.world.resource::<StagedView>();
    assert!(matches!(view.camera, ViewSource::Framed { why, .. } if why.contains("sees none")), "{:?}", view.camera);
}
