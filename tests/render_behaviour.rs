//! Properties of the renderer that goldens alone would not pin down: pipelines compile once,
//! unchanged frames upload nothing, mirrored transforms keep their front faces, a material whose
//! image vanished still draws, and frames are deterministic.

use penumbra::prelude::*;
use penumbra::render::AlphaTest;
use penumbra::render::{RenderOutput, RenderSettings, Renderer};

mod common;
use common::{brightness, render_app, scene_app, spawn_mesh};

const SIZE: (u32, u32) = (64, 64);

fn lit_camera(app: &mut App, z: f32) {
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 0.0, z).looking_at(Vec3::ZERO, Vec3::Y)));
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 1.0 });
}

fn white() -> StandardMaterial {
    StandardMaterial::from_color(Vec4::ONE, 1.0)
}

/// A plane facing +Z (towards the camera) before any transform.
fn facing_quad() -> Mesh {
    let mut m = Mesh::plane(2.0);
    for p in &mut m.positions {
        *p = Vec3::new(p.x, -p.z, 0.0);
    }
    for n in &mut m.normals {
        *n = Vec3::Z;
    }
    m
}

fn settings() -> RenderSettings {
    RenderSettings { msaa: 1, ..Default::default() }
}

#[test]
fn pipelines_compile_once_and_unchanged_frames_upload_nothing() {
    let mut app = scene_app();
    lit_camera(&mut app, 4.0);
    let material = app.world.resource_mut::<Assets<StandardMaterial>>().add(white());
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
    // A second asset with the same content: the mesh pool stores it once, so it batches too.
    let twin = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
    let cubes: Vec<Entity> = [mesh, mesh, twin]
        .into_iter()
        .enumerate()
        .map(|(i, m)| {
            app.world.spawn((Mesh3d(m), MeshMaterial3d(material), Transform::from_xyz(i as f32 - 1.0, 0.0, 0.0))).id()
        })
        .collect();
    render_app(&mut app, SIZE, settings());
    let first = app.world.resource::<Renderer>().stats().clone();
    assert_eq!(first.instances, 3);
    assert_eq!(first.draw_calls, 1, "three cubes sharing mesh content and material are one instanced draw");
    assert_eq!(first.instance_bytes_uploaded, 3 * 64);
    render_app(&mut app, SIZE, settings());
    let second = app.world.resource::<Renderer>().stats().clone();
    assert_eq!(second.instance_bytes_uploaded, 0, "nothing changed, nothing uploaded");
    assert_eq!(second.pipelines, first.pipelines, "no pipeline was compiled twice");
    app.world.get_mut::<Transform>(cubes[1]).unwrap().translation.y = 0.5;
    render_app(&mut app, SIZE, settings());
    let third = app.world.resource::<Renderer>().stats().clone();
    assert_eq!(third.instance_bytes_uploaded, 64, "one moved entity, one instance record");
}

#[test]
fn mirrored_transforms_keep_their_front_faces() {
    for scale in [Vec3::new(-1.0, 1.0, 1.0), Vec3::new(1.0, -1.0, 1.0), Vec3::new(-1.0, -1.0, 1.0)] {
        let mut app = scene_app();
        lit_camera(&mut app, 4.0);
        spawn_mesh(&mut app, facing_quad(), white(), Transform::from_scale(scale));
        let px = render_app(&mut app, SIZE, settings());
        assert!(brightness(&px, SIZE.0, 32, 32) > 150.0, "scale {scale}: the quad was culled");
    }
    // A quad turned away is culled: single-sided materials show nothing from behind.
    let mut app = scene_app();
    lit_camera(&mut app, 4.0);
    spawn_mesh(&mut app, facing_quad(), white(), Transform::from_rotation(Quat::from_rotation_y(std::f32::consts::PI)));
    let px = render_app(&mut app, SIZE, settings());
    assert!(brightness(&px, SIZE.0, 32, 32) < 20.0, "a back face was drawn");
}

#[test]
fn double_sided_materials_light_their_back_faces() {
    let mut app = scene_app();
    lit_camera(&mut app, 4.0);
    let material = StandardMaterial { double_sided: true, ..white() };
    spawn_mesh(
        &mut app,
        facing_quad(),
        material,
        Transform::from_rotation(Quat::from_rotation_y(std::f32::consts::PI)),
    );
    let px = render_app(&mut app, SIZE, settings());
    assert!(brightness(&px, SIZE.0, 32, 32) > 150.0, "the back face of a double-sided quad is dark or missing");
}

#[test]
fn a_material_whose_image_vanished_draws_with_the_null_texture() {
    let mut app = scene_app();
    lit_camera(&mut app, 4.0);
    let image = app.world.resource_mut::<Assets<Image>>().add(Image::solid([0, 0, 0, 255], "black"));
    let material = StandardMaterial { base_color_texture: Some(TextureRef::new(image)), ..white() };
    spawn_mesh(&mut app, facing_quad(), material, Transform::IDENTITY);
    let black = render_app(&mut app, SIZE, settings());
    assert!(brightness(&black, SIZE.0, 32, 32) < 20.0, "the black texture was not applied");
    app.world.resource_mut::<Assets<Image>>().remove(image).unwrap();
    let white = render_app(&mut app, SIZE, settings());
    assert!(brightness(&white, SIZE.0, 32, 32) > 150.0, "without its image the draw must use the white null texture");
}

#[test]
fn frames_are_deterministic() {
    let shot = || {
        let mut app = scene_app();
        lit_camera(&mut app, 5.0);
        for i in 0..5 {
            let m = StandardMaterial {
                base_color: Vec4::new(0.2 * i as f32, 0.5, 0.8, 0.6),
                alpha_mode: AlphaMode::Blend,
                ..white()
            };
            spawn_mesh(
                &mut app,
                Mesh::uv_sphere(0.6, 24, 12),
                m,
                Transform::from_xyz(i as f32 * 0.4 - 0.8, 0.0, i as f32 * -0.3),
            );
        }
        render_app(&mut app, SIZE, RenderSettings::default())
    };
    assert_eq!(shot(), shot());
}

