//! The stability suite: extreme inputs render finite, bounded images. Scenes tiny and huge,
//! far from the origin, perfectly smooth surfaces lit by lights touching them, and NaN or
//! infinite values in geometry, materials and lights.

use penumbra::engine::framing::{framing_camera_from, world_bounds};
use penumbra::prelude::*;
use penumbra::render::RenderSettings;

mod common;
use common::{assert_finite_hdr, flip_mean, hdr_of, render_app, scene_app, spawn_mesh};

const SIZE: (u32, u32) = (96, 96);

fn settings() -> RenderSettings {
    RenderSettings { msaa: 4, ..Default::default() }
}

/// Three spheres and a floor, scaled by `scale` and moved by `offset`, framed by the
/// auto-framing camera, lit by a point light scaled with the scene (its intensity grows with
/// the square of the scale so the illuminance is the same).
fn reference_scene(scale: f32, offset: Vec3) -> App {
    let mut app = scene_app();
    let place = |p: Vec3| Transform::from_translation(offset + p * scale).with_scale(Vec3::splat(scale));
    for (i, metallic) in [0.0, 0.5, 1.0].into_iter().enumerate() {
        let m = StandardMaterial {
            base_color: Vec4::new(0.9, 0.6, 0.3, 1.0),
            metallic,
            roughness: 0.3,
            ..Default::default()
        };
        spawn_mesh(&mut app, Mesh::uv_sphere(0.5, 32, 16), m, place(Vec3::new(i as f32 * 1.2 - 1.2, 0.5, 0.0)));
    }
    spawn_mesh(&mut app, Mesh::plane(4.0), StandardMaterial::from_color(Vec4::splat(0.8), 0.8), place(Vec3::ZERO));
    app.world.spawn((
        PointLight { intensity: 40.0 * scale * scale, ..Default::default() },
        Transform::from_translation(offset + Vec3::new(1.0, 2.5, 2.0) * scale),
    ));
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.1 });
    app.update();
    let bounds = world_bounds(&mut app.world);
    let (camera, transform) = framing_camera_from(&bounds, Vec3::new(0.3, 0.5, 1.0), 45f32.to_radians(), 1.0);
    app.world.spawn((camera, transform));
    app
}

fn shot(scale: f32, offset: Vec3) -> (Vec<u8>, Vec<[f32; 4]>) {
    let mut app = reference_scene(scale, offset);
    let px = render_app(&mut app, SIZE, settings());
    (px, hdr_of(&app))
}

/// Measured: FLIP mean 0 (identical images) at every scale from 1e-6 to 1e6.
#[test]
fn tiny_and_huge_scenes_look_like_the_unit_scene() {
    let (unit, _) = shot(1.0, Vec3::ZERO);
    for scale in [1e-6, 1e-4, 1e-2, 1e2, 1e4, 1e6] {
        let (px, hdr) = shot(scale, Vec3::ZERO);
        assert_finite_hdr(&hdr, &format!("scale {scale}"));
        let e = flip_mean(&unit, &px, SIZE.0, SIZE.1);
        assert!(e < 0.02, "scale {scale}: FLIP mean {e} against the unit-scale scene");
    }
}

#[test]
fn far_from_the_origin_looks_like_at_the_origin() {
    let (origin, _) = shot(1.0, Vec3::ZERO);
    // f32 positions are spaced 1 mm apart at 10 km and 6 cm at 1000 km, so geometry moves by
    // up to half that; camera-relative shading must not lose more. Measured FLIP means: 0.0010
    // and 0.0023 at 10 km, 0.0040 at 100 km, 0.0096 at 1000 km.
    for offset in
        [Vec3::new(1e4, 0.0, 0.0), Vec3::new(-1e4, 1e4, 1e4), Vec3::new(1e5, 0.0, 0.0), Vec3::new(1e6, 0.0, 0.0)]
    {
        let (px, hdr) = shot(1.0, offset);
        assert_finite_hdr(&hdr, &format!("offset {offset}"));
        let e = flip_mean(&origin, &px, SIZE.0, SIZE.1);
        assert!(e < 0.02, "offset {offset}: FLIP mean {e} against the scene at the origin");
    }
}

