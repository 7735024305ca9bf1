//! The visibility buffer (`Raster::Compute`, `features::visibility`) draws what the forward pass
//! draws. A scene built to stress a rasteriser (a ground plane reaching behind the eye, so the
//! near plane clips it; a box the near plane cuts; mirrored and double-sided surfaces seen from
//! behind; triangles from sub-pixel to view-filling; a textured, normal-mapped model; shadows,
//! local lights and an environment) is rendered both ways at MSAA 1 and 4 and compared, and so
//! are alpha-masked surfaces (cut out by the raster steps), skinned and morphed meshes
//! (rasterised from their GPU-deformed vertices) and hybrid frames (line and point meshes,
//! blended draws and gizmo lines drawn by the forward pass over the shaded samples; transmissive
//! draws seeing the shaded opaque colour). Frames without an opaque triangle mesh fall back to
//! the forward pass, and so does every frame on adapters without 64-bit atomics (GL); the plan
//! says which ran.

use penumbra::engine::material::UvTransform;
use penumbra::prelude::*;
use penumbra::render::Raster;
use penumbra::render::features::tonemap;
use penumbra::render::frame::Pass;
use penumbra::render::pipelines::shader_library::EMBEDDED;
use penumbra::render::{MsaaResolve, RenderSettings, Renderer, ShaderSource};

mod common;
use common::{
    assert_finite_hdr, asset, flip_mean, hdr_of, render_app, render_app_despite_shader_errors, scene_app, spawn_mesh,
};

const SIZE: (u32, u32) = (192, 112);

fn settings(msaa: u32, raster: Raster) -> RenderSettings {
    RenderSettings { msaa, raster, keep_hdr: true, max_anisotropy: Some(1), ..Default::default() }
}

/// Without HDR readback: the compute raster writes the displayed colour itself.
fn display_settings(msaa: u32, raster: Raster, resolve: MsaaResolve) -> RenderSettings {
    RenderSettings { keep_hdr: false, msaa_resolve: resolve, ..settings(msaa, raster) }
}