#[test]
fn blended_draws_are_sorted_back_to_front() {
    // A red quad in front of a green one, both half transparent: the front colour dominates.
    let mut app = scene_app();
    lit_camera(&mut app, 4.0);
    let blend = |c: Vec4| StandardMaterial { base_color: c, alpha_mode: AlphaMode::Blend, unlit: true, ..white() };
    // Spawned front first, so only sorting puts it last.
    spawn_mesh(&mut app, facing_quad(), blend(Vec4::new(1.0, 0.0, 0.0, 0.7)), Transform::from_xyz(0.0, 0.0, 0.5));
    spawn_mesh(&mut app, facing_quad(), blend(Vec4::new(0.0, 1.0, 0.0, 0.7)), Transform::from_xyz(0.0, 0.0, -0.5));
    let px = render_app(&mut app, SIZE, settings());
    let i = ((32 * SIZE.0 + 32) * 4) as usize;
    assert!(px[i] > px[i + 1], "green ended on top of red: {:?}", &px[i..i + 4]);
}

#[test]
fn changing_msaa_between_frames_rebuilds_what_depends_on_it() {
    let mut app = scene_app();
    lit_camera(&mut app, 4.0);
    spawn_mesh(&mut app, Mesh::cuboid(Vec3::ONE), white(), Transform::IDENTITY);
    render_app(&mut app, SIZE, RenderSettings { msaa: 4, ..Default::default() });
    app.world.resource_mut::<Renderer>().set_settings(settings()).unwrap();
    let px = render_app(&mut app, SIZE, settings());
    assert!(brightness(&px, SIZE.0, 32, 32) > 100.0);
    assert!(
        app.world.resource_mut::<Renderer>().set_settings(RenderSettings { msaa: 3, ..Default::default() }).is_err()
    );
}