#[test]
fn smooth_surfaces_and_lights_touching_them_stay_finite() {
    let mut app = scene_app();
    for (i, metallic) in [0.0f32, 1.0].into_iter().enumerate() {
        let m = StandardMaterial { base_color: Vec4::ONE, metallic, roughness: 0.0, ..Default::default() };
        spawn_mesh(&mut app, Mesh::uv_sphere(1.0, 48, 24), m, Transform::from_xyz(i as f32 * 2.5 - 1.25, 0.0, 0.0));
    }
    // One light exactly on a sphere's surface, one a hair above it, one absurdly bright.
    for (p, intensity) in
        [(Vec3::new(-1.25, 0.0, 1.0), 1e3), (Vec3::new(1.25, 0.0, 1.0 + 1e-7), 1e3), (Vec3::new(0.0, 3.0, 2.0), 1e30)]
    {
        app.world.spawn((PointLight { intensity, ..Default::default() }, Transform::from_translation(p)));
    }
    app.world.spawn((
        SpotLight { intensity: 1e6, inner_cone_angle: 0.3, outer_cone_angle: 0.3, ..Default::default() },
        Transform::from_xyz(-1.25, 0.0, 1.0).looking_at(Vec3::new(-1.25, 0.0, 0.0), Vec3::Y),
    ));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 0.0, 6.0)));
    render_app(&mut app, SIZE, settings());
    assert_finite_hdr(&hdr_of(&app), "roughness 0 with touching lights");
}

#[test]
fn nan_and_infinity_in_inputs_never_reach_the_target() {
    let mut app = scene_app();
    let mut broken = Mesh::uv_sphere(1.0, 16, 8);
    for (i, n) in broken.normals.iter_mut().enumerate() {
        if i % 3 == 0 {
            *n = Vec3::NAN;
        }
    }
    broken.uv0[5] = Vec2::splat(f32::INFINITY);
    broken.positions[7] = Vec3::NAN;
    broken.tangents[9] = Vec4::NAN;
    spawn_mesh(&mut app, broken, StandardMaterial::from_color(Vec4::ONE, 0.5), Transform::from_xyz(-1.2, 0.0, 0.0));
    let nan_material = StandardMaterial {
        base_color: Vec4::new(f32::NAN, 1.0, 1.0, 1.0),
        roughness: f32::NAN,
        metallic: f32::INFINITY,
        emissive: Vec3::splat(f32::INFINITY),
        ..Default::default()
    };
    spawn_mesh(&mut app, Mesh::uv_sphere(1.0, 16, 8), nan_material, Transform::from_xyz(1.2, 0.0, 0.0));
    app.world
        .spawn((PointLight { intensity: f32::INFINITY, ..Default::default() }, Transform::from_xyz(0.0, 2.0, 2.0)));
    app.world.spawn((DirectionalLight { illuminance: f32::NAN, ..Default::default() }, Transform::IDENTITY));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 0.0, 6.0)));
    render_app(&mut app, SIZE, settings());
    assert_finite_hdr(&hdr_of(&app), "NaN inputs");
}

fn unit_camera(transform: Transform, znear: f32) -> (Camera, Transform) {
    let projection = Projection::Perspective { yfov: 45f32.to_radians(), znear, aspect_ratio: None };
    (Camera { projection, exposure: Exposure::unit(), ..Default::default() }, transform)
}

fn unlit(color: Vec3) -> StandardMaterial {
    StandardMaterial { unlit: true, ..StandardMaterial::from_color(color.extend(1.0), 1.0) }
}

