//! Post-processing: bloom, FXAA and automatic exposure, each off unless asked for, checked for
//! what it must do and must not do.
//!
//! - bloom spreads a bright spot's light around it, falling off with distance, and leaves a
//!   uniform image unchanged (its mix is energy-preserving);
//! - FXAA turns a hard edge's two-valued staircase into intermediate values, keeps the image's
//!   mean, and moves a 1-sample image towards the 4-sample one;
//! - automatic exposure meters a uniform scene to the calibrated mid-grey in one frame, then
//!   adapts towards a new brightness at its rate per second, within its EV limits;
//! - goldens of DamagedHelmet under the studio environment with each, and with all three.

use std::sync::Arc;
use std::time::Duration;

use penumbra::prelude::*;
use penumbra::render::features::environment::EnvironmentSettings;
use penumbra::render::features::{bloom, fxaa};
use penumbra::render::{AutoExposure, BloomSettings, PostSettings};
use penumbra::render::{RenderSettings, Renderer};

mod common;
use common::{render_app, scene_app, spawn_mesh};

const SIZE: u32 = 64;

fn camera(app: &mut App) {
    app.world.spawn((
        Camera { exposure: Exposure::unit(), ..Default::default() },
        Transform::from_xyz(0.0, 0.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    app.insert_resource(Time::new(TimeMode::Fixed(Duration::from_millis(100))));
}

/// Black background (no environment, clear colour black), an unlit shape of radiance `l`.
fn unlit_scene(mesh: Mesh, l: f32, transform: Transform) -> App {
    let mut app = scene_app();
    let material = StandardMaterial { base_color: Vec4::new(l, l, l, 1.0), unlit: true, ..Default::default() };
    spawn_mesh(&mut app, mesh, material, transform);
    camera(&mut app);
    app
}

fn settings(post: PostSettings, msaa: u32) -> RenderSettings {
    RenderSettings { msaa, clear_color: [0.0; 3], post, ..Default::default() }
}

fn luma(px: &[u8], x: u32, y: u32) -> f32 {
    let i = ((y * SIZE + x) * 4) as usize;
    (px[i] as f32 + px[i + 1] as f32 + px[i + 2] as f32) / 3.0
}

#[test]
fn bloom_spreads_a_bright_spot_and_falls_off() {
    let bloom =
        PostSettings { bloom: Some(BloomSettings { strength: 0.2, ..Default::default() }), ..Default::default() };
    let render = |post| {
        let mut app = unlit_scene(Mesh::uv_sphere(0.05, 16, 8), 200.0, Transform::IDENTITY);
        let px = render_app(&mut app, (SIZE, SIZE), settings(post, 1));
        (px, app.world.resource::<Renderer>().stats().plan.clone())
    };
    let (plain, plan) = render(PostSettings::default());
    assert!(!plan.runs(bloom::PASS), "bloom is off by default");
    let (bloomed, plan) = render(bloom);
    assert!(plan.runs(bloom::PASS));
    let c = SIZE / 2;
    // Off the spot the plain image is black; with bloom, a glow that falls with distance.
    assert_eq!(luma(&plain, c + 6, c), 0.0);
    let near = luma(&bloomed, c + 4, c);
    let mid = luma(&bloomed, c + 8, c);
    let far = luma(&bloomed, c + 16, c);
    assert!(near > mid && mid > far && near > 20.0, "glow near {near}, mid {mid}, far {far}");
    assert!(luma(&bloomed, c, c) >= 250.0, "the spot itself stays bright");
}

#[test]
fn bloom_leaves_a_uniform_image_unchanged() {
    // A plane filling the view with radiance 0.5: the blur of a uniform image is itself.
    let render = |post| {
        let mut app = unlit_scene(
            Mesh::plane(40.0),
            0.5,
            Transform::from_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2)),
        );
        render_app(&mut app, (SIZE, SIZE), settings(post, 1))
    };
    let plain = render(PostSettings::default());
    let bloomed = render(PostSettings {
        bloom: Some(BloomSettings { strength: 1.0, ..Default::default() }),
        ..Default::default()
    });
    let centre = luma(&plain, SIZE / 2, SIZE / 2);
    assert!(centre > 100.0, "the plane fills the view: {centre}");
    for (a, b) in plain.iter().zip(&bloomed) {
        assert!((*a as i32 - *b as i32).abs() <= 1, "bloom changed a uniform image: {a} vs {b}");
    }
}

#[test]
fn fxaa_smooths_a_hard_edge_and_keeps_the_mean() {
    // A light square turned 20° (radiance below the tonemap's knee, so that averaging samples
    // in HDR, as MSAA's resolve does, is the reference): at one sample per pixel its edges are
    // staircases of two values.
    let square = || {
        unlit_scene(
            Mesh::plane(1.6),
            0.7,
            Transform::from_rotation(Quat::from_rotation_z(0.35) * Quat::from_rotation_x(std::f32::consts::FRAC_PI_2)),
        )
    };
    let plain = render_app(&mut square(), (SIZE, SIZE), settings(PostSettings::default(), 1));
    let mut app = square();
    let fxaa = render_app(&mut app, (SIZE, SIZE), settings(PostSettings { fxaa: true, ..Default::default() }, 1));
    assert!(app.world.resource::<Renderer>().stats().plan.runs(fxaa::PASS));
    let msaa = render_app(&mut square(), (SIZE, SIZE), settings(PostSettings::default(), 4));
    // Radiance 0.7 is below the neutral curve's knee: the square's pixels all read `white`.
    let white = luma(&plain, SIZE / 2, SIZE / 2) as u8;
    assert!(white > 150, "the square is at the centre: {white}");
    let grey = |px: &[u8]| px.chunks_exact(4).filter(|p| p[0] > 10 && p[0] < white - 10).count();
    assert!(grey(&plain) < 5, "one sample per pixel: hard edges ({} grey pixels)", grey(&plain));
    assert!(grey(&fxaa) > 40, "FXAA blends along the edges ({} grey pixels)", grey(&fxaa));
    let mean = |px: &[u8]| px.chunks_exact(4).map(|p| p[0] as f64).sum::<f64>() / (SIZE * SIZE) as f64;
    assert!((mean(&fxaa) - mean(&plain)).abs() < 0.02 * mean(&plain), "{} vs {}", mean(&fxaa), mean(&plain));
    let error = |px: &[u8]| {
        px.chunks_exact(4).zip(msaa.chunks_exact(4)).map(|(a, b)| (a[0] as f64 - b[0] as f64).abs()).sum::<f64>()
    };
    assert!(error(&fxaa) < 0.8 * error(&plain), "FXAA is nearer to MSAA 4: {} vs {}", error(&fxaa), error(&plain));
}

/// A uniform grey world: the background shows radiance `l` everywhere.
fn grey_world(l: f32) -> App {
    let mut app = scene_app();
    camera(&mut app);
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.0 });
    let black = Arc::new(EnvironmentImage::from_fn(8, 4, "black", |_| Vec3::ZERO));
    app.insert_resource(Environment { background: Background::Color([l; 3]), ..Environment::image(black) });
    app
}