/// An orthographic camera whose 64² view spans x and y from −1 to 1 (a pixel is 1/32 wide),
/// with HDR values equal to radiance.
fn ortho_app() -> App {
    let mut app = scene_app();
    app.world.spawn((
        Camera {
            projection: Projection::Orthographic { xmag: Some(1.0), ymag: 1.0, znear: 0.1, zfar: 10.0 },
            exposure: Exposure::unit(),
            ..Default::default()
        },
        Transform::from_xyz(0.0, 0.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    app
}

/// One frame of `app` over a black clear colour: its resolved radiance, row by row.
fn radiance_over_black(app: &mut App, msaa: u32) -> Vec<[f32; 4]> {
    let settings = RenderSettings { msaa, keep_hdr: true, clear_color: [0.0; 3], ..Default::default() };
    render_app(app, SIZE, settings);
    common::hdr_of(app)
}

/// Where a masked quad's alpha comes from; each ramps across the quad from left to right.
#[derive(Debug, Clone, Copy)]
enum AlphaRamp {
    /// Vertex colours: alpha x / 64 at pixel x.
    VertexColors,
    /// A base colour texture of 16 texels in a row (alpha 0, 1/15, .. 1, exact in 8 bits).
    Texture,
    /// The same through KHR_texture_transform (TRANSFORMED_UVS): 52 texels (alpha i / 51),
    /// half of them across the quad.
    TransformedTexture,
}

impl AlphaRamp {
    /// The alpha at pixel x (continuous, in pixels from the left edge).
    fn alpha_at(self, x: f32) -> f32 {
        match self {
            AlphaRamp::VertexColors => x / 64.0,
            // Texel i's centre sits at i + 0.5 texels; alpha is linear between centres.
            AlphaRamp::Texture => (16.0 * x / 64.0 - 0.5) / 15.0,
            AlphaRamp::TransformedTexture => (52.0 * 0.5 * x / 64.0 - 0.5) / 51.0,
        }
    }
}

/// The resolved radiance of pixel columns 31, 32 and 33 for a white, unlit, masked quad filling
/// a 64² orthographic view over black, its alpha ramping from left to right as `ramp` says.
/// Every row must agree (the quad's diagonal crosses the columns).
fn masked_ramp_columns(ramp: AlphaRamp, msaa: u32, cutoff: f32) -> [f32; 3] {
    let mut app = ortho_app();
    let mut quad = facing_quad();
    let mut material = StandardMaterial {
        unlit: true,
        alpha_mode: AlphaMode::Mask(cutoff),
        ..StandardMaterial::from_color(Vec4::ONE, 1.0)
    };
    let texels = |n: u32| Image {
        width: n,
        height: 1,
        rgba8: (0..n).flat_map(|i| [255, 255, 255, (i * 255 / (n - 1)) as u8]).collect(),
        label: "alpha ramp".into(),
        mips: None,
        compressed: None,
    };
    match ramp {
        AlphaRamp::VertexColors => {
            quad.colors = quad.positions.iter().map(|p| Vec4::new(1.0, 1.0, 1.0, (p.x + 1.0) / 2.0)).collect();
        }
        AlphaRamp::Texture => {
            let image = app.world.resource_mut::<Assets<Image>>().add(texels(16));
            material.base_color_texture = Some(TextureRef::new(image));
        }
        AlphaRamp::TransformedTexture => {
            let image = app.world.resource_mut::<Assets<Image>>().add(texels(52));
            let mut texture = TextureRef::new(image);
            texture.transform.scale = Vec2::new(0.5, 1.0);
            material.base_color_texture = Some(texture);
        }
    }
    spawn_mesh(&mut app, quad, material, Transform::IDENTITY);
    let hdr = radiance_over_black(&mut app, msaa);
    [31, 32, 33].map(|x| {
        let column: Vec<f32> = (0..SIZE.1 as usize).map(|y| hdr[y * SIZE.0 as usize + x][1]).collect();
        assert!(
            column.iter().all(|v| (v - column[0]).abs() < 1e-3),
            "{ramp:?}, MSAA {msaa}, cutoff {cutoff}: column {x} varies: {column:?}"
        );
        column[0]
    })
}

#[test]
fn masked_edges_cover_the_samples_whose_alpha_reaches_the_cutoff() {
    // Pixel 32's samples (the standard 4-sample positions) lie at x = 32.125, 32.375, 32.625 and
    // 32.875. Where the alpha crosses the cutoff decides how many of them are covered; a pixel
    // tested once, at its centre (32.5), is all or nothing.
    for ramp in [AlphaRamp::VertexColors, AlphaRamp::Texture, AlphaRamp::TransformedTexture] {
        for (crossing, covered) in [(32.2, 3.0), (32.45, 2.0), (32.7, 1.0)] {
            let cutoff = ramp.alpha_at(crossing);
            let [left, edge, right] = masked_ramp_columns(ramp, 4, cutoff);
            let what = format!("{ramp:?}, alpha crossing the cutoff at x = {crossing}");
            assert!(left < 1e-3 && (right - 1.0).abs() < 1e-3, "{what}: beside the edge {left}, {right}");
            assert!((edge - covered / 4.0).abs() < 2e-3, "{what}: edge pixel {edge}, expected {covered} of 4 samples");
            let [_, centre_only, _] = masked_ramp_columns(ramp, 1, cutoff);
            let expected = if crossing <= 32.5 { 1.0 } else { 0.0 };
            assert!((centre_only - expected).abs() < 1e-3, "{what}, MSAA 1: {centre_only}");
        }
    }
}

#[test]
fn masked_coverage_names_the_samples_it_tests() {
    // The quad's right edge runs through pixel column 32 at x = 32.25, and its alpha ramps down
    // the view (y / 64 in pixels) to cross the cutoff at y = 32.5. Pixel (32, 32)'s samples lie
    // at (x, y) = s0 (32.375, 32.125), s1 (32.875, 32.375), s2 (32.125, 32.625) and
    // s3 (32.625, 32.875): the edge covers s2 alone, the alpha s2 and s3, so one sample is both.
    // A mask whose bits named other samples (reversed, or x and y swapped) would cover none.
    let right = 32.25 / 32.0 - 1.0;
    let mut app = ortho_app();
    let mut quad = facing_quad();
    for p in &mut quad.positions {
        p.x = if p.x > 0.0 { right } else { p.x };
    }
    quad.colors = quad.positions.iter().map(|p| Vec4::new(1.0, 1.0, 1.0, (1.0 - p.y) / 2.0)).collect();
    let material = StandardMaterial {
        unlit: true,
        alpha_mode: AlphaMode::Mask(32.5 / 64.0),
        ..StandardMaterial::from_color(Vec4::ONE, 1.0)
    };
    spawn_mesh(&mut app, quad, material, Transform::IDENTITY);
    let hdr = radiance_over_black(&mut app, 4);
    let at = |x: usize, y: usize| hdr[y * SIZE.0 as usize + x][1];
    // (x, y, samples covered of 4): inside the quad, the alpha's two lower samples; below the
    // cutoff, the edge's one; above it, none.
    for (x, y, covered) in [(32, 32, 1.0), (31, 32, 2.0), (32, 33, 1.0), (31, 33, 4.0), (32, 31, 0.0), (33, 32, 0.0)] {
        assert!((at(x, y) - covered / 4.0).abs() < 2e-3, "pixel ({x}, {y}): {}, expected {covered} of 4", at(x, y));
    }
    let keys = app.world.resource::<Renderer>().forward_pipeline_keys();
    assert!(keys.iter().all(|k| k.alpha_test != AlphaTest::PerPixel), "{keys:?}");
}

#[test]
fn a_constant_alpha_is_tested_once_per_pixel() {
    // No texture, no vertex colours: every sample passes or fails alike.
    let mut app = ortho_app();
    let material = StandardMaterial {
        unlit: true,
        alpha_mode: AlphaMode::Mask(0.5),
        ..StandardMaterial::from_color(Vec4::new(1.0, 1.0, 1.0, 0.7), 1.0)
    };
    spawn_mesh(&mut app, facing_quad(), material, Transform::IDENTITY);
    let hdr = radiance_over_black(&mut app, 4);
    assert!(hdr.iter().all(|p| (p[1] - 1.0).abs() < 1e-3), "the quad covers the view");
    let keys = app.world.resource::<Renderer>().forward_pipeline_keys();
    assert!(keys.iter().all(|k| k.alpha_test == AlphaTest::PerPixel), "{keys:?}");
}

#[test]
fn a_mesh_removed_and_reinserted_in_one_frame_stays_drawn() {
    let mut app = scene_app();
    lit_camera(&mut app, 4.0);
    let e = spawn_mesh(&mut app, facing_quad(), white(), Transform::IDENTITY);
    render_app(&mut app, SIZE, settings());
    let mesh = *app.world.get::<Mesh3d>(e).unwrap();
    app.world.entity_mut(e).remove::<Mesh3d>();
    app.world.entity_mut(e).insert(mesh);
    let px = render_app(&mut app, SIZE, settings());
    assert!(brightness(&px, SIZE.0, 32, 32) > 150.0, "the re-inserted mesh vanished");
}

/// An entity that loses its placement (GlobalTransform) or visibility (InheritedVisibility)
/// while keeping its mesh or light stops drawing or lighting, and comes back when the component
/// does, also when it is removed and added back within one frame.
#[test]
fn losing_placement_or_visibility_removes_draws_and_lights() {
    let mut app = scene_app();
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 0.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y)));
    let mesh = spawn_mesh(&mut app, facing_quad(), white(), Transform::IDENTITY);
    let light = app
        .world
        .spawn((PointLight { intensity: 20.0, ..Default::default() }, Transform::from_xyz(0.0, 0.0, 2.0)))
        .id();
    let ambient = app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.2 }).id();
    let counts = |app: &App| {
        let r = app.world.resource::<Renderer>();
        (r.stats().draw_calls, r.light_store().count())
    };
    render_app(&mut app, SIZE, settings());
    assert_eq!(counts(&app), (1, 2));
    let placed = *app.world.get::<GlobalTransform>(light).unwrap();
    let drawn = *app.world.get::<GlobalTransform>(mesh).unwrap();
    app.world.entity_mut(light).remove::<GlobalTransform>();
    app.world.entity_mut(mesh).remove::<InheritedVisibility>();
    app.world.entity_mut(ambient).remove::<InheritedVisibility>();
    render_app(&mut app, SIZE, settings());
    assert_eq!(counts(&app), (0, 0), "unplaced light, hidden mesh and hidden ambient light are gone");
    app.world.entity_mut(light).insert(placed);
    app.world.entity_mut(mesh).insert(InheritedVisibility(true));
    app.world.entity_mut(ambient).insert(InheritedVisibility(true));
    render_app(&mut app, SIZE, settings());
    assert_eq!(counts(&app), (1, 2), "back when the components are");
    // Removed and added back within one frame: still there.
    app.world.entity_mut(mesh).remove::<GlobalTransform>();
    app.world.entity_mut(mesh).insert(drawn);
    app.world.entity_mut(light).remove::<GlobalTransform>();
    app.world.entity_mut(light).insert(placed);
    let px = render_app(&mut app, SIZE, settings());
    assert_eq!(counts(&app), (1, 2));
    assert!(brightness(&px, SIZE.0, 32, 32) > 50.0, "the quad is drawn and lit");
}