/// A square of `size` facing +Z at `center`.
fn facing_quad(app: &mut App, size: f32, center: Vec3, material: StandardMaterial) {
    let t = Transform::from_translation(center).with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2));
    spawn_mesh(app, Mesh::plane(size), material, t);
}

/// Reverse-Z keeps depth as precise relative to distance everywhere: with the near plane at
/// 1e-4, two walls a million units away and 100 units (1e-4 of their distance) apart never
/// z-fight, and a square 2e-4 in front of the camera still draws over both.
#[test]
fn a_near_plane_of_1e_minus_4_resolves_walls_a_million_units_away() {
    let mut app = scene_app();
    app.world.spawn(unit_camera(Transform::IDENTITY, 1e-4));
    facing_quad(&mut app, 2e6, Vec3::new(0.0, 0.0, -1e6), unlit(Vec3::X));
    facing_quad(&mut app, 4e6, Vec3::new(0.0, 0.0, -1e6 - 100.0), unlit(Vec3::Y));
    facing_quad(&mut app, 1e-4, Vec3::new(0.0, 0.0, -2e-4), unlit(Vec3::Z));
    render_app(&mut app, SIZE, RenderSettings { msaa: 1, keep_hdr: true, ..Default::default() });
    let hdr = hdr_of(&app);
    assert_finite_hdr(&hdr, "near plane 1e-4");
    let at = |x: u32, y: u32| hdr[(y * SIZE.0 + x) as usize];
    assert!(at(48, 48)[2] > 0.9 && at(48, 48)[0] < 0.01, "the square just past the near plane: {:?}", at(48, 48));
    for y in 0..SIZE.1 {
        for x in [0, 5, 90, 95] {
            let p = at(x, y);
            assert!(p[0] > 0.9 && p[1] < 0.01, "pixel ({x}, {y}) is {p:?}: the far wall behind showed through");
        }
    }
}

