//! The golden frames that every backend must draw alike, built in one place: the sample models
//! (tests/goldens.rs), the environment goldens (tests/ibl.rs) and the shadow goldens
//! (tests/shadows.rs) take their frames from here, and tests/backend_parity.rs draws every one
//! of them again on wgpu's GL backend and holds it to the same golden.
//! [`check_golden_frame`] draws a frame and compares it: with the golden's threshold on the
//! driver that made the goldens (llvmpipe, which GL is in CI too), and on any other with the
//! threshold at the 99.9th percentile raised to what a 1/32-pixel camera turn changes the
//! frame by on llvmpipe ([`TURN_SENSITIVITY`], [`golden_tolerance`]).

use penumbra::engine::environment::Environment;
use penumbra::engine::import::{GltfScene, ImportOptions};
use penumbra::prelude::*;
use penumbra::render::features::environment::EnvironmentSettings;
use penumbra::render::features::shadows::{ShadowFilter, ShadowSettings};
use penumbra::render::headless::{CameraChoice, ShotSettings, render_frames, stage_scene};
use penumbra::render::{GpuContext, RenderSettings, Renderer};

use super::{
    Shot, Tolerance, asset, check_golden, flip_weighted_percentile, gpu, made_the_goldens, scene_app, spawn_mesh,
};

/// From the front-right and above, so three faces of a model show.
pub const THREE_QUARTER: CameraChoice = CameraChoice::THREE_QUARTER;
const FRONT: CameraChoice = CameraChoice::FRONT;

/// The sample-model goldens: (golden name, asset, camera), each at 256 × 256 with the default
/// settings.
pub const SAMPLE_MODELS: &[(&str, &str, CameraChoice)] = &[
    ("DamagedHelmet", "DamagedHelmet/DamagedHelmet.glb", FRONT),
    ("BoxTextured", "BoxTextured/BoxTextured.glb", THREE_QUARTER),
    ("MetalRoughSpheresNoTextures", "MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.glb", FRONT),
    ("NormalTangentMirrorTest", "NormalTangentMirrorTest/NormalTangentMirrorTest.glb", FRONT),
    ("NormalTangentTest", "NormalTangentTest/NormalTangentTest.glb", FRONT),
    ("AlphaBlendModeTest", "AlphaBlendModeTest/AlphaBlendModeTest.glb", FRONT),
    ("OrientationTest", "OrientationTest/OrientationTest.glb", THREE_QUARTER),
    ("TextureCoordinateTest", "TextureCoordinateTest/TextureCoordinateTest.glb", FRONT),
    ("TextureSettingsTest", "TextureSettingsTest/TextureSettingsTest.glb", FRONT),
    ("VertexColorTest", "VertexColorTest/VertexColorTest.glb", FRONT),
    ("CesiumMilkTruck", "CesiumMilkTruck/CesiumMilkTruck.glb", THREE_QUARTER),
    ("LightsPunctualLamp", "LightsPunctualLamp/LightsPunctualLamp.gltf", THREE_QUARTER),
    ("Cameras-0", "Cameras/Cameras.gltf", CameraChoice::Gltf(0)),
    ("Cameras-1", "Cameras/Cameras.gltf", CameraChoice::Gltf(1)),
    ("MultiUVTest", "MultiUVTest/MultiUVTest.glb", FRONT),
    ("UnlitTest", "UnlitTest/UnlitTest.glb", FRONT),
    ("MeshPrimitiveModes", "MeshPrimitiveModes/MeshPrimitiveModes.gltf", FRONT),
    ("TextureTransformTest", "TextureTransformTest/TextureTransformTest.gltf", FRONT),
    ("EmissiveStrengthTest", "EmissiveStrengthTest/EmissiveStrengthTest.glb", FRONT),
    ("BoxWithSpaces", "BoxWithSpaces/Box With Spaces.gltf", THREE_QUARTER),
    ("SimpleInstancing", "SimpleInstancing/SimpleInstancing.glb", THREE_QUARTER),
];

/// The defaults, with what the renderer would otherwise choose per adapter pinned: anisotropic
/// filtering off, as on the software rasteriser the goldens are made on, so that a GPU draws
/// the same frame.
pub fn golden_settings() -> RenderSettings {
    RenderSettings { max_anisotropy: Some(1), ..Default::default() }
}