fn stress_scene() -> App {
    let mut app = scene_app();
    let colours = [Vec4::new(0.9, 0.25, 0.2, 1.0), Vec4::new(0.25, 0.8, 0.3, 1.0), Vec4::new(0.3, 0.4, 0.95, 1.0)];
    let mut paint: Vec<Handle<StandardMaterial>> = {
        let mut materials = app.world.resource_mut::<Assets<StandardMaterial>>();
        colours.into_iter().map(|c| materials.add(StandardMaterial::from_color(c, 0.5))).collect()
    };
    let (cube, sphere) = {
        let mut meshes = app.world.resource_mut::<Assets<Mesh>>();
        (meshes.add(Mesh::cuboid(Vec3::ONE)), meshes.add(Mesh::uv_sphere(0.5, 16, 10)))
    };
    let shiny = app.world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial {
        base_color: Vec4::new(0.95, 0.9, 0.8, 1.0),
        metallic: 1.0,
        roughness: 0.2,
        ..Default::default()
    });
    paint.push(shiny);
    // A ground far larger than the view, reaching behind the eye: the near plane clips its two
    // triangles, which cover most of the frame (the tile jobs).
    spawn_mesh(
        &mut app,
        Mesh::plane(400.0),
        StandardMaterial::from_color(Vec4::new(0.6, 0.6, 0.55, 1.0), 0.8),
        Transform::IDENTITY,
    );
    // Rows of cubes and spheres from near to far: triangles from many pixels to sub-pixel.
    let mut i = 0;
    for row in 0..12 {
        for col in -4i32..=4 {
            let z = -2.5 - row as f32 * 2.2;
            let at = Vec3::new(col as f32 * 1.4 + 0.3 * row as f32, 0.5, z);
            let mesh = if (row + col) % 2 == 0 { cube } else { sphere };
            let t = Transform::from_translation(at).with_rotation(Quat::from_rotation_y(0.4 * i as f32));
            app.world.spawn((Mesh3d(mesh), MeshMaterial3d(paint[i % paint.len()]), t));
            i += 1;
        }
    }
    // Mirrored (negative determinant: the front faces wind the other way on screen).
    app.world.spawn((
        Mesh3d(cube),
        MeshMaterial3d(paint[0]),
        Transform::from_xyz(-1.6, 1.4, -3.0).with_scale(Vec3::new(-0.6, 0.6, 0.6)),
    ));
    // A double-sided quad seen from behind, and a one-sided one seen from behind (culled).
    let back =
        StandardMaterial { double_sided: true, ..StandardMaterial::from_color(Vec4::new(0.9, 0.8, 0.2, 1.0), 0.4) };
    let face_away = Transform::from_xyz(1.2, 1.3, -2.6).with_rotation(Quat::from_rotation_x(-1.2));
    spawn_mesh(&mut app, Mesh::plane(0.8), back.clone(), face_away);
    spawn_mesh(
        &mut app,
        Mesh::plane(0.8),
        StandardMaterial { double_sided: false, ..back },
        Transform::from_xyz(2.4, 1.3, -2.6).with_rotation(Quat::from_rotation_x(-1.2)),
    );
    // A box the near plane cuts through, at the bottom left of the view.
    app.world.spawn((
        Mesh3d(cube),
        MeshMaterial3d(paint[1]),
        Transform::from_xyz(-0.25, 1.05, -0.1).with_scale(Vec3::splat(0.3)),
    ));
    // A textured, normal-mapped model.
    let helmet =
        load_scene(&mut app.world, &asset("DamagedHelmet/DamagedHelmet.glb"), &ImportOptions::default()).unwrap();
    app.world.entity_mut(helmet).insert(Transform::from_xyz(0.9, 1.2, -3.2).with_scale(Vec3::splat(0.6)));
    // Tiny cubes far away and a huge sphere on the horizon.
    for k in 0..20 {
        let t = Transform::from_xyz(-6.0 + 0.6 * k as f32, 0.3 + 0.05 * k as f32, -60.0).with_scale(Vec3::splat(0.04));
        app.world.spawn((Mesh3d(cube), MeshMaterial3d(paint[k % 3]), t));
    }
    app.world.spawn((
        Mesh3d(sphere),
        MeshMaterial3d(paint[2]),
        Transform::from_xyz(30.0, 10.0, -250.0).with_scale(Vec3::splat(60.0)),
    ));
    // Shadows, two local lights, ambient and a sky.
    app.world.spawn((
        DirectionalLight { illuminance: 4.0, shadows: true, ..Default::default() },
        Transform::from_xyz(0.5, 1.0, 0.4).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    for (x, c) in [(-1.5f32, Vec3::new(1.0, 0.5, 0.3)), (2.0, Vec3::new(0.3, 0.6, 1.0))] {
        app.world.spawn((
            PointLight { color: c, intensity: 3.0, range: Some(6.0), ..Default::default() },
            Transform::from_xyz(x, 1.2, -4.0),
        ));
    }
    app.world.spawn((
        Camera {
            projection: Projection::Perspective { yfov: 55f32.to_radians(), znear: 0.05, aspect_ratio: None },
            exposure: Exposure::unit(),
            ..Default::default()
        },
        Transform::from_xyz(0.0, 1.2, 0.0).looking_at(Vec3::new(0.0, 0.7, -6.0), Vec3::Y),
    ));
    app.insert_resource(Environment::default());
    app
}

fn visibility_supported(app: &App) -> bool {
    app.world.resource::<Renderer>().context().caps.visibility_raster
}

fn plan_runs(app: &App, pass: Pass) -> bool {
    app.world.resource::<Renderer>().stats().plan.runs(pass)
}

/// Renders the stress scene with `settings` (two frames: shadow maps and the environment
/// settle in the first).
fn render_with(settings: RenderSettings, tweak: impl FnOnce(&mut App)) -> (Vec<u8>, App) {
    let mut app = stress_scene();
    tweak(&mut app);
    render_app(&mut app, SIZE, settings.clone());
    let rgba = render_app(&mut app, SIZE, settings);
    (rgba, app)
}

/// Pixels whose largest channel difference exceeds `threshold` (of 255).
fn pixels_apart(a: &[u8], b: &[u8], threshold: u8) -> usize {
    a.chunks_exact(4)
        .zip(b.chunks_exact(4))
        .filter(|(p, q)| p.iter().zip(*q).any(|(x, y)| x.abs_diff(*y) > threshold))
        .count()
}

#[test]
fn compute_raster_draws_what_the_forward_pass_draws() {
    // HDR colour read back (then tonemapped by the tonemap pass) at MSAA 1 and 4, and the
    // displayed colour written by the shading pass itself: radiance and display resolves. The
    // forward pass resolves display colours only where nothing needs an HDR target, so that
    // frame shows a solid colour behind the scene instead of the environment.
    let configs = [
        ("HDR, MSAA 1", settings(1, Raster::Hardware), false),
        ("HDR, MSAA 4", settings(4, Raster::Hardware), false),
        ("display, MSAA 1", display_settings(1, Raster::Hardware, MsaaResolve::Radiance), false),
        ("display, MSAA 4, radiance resolve", display_settings(4, Raster::Hardware, MsaaResolve::Radiance), false),
        ("display, MSAA 4, display resolve", display_settings(4, Raster::Hardware, MsaaResolve::Display), true),
    ];
    for (name, hardware_settings, solid) in configs {
        let compute_settings = RenderSettings { raster: Raster::Compute, ..hardware_settings.clone() };
        let direct = !compute_settings.keep_hdr;
        let background = |app: &mut App| {
            if solid {
                app.insert_resource(Environment {
                    background: Background::Color([0.3, 0.4, 0.6]),
                    ..Default::default()
                });
            }
        };
        let (hardware, hw_app) = render_with(hardware_settings, background);
        assert!(plan_runs(&hw_app, Pass::OPAQUE) && !plan_runs(&hw_app, Pass::VISIBILITY_RASTER));
        assert_eq!(plan_runs(&hw_app, tonemap::PASS), !(direct && solid), "{name}");
        let (compute, app) = render_with(compute_settings, background);
        if !direct {
            assert_finite_hdr(&hdr_of(&app), "visibility buffer");
        }
        if !visibility_supported(&app) {
            // GL: no 64-bit atomics; the forward pass draws the frame.
            assert!(plan_runs(&app, Pass::OPAQUE) && !plan_runs(&app, Pass::VISIBILITY_RASTER));
            assert!(pixels_apart(&compute, &hardware, 0) == 0, "{name}: the fallback frame differs");
            continue;
        }
        assert!(plan_runs(&app, Pass::VISIBILITY_RASTER) && plan_runs(&app, Pass::VISIBILITY_SHADE), "{name}");
        assert!(!plan_runs(&app, Pass::OPAQUE) && !plan_runs(&app, Pass::BACKGROUND), "{name}");
        // The shading pass shows the environment and, without HDR readback, tonemaps itself.
        assert_eq!(plan_runs(&app, tonemap::PASS), !direct, "{name}");
        let flip = flip_mean(&hardware, &compute, SIZE.0, SIZE.1);
        let apart = pixels_apart(&hardware, &compute, 24);
        let total = (SIZE.0 * SIZE.1) as usize;
        eprintln!("{name}: FLIP mean {flip:.5}, {apart} of {total} pixels more than 24/255 apart");
        // On lavapipe, with HDR colour, a fraction of the bound, and no pixel that far apart. The
        // displayed colour goes from f32 straight to 8 bits where the forward pass's frame went
        // through the f16 HDR target (or, resolving display colours, 8-bit samples) first:
        // pixels one or two steps apart, FLIP somewhat below the direct bound.
        let bound = if direct { 0.01 } else { 0.003 };
        assert!(flip < bound, "{name}: FLIP mean {flip} between the compute and hardware rasters");
        assert!(apart * 500 < total, "{name}: {apart} of {total} pixels differ by more than 24/255");
    }
}

/// Overlapping cards of about 20×20 pixels at many depths: each is larger than a thread
/// rasterises alone, so each becomes tile jobs.
fn cards() -> App {
    let mut app = scene_app();
    for k in 0..40 {
        let colour = Vec4::new(0.2 + 0.02 * k as f32, 0.9 - 0.02 * k as f32, 0.3 + 0.3 * (k % 2) as f32, 1.0);
        let at = Vec3::new(-1.5 + 0.08 * k as f32, -0.6 + 0.035 * k as f32, -4.0 - 0.05 * k as f32);
        let t = Transform::from_translation(at)
            .with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2 + 0.02 * k as f32));
        spawn_mesh(&mut app, Mesh::plane(0.5), StandardMaterial::from_color(colour, 0.6), t);
    }
    sun_and_camera(&mut app, Vec3::new(0.3, 0.5, 1.0));
    app
}