/// Roughness 0 and 1, metal and dielectric, black and white, each facing a sun from the
/// camera's side, and a floor seen at a grazing angle (N·V → 0): finite, and as bright as
/// the BRDF says where it can be checked.
#[test]
fn material_extremes_and_grazing_views_stay_finite_and_bounded() {
    let mut app = scene_app();
    let mut centres = Vec::new();
    for (i, (roughness, metallic, white)) in [
        (0.0, 0.0, true),
        (1.0, 0.0, true),
        (0.0, 1.0, true),
        (1.0, 1.0, true),
        (0.0, 0.0, false),
        (1.0, 0.0, false),
        (0.0, 1.0, false),
        (1.0, 1.0, false),
    ]
    .into_iter()
    .enumerate()
    {
        let base = if white { Vec4::ONE } else { Vec4::new(0.0, 0.0, 0.0, 1.0) };
        let m = StandardMaterial { base_color: base, roughness, metallic, ..Default::default() };
        let p = Vec3::new((i % 4) as f32 * 1.2 - 1.8, if i < 4 { 0.7 } else { -0.7 }, 0.0);
        spawn_mesh(&mut app, Mesh::uv_sphere(0.5, 48, 24), m, Transform::from_translation(p));
        centres.push(p);
    }
    // A floor whose far part the camera sees edge-on.
    spawn_mesh(
        &mut app,
        Mesh::plane(200.0),
        StandardMaterial::from_color(Vec4::ONE, 0.0),
        Transform::from_xyz(0.0, -1.5, 0.0),
    );
    app.world.spawn((
        DirectionalLight { illuminance: 1.0, shadows: false, ..Default::default() },
        Transform::from_xyz(0.0, 0.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    app.world.spawn(unit_camera(Transform::from_xyz(0.0, 0.0, 6.0), 0.1));
    let size = (160, 96);
    render_app(&mut app, size, settings());
    let hdr = hdr_of(&app);
    assert_finite_hdr(&hdr, "material extremes");
    // Sphere centres face the sun and the camera (N = L = V): a white rough dielectric gives
    // (1 − F0)/π of the sun's illuminance from its diffuse lobe plus a little specular.
    let camera_project = |p: Vec3| {
        let t = (45f32.to_radians() / 2.0).tan();
        let (ndc_x, ndc_y) = (p.x / ((6.0 - p.z) * t * size.0 as f32 / size.1 as f32), p.y / ((6.0 - p.z) * t));
        (((ndc_x * 0.5 + 0.5) * size.0 as f32) as u32, ((0.5 - ndc_y * 0.5) * size.1 as f32) as u32)
    };
    let at = |p: Vec3| {
        let (x, y) = camera_project(p + Vec3::Z * 0.5);
        let px = hdr[(y * size.0 + x) as usize];
        (px[0] + px[1] + px[2]) / 3.0
    };
    let lambert = 0.96 / std::f32::consts::PI;
    let white_rough = at(centres[1]);
    assert!((white_rough - lambert).abs() < 0.15 * lambert, "white rough dielectric: {white_rough}, about {lambert}");
    let black_rough_metal = at(centres[7]);
    assert!(black_rough_metal < 0.02, "a black metal reflects (nearly) nothing head-on: {black_rough_metal}");
    let black_rough_dielectric = at(centres[5]);
    assert!(
        black_rough_dielectric > 0.0 && black_rough_dielectric < 0.1 * white_rough,
        "a black dielectric keeps only its 4 % specular: {black_rough_dielectric}"
    );
}

/// A point light inside a closed sphere, a spot with a zero cone and a light of 1e9 cd: finite;
/// the zero-cone spot lights no more than the point its axis meets.
#[test]
fn lights_inside_surfaces_zero_cones_and_huge_intensities_stay_finite() {
    let mut app = scene_app();
    spawn_mesh(&mut app, Mesh::plane(10.0), StandardMaterial::from_color(Vec4::ONE, 0.8), Transform::IDENTITY);
    spawn_mesh(
        &mut app,
        Mesh::uv_sphere(0.5, 32, 16),
        StandardMaterial::from_color(Vec4::ONE, 0.5),
        Transform::from_xyz(-1.5, 0.5, 0.0),
    );
    app.world.spawn((PointLight { intensity: 50.0, ..Default::default() }, Transform::from_xyz(-1.5, 0.5, 0.0)));
    app.world.spawn((PointLight { intensity: 1e9, ..Default::default() }, Transform::from_xyz(2.0, 0.05, 0.0)));
    app.world.spawn(unit_camera(Transform::from_xyz(0.0, 4.0, 6.0).looking_at(Vec3::ZERO, Vec3::Y), 0.1));
    render_app(&mut app, SIZE, settings());
    assert_finite_hdr(&hdr_of(&app), "light inside a sphere, 1e9 cd");

    let mut app = scene_app();
    spawn_mesh(&mut app, Mesh::plane(10.0), StandardMaterial::from_color(Vec4::ONE, 0.8), Transform::IDENTITY);
    app.world.spawn((
        SpotLight { intensity: 1e6, inner_cone_angle: 0.0, outer_cone_angle: 0.0, ..Default::default() },
        Transform::from_xyz(0.0, 2.0, 0.0).looking_at(Vec3::ZERO, Vec3::Z),
    ));
    app.world.spawn(unit_camera(Transform::from_xyz(0.0, 4.0, 6.0).looking_at(Vec3::ZERO, Vec3::Y), 0.1));
    render_app(&mut app, SIZE, RenderSettings { clear_color: [0.0; 3], ..settings() });
    let hdr = hdr_of(&app);
    assert_finite_hdr(&hdr, "zero-cone spot");
    // What is left of the cone is a needle of light around the axis (the falloff's width is
    // clamped away from zero): nothing lights the floor beyond the pixels the axis meets.
    for (i, p) in hdr.iter().enumerate() {
        let (x, y) = ((i as u32 % SIZE.0) as i32 - 48, (i as u32 / SIZE.0) as i32 - 48);
        if x * x + y * y > 9 {
            assert!(p[0] < 1e-3, "a zero-cone spot lit pixel ({}, {}): {p:?}", x + 48, y + 48);
        }
    }
}

/// 10 000 point lights of 1 mcd at one spot light a floor exactly as one light of 10 cd:
/// every cluster there lists all of them.
#[test]
fn ten_thousand_lights_in_one_cluster_add_up() {
    let shot = |lights: &[(Vec3, f32)]| {
        let mut app = scene_app();
        spawn_mesh(&mut app, Mesh::plane(4.0), StandardMaterial::from_color(Vec4::ONE, 1.0), Transform::IDENTITY);
        for &(p, intensity) in lights {
            app.world.spawn((
                PointLight { intensity, range: Some(50.0), shadows: false, ..Default::default() },
                Transform::from_translation(p),
            ));
        }
        app.world.spawn(unit_camera(Transform::from_xyz(0.0, 3.0, 0.01).looking_at(Vec3::ZERO, Vec3::Y), 0.1));
        render_app(&mut app, (48, 48), RenderSettings { msaa: 1, keep_hdr: true, ..Default::default() });
        let stats = app.world.resource::<Renderer>().stats().clone();
        (hdr_of(&app), stats.local_lights)
    };
    let many: Vec<(Vec3, f32)> =
        (0..10_000).map(|i| (Vec3::new((i % 100) as f32 * 1e-5, 1.0, (i / 100) as f32 * 1e-5), 1e-3)).collect();
    let (hdr_many, count) = shot(&many);
    assert_eq!(count, 10_000);
    assert_finite_hdr(&hdr_many, "10 000 lights");
    let (hdr_one, _) = shot(&[(Vec3::new(5e-4, 1.0, 5e-4), 10.0)]);
    for (i, (a, b)) in hdr_many.iter().zip(&hdr_one).enumerate() {
        if b[0] > 0.01 {
            assert!((a[0] - b[0]).abs() <= 0.01 * b[0], "pixel {i}: {} from 10 000 lights, {} from one", a[0], b[0]);
        }
    }
}

/// A sun shining exactly along the view direction (both straight down, the degenerate case of
/// a look-at with a Y up vector) shades and shadows as one tilted by a thousandth of a radian.
#[test]
fn a_sun_parallel_to_the_view_direction_is_not_a_special_case() {
    let shot = |tilt: f32| {
        let mut app = scene_app();
        spawn_mesh(&mut app, Mesh::plane(20.0), StandardMaterial::from_color(Vec4::ONE, 0.8), Transform::IDENTITY);
        spawn_mesh(
            &mut app,
            Mesh::cuboid(Vec3::ONE),
            StandardMaterial::from_color(Vec4::ONE, 0.8),
            Transform::from_xyz(0.0, 1.5, 0.0),
        );
        let sun = Transform::from_rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2 + tilt));
        app.world.spawn((DirectionalLight { illuminance: 2.0, ..Default::default() }, sun));
        let camera =
            Transform::from_xyz(0.0, 8.0, 0.0).with_rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2));
        app.world.spawn(unit_camera(camera, 0.1));
        let px = render_app(&mut app, SIZE, settings());
        (px, hdr_of(&app))
    };
    let (straight, hdr) = shot(0.0);
    assert_finite_hdr(&hdr, "sun along the view");
    // The cube's shadow fills the centre of the floor around the cube's own top face.
    let centre = hdr[(48 * SIZE.0 + 48) as usize][0];
    let (tilted, _) = shot(1e-3);
    let e = flip_mean(&straight, &tilted, SIZE.0, SIZE.1);
    assert!(e < 0.02, "FLIP mean {e} between the sun straight down and tilted by 1e-3 rad");
    assert!(centre > 0.3, "the cube's top is lit: {centre}");
}