/// A scene ready to draw one golden frame.
pub struct GoldenFrame {
    pub name: String,
    pub app: App,
    pub size: (u32, u32),
    pub settings: RenderSettings,
}

impl GoldenFrame {
    /// Draws the frame on `ctx` with a fresh renderer (the renderer stays in the app).
    pub fn render(&mut self, ctx: GpuContext) -> Shot {
        self.app.world.remove_resource::<Renderer>();
        let renderer = Renderer::new(ctx, self.settings.clone()).unwrap_or_else(|e| panic!("{}: {e}", self.name));
        let rgba8 =
            render_frames(&mut self.app, renderer, self.size, 1).unwrap_or_else(|e| panic!("{}: {e}", self.name));
        assert_eq!(self.app.world.resource::<Renderer>().shader_error(), None, "{}", self.name);
        Shot { width: self.size.0, height: self.size.1, rgba8 }
    }

    /// The frame with its camera turned to the right by `px` pixels at the image centre: a
    /// perspective camera about its own up axis, an orthographic one moved sideways.
    pub fn turned(mut self, px: f32) -> Self {
        let (width, height) = (self.size.0 as f32, self.size.1 as f32);
        let mut cameras = self.app.world.query::<(&Camera, &mut Transform)>();
        let mut found = 0;
        for (camera, mut transform) in cameras.iter_mut(&mut self.app.world) {
            found += 1;
            match camera.projection {
                Projection::Perspective { yfov, aspect_ratio, .. } => {
                    // A pixel at the centre spans 2·tan(xfov/2)/width of the image plane at
                    // distance 1, tan(xfov/2) being tan(yfov/2)·aspect.
                    let half_width = (yfov * 0.5).tan() * aspect_ratio.unwrap_or(width / height);
                    let angle = (2.0 * half_width * px / width).atan();
                    transform.rotation *= Quat::from_rotation_y(-angle);
                }
                Projection::Orthographic { xmag, ymag, .. } => {
                    let half_width = xmag.unwrap_or(ymag * width / height);
                    let right = transform.rotation * Vec3::X;
                    transform.translation += right * (2.0 * half_width * px / width);
                }
            }
        }
        assert!(found > 0, "{}: no camera to turn", self.name);
        self
    }
}

/// How far, in pixels at the image centre, a golden frame's camera turns to measure how much
/// the frame depends on sub-pixel rounding: half a step of the coarsest sub-pixel grid Vulkan
/// lets a driver rasterise on (4 bits, `subPixelPrecisionBits`; filtering may be as coarse,
/// `subTexelPrecisionBits`). An empirical allowance, not a bound on what two drivers differ
/// by: a turn moves every vertex alike, where drivers round each their own way.
pub const DRIVER_TURN_PX: f32 = 1.0 / 32.0;

/// Every frame of the golden suite: the sample models, the environment goldens and the shadow
/// goldens, each built afresh by its function.
pub fn golden_suite() -> Vec<Box<dyn Fn() -> GoldenFrame>> {
    let mut frames: Vec<Box<dyn Fn() -> GoldenFrame>> = Vec::new();
    for &(name, ..) in SAMPLE_MODELS {
        frames.push(Box::new(move || sample_model(name)));
    }
    for &name in ENVIRONMENT_GOLDENS {
        frames.push(Box::new(move || environment_golden(name)));
    }
    frames.push(Box::new(night_club));
    frames.push(Box::new(helmet_under_the_sun));
    frames
}