#[test]
fn auto_exposure_meters_mid_grey_then_adapts_at_its_rate() {
    let auto = AutoExposure::default();
    let s = RenderSettings {
        msaa: 1,
        environment: EnvironmentSettings { cube_size: Some(32), specular_samples: Some(4) },
        post: PostSettings { auto_exposure: Some(auto.clone()), ..Default::default() },
        ..Default::default()
    };
    let mut app = grey_world(50.0);
    render_app(&mut app, (SIZE, SIZE), s.clone());
    let (scale, ev) = app.world.resource::<Renderer>().auto_exposure_state().unwrap();
    // EV100 = log2(L · 100 / 12.5); the histogram's bins are 0.094 EV wide.
    let expected_ev = (50.0f32 * 8.0).log2();
    assert!((ev - expected_ev).abs() < 0.1, "first frame meters EV {ev}, expected {expected_ev}");
    assert!((scale - 1.0 / (1.2 * 2f32.powf(ev))).abs() < 1e-3 * scale, "correction {scale} for camera exposure 1");
    // Four times brighter: one 0.1 s frame closes 1 − e^(−0.3) of the 2 EV gap.
    app.world.resource_mut::<Environment>().background = Background::Color([200.0; 3]);
    render_app(&mut app, (SIZE, SIZE), s.clone());
    let (_, ev2) = app.world.resource::<Renderer>().auto_exposure_state().unwrap();
    let want = ev + ((200.0f32 * 8.0).log2() - ev) * (1.0 - (-0.3f32).exp());
    assert!((ev2 - want).abs() < 0.1, "second frame EV {ev2}, expected {want}");
    // Limits hold.
    let mut dark = grey_world(1e-6);
    render_app(&mut dark, (SIZE, SIZE), s);
    let (_, ev3) = dark.world.resource::<Renderer>().auto_exposure_state().unwrap();
    assert_eq!(ev3, auto.min_ev100, "clamped at the lower limit");
}

#[test]
fn golden_damaged_helmet_with_bloom_fxaa_and_auto_exposure() {
    let post = PostSettings {
        bloom: Some(BloomSettings { strength: 0.1, ..Default::default() }),
        fxaa: true,
        auto_exposure: Some(AutoExposure::default()),
    };
    helmet_golden("DamagedHelmet-post", 1, post);
}

/// DamagedHelmet under the studio environment with one post-processing setting.
fn helmet_golden(name: &str, msaa: u32, post: PostSettings) {
    use penumbra::engine::import::{GltfScene, ImportOptions};
    use penumbra::render::headless::{ShotSettings, render_frames, stage_scene};
    let scene = GltfScene::load(&common::asset("DamagedHelmet/DamagedHelmet.glb"), &ImportOptions::default()).unwrap();
    let shot = ShotSettings {
        size: Some((256, 256)),
        camera: penumbra::render::headless::CameraChoice::FRONT,
        ..Default::default()
    };
    let (mut app, size) = stage_scene(&scene, &shot).unwrap();
    app.insert_resource(Environment::default());
    let settings = RenderSettings {
        msaa,
        environment: EnvironmentSettings { cube_size: Some(128), ..Default::default() },
        post,
        ..Default::default()
    };
    let renderer = Renderer::new(common::gpu(), settings).unwrap();
    let rgba8 = render_frames(&mut app, renderer, size, 1).unwrap();
    common::check_golden(name, &common::Shot { width: size.0, height: size.1, rgba8 }, common::Tolerance::default());
}

#[test]
fn golden_damaged_helmet_with_bloom() {
    let post =
        PostSettings { bloom: Some(BloomSettings { strength: 0.15, ..Default::default() }), ..Default::default() };
    helmet_golden("DamagedHelmet-bloom", 4, post);
}

#[test]
fn golden_damaged_helmet_with_fxaa_instead_of_msaa() {
    helmet_golden("DamagedHelmet-fxaa", 1, PostSettings { fxaa: true, ..Default::default() });
}

#[test]
fn golden_damaged_helmet_with_auto_exposure() {
    helmet_golden(
        "DamagedHelmet-auto-exposure",
        4,
        PostSettings { auto_exposure: Some(AutoExposure::default()), ..Default::default() },
    );
}