/// Standing inside a double-sided white sphere with a point light at its centre: every wall
/// point is lit head-on by E = I/r², so the inside looks uniform (no shadow acne from the
/// sphere casting onto itself, no hole in the light).
#[test]
fn a_camera_inside_a_lit_sphere_sees_it_evenly_lit() {
    let mut app = scene_app();
    let material = StandardMaterial { double_sided: true, ..StandardMaterial::from_color(Vec4::ONE, 1.0) };
    spawn_mesh(&mut app, Mesh::uv_sphere(2.0, 96, 48), material, Transform::IDENTITY);
    app.world.spawn((PointLight { intensity: 4.0, ..Default::default() }, Transform::IDENTITY));
    app.world
        .spawn(unit_camera(Transform::from_xyz(0.3, 0.2, 0.0).looking_at(Vec3::new(1.0, 0.5, 2.0), Vec3::Y), 0.05));
    render_app(&mut app, SIZE, settings());
    let hdr = hdr_of(&app);
    assert_finite_hdr(&hdr, "camera inside a sphere");
    let lum: Vec<f32> = hdr.iter().map(|p| (p[0] + p[1] + p[2]) / 3.0).collect();
    let (lo, hi) = lum.iter().fold((f32::MAX, 0.0f32), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    // Lambert with E = 4/2² = 1: about 0.96/π, give or take the rough specular lobe.
    assert!(lo > 0.25 && hi < 0.45, "inside the sphere radiance spans {lo}..{hi}, expected about 0.31 everywhere");
}

/// A glTF with NaN positions, zero-length normals and degenerate triangles imports with
/// warnings naming what was repaired, and renders finite.
#[test]
fn broken_vertex_data_is_repaired_at_import_and_reported() {
    let positions: [[f32; 3]; 9] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [f32::NAN, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [2.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [3.0, 1.0, 0.0],
    ];
    let normals: [[f32; 3]; 9] = [
        [0.0, 0.0, 1.0],
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
    ];
    let mut bytes = Vec::new();
    for v in positions.iter().chain(&normals).flatten() {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    use base64::Engine;
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1}}}}]}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 9, "type": "VEC3", "min": [0, 0, 0], "max": [3, 1, 0]}},
                {{"bufferView": 0, "byteOffset": 108, "componentType": 5126, "count": 9, "type": "VEC3"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 216}}],
  "buffers": [{{"byteLength": 216, "uri": "data:application/octet-stream;base64,{}"}}]}}"#,
        base64::engine::general_purpose::STANDARD.encode(&bytes)
    );
    let path = common::scratch_dir("broken_vertices").join("broken.gltf");
    std::fs::write(&path, json).unwrap();
    let scene = penumbra::engine::import::GltfScene::load(&path, &Default::default()).unwrap();
    let warnings = scene.warnings.join("\n");
    assert!(warnings.contains("replaced 2 non-finite or zero-length"), "{warnings}");
    assert!(warnings.contains("1 degenerate triangles"), "{warnings}");
    let mut app = scene_app();
    scene.spawn(&mut app.world);
    app.world.spawn((DirectionalLight::default(), Transform::from_xyz(0.0, 0.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y)));
    app.world.spawn(unit_camera(Transform::from_xyz(1.5, 0.5, 4.0), 0.1));
    render_app(&mut app, SIZE, settings());
    assert_finite_hdr(&hdr_of(&app), "repaired vertex data");
}