/// What each golden-suite frame changes by at FLIP's 99.9th percentile when its camera turns
/// [`DRIVER_TURN_PX`] to either side (the larger of the two; a horizontal turn, so edges
/// exactly on pixel columns may not move at all: Cameras-1), measured on llvmpipe, the
/// goldens' driver. On any other driver a frame's limit at that percentile is the larger of
/// this and the golden's own (see [`golden_tolerance`]). `tests/golden_compare.rs` measures
/// them again in CI and fails, printing the table anew, when one has moved.
pub const TURN_SENSITIVITY: &[(&str, f32)] = &[
    ("DamagedHelmet", 0.283),
    ("BoxTextured", 0.271),
    ("MetalRoughSpheresNoTextures", 0.363),
    ("NormalTangentMirrorTest", 0.341),
    ("NormalTangentTest", 0.299),
    ("AlphaBlendModeTest", 0.241),
    ("OrientationTest", 0.232),
    ("TextureCoordinateTest", 0.324),
    ("TextureSettingsTest", 0.491),
    ("VertexColorTest", 0.138),
    ("CesiumMilkTruck", 0.288),
    ("LightsPunctualLamp", 0.735),
    ("Cameras-0", 0.211),
    ("Cameras-1", 0.000),
    ("MultiUVTest", 0.320),
    ("UnlitTest", 0.152),
    ("MeshPrimitiveModes", 0.302),
    ("TextureTransformTest", 0.365),
    ("EmissiveStrengthTest", 0.281),
    ("BoxWithSpaces", 0.071),
    ("SimpleInstancing", 0.227),
    ("DamagedHelmet-studio", 0.253),
    ("MetalRoughSpheresNoTextures-studio", 0.216),
    ("MetalRoughSpheresNoTextures-sky", 0.289),
    ("SpecularTest-studio", 0.483),
    ("SpecGlossVsMetalRough-studio", 0.210),
    ("ClearCoatTest-studio", 0.293),
    ("SheenCloth-sky", 0.105),
    ("TransmissionTest-studio", 0.203),
    ("AttenuationTest-studio", 0.194),
    ("TransmissionRoughnessTest-studio", 0.391),
    ("AnisotropyStrengthTest-studio", 0.159),
    ("IridescenceSuzanne-sky", 0.668),
    ("IridescenceLamp-studio", 0.210),
    ("shadows_night_club", 0.370),
    ("shadows_damaged_helmet", 0.325),
];

/// The tolerance the golden `name` is held to on `ctx`: `tol` on the driver that made the
/// goldens (llvmpipe, through Vulkan or GL); elsewhere `tol` with its limit at the 99.9th
/// percentile raised to the frame's [`TURN_SENSITIVITY`] where that is larger, so a driver may
/// differ from llvmpipe there by as much as a 1/32-pixel camera turn changes on llvmpipe. The
/// limit comes from the goldens' driver, not from the driver under test, so a frame that a
/// driver breaks into noise does not widen its own limit. The mean's limit stays: an error
/// fails once its area times its FLIP error exceeds what the mean has left. Only the
/// golden-suite frames have an entry; other goldens keep `tol`.
pub fn golden_tolerance(ctx: &GpuContext, name: &str, tol: Tolerance) -> Tolerance {
    if made_the_goldens(ctx) {
        return tol;
    }
    debug_assert_eq!(tol.percentile, 0.999, "TURN_SENSITIVITY holds 99.9th percentiles");
    match TURN_SENSITIVITY.iter().find(|(n, _)| *n == name) {
        Some(&(_, sensitivity)) => tol.across_drivers(sensitivity),
        None => tol,
    }
}

/// What the frame `make` builds (`still`, already drawn on `ctx`) changes by at `percentile`
/// when its camera turns [`DRIVER_TURN_PX`] to either side: the larger of the two.
pub fn turn_sensitivity(ctx: &GpuContext, make: &dyn Fn() -> GoldenFrame, still: &Shot, percentile: f32) -> f32 {
    [DRIVER_TURN_PX, -DRIVER_TURN_PX]
        .map(|px| {
            let turned = make().turned(px).render(ctx.clone());
            flip_weighted_percentile(&still.rgba8, &turned.rgba8, still.width, still.height, percentile)
        })
        .into_iter()
        .fold(0.0f32, f32::max)
}

/// Draws the frame `make` builds on the test GPU and checks it against its golden with `tol`
/// ([`golden_tolerance`]); returns the drawn frame, its renderer in its app.
pub fn check_golden_frame(make: &dyn Fn() -> GoldenFrame, tol: Tolerance) -> GoldenFrame {
    let ctx = gpu();
    let mut frame = make();
    let shot = frame.render(ctx.clone());
    let tol = golden_tolerance(&ctx, &frame.name, tol);
    if !made_the_goldens(&ctx)
        && let Ok(golden) = image::open(super::golden_dir().join(format!("{}.png", frame.name)))
    {
        // For the record on other drivers (`--nocapture`): docs/quality.md lists these.
        let (golden, (w, h)) = (golden.into_rgba8(), frame.size);
        println!(
            "{} on {}: FLIP mean {:.5}, error-weighted {}th percentile {:.4} (limit {:.3})",
            frame.name,
            ctx.info.name,
            super::flip_mean(golden.as_raw(), &shot.rgba8, w, h),
            tol.percentile * 100.0,
            flip_weighted_percentile(golden.as_raw(), &shot.rgba8, w, h, tol.percentile),
            tol.at_percentile
        );
    }
    check_golden(&frame.name, &shot, tol);
    frame
}