/// An unshadowed sun shining from `from` towards the origin, and a camera at the origin
/// looking down -Z.
fn sun_and_camera(app: &mut App, from: Vec3) {
    app.world.spawn((
        DirectionalLight { illuminance: 3.0, shadows: false, ..Default::default() },
        Transform::from_translation(from).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    app.world.spawn((Camera { exposure: Exposure::unit(), ..Default::default() }, Transform::IDENTITY));
}

#[test]
fn large_triangles_without_room_are_still_drawn() {
    let mut roomy = cards();
    let reference = render_app(&mut roomy, SIZE, settings(4, Raster::Compute));
    if !visibility_supported(&roomy) {
        return assert!(plan_runs(&roomy, Pass::OPAQUE));
    }
    // Room for 5 large triangles: the other cards' triangles rasterise whole in their own
    // threads.
    let mut squeezed = cards();
    squeezed.insert_resource(Renderer::new(common::gpu(), settings(4, Raster::Compute)).unwrap());
    squeezed.world.resource_mut::<Renderer>().set_visibility_large_triangle_capacity(5);
    let rgba = render_app(&mut squeezed, SIZE, settings(4, Raster::Compute));
    assert!(plan_runs(&squeezed, Pass::VISIBILITY_RASTER));
    let hardware = render_app(&mut cards(), SIZE, settings(4, Raster::Hardware));
    assert!(flip_mean(&hardware, &reference, SIZE.0, SIZE.1) < 0.01, "the cards differ from the forward pass's");
    let apart = pixels_apart(&rgba, &reference, 0);
    assert!(apart == 0, "{apart} pixels changed when large triangles' records did not fit");
}

/// A zigzag line mesh and a point mesh crossing opaque surfaces.
fn add_lines_and_points(app: &mut App) {
    let unlit = |c: Vec4| StandardMaterial { unlit: true, ..StandardMaterial::from_color(c, 1.0) };
    let zigzag: Vec<Vec3> =
        (0..12).map(|k| Vec3::new(-2.2 + 0.4 * k as f32, 0.4 + 0.5 * (k % 2) as f32, -3.4)).collect();
    let lines = Mesh {
        topology: Topology::LineList,
        positions: zigzag.windows(2).flat_map(|w| [w[0], w[1]]).collect(),
        ..Default::default()
    };
    spawn_mesh(app, lines, unlit(Vec4::new(1.0, 0.95, 0.2, 1.0)), Transform::IDENTITY);
    let points = Mesh {
        topology: Topology::PointList,
        positions: (0..60)
            .map(|k| Vec3::new(-2.5 + 0.09 * k as f32, 0.2 + 0.02 * k as f32, -3.0 - 0.03 * k as f32))
            .collect(),
        ..Default::default()
    };
    spawn_mesh(app, points, unlit(Vec4::new(0.1, 1.0, 1.0, 1.0)), Transform::IDENTITY);
}

/// Blended boxes (one half inside an opaque box, one in front of the helmet), one lit by a
/// small local light of its own (found through its pixel's cluster).
fn add_blended(app: &mut App) {
    app.world.spawn((
        PointLight { color: Vec3::new(1.0, 0.9, 0.6), intensity: 2.0, range: Some(0.35), ..Default::default() },
        Transform::from_xyz(0.9, 1.3, -1.95),
    ));
    for (k, (at, colour)) in [
        (Vec3::new(-1.9, 1.0, -3.0), Vec4::new(0.2, 0.5, 0.9, 0.5)),
        (Vec3::new(0.9, 1.3, -2.4), Vec4::new(0.9, 0.3, 0.6, 0.35)),
    ]
    .into_iter()
    .enumerate()
    {
        spawn_mesh(
            app,
            Mesh::cuboid(Vec3::splat(0.7 - 0.2 * k as f32)),
            StandardMaterial { alpha_mode: AlphaMode::Blend, ..StandardMaterial::from_color(colour, 0.5) },
            Transform::from_translation(at).with_rotation(Quat::from_rotation_y(0.5)),
        );
    }
}

/// Everything a hybrid frame's overlay draws, added to the stress scene: blended boxes, gizmo
/// lines (through the ground and the boxes), and line and point meshes.
fn add_hybrid_draws(app: &mut App) {
    add_blended(app);
    add_lines_and_points(app);
    let mut gizmos = Gizmos::default();
    gizmos.line(Vec3::new(-3.0, -0.5, -4.0), Vec3::new(3.0, 1.5, -6.0), Vec3::new(1.0, 0.9, 0.1));
    gizmos.line(Vec3::new(-2.5, 1.6, -3.5), Vec3::new(2.5, 0.2, -3.5), Vec3::new(0.1, 1.0, 0.4));
    app.insert_resource(gizmos);
}

#[test]
fn blended_draws_and_gizmos_are_drawn_over_the_visibility_buffer() {
    // A hybrid frame: opaque draws rasterised and shaded in compute, the forward pass drawing
    // the line and point meshes, blended boxes and gizmo lines into an overlay, each sample tested
    // against the visibility buffer's depth, composited by the shading pass. With HDR colour, and
    // with the displayed colour written by the shading pass (display resolve asked for: the
    // forward pass resolves radiance once blended draws need an HDR target, and so does this).
    // Blended boxes alone: the overlay covers only their part of the frame, and their lights and
    // shadows must be looked up at the frame's pixel, not the overlay's.
    let configs: [(&str, RenderSettings, fn(&mut App)); 4] = [
        ("HDR, MSAA 1", settings(1, Raster::Hardware), add_hybrid_draws),
        ("HDR, MSAA 4", settings(4, Raster::Hardware), add_hybrid_draws),
        ("display, MSAA 4", display_settings(4, Raster::Hardware, MsaaResolve::Display), add_hybrid_draws),
        ("HDR, MSAA 4, blended boxes alone", settings(4, Raster::Hardware), add_blended),
    ];
    for (name, hardware_settings, add) in configs {
        let ((hardware, hw_app), (compute, app), compute_settings) = both_rasters(hardware_settings, add);
        assert!(plan_runs(&hw_app, Pass::TRANSPARENT));
        assert!(plan_runs(&app, Pass::TRANSPARENT), "{name}");
        if !visibility_supported(&app) {
            assert!(plan_runs(&app, Pass::OPAQUE) && !plan_runs(&app, Pass::VISIBILITY_RASTER));
            continue;
        }
        assert!(plan_runs(&app, Pass::VISIBILITY_RASTER) && plan_runs(&app, Pass::VISIBILITY_OVERLAY));
        assert!(!plan_runs(&app, Pass::OPAQUE), "{name}");
        if compute_settings.keep_hdr {
            assert_finite_hdr(&hdr_of(&app), "hybrid frame");
        }
        // Without them, the frame differs where they are: they were drawn, and depth-tested
        // (the compared frames would differ if a line or box showed through a surface). Where a
        // line or a blended edge crosses an opaque edge, a composite over the pixel's mean
        // instead of each sample's own put 14 pixels more than 24/255 apart.
        assert_hybrid_matches(name, (&compute, &hardware), compute_settings, 100);
    }
}

/// The stress scene with `add` drawn with `hardware_settings`, then with the same settings but
/// rasterised in compute; and those settings.
fn both_rasters(
    hardware_settings: RenderSettings,
    add: fn(&mut App),
) -> ((Vec<u8>, App), (Vec<u8>, App), RenderSettings) {
    let compute_settings = RenderSettings { raster: Raster::Compute, ..hardware_settings.clone() };
    let hardware = render_with(hardware_settings, add);
    let compute = render_with(compute_settings.clone(), add);
    (hardware, compute, compute_settings)
}

/// Compares a hybrid frame rasterised in compute (drawn with `settings`) with the forward
/// pass's: its overlay's draws changed more than one pixel in `one_in` against the stress scene
/// without them; FLIP within 0.0012 with HDR colour and 0.012 with displayed colour (8 bits from
/// f32, where the forward pass's frame goes through the f16 target and the tonemap pass: pixels
/// one step apart all over the sky, which FLIP weighs); fewer than 1 pixel in 5000 more than
/// 24/255 apart, as each overlay sample is blended over its own sample's colour, the way
/// multisampled blending does.
fn assert_hybrid_matches(name: &str, (compute, hardware): (&[u8], &[u8]), settings: RenderSettings, one_in: usize) {
    let bound = if settings.keep_hdr { 0.0012 } else { 0.012 };
    let (plain, _) = render_with(settings, |_| {});
    let drawn = pixels_apart(compute, &plain, 24);
    let flip = flip_mean(hardware, compute, SIZE.0, SIZE.1);
    let apart = pixels_apart(hardware, compute, 24);
    let total = (SIZE.0 * SIZE.1) as usize;
    eprintln!("{name}: FLIP mean {flip:.5}, {apart} of {total} pixels more than 24/255 apart, {drawn} drawn over");
    assert!(drawn * one_in > total, "{name}: only {drawn} pixels changed with the overlay's draws");
    assert!(flip < bound, "{name}: FLIP mean {flip} between the compute and hardware rasters");
    assert!(apart * 5000 < total, "{name}: {apart} of {total} pixels differ by more than 24/255");
}

/// A transmissive box (seen through, tinted) and a rough transmissive sphere with a volume
/// (refracted and blurred), in front of the stress scene's boxes and ground.
fn add_transmissive(app: &mut App) {
    spawn_transmissive(app);
}

fn spawn_transmissive(app: &mut App) -> [Entity; 2] {
    let clear = spawn_mesh(
        app,
        Mesh::cuboid(Vec3::ONE),
        StandardMaterial { transmission: 0.9, ..StandardMaterial::from_color(Vec4::new(0.8, 0.9, 1.0, 1.0), 0.05) },
        Transform::from_xyz(-0.7, 0.8, -3.0).with_rotation(Quat::from_rotation_y(0.4)),
    );
    let volume = spawn_mesh(
        app,
        Mesh::uv_sphere(0.45, 24, 16),
        StandardMaterial {
            transmission: 1.0,
            thickness: 0.9,
            ior: 1.5,
            attenuation_color: Vec3::new(1.0, 0.7, 0.5),
            attenuation_distance: 1.0,
            ..StandardMaterial::from_color(Vec4::ONE, 0.35)
        },
        Transform::from_xyz(0.8, 0.7, -2.6),
    );
    [clear, volume]
}

#[test]
fn transmissive_draws_see_the_scene_the_visibility_buffer_shaded() {
    // A first shading writes the opaque colour into the transmission copy, the overlay's
    // transmissive draws read it, and the shading pass composites them: the frame the forward
    // pass draws, with HDR colour (MSAA 1 and 4) and with the displayed colour asked for.
    let with_blended = |app: &mut App| {
        add_transmissive(app);
        add_blended(app);
    };
    let configs: [(&str, RenderSettings, fn(&mut App)); 4] = [
        ("HDR, MSAA 1", settings(1, Raster::Hardware), add_transmissive),
        ("HDR, MSAA 4", settings(4, Raster::Hardware), add_transmissive),
        ("display, MSAA 4", display_settings(4, Raster::Hardware, MsaaResolve::Display), add_transmissive),
        ("HDR, MSAA 4, with blended boxes", settings(4, Raster::Hardware), with_blended),
    ];
    for (name, hardware_settings, add) in configs {
        let ((hardware, hw_app), (compute, app), compute_settings) = both_rasters(hardware_settings, add);
        assert!(plan_runs(&hw_app, Pass::TRANSMISSION) && plan_runs(&hw_app, Pass::OPAQUE), "{name}");
        if !visibility_supported(&app) {
            assert!(plan_runs(&app, Pass::OPAQUE) && !plan_runs(&app, Pass::VISIBILITY_RASTER));
            continue;
        }
        let plan = &app.world.resource::<Renderer>().stats().plan;
        let at = |pass| plan.passes.iter().position(|(p, _)| *p == pass).unwrap_or_else(|| panic!("{name}: {pass:?}"));
        assert!(!plan.runs(Pass::OPAQUE), "{name}");
        assert!(at(Pass::VISIBILITY_RASTER) < at(Pass::VISIBILITY_SHADE), "{name}");
        assert!(at(Pass::VISIBILITY_SHADE) < at(Pass::TRANSMISSION), "{name}");
        assert!(at(Pass::TRANSMISSION) < at(Pass::VISIBILITY_OVERLAY), "{name}");
        // Displayed colour asked for: the shading pass writes it, no tonemap pass runs.
        assert_eq!(plan.runs(tonemap::PASS), compute_settings.keep_hdr, "{name}");
        if compute_settings.keep_hdr {
            assert_finite_hdr(&hdr_of(&app), "hybrid frame with transmission");
        }
        // Pixels of one triangle reuse the first shading's colour, the others (where an opaque
        // silhouette in front of a transmissive surface crosses a pixel) are shaded again, each
        // overlay sample over its own sample (over the pixel's mean instead: 27 pixels more than
        // 24/255 apart, FLIP 0.0032).
        assert_hybrid_matches(name, (&compute, &hardware), compute_settings, 50);
    }
}

#[test]
fn transmissive_hybrid_frames_follow_size_changes_and_come_and_go() {
    // One renderer across a size change, then with the transmissive draws removed and added
    // again: each frame equals a fresh renderer's (the copy, the overlay's groups and both
    // shadings' groups are made again or dropped, none left pointing at an old target).
    let settings = settings(4, Raster::Compute);
    let twice = |app: &mut App, size| {
        render_app(app, size, settings.clone());
        render_app(app, size, settings.clone())
    };
    let fresh = |size, transmissive: bool| {
        let mut app = stress_scene();
        if transmissive {
            add_transmissive(&mut app);
        }
        twice(&mut app, size)
    };
    let mut app = stress_scene();
    let glass = spawn_transmissive(&mut app);
    twice(&mut app, SIZE);
    if !visibility_supported(&app) {
        assert!(plan_runs(&app, Pass::OPAQUE) && !plan_runs(&app, Pass::VISIBILITY_RASTER));
        return;
    }
    assert!(plan_runs(&app, Pass::VISIBILITY_OVERLAY) && plan_runs(&app, Pass::TRANSMISSION));
    let small = (160, 96);
    let apart = pixels_apart(&twice(&mut app, small), &fresh(small, true), 0);
    assert_eq!(apart, 0, "after the size change");
    for e in glass {
        app.world.despawn(e);
    }
    let apart = pixels_apart(&twice(&mut app, SIZE), &fresh(SIZE, false), 0);
    assert_eq!(apart, 0, "without the transmissive draws");
    assert!(!plan_runs(&app, Pass::TRANSMISSION));
    spawn_transmissive(&mut app);
    let apart = pixels_apart(&twice(&mut app, SIZE), &fresh(SIZE, true), 0);
    assert_eq!(apart, 0, "with them again");
}

#[test]
fn frames_of_line_and_point_meshes_alone_are_drawn_by_the_forward_pass() {
    // Line and point meshes alone: nothing for the buffer to rasterise.
    let frame = |raster| {
        let mut app = scene_app();
        add_lines_and_points(&mut app);
        app.world.spawn((
            Camera { exposure: Exposure::unit(), ..Default::default() },
            Transform::from_xyz(0.0, 1.2, 0.0).looking_at(Vec3::new(0.0, 0.7, -6.0), Vec3::Y),
        ));
        let rgba = render_app(&mut app, SIZE, settings(4, raster));
        (rgba, app)
    };
    let (compute, app) = frame(Raster::Compute);
    assert!(plan_runs(&app, Pass::OPAQUE) && !plan_runs(&app, Pass::VISIBILITY_RASTER));
    let why = app.world.resource::<Renderer>().stats().plan.left_out();
    let (_, reason) = why.iter().find(|(p, _)| *p == Pass::VISIBILITY_RASTER).expect("left out");
    assert!(reason.contains("no opaque or masked triangle"), "{reason}");
    assert!(pixels_apart(&compute, &frame(Raster::Hardware).0, 0) == 0);
    assert!(compute.chunks_exact(4).any(|p| p[0] > 200 && p[1] > 200 && p[2] < 100), "the yellow lines are drawn");
}

#[test]
fn a_frame_of_blended_draws_only_draws_the_same_either_way() {
    // With --raster compute culling may run for one opaque instance; with none, the blended
    // draws must still read their own slots.
    let frame = |raster| {
        let mut app = scene_app();
        for (k, colour) in [Vec4::new(0.9, 0.2, 0.2, 0.6), Vec4::new(0.2, 0.4, 0.9, 0.5)].into_iter().enumerate() {
            let material =
                StandardMaterial { alpha_mode: AlphaMode::Blend, ..StandardMaterial::from_color(colour, 0.5) };
            spawn_mesh(
                &mut app,
                Mesh::cuboid(Vec3::ONE),
                material,
                Transform::from_xyz(-0.6 + 1.2 * k as f32, 0.0, -4.0),
            );
        }
        app.world.spawn((Camera { exposure: Exposure::unit(), ..Default::default() }, Transform::IDENTITY));
        let rgba = render_app(&mut app, SIZE, settings(4, raster));
        assert!(plan_runs(&app, Pass::TRANSPARENT) && !plan_runs(&app, Pass::VISIBILITY_RASTER));
        rgba
    };
    let hardware = frame(Raster::Hardware);
    assert!(hardware.chunks_exact(4).any(|p| p[0] > 150 && p[2] < 120), "the red cube is drawn");
    let apart = pixels_apart(&frame(Raster::Compute), &hardware, 0);
    assert!(apart == 0, "{apart} pixels differ");
}

/// A grey cube on the left and DamagedHelmet (normal-mapped) on the right, shaded in compute,
/// with shaders from `dir` if given.
fn cube_and_helmet(shaders: Option<&std::path::Path>, helmet: bool) -> (Vec<u8>, App) {
    let mut app = scene_app();
    spawn_mesh(
        &mut app,
        Mesh::cuboid(Vec3::ONE),
        StandardMaterial::from_color(Vec4::new(0.6, 0.6, 0.6, 1.0), 0.5),
        Transform::from_xyz(-1.2, 0.0, -4.0).with_rotation(Quat::from_rotation_y(0.5)),
    );
    if helmet {
        let root =
            load_scene(&mut app.world, &asset("DamagedHelmet/DamagedHelmet.glb"), &ImportOptions::default()).unwrap();
        app.world.entity_mut(root).insert(Transform::from_xyz(1.2, 0.0, -4.0).with_scale(Vec3::splat(0.8)));
    }
    app.world.spawn((
        DirectionalLight { illuminance: 3.0, shadows: false, ..Default::default() },
        Transform::from_xyz(0.3, 1.0, 0.5).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    app.world.spawn((Camera { exposure: Exposure::unit(), ..Default::default() }, Transform::IDENTITY));
    let shaders = match shaders {
        Some(dir) => ShaderSource::Folder { dir: dir.to_path_buf(), watch: false },
        None => ShaderSource::Embedded,
    };
    // A broken shader folder in one test: its frame is wanted as drawn.
    let rgba =
        render_app_despite_shader_errors(&mut app, SIZE, RenderSettings { shaders, ..settings(4, Raster::Compute) });
    (rgba, app)
}

#[test]
fn a_shading_variant_that_fails_leaves_the_others_drawn() {
    // The normal-mapped variant does not compile: the helmet's samples are not shaded (the
    // background shows there) and the cube's group still writes the whole frame.
    let dir = common::scratch_dir("visibility-broken-variant");
    for (file, source) in EMBEDDED {
        let source = if *file == "forward.wgsl" {
            source.replacen("#ifdef NORMAL_MAP\n", "#ifdef NORMAL_MAP\n    let broken: u32 = 1.5;\n", 1)
        } else {
            source.to_string()
        };
        std::fs::write(dir.join(file), source).unwrap();
    }
    let (broken, app) = cube_and_helmet(Some(&dir), true);
    if !visibility_supported(&app) {
        return assert!(plan_runs(&app, Pass::OPAQUE));
    }
    assert!(plan_runs(&app, Pass::VISIBILITY_SHADE));
    let error = app.world.resource::<Renderer>().shader_error().map(|e| e.to_string()).unwrap_or_default();
    assert!(error.contains("forward.wgsl"), "the failing variant is reported: {error:?}");
    let (cube_only, _) = cube_and_helmet(None, false);
    let left = |rgba: &[u8]| -> Vec<u8> {
        rgba.chunks_exact(SIZE.0 as usize * 4).flat_map(|row| row[..SIZE.0 as usize * 2].to_vec()).collect()
    };
    assert!(left(&cube_only).chunks_exact(4).any(|p| p[0] > 60), "the cube is in the left half");
    assert!(pixels_apart(&left(&broken), &left(&cube_only), 0) == 0, "the cube's half changed");
    let (whole, _) = cube_and_helmet(None, true);
    assert!(pixels_apart(&broken, &whole, 24) > 100, "the helmet was shaded after all");
}

/// A 32×32 texture whose alpha ramps up from its centre outwards and is striped, so that the
/// cutoff crosses texels at many angles; colour varies with the texel.
fn alpha_pattern(app: &mut App) -> Handle<Image> {
    let side = 32u32;
    let mut rgba = Vec::with_capacity((side * side * 4) as usize);
    for y in 0..side {
        for x in 0..side {
            let (u, v) = ((x as f32 + 0.5) / side as f32 - 0.5, (y as f32 + 0.5) / side as f32 - 0.5);
            let ring = (u * u + v * v).sqrt() * 2.0;
            let stripe = 0.5 + 0.5 * ((u + 0.6 * v) * 19.0).sin();
            let alpha = (0.35 * ring + 0.65 * stripe).clamp(0.0, 1.0);
            rgba.extend_from_slice(&[40 + 6 * x as u8, 220 - 6 * y as u8, 120, (alpha * 255.0).round() as u8]);
        }
    }
    app.world.resource_mut::<Assets<Image>>().add(Image::rgba8(side, side, rgba, "alpha pattern"))
}

/// Masked surfaces in front of an opaque wall: textured (as it is, and with a texture transform
/// on a double-sided card seen from behind), vertex-coloured, wholly cut out, wholly kept, one
/// filling much of the view (its triangles become tile jobs) and one behind an opaque box.
fn masked_scene() -> App {
    let mut app = scene_app();
    let pattern = alpha_pattern(&mut app);
    let masked = |base: Vec4, cutoff: f32| StandardMaterial {
        alpha_mode: AlphaMode::Mask(cutoff),
        double_sided: true,
        ..StandardMaterial::from_color(base, 0.6)
    };
    let facing = |x: f32, y: f32, z: f32, size: f32| {
        Transform::from_xyz(x, y, z)
            .with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
            .with_scale(Vec3::splat(size))
    };
    spawn_mesh(
        &mut app,
        Mesh::plane(12.0),
        StandardMaterial::from_color(Vec4::new(0.35, 0.3, 0.6, 1.0), 0.8),
        facing(0.0, 0.0, -7.0, 1.0),
    );
    let textured = StandardMaterial { base_color_texture: Some(TextureRef::new(pattern)), ..masked(Vec4::ONE, 0.5) };
    spawn_mesh(&mut app, Mesh::plane(1.0), textured.clone(), facing(-1.3, 0.6, -4.0, 1.1));
    let transformed = StandardMaterial {
        base_color_texture: Some(TextureRef {
            transform: UvTransform { offset: Vec2::new(0.2, -0.1), rotation: 0.4, scale: Vec2::new(2.0, 1.5) },
            ..TextureRef::new(pattern)
        }),
        ..masked(Vec4::new(1.0, 0.8, 0.6, 0.9), 0.4)
    };
    let behind = Transform::from_xyz(0.0, 0.6, -4.0)
        .with_rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2) * Quat::from_rotation_z(0.3));
    spawn_mesh(&mut app, Mesh::plane(1.1), transformed, behind);
    let mut coloured = Mesh::uv_sphere(0.5, 24, 16);
    coloured.colors = coloured.positions.iter().map(|p| Vec4::new(1.0, 0.6 + p.y, 0.4, 0.5 + 1.2 * p.x)).collect();
    spawn_mesh(&mut app, coloured, masked(Vec4::new(0.9, 0.9, 0.9, 1.0), 0.5), Transform::from_xyz(1.3, 0.6, -4.0));
    spawn_mesh(
        &mut app,
        Mesh::cuboid(Vec3::splat(0.7)),
        masked(Vec4::new(0.9, 0.2, 0.2, 0.3), 0.5),
        Transform::from_xyz(-1.3, -0.7, -4.0),
    );
    spawn_mesh(
        &mut app,
        Mesh::cuboid(Vec3::splat(0.7)),
        masked(Vec4::new(0.2, 0.9, 0.3, 0.8), 0.5),
        Transform::from_xyz(0.0, -0.7, -4.0),
    );
    // Near the eye, over the bottom right of the view.
    spawn_mesh(&mut app, Mesh::plane(1.0), textured.clone(), facing(0.55, -0.35, -1.2, 0.9));
    // Behind an opaque box: its samples are won before its alpha is tested.
    spawn_mesh(
        &mut app,
        Mesh::cuboid(Vec3::splat(0.5)),
        StandardMaterial::from_color(Vec4::new(0.8, 0.8, 0.3, 1.0), 0.5),
        Transform::from_xyz(1.3, -0.7, -3.6),
    );
    spawn_mesh(&mut app, Mesh::plane(1.0), textured, facing(1.3, -0.7, -4.5, 1.0));
    sun_and_camera(&mut app, Vec3::new(0.3, 0.6, 1.0));
    app
}

#[test]
fn masked_materials_are_cut_out_in_compute_as_in_the_forward_pass() {
    for msaa in [1, 4] {
        let hardware = render_app(&mut masked_scene(), SIZE, settings(msaa, Raster::Hardware));
        let mut app = masked_scene();
        let compute = render_app(&mut app, SIZE, settings(msaa, Raster::Compute));
        if !visibility_supported(&app) {
            assert!(plan_runs(&app, Pass::OPAQUE) && !plan_runs(&app, Pass::VISIBILITY_RASTER));
            continue;
        }
        assert!(plan_runs(&app, Pass::VISIBILITY_RASTER) && !plan_runs(&app, Pass::OPAQUE), "MSAA {msaa}");
        // The same scene with every surface opaque: what the alpha test must have cut away.
        let mut solid = masked_scene();
        let mut materials = solid.world.resource_mut::<Assets<StandardMaterial>>();
        let handles: Vec<_> = materials.iter().map(|(h, _)| h).collect();
        for h in handles {
            materials.get_mut(h).unwrap().alpha_mode = AlphaMode::Opaque;
        }
        let unmasked = render_app(&mut solid, SIZE, settings(msaa, Raster::Compute));
        let cut = pixels_apart(&compute, &unmasked, 24);
        let flip = flip_mean(&hardware, &compute, SIZE.0, SIZE.1);
        let apart = pixels_apart(&hardware, &compute, 24);
        let total = (SIZE.0 * SIZE.1) as usize;
        eprintln!("MSAA {msaa}: FLIP mean {flip:.5}, {apart} of {total} pixels more than 24/255 apart, {cut} cut out");
        assert!(cut * 10 > total, "MSAA {msaa}: only {cut} pixels were cut out");
        assert!(flip < 0.003, "MSAA {msaa}: FLIP mean {flip} between the compute and hardware rasters");
        assert!(apart * 500 < total, "MSAA {msaa}: {apart} of {total} pixels differ by more than 24/255");
    }
}

/// CesiumMan (skinned) beside AnimatedMorphCube (morph targets), both posed at `time` seconds,
/// drawn with `raster`.
fn deformed_frame(time: f32, raster: Raster) -> (Vec<u8>, App) {
    use penumbra::engine::import::GltfScene;
    use penumbra::render::headless::{CameraChoice, ShotSettings, stage_camera};
    let mut app = scene_app();
    app.insert_resource(Time::fixed_hz(60.0));
    for (file, at, scale) in [
        ("CesiumMan/CesiumMan.glb", Vec3::new(-0.45, 0.0, 0.0), 1.0),
        ("AnimatedMorphCube/AnimatedMorphCube.glb", Vec3::new(0.5, 0.6, 0.0), 0.25),
    ] {
        let scene = GltfScene::load(&asset(file), &ImportOptions::default()).unwrap();
        let root = scene.spawn(&mut app.world);
        let mut transform = app.world.get_mut::<Transform>(root).unwrap();
        transform.translation = at;
        transform.scale = Vec3::splat(scale);
        let mut player = app.world.get_mut::<AnimationPlayer>(root).unwrap();
        player.seek(time).unwrap();
        player.pause();
    }
    app.update();
    let shot =
        ShotSettings { size: Some(SIZE), camera: CameraChoice::Orbit { yaw: 30.0, pitch: 8.0 }, ..Default::default() };
    stage_camera(&mut app, &shot).unwrap();
    let rgba = render_app(&mut app, SIZE, settings(4, raster));
    (rgba, app)
}

#[test]
fn skinned_and_morphed_meshes_are_rasterised_in_compute_from_their_pose() {
    let mut frames = Vec::new();
    for time in [0.3, 1.1] {
        let (hardware, _) = deformed_frame(time, Raster::Hardware);
        let (compute, app) = deformed_frame(time, Raster::Compute);
        if !visibility_supported(&app) {
            assert!(plan_runs(&app, Pass::OPAQUE) && !plan_runs(&app, Pass::VISIBILITY_RASTER));
            return;
        }
        assert!(plan_runs(&app, Pass::VISIBILITY_RASTER) && !plan_runs(&app, Pass::OPAQUE), "at {time} s");
        assert!(plan_runs(&app, Pass::DEFORM), "the poses were computed on the GPU");
        let flip = flip_mean(&hardware, &compute, SIZE.0, SIZE.1);
        let apart = pixels_apart(&hardware, &compute, 24);
        let total = (SIZE.0 * SIZE.1) as usize;
        eprintln!("at {time} s: FLIP mean {flip:.5}, {apart} of {total} pixels more than 24/255 apart");
        assert!(flip < 0.003, "at {time} s: FLIP mean {flip} between the compute and hardware rasters");
        assert!(apart * 500 < total, "at {time} s: {apart} of {total} pixels differ by more than 24/255");
        frames.push(compute);
    }
    // Each pose drawn, not the bind pose twice.
    let moved = pixels_apart(&frames[0], &frames[1], 24);
    assert!(moved * 50 > (SIZE.0 * SIZE.1) as usize, "only {moved} pixels changed between the poses");
}