/// A quad facing +Z, normal-mapped with a flat normal map, with the given tangent at every
/// vertex (or none), imported through glTF.
fn normal_mapped_quad(
    name: &str,
    tangent: Option<[f32; 4]>,
    uv: Option<[f32; 2]>,
) -> penumbra::engine::import::GltfScene {
    let positions = [[-1.0f32, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]];
    let uvs = [[0.0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]].map(|c| uv.unwrap_or(c));
    let mut bytes = Vec::new();
    for v in positions.iter().flatten() {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    for _ in 0..4 {
        for c in [0.0f32, 0.0, 1.0] {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    for v in uvs.iter().flatten() {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    for _ in 0..4 {
        for c in tangent.unwrap_or([1.0, 0.0, 0.0, 1.0]) {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    let tangent_attribute = if tangent.is_some() { r#", "TANGENT": 3"# } else { "" };
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2{tangent_attribute}}},
     "indices": 4, "material": 0}}]}}],
  "materials": [{{"normalTexture": {{"index": 0}}, "pbrMetallicRoughness": {{"metallicFactor": 0, "roughnessFactor": 0.4}}}}],
  "textures": [{{"source": 0}}], "images": [{{"uri": "flat.png"}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]}},
    {{"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3"}},
    {{"bufferView": 0, "byteOffset": 96, "componentType": 5126, "count": 4, "type": "VEC2"}},
    {{"bufferView": 0, "byteOffset": 128, "componentType": 5126, "count": 4, "type": "VEC4"}},
    {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 192}}, {{"buffer": 0, "byteOffset": 192, "byteLength": 12}}],
  "buffers": [{{"byteLength": 204, "uri": "quad.bin"}}]}}"#
    );
    let dir = common::scratch_dir(name);
    std::fs::write(dir.join("quad.bin"), bytes).unwrap();
    image::RgbImage::from_pixel(4, 4, image::Rgb([128, 128, 255])).save(dir.join("flat.png")).unwrap();
    let path = dir.join("quad.gltf");
    std::fs::write(&path, json).unwrap();
    penumbra::engine::import::GltfScene::load(&path, &Default::default()).unwrap()
}