fn staged(name: &str, rel: &str, camera: CameraChoice, size: (u32, u32), settings: RenderSettings) -> GoldenFrame {
    let scene = GltfScene::load(&asset(rel), &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    // Exposure pinned at EV100 0: these goldens are of the renderer's shading, not of the
    // default exposure (tests/defaults.rs has those).
    let shot = ShotSettings { size: Some(size), camera, exposure_ev100: Some(0.0), ..Default::default() };
    let (app, size) = stage_scene(&scene, &shot).unwrap_or_else(|e| panic!("{e}"));
    GoldenFrame { name: name.to_string(), app, size, settings }
}

/// The sample model of [`SAMPLE_MODELS`] called `name`.
pub fn sample_model(name: &str) -> GoldenFrame {
    let &(name, rel, camera) =
        SAMPLE_MODELS.iter().find(|(n, ..)| *n == name).unwrap_or_else(|| panic!("no sample golden {name}"));
    staged(name, rel, camera, (256, 256), golden_settings())
}

/// The environment goldens' names.
pub const ENVIRONMENT_GOLDENS: &[&str] = &[
    "DamagedHelmet-studio",
    "MetalRoughSpheresNoTextures-studio",
    "MetalRoughSpheresNoTextures-sky",
    "SpecularTest-studio",
    "SpecGlossVsMetalRough-studio",
    "ClearCoatTest-studio",
    "SheenCloth-sky",
    "TransmissionTest-studio",
    "AttenuationTest-studio",
    "TransmissionRoughnessTest-studio",
    "AnisotropyStrengthTest-studio",
    "IridescenceSuzanne-sky",
    "IridescenceLamp-studio",
];

/// A model under the default environment (the studio gradient, or with `-sky` the sky made
/// for a low sun from the front-left), 128² cubes.
pub fn environment_golden(name: &str) -> GoldenFrame {
    let (rel, sun) = match name {
        "DamagedHelmet-studio" => ("DamagedHelmet/DamagedHelmet.glb", false),
        "MetalRoughSpheresNoTextures-studio" => ("MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.glb", false),
        "MetalRoughSpheresNoTextures-sky" => ("MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.glb", true),
        "SpecularTest-studio" => ("SpecularTest/SpecularTest.glb", false),
        "SpecGlossVsMetalRough-studio" => ("SpecGlossVsMetalRough/SpecGlossVsMetalRough.gltf", false),
        "ClearCoatTest-studio" => ("ClearCoatTest/ClearCoatTest.glb", false),
        "SheenCloth-sky" => ("SheenCloth/SheenCloth.gltf", true),
        "TransmissionTest-studio" => ("TransmissionTest/TransmissionTest.glb", false),
        "AttenuationTest-studio" => ("AttenuationTest/AttenuationTest.glb", false),
        "TransmissionRoughnessTest-studio" => ("TransmissionRoughnessTest/TransmissionRoughnessTest.glb", false),
        "AnisotropyStrengthTest-studio" => ("AnisotropyStrengthTest/AnisotropyStrengthTest.glb", false),
        "IridescenceSuzanne-sky" => ("IridescenceSuzanne/IridescenceSuzanne.glb", false),
        "IridescenceLamp-studio" => ("IridescenceLamp/IridescenceLamp.gltf", false),
        _ => panic!("no environment golden {name}"),
    };
    let settings = RenderSettings {
        // Pinned, not left to the adapter: a GPU would make 512² cubes.
        environment: EnvironmentSettings { cube_size: Some(128), ..Default::default() },
        ..golden_settings()
    };
    let mut frame = staged(name, rel, FRONT, (256, 256), settings);
    if sun {
        // Low and from the front-left, so the sky has a bright side.
        frame.app.world.spawn((
            DirectionalLight { illuminance: 4.0, ..Default::default() },
            Transform::IDENTITY.looking_at(Vec3::new(1.0, -0.5, -1.0), Vec3::Y),
        ));
    }
    frame.app.insert_resource(Environment::default());
    frame
}

/// A directional light at `elevation` degrees above the horizon, shining from azimuth
/// `azimuth` degrees (0: from +Z toward −Z, 90: from +X toward −X).
pub fn sun(elevation: f32, azimuth: f32) -> Transform {
    let (e, a) = (elevation.to_radians(), azimuth.to_radians());
    let towards_light = Vec3::new(e.cos() * a.sin(), e.sin(), e.cos() * a.cos());
    let up = if elevation.abs() > 89.0 { Vec3::Z } else { Vec3::Y };
    Transform::from_translation(towards_light).looking_at(Vec3::ZERO, up)
}

pub fn grey(v: f32) -> StandardMaterial {
    StandardMaterial::from_color(Vec4::new(v, v, v, 1.0), 1.0)
}

fn shadow_golden(name: &str, app: App, size: (u32, u32), shadows: ShadowSettings) -> GoldenFrame {
    GoldenFrame {
        name: name.to_string(),
        app,
        size,
        settings: RenderSettings { msaa: 4, shadows, ..golden_settings() },
    }
}

/// "Night club": 200 coloured point lights over a floor with pillars and balls, four of them
/// casting cube shadows, under a dim moon with cascades.
pub fn night_club() -> GoldenFrame {
    let mut app = scene_app();
    spawn_mesh(&mut app, Mesh::plane(30.0), grey(0.6), Transform::default());
    let mut rng = penumbra::engine::scenes::SplitMix64(7);
    for i in 0..12 {
        let (x, z) = (rng.uniform(-8.0, 8.0), rng.uniform(-8.0, 4.0));
        let t = if i % 2 == 0 {
            Transform::from_xyz(x, 1.25, z).with_scale(Vec3::new(0.4, 2.5, 0.4))
        } else {
            Transform::from_xyz(x, 0.5, z).with_scale(Vec3::splat(0.5))
        };
        let mesh = if i % 2 == 0 { Mesh::cuboid(Vec3::ONE) } else { Mesh::uv_sphere(1.0, 24, 12) };
        spawn_mesh(&mut app, mesh, grey(0.7), t);
    }
    for i in 0..200 {
        let hue = rng.uniform(0.0, 360.0);
        let c = penumbra::engine::scenes::hsl_to_srgb(hue, 1.0, 0.5);
        let at = Vec3::new(rng.uniform(-10.0, 10.0), rng.uniform(0.3, 2.5), rng.uniform(-10.0, 6.0));
        let shadows = i % 50 == 0;
        let intensity = if shadows { 6.0 } else { 0.6 };
        app.world.spawn((
            PointLight {
                color: c.map(penumbra::engine::color::srgb_to_linear),
                intensity,
                range: Some(if shadows { 8.0 } else { 2.5 }),
                shadows,
            },
            Transform::from_translation(at),
        ));
    }
    let moon = DirectionalLight { color: Vec3::new(0.6, 0.7, 1.0), illuminance: 0.15, ..Default::default() };
    app.world.spawn((moon, sun(40.0, 200.0)));
    app.world
        .spawn((Camera::default(), Transform::from_xyz(0.0, 5.0, 12.0).looking_at(Vec3::new(0.0, 0.0, -1.0), Vec3::Y)));
    let small = ShadowSettings { atlas_size: 1024, local_map_size: 256, ..Default::default() };
    shadow_golden("shadows_night_club", app, (256, 160), small)
}

/// DamagedHelmet on a ground plane under a shadowed sun (PCSS).
pub fn helmet_under_the_sun() -> GoldenFrame {
    let mut app = scene_app();
    load_scene(&mut app.world, &asset("DamagedHelmet/DamagedHelmet.glb"), &ImportOptions::default()).unwrap();
    spawn_mesh(&mut app, Mesh::plane(10.0), grey(0.7), Transform::from_xyz(0.0, -1.0, 0.0));
    app.world.spawn((DirectionalLight { illuminance: 3.0, ..Default::default() }, sun(50.0, 35.0)));
    app.world.spawn(AmbientLight { color: Vec3::new(0.6, 0.7, 1.0), intensity: 0.15 });
    app.world
        .spawn((Camera::default(), Transform::from_xyz(1.2, 1.2, 4.0).looking_at(Vec3::new(0.0, -0.3, 0.0), Vec3::Y)));
    let pcss = ShadowSettings { atlas_size: 1024, filter: ShadowFilter::Pcss, ..Default::default() };
    shadow_golden("shadows_damaged_helmet", app, (256, 192), pcss)
}