/// The built-in shapes (UV and ico spheres, cuboid, cylinder, cone, capsule, torus, plane) with a
/// checker texture, lit from the upper left: a golden that shows their normals (smooth shading,
/// sharp cap edges) and UVs (squares of even size, seams lined up).
#[test]
fn golden_primitives() {
    let mut app = scene_app();
    let checker: Vec<u8> = (0..64 * 64)
        .flat_map(|i| {
            let (x, y) = (i % 64, i / 64);
            if (x / 8 + y / 8) % 2 == 0 { [230, 230, 230, 255] } else { [40, 90, 200, 255] }
        })
        .collect();
    let image = app.world.resource_mut::<Assets<Image>>().add(Image {
        width: 64,
        height: 64,
        rgba8: checker,
        label: "checker".into(),
        mips: None,
        compressed: None,
    });
    let material =
        StandardMaterial { base_color_texture: Some(TextureRef::new(image)), roughness: 0.5, ..Default::default() };
    let shapes = [
        Mesh::uv_sphere(0.5, 24, 12),
        Mesh::ico_sphere(0.5, 2),
        Mesh::cuboid(Vec3::splat(0.8)),
        Mesh::cylinder(0.4, 0.9, 24),
        Mesh::cone(0.45, 0.9, 24),
        Mesh::capsule(0.3, 0.5, 24, 6),
        Mesh::torus(0.4, 0.15, 32, 12),
        Mesh::plane(0.9),
    ];
    for (i, mesh) in shapes.into_iter().enumerate() {
        let (x, y) = ((i % 4) as f32 * 1.3 - 1.95, if i < 4 { 0.7 } else { -0.7 });
        spawn_mesh(
            &mut app,
            mesh,
            material.clone(),
            Transform::from_xyz(x, y, 0.0).with_rotation(Quat::from_rotation_x(0.5)),
        );
    }
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 0.0, 6.0).looking_at(Vec3::ZERO, Vec3::Y)));
    app.world.spawn((
        DirectionalLight { illuminance: 3.0, ..Default::default() },
        Transform::default().looking_at(Vec3::new(0.5, -0.6, -0.6), Vec3::Y),
    ));
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.3 });
    let rgba8 = render_app(&mut app, (256, 128), settings());
    common::check_golden("primitives", &common::Shot { width: 256, height: 128, rgba8 }, common::Tolerance::default());
}

/// Extraction lists a changed entity once per frame, however many times a component came and
/// went since the last one (the renderer writes each listed entity's instance from one thread).
#[test]
fn a_changed_entity_is_listed_once_however_often_its_material_went() {
    let mut app = scene_app();
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
    let material = app.world.resource_mut::<Assets<StandardMaterial>>().add(white());
    let cube = app.world.spawn((Mesh3d(mesh), MeshMaterial3d(material), Transform::default())).id();
    app.update();
    app.world.entity_mut(cube).remove::<MeshMaterial3d>();
    app.world.entity_mut(cube).insert(MeshMaterial3d(material));
    app.world.entity_mut(cube).remove::<MeshMaterial3d>();
    app.update();
    let scene = app.world.resource::<penumbra::render::RenderScene>();
    assert_eq!(scene.changed_draws.iter().filter(|e| **e == cube).count(), 1, "{:?}", scene.changed_draws);
    assert_eq!(scene.draws.get(cube).map(|d| d.material), Some(None), "drawn with the default material");
}

/// The normals view shows world-space normals as colour (+X red, +Y green, +Z blue at the
/// sphere's right, top and middle); the UV view shows u in red and v in green, growing to the
/// right and downwards across a quad (glTF's v points down the image).
#[test]
fn normal_and_uv_debug_views_show_their_attribute() {
    use penumbra::render::DebugView;
    let px = |rgba: &[u8], x: u32, y: u32| -> [u8; 3] {
        let i = ((y * SIZE.0 + x) * 4) as usize;
        [rgba[i], rgba[i + 1], rgba[i + 2]]
    };
    let mut app = scene_app();
    lit_camera(&mut app, 4.0);
    spawn_mesh(&mut app, Mesh::uv_sphere(1.2, 48, 24), white(), Transform::default());
    let rgba = render_app(&mut app, SIZE, RenderSettings { debug_view: DebugView::Normals, ..settings() });
    let (middle, right, top) = (px(&rgba, 32, 32), px(&rgba, 50, 32), px(&rgba, 32, 14));
    assert!(middle[2] > 200 && middle[0].abs_diff(middle[1]) < 12, "middle (+Z) {middle:?}");
    assert!(right[0] > right[1] + 40 && right[0] > 180, "right (+X) {right:?}");
    assert!(top[1] > top[0] + 40 && top[1] > 180, "top (+Y) {top:?}");

    let mut app = scene_app();
    lit_camera(&mut app, 2.4);
    spawn_mesh(&mut app, facing_quad(), white(), Transform::default());
    let rgba = render_app(&mut app, SIZE, RenderSettings { debug_view: DebugView::Uvs, ..settings() });
    let (left, right) = (px(&rgba, 16, 32), px(&rgba, 48, 32));
    let (upper, lower) = (px(&rgba, 32, 16), px(&rgba, 32, 48));
    assert!(right[0] > left[0] + 40, "u grows to the right: {left:?} → {right:?}");
    assert!(lower[1] > upper[1] + 40, "v grows downwards: {upper:?} → {lower:?}");
    assert!(left[2] < 5 && right[2] < 5, "blue stays 0");
}