fn render_quad(scene: &penumbra::engine::import::GltfScene) -> (Vec<u8>, Vec<[f32; 4]>) {
    let mut app = scene_app();
    scene.spawn(&mut app.world);
    let sun = Transform::from_xyz(0.3, 0.4, 1.0).looking_at(Vec3::ZERO, Vec3::Y);
    app.world.spawn((DirectionalLight { illuminance: 2.0, ..Default::default() }, sun));
    app.world.spawn(unit_camera(Transform::from_xyz(0.0, 0.0, 3.0), 0.1));
    let px = render_app(&mut app, SIZE, settings());
    (px, hdr_of(&app))
}

/// Tangents parallel to the normals (with a normal map) gave the shader's tangent frame no
/// direction: black and white noise over the surface. They are rebuilt at import (MikkTSpace)
/// with a warning, and the quad renders as with good tangents; so does one whose UVs are all
/// one point (no direction to rebuild from), with a warning naming it.
#[test]
fn tangents_parallel_to_normals_are_rebuilt() {
    let good = normal_mapped_quad("tangents_good", Some([1.0, 0.0, 0.0, 1.0]), None);
    assert!(good.warnings.is_empty(), "{:?}", good.warnings);
    let (good_px, _) = render_quad(&good);
    let parallel = normal_mapped_quad("tangents_parallel", Some([0.0, 0.0, 1.0, 1.0]), None);
    let warnings = parallel.warnings.join("\n");
    assert!(warnings.contains("4 vertices had tangents parallel to their normals; rebuilt"), "{warnings}");
    let (px, hdr) = render_quad(&parallel);
    assert_finite_hdr(&hdr, "tangents parallel to normals");
    let e = flip_mean(&good_px, &px, SIZE.0, SIZE.1);
    assert!(e < 1e-3, "FLIP mean {e} against the quad with good tangents");

    let one_uv = normal_mapped_quad("tangents_one_uv", None, Some([0.5, 0.5]));
    let warnings = one_uv.warnings.join("\n");
    assert!(warnings.contains("zero area on every triangle"), "{warnings}");
    let (px, hdr) = render_quad(&one_uv);
    assert_finite_hdr(&hdr, "all UVs equal");
    let e = flip_mean(&good_px, &px, SIZE.0, SIZE.1);
    assert!(e < 1e-3, "FLIP mean {e} against the quad with good tangents");
}