/// Gizmo lines are drawn over the scene but depth-tested against it: a line behind a cube is
/// hidden where the cube covers it, one in front crosses it; without lines the pass is left out.
/// With and without MSAA, and with local lights shaded by the compute pass (the lines then end
/// the composite pass instead of the forward pass).
#[test]
fn gizmo_lines_are_depth_tested_and_only_drawn_when_present() {
    use penumbra::render::LightWalk;
    use penumbra::render::frame::Pass;
    let variants = [
        (settings(), false),
        (RenderSettings { msaa: 4, ..Default::default() }, false),
        (RenderSettings { msaa: 4, light_walk: LightWalk::ClusteredCompute, ..Default::default() }, true),
    ];
    for (settings, deferred) in variants {
        let mut app = scene_app();
        lit_camera(&mut app, 4.0);
        spawn_mesh(&mut app, Mesh::cuboid(Vec3::ONE), white(), Transform::default());
        if deferred {
            app.world.spawn((PointLight { intensity: 2.0, ..Default::default() }, Transform::from_xyz(0.0, 2.0, 2.0)));
        }
        let (red, green) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        let mut gizmos = Gizmos::default();
        gizmos.line(Vec3::new(-2.0, 0.3, -1.0), Vec3::new(2.0, 0.3, -1.0), red);
        gizmos.line(Vec3::new(-2.0, -0.3, 1.0), Vec3::new(2.0, -0.3, 1.0), green);
        app.insert_resource(gizmos);
        let rgba = render_app(&mut app, SIZE, settings.clone());
        let column_has = |x: u32, want: fn([u8; 3]) -> bool| {
            (0..SIZE.1).any(|y| {
                let i = ((y * SIZE.0 + x) * 4) as usize;
                want([rgba[i], rgba[i + 1], rgba[i + 2]])
            })
        };
        // Dominant, not pure: with MSAA a one-pixel line covers part of a pixel's samples.
        let is_red = |p: [u8; 3]| p[0] as i32 > p[1] as i32 + 70 && p[0] as i32 > p[2] as i32 + 70;
        let is_green = |p: [u8; 3]| p[1] as i32 > p[0] as i32 + 70 && p[1] as i32 > p[2] as i32 + 70;
        let what = format!("MSAA {}, deferred {deferred}", settings.msaa);
        assert!(column_has(4, is_red) && column_has(60, is_red), "{what}: the line behind shows beside the cube");
        assert!(!column_has(32, is_red), "{what}: the line behind is hidden by the cube");
        assert!(column_has(32, is_green) && column_has(4, is_green), "{what}: the line in front crosses the cube");
        let plan = app.world.resource::<Renderer>().stats().plan.clone();
        assert!(plan.runs(Pass::GIZMOS), "{what}");
        // GL (WGPU_BACKEND=gl) has no deferred-lights pass: `Capabilities::deferred_lights`.
        assert_eq!(plan.runs(Pass::DEFERRED_LIGHTS), deferred && common::gpu().caps.deferred_lights, "{what}");

        app.world.resource_mut::<Gizmos>().clear();
        let rgba = render_app(&mut app, SIZE, settings);
        let coloured = rgba.chunks_exact(4).any(|p| is_red([p[0], p[1], p[2]]) || is_green([p[0], p[1], p[2]]));
        assert!(!coloured, "{what}: cleared lines stay");
        assert!(!app.world.resource::<Renderer>().stats().plan.runs(Pass::GIZMOS), "{what}: a pass without lines ran");
    }
}

#[test]
fn anisotropy_is_a_setting_that_applies_to_textures_already_bound() {
    // A fine checker on a floor seen at a grazing angle: trilinear filtering blurs its far rows
    // to grey, anisotropic filtering keeps their contrast. The texture has no transform, so it
    // is sampled with implicit derivatives as most material textures are: lavapipe (newer
    // releases) filters explicit gradients (KHR_texture_transform's path) without anisotropy.
    let mut app = scene_app();
    app.world
        .spawn((Camera::default(), Transform::from_xyz(0.0, 0.3, 4.0).looking_at(Vec3::new(0.0, 0.0, -4.0), Vec3::Y)));
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 1.0 });
    let side = 512u32;
    let rgba8 = (0..side * side)
        .flat_map(|i| if ((i % side) / 4 + (i / side) / 4).is_multiple_of(2) { [255u8; 4] } else { [0, 0, 0, 255] })
        .collect();
    let image = app.world.resource_mut::<Assets<Image>>().add(Image {
        width: side,
        height: side,
        rgba8,
        label: "checker".into(),
        mips: None,
        compressed: None,
    });
    let texture = penumbra::engine::material::TextureRef::new(image);
    let material = StandardMaterial { base_color_texture: Some(texture), unlit: true, ..white() };
    spawn_mesh(&mut app, Mesh::plane(16.0), material, Transform::IDENTITY);
    let size = (48, 32);
    let with = |app: &mut App, n: u16| {
        let s = RenderSettings { max_anisotropy: Some(n), ..settings() };
        if app.world.get_resource::<Renderer>().is_some() {
            app.world.resource_mut::<Renderer>().set_settings(s.clone()).unwrap();
        }
        render_app(app, size, s)
    };
    // Contrast of the floor's far rows (the horizon is at row 16; on lavapipe anisotropy 4 keeps
    // a fifth to twice as much as trilinear filtering there).
    let contrast = |px: &[u8]| {
        let rows: Vec<f32> = (18..24)
            .flat_map(|y| (0..size.0).map(move |x| (x, y)))
            .map(|(x, y)| brightness(px, size.0, x, y))
            .collect();
        let mean = rows.iter().sum::<f32>() / rows.len() as f32;
        (rows.iter().map(|v| (v - mean) * (v - mean)).sum::<f32>() / rows.len() as f32).sqrt()
    };
    let trilinear = with(&mut app, 1);
    let anisotropic = with(&mut app, 4);
    assert!(
        contrast(&anisotropic) > 1.15 * contrast(&trilinear),
        "anisotropy 4 keeps the far checks: contrast {} vs {}",
        contrast(&anisotropic),
        contrast(&trilinear)
    );
    assert_eq!(with(&mut app, 1), trilinear, "back to 1: the first frame again");
    let err =
        app.world.resource_mut::<Renderer>().set_settings(RenderSettings { max_anisotropy: Some(0), ..settings() });
    assert!(err.unwrap_err().to_string().contains("1..=16"));
    assert!(RenderSettings { max_anisotropy: Some(17), ..settings() }.validate().is_err());
}

/// An image that carries its mip chain (as imported images do, made on the decoding thread) is
/// uploaded with it; one without has its chain rendered on the GPU; both draw the same floor.
#[test]
fn mip_chains_made_on_the_cpu_draw_what_the_gpu_makes() {
    use penumbra::engine::mip_chain::{MipChain, MipLevel};
    let side = 64u32;
    // Noise of every colour, so that every level of the chain differs from its neighbours.
    let mut rng = penumbra::engine::scenes::SplitMix64(7);
    let rgba8: Vec<u8> = (0..side * side * 4).map(|_| (rng.next_u64() >> 56) as u8).collect();
    let texture_of = |mips: Option<MipChain>| Image { mips, ..Image::rgba8(side, side, rgba8.clone(), "noise") };
    let floor = |mips: Option<MipChain>| {
        let mut app = scene_app();
        app.world.spawn((
            Camera::default(),
            Transform::from_xyz(0.0, 0.6, 4.0).looking_at(Vec3::new(0.0, 0.0, -4.0), Vec3::Y),
        ));
        app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 1.0 });
        let image = app.world.resource_mut::<Assets<Image>>().add(texture_of(mips));
        let texture = penumbra::engine::material::TextureRef::new(image);
        let material = StandardMaterial { base_color_texture: Some(texture), unlit: true, ..white() };
        spawn_mesh(&mut app, Mesh::plane(16.0), material, Transform::IDENTITY);
        // Trilinear only (the goldens' setting): anisotropic filtering, on by default on a GPU,
        // reads finer levels along the grazing rows.
        render_app(&mut app, (48, 32), RenderSettings { max_anisotropy: Some(1), ..settings() })
    };
    let gpu = floor(None);
    let cpu = floor(Some(texture_of(None).build_mips(true)));
    // The GPU chain encodes each mean with the shader's sRGB curve, the CPU one exactly: a stored
    // level may differ by one step here and there.
    let worst = gpu.iter().zip(&cpu).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
    assert!(worst <= 2, "CPU and GPU chains differ by up to {worst}/255");
    // A chain for the other colour space is not used: the GPU makes the sRGB one.
    assert_eq!(floor(Some(texture_of(None).build_mips(false))), gpu);
    // The chain uploaded is the one drawn: black levels blacken the far floor (rows 15..20; the
    // horizon is at row 15) and leave the near rows, which read level 0, as they were.
    let mut black = texture_of(None).build_mips(true);
    for level in &mut black.levels {
        *level = MipLevel { rgba8: [0, 0, 0, 255].repeat(level.rgba8.len() / 4), ..level.clone() };
    }
    let dark = floor(Some(black));
    let rows = |px: &[u8], ys: std::ops::Range<u32>| -> f32 {
        ys.flat_map(|y| (0..48).map(move |x| (x, y))).map(|(x, y)| brightness(px, 48, x, y)).sum()
    };
    assert!(rows(&gpu, 15..20) > 0.0 && rows(&dark, 15..20) == 0.0, "far rows read the black levels");
    assert_eq!(rows(&dark, 24..32), rows(&gpu, 24..32), "near rows read level 0");
}

/// Texels imported where they lie (`host_memory`; lavapipe has VK_EXT_external_memory_host): the
/// buffer reads exactly the bytes, from a start that is not aligned, and holds their owner until
/// the GPU is done with it. Every textured golden on lavapipe goes through this path too; GL
/// (`backend_parity`) through staging copies, against the same goldens.
#[test]
fn host_memory_imports_read_the_bytes_where_they_lie() {
    use std::sync::Arc;
    let ctx = common::gpu();
    let Some(alignment) = ctx.caps.host_import_alignment else {
        let lavapipe = ctx.info.backend == wgpu::Backend::Vulkan && ctx.info.device_type == wgpu::DeviceType::Cpu;
        assert!(!lavapipe, "lavapipe imports host memory; the capability should be found");
        return;
    };
    let owner: Arc<Vec<u8>> =
        Arc::new((0..3_000_000u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8).collect());
    let len = 2_000_000;
    let bytes = &owner[12..12 + len];
    // SAFETY: the context's device was opened with imports (the capability says so), and the
    // bytes lie in `owner`, which nothing writes.
    let (buffer, offset) = unsafe {
        penumbra::render::gpu::host_memory::import(&ctx.device, alignment, bytes, owner.clone() as Arc<dyn Send + Sync>)
    }
    .expect("the driver imports the bytes");
    assert_eq!(Arc::strong_count(&owner), 2, "the buffer holds the bytes' owner");
    let copy = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("copy of the import"),
        size: len as u64,
        usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(&buffer, offset, &copy, 0, len as u64);
    ctx.queue.submit([encoder.finish()]);
    drop(buffer);
    let back = penumbra::render::gpu::readback::read_buffer(&ctx.device, &ctx.queue, &copy, len as u64).unwrap();
    assert!(back == bytes, "the copy reads the bytes in place");
    let _ = ctx.device.poll(wgpu::PollType::wait_indefinitely());
    assert_eq!(Arc::strong_count(&owner), 1, "released once the GPU is done");
}