/// A ground plane and a cube lit by a sun, seen from a three-quarter view.
fn sunlit_ground(ground: f32, sun: Quat) -> Vec<u8> {
    let mut app = scene_app();
    spawn_mesh(&mut app, Mesh::plane(ground), StandardMaterial::from_color(Vec4::ONE, 0.8), Transform::IDENTITY);
    spawn_mesh(
        &mut app,
        Mesh::cuboid(Vec3::ONE),
        StandardMaterial::from_color(Vec4::ONE, 0.8),
        Transform::from_xyz(0.0, 1.5, 0.0),
    );
    app.world.spawn((DirectionalLight { illuminance: 2.0, ..Default::default() }, Transform::from_rotation(sun)));
    app.world.spawn(unit_camera(Transform::from_xyz(6.0, 5.0, 8.0).looking_at(Vec3::ZERO, Vec3::Y), 0.1));
    render_app(&mut app, (160, 120), RenderSettings::default())
}

/// A sun exactly overhead drew false shadow streaks across a ground facing it (FLIP 0.084
/// against a sun tilted by a thousandth of a radian; now 1e-4): the ground's depth in the map
/// and its depth as a receiver are one surface computed two ways, and with no depth slope
/// there is nothing for the slope-scaled bias to hide. Receivers now move toward the light by a
/// few ulps of the casters' distance (`DEPTH_PRECISION_ULPS`).
#[test]
fn a_sun_straight_down_shadows_a_ground_as_one_slightly_tilted() {
    let down = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    let straight = sunlit_ground(20.0, down);
    let tilted = sunlit_ground(20.0, Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2 + 1e-3));
    let e = flip_mean(&straight, &tilted, 160, 120);
    assert!(e < 0.01, "FLIP mean {e} between the sun straight down and tilted by 1e-3 rad");
}

/// A ground a million metres wide shadowed the near half of itself (its corners, 7e5 m from the
/// camera, carry centimetres of f32 rounding into the cascades' stored depth); 2e5 m was clean.
/// Now both look like a 200 m ground under the same sun.
#[test]
fn a_ground_a_million_metres_wide_does_not_shadow_itself() {
    let sun = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2 + 0.3);
    let reference = sunlit_ground(200.0, sun);
    // Below the horizon only: beyond 200 m the smaller ground ends.
    let near_half = |px: &[u8]| px[px.len() / 2..].to_vec();
    for ground in [2e5, 1e6] {
        let px = sunlit_ground(ground, sun);
        let e = flip_mean(&near_half(&reference), &near_half(&px), 160, 60);
        assert!(e < 0.02, "ground {ground} m: FLIP mean {e} of the near half against a 200 m ground");
    }
}

/// A camera node scaled to zero on one axis (glTF allows zero scale) has no inverse: its view
/// was NaN and the frame empty. The view keeps the node's rotation and position.
#[test]
fn a_zero_scaled_camera_sees_what_an_unscaled_one_sees() {
    let shot = |scale: Vec3| {
        let mut app = reference_scene(1.0, Vec3::ZERO);
        let mut q = app.world.query::<(&Camera, &mut Transform)>();
        for (_, mut t) in q.iter_mut(&mut app.world) {
            t.scale = scale;
        }
        render_app(&mut app, SIZE, settings())
    };
    let unscaled = shot(Vec3::ONE);
    for scale in [Vec3::new(0.0, 1.0, 1.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(2.0, 0.5, 3.0)] {
        let e = flip_mean(&unscaled, &shot(scale), SIZE.0, SIZE.1);
        assert!(e < 1e-4, "camera scale {scale}: FLIP mean {e}");
    }
}