/// 70 000 instances moved in one frame (4.5 MB of records, copied into wgpu's staging memory on
/// several threads; `resources::instances` tests the copy byte for byte): the moved scene draws
/// exactly what a scene built in the moved places draws.
#[test]
fn moving_many_instances_at_once_uploads_every_record() {
    const SIDE: usize = 265;
    let build = || {
        let mut app = scene_app();
        app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 30.0, 0.1).looking_at(Vec3::ZERO, Vec3::Y)));
        let mesh = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::splat(0.06)));
        let material =
            app.world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial::from_color(Vec4::ONE, 0.5));
        let cubes: Vec<Entity> = (0..SIDE * SIDE)
            .map(|i| {
                let at = Vec3::new((i % SIDE) as f32 * 0.1 - 13.2, 0.0, (i / SIDE) as f32 * 0.1 - 13.2);
                app.world.spawn((Mesh3d(mesh), MeshMaterial3d(material), Transform::from_translation(at))).id()
            })
            .collect();
        (app, cubes)
    };
    let size = (64, 64);
    let (mut moved, cubes) = build();
    let before = render_app(&mut moved, size, RenderSettings::default());
    for (i, &c) in cubes.iter().enumerate() {
        // Not a whole grid step, so every cube lands somewhere no cube stood.
        moved.world.get_mut::<Transform>(c).unwrap().translation.x += 0.037 + (i % 7) as f32 * 0.001;
    }
    let after = render_app(&mut moved, size, RenderSettings::default());
    assert_ne!(before, after, "the move shows");
    let (mut fresh, fresh_cubes) = build();
    for (i, &c) in fresh_cubes.iter().enumerate() {
        fresh.world.get_mut::<Transform>(c).unwrap().translation.x += 0.037 + (i % 7) as f32 * 0.001;
    }
    let expected = render_app(&mut fresh, size, RenderSettings::default());
    assert_eq!(after, expected);
}

#[test]
fn a_multisampled_frame_times_its_resolve_where_the_shader_resolves() {
    let mut app = scene_app();
    lit_camera(&mut app, 4.0);
    spawn_mesh(&mut app, facing_quad(), white(), Transform::default());
    let timed = RenderSettings { msaa: 4, gpu_timing: true, ..Default::default() };
    render_app(&mut app, SIZE, timed.clone());
    render_app(&mut app, SIZE, timed);
    let mut renderer = app.world.resource_mut::<Renderer>();
    renderer.finish();
    let caps = renderer.context().caps;
    let Some(timings) = renderer.stats().gpu.clone() else {
        // Without timestamp queries (wgpu's GL backend) frames are untimed, and say so.
        assert!(!caps.timestamps, "the adapter has timestamp queries, yet no frame was timed");
        return;
    };
    let passes: Vec<&str> = timings.passes.iter().map(|p| p.0).collect();
    assert!(passes.contains(&"forward"), "{passes:?}");
    // Where the frame resolves by its own pass (CPU rasterisers through Vulkan, as in CI), that
    // pass is timed too, so the passes add up to the frame; on a GPU the render pass resolves
    // and no such pass exists (no setting forces the shader resolve there).
    assert_eq!(passes.contains(&"resolve"), caps.shader_msaa_resolve, "{passes:?}");
}

/// A frame larger than the device's textures can be (a size from a file, or a script) fails
/// with the reason instead of wgpu's validation panic, and the next frame of a size that fits
/// draws again.
#[test]
fn a_frame_larger_than_the_gpus_textures_is_an_error_not_a_panic() {
    let mut app = scene_app();
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 0.0, 3.0)));
    render_app(&mut app, (8, 8), RenderSettings::default());
    let max = app.world.resource::<Renderer>().context().device.limits().max_texture_dimension_2d;
    app.insert_resource(RenderOutput::Headless { width: max + 1, height: 4 });
    app.update();
    let err = app.world.resource::<Renderer>().read_frame().expect_err("too wide for the GPU");
    assert!(err.to_string().contains(&format!("is larger than this GPU's textures can be ({max} a side)")), "{err}");
    render_app(&mut app, (8, 8), RenderSettings::default());
}

/// Renders a lit cube with a renderer whose context keeps pipelines in `cache`; returns the
/// pixels and the bytes of cache data the renderer's store read when it opened.
fn render_with_cache(cache: penumbra::render::PipelineCacheDir) -> (Vec<u8>, Option<usize>) {
    let request = penumbra::render::AdapterRequest {
        backends: Some(wgpu::Backends::VULKAN),
        pipeline_cache: cache,
        ..Default::default()
    };
    let ctx = penumbra::render::GpuContext::new_headless(&request).unwrap_or_else(|e| panic!("{e}"));
    let mut app = scene_app();
    lit_camera(&mut app, 4.0);
    let material = app.world.resource_mut::<Assets<StandardMaterial>>().add(white());
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
    app.world.spawn((Mesh3d(mesh), MeshMaterial3d(material), Transform::from_rotation(Quat::from_rotation_y(0.5))));
    app.insert_resource(Renderer::new(ctx, settings()).unwrap());
    let pixels = render_app(&mut app, SIZE, settings());
    let loaded = app.world.resource::<Renderer>().pipeline_store().map(|s| s.loaded_bytes());
    // Dropping the renderer writes the cache.
    drop(app.world.remove_resource::<Renderer>());
    (pixels, loaded)
}

/// The one cache file in `dir`.
fn cache_file(dir: &std::path::Path) -> std::path::PathBuf {
    let files: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(files.len(), 1, "one cache file per adapter, no stray temporary files: {files:?}");
    files.into_iter().next().unwrap()
}

#[test]
fn the_pipeline_cache_survives_runs_and_bad_files() {
    use penumbra::render::PipelineCacheDir;
    let dir = common::scratch_dir("pipeline-cache");
    let at = || PipelineCacheDir::At(dir.clone());

    // First run: nothing to read; the file is written when the renderer goes.
    let (first, loaded) = render_with_cache(at());
    assert_eq!(loaded, Some(0), "lavapipe's Vulkan has a pipeline cache; the folder was empty");
    let file = cache_file(&dir);
    let written = std::fs::read(&file).unwrap();
    assert!(file.file_name().unwrap().to_str().unwrap().starts_with("wgpu_pipeline_cache_vulkan_"));

    // Second run reads it back whole and draws the same.
    let (second, loaded) = render_with_cache(at());
    assert_eq!(loaded, Some(written.len() - 48), "the data inside the file's 48-byte envelope");
    assert_eq!(second, first);

    // Damaged, cut short, not ours at all: each is refused before the driver sees it, the frame
    // is the same, and the file is replaced by a good one.
    let mut flipped = written.clone();
    let last = flipped.len() - 1;
    flipped[last] ^= 0x40;
    for bad in [flipped, written[..written.len() / 2].to_vec(), b"not a pipeline cache".to_vec()] {
        std::fs::write(&file, &bad).unwrap();
        let (pixels, loaded) = render_with_cache(at());
        assert_eq!(loaded, Some(0));
        assert_eq!(pixels, first);
        assert_eq!(std::fs::read(cache_file(&dir)).unwrap().len(), written.len(), "rewritten whole");
    }

    // A whole envelope around data wgpu's own header check refuses (another adapter's or a
    // stale driver's): wgpu starts an empty cache, the frame is the same.
    let mut foreign = b"PNBRPLC1".to_vec();
    let junk = vec![7u8; 300];
    foreign.extend_from_slice(&(junk.len() as u64).to_le_bytes());
    foreign.extend_from_slice(blake3::hash(&junk).as_bytes());
    foreign.extend_from_slice(&junk);
    std::fs::write(&file, &foreign).unwrap();
    let (pixels, loaded) = render_with_cache(at());
    assert_eq!(loaded, Some(300));
    assert_eq!(pixels, first);

    // A file made for another adapter (wgpu's header names the vendor and device, bytes 17..32;
    // a copied or renamed file): wgpu refuses it, an empty cache is made, the frame is the same.
    let data = written[48..].to_vec();
    assert!(data.len() >= 32 && &data[..8] == b"WGPUPLCH", "wgpu's header inside the envelope");
    let mut other = data.clone();
    other[20] ^= 0x5a;
    let mut moved = b"PNBRPLC1".to_vec();
    moved.extend_from_slice(&(other.len() as u64).to_le_bytes());
    moved.extend_from_slice(blake3::hash(&other).as_bytes());
    moved.extend_from_slice(&other);
    std::fs::write(&file, &moved).unwrap();
    let (pixels, loaded) = render_with_cache(at());
    assert_eq!(loaded, Some(other.len()));
    assert_eq!(pixels, first);

    // A folder that cannot be made (a file is in the way): the frame is drawn all the same.
    let blocked = dir.join("blocked");
    std::fs::write(&blocked, b"a file, not a folder").unwrap();
    let (pixels, _) = render_with_cache(PipelineCacheDir::At(blocked.join("pipelines")));
    assert_eq!(pixels, first);

    // Off: no store at all.
    let (pixels, loaded) = render_with_cache(PipelineCacheDir::Off);
    assert_eq!((pixels, loaded), (first, None));
}

#[test]
fn warming_up_compiles_ahead_only_what_the_first_frame_compiles() {
    use penumbra::render::Raster;
    let frame = |warm: bool, raster: Raster| {
        let settings = RenderSettings { raster, ..settings() };
        let mut app = scene_app();
        lit_camera(&mut app, 4.0);
        app.insert_resource(Environment::default());
        let material = app.world.resource_mut::<Assets<StandardMaterial>>().add(white());
        let mesh = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
        app.world.spawn((Mesh3d(mesh), MeshMaterial3d(material), Transform::default()));
        let mut renderer = Renderer::new(common::gpu(), settings.clone()).unwrap();
        if warm {
            renderer.warm_up(true);
        }
        let ahead = renderer.pipelines_created();
        app.insert_resource(renderer);
        let pixels = render_app(&mut app, SIZE, settings);
        (pixels, ahead, app.world.resource::<Renderer>().pipelines_created())
    };
    // The default (the forward pass on lavapipe): the environment's steps ahead; rasterised in
    // compute: also the frustum cull and the rasteriser's four steps.
    for (raster, least) in [(Raster::Auto, 5), (Raster::Compute, 10)] {
        let (cold, none_ahead, cold_total) = frame(false, raster);
        let (warm, ahead, warm_total) = frame(true, raster);
        assert_eq!(none_ahead, 0);
        assert!(ahead >= least, "{raster:?}: {ahead} pipelines ahead");
        assert_eq!(warm_total, cold_total, "{raster:?}: nothing compiled that the frame would not have");
        assert_eq!(warm, cold, "{raster:?}");
    }
}

#[test]
fn a_preloaded_shader_library_is_the_embedded_one() {
    use penumbra::render::pipelines::ShaderLibrary;
    ShaderLibrary::preload_embedded();
    let preloaded = ShaderLibrary::embedded().unwrap();
    let fresh = ShaderLibrary::embedded().unwrap();
    assert!(preloaded.changed_files(&fresh).is_empty());
}
