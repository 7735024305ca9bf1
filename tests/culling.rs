//! GPU frustum culling and instancing change how draws are issued, never what is drawn: a
//! culled frame equals the same frame drawn without culling (scenes built to stress the test:
//! objects straddling every frustum plane and the near plane, tiny objects at the edges, objects
//! behind the camera, far from the origin, and objects moving in and out of view between
//! frames), also with occlusion culling, which must moreover leave out what a wall hides and
//! draw it again in the frame the wall moves away; and a scene drawn as instanced batches
//! equals it drawn one draw per entity.

use penumbra::prelude::*;
use penumbra::render::{OcclusionCulling, TriangleCulling};
use penumbra::render::{RenderSettings, Renderer};

mod common;
use common::{render_app, scene_app};

const SIZE: (u32, u32) = (96, 64);

fn settings(gpu_culling: bool) -> RenderSettings {
    RenderSettings { msaa: 1, gpu_culling, ..Default::default() }
}

/// A material per colour index, so neighbours differ in the image.
fn palette(app: &mut App) -> Vec<Handle<StandardMaterial>> {
    let colours = [Vec4::new(0.9, 0.2, 0.2, 1.0), Vec4::new(0.2, 0.8, 0.3, 1.0), Vec4::new(0.3, 0.4, 0.9, 1.0)];
    let mut materials = app.world.resource_mut::<Assets<StandardMaterial>>();
    colours.into_iter().map(|c| materials.add(StandardMaterial::from_color(c, 0.6))).collect()
}

/// The stress scene around `origin`, seen from `origin` looking down −Z with a 60° field of
/// view. Returns the entities and how many of them lie wholly behind the camera.
fn stress_scene(app: &mut App, origin: Vec3) -> (Vec<Entity>, usize) {
    let cube = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
    let sphere = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::uv_sphere(0.5, 12, 8));
    let paint = palette(app);
    let mut entities = Vec::new();
    let mut spawn = |app: &mut App, mesh: Handle<Mesh>, i: usize, t: Transform| {
        let t = Transform { translation: t.translation + origin, ..t };
        entities.push(app.world.spawn((Mesh3d(mesh), MeshMaterial3d(paint[i % paint.len()]), t)).id());
    };
    // A field of cubes and spheres from behind the camera to far ahead and well beyond the
    // sides: many straddle the left, right, top and bottom planes.
    let mut behind = 0;
    let mut i = 0;
    for gx in -12i32..=12 {
        for gz in -30..=6 {
            let at = Vec3::new(gx as f32 * 1.7, -1.5 + 0.25 * (gx + gz).rem_euclid(5) as f32, gz as f32 * 1.7);
            let mesh = if (gx + gz) % 2 == 0 { cube } else { sphere };
            let t = Transform::from_translation(at).with_rotation(Quat::from_rotation_y(0.3 * i as f32));
            // Bounding radius of either mesh is below 0.9; behind means beyond that.
            if at.z > 0.9 {
                behind += 1;
            }
            spawn(app, mesh, i, t);
            i += 1;
        }
    }
    // Tiny cubes on the frustum's side planes at several depths, and one at the near plane.
    let half = 30f32.to_radians().tan();
    for (k, d) in [0.5f32, 2.0, 8.0, 30.0].into_iter().enumerate() {
        let aspect = SIZE.0 as f32 / SIZE.1 as f32;
        for side in [-1.0, 1.0] {
            let t = Transform::from_xyz(side * d * half * aspect, 0.1 * k as f32, -d).with_scale(Vec3::splat(0.01 * d));
            spawn(app, cube, i, t);
            i += 1;
            let t = Transform::from_xyz(0.2 * k as f32, side * d * half, -d).with_scale(Vec3::splat(0.01 * d));
            spawn(app, cube, i, t);
            i += 1;
        }
    }
    // A large box the near plane cuts through, and one far away and huge.
    spawn(app, cube, i, Transform::from_xyz(0.8, 0.6, -0.05).with_scale(Vec3::new(0.3, 0.3, 0.3)));
    spawn(app, sphere, i + 1, Transform::from_xyz(40.0, 20.0, -900.0).with_scale(Vec3::splat(120.0)));
    view_and_lights(app, origin);
    (entities, behind)
}

/// A camera at `origin` looking down −Z with a 60° field of view, a sun and ambient light.
fn view_and_lights(app: &mut App, origin: Vec3) {
    app.world.spawn((
        Camera {
            projection: Projection::Perspective { yfov: 60f32.to_radians(), znear: 0.1, aspect_ratio: None },
            ..Default::default()
        },
        Transform::from_translation(origin),
    ));
    app.world.spawn((
        DirectionalLight { illuminance: 3.0, shadows: false, ..Default::default() },
        Transform::from_xyz(0.3, 1.0, 0.5).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.3 });
}

fn visible_total(app: &App) -> Option<u32> {
    app.world.resource::<Renderer>().visible_instance_counts().unwrap().map(|c| c.iter().sum())
}

fn check_stress_scene(origin: Vec3, occlusion: OcclusionCulling) {
    let mut culled = scene_app();
    let mut reference = scene_app();
    let (entities, behind) = stress_scene(&mut culled, origin);
    stress_scene(&mut reference, origin);
    let total = entities.len() as u32;
    for frame in 0..3 {
        let a = render_app(&mut culled, SIZE, RenderSettings { occlusion_culling: occlusion, ..settings(true) });
        let b = render_app(&mut reference, SIZE, settings(false));
        assert!(
            a == b,
            "origin {origin}, {occlusion:?}, frame {frame}: the culled frame differs from the unculled one"
        );
        let visible = visible_total(&culled).expect("culling ran");
        assert!(visible > 0, "origin {origin}, frame {frame}: nothing drawn");
        assert!(
            visible <= total - behind as u32,
            "origin {origin}, frame {frame}: {visible} of {total} drawn, but {behind} lie behind the camera"
        );
        assert_eq!(visible_total(&reference), None, "culling off draws the full list");
        // Next frame: everything turns and shifts sideways, so objects cross the side planes.
        for app in [&mut culled, &mut reference] {
            for &e in &entities {
                let mut t = app.world.get_mut::<Transform>(e).unwrap();
                t.translation.x += 0.9;
                t.rotation *= Quat::from_rotation_x(0.4);
            }
        }
    }
}

#[test]
fn culled_frames_equal_unculled_frames() {
    check_stress_scene(Vec3::ZERO, OcclusionCulling::Off);
}

#[test]
fn occlusion_culled_frames_equal_unculled_frames() {
    check_stress_scene(Vec3::ZERO, OcclusionCulling::On);
    check_stress_scene(Vec3::new(1.0e5, -3.0e4, 2.0e5), OcclusionCulling::On);
}

#[test]
fn culled_frames_equal_unculled_frames_far_from_the_origin() {
    check_stress_scene(Vec3::new(1.0e5, -3.0e4, 2.0e5), OcclusionCulling::Off);
}

#[test]
fn an_object_entering_the_view_is_drawn_in_that_frame() {
    let mut app = scene_app();
    let paint = palette(&mut app);
    let cube = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
    let mover = app.world.spawn((Mesh3d(cube), MeshMaterial3d(paint[0]), Transform::from_xyz(0.0, 0.0, 5.0))).id();
    app.world.spawn((Mesh3d(cube), MeshMaterial3d(paint[1]), Transform::from_xyz(3.0, 0.0, -6.0)));
    app.world.spawn((Camera::default(), Transform::default()));
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 1.0 });
    render_app(&mut app, SIZE, settings(true));
    assert_eq!(visible_total(&app), Some(1), "the cube behind the camera is culled");
    app.world.get_mut::<Transform>(mover).unwrap().translation = Vec3::new(0.0, 0.0, -4.0);
    let frame = render_app(&mut app, SIZE, settings(true));
    assert_eq!(visible_total(&app), Some(2));
    let centre = (((SIZE.1 / 2) * SIZE.0 + SIZE.0 / 2) * 4) as usize;
    assert!(frame[centre] > 100, "the cube that moved into view is drawn: {:?}", &frame[centre..centre + 4]);
}

#[test]
fn instanced_batches_equal_one_draw_per_entity() {
    // The same cubes, once sharing one material (one instanced draw), once each with its own
    // material of equal values (one draw each).
    let render = |shared: bool| {
        let mut app = scene_app();
        let cube = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
        let one =
            app.world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial::from_color(Vec4::ONE, 0.4));
        for i in 0..60 {
            let material = if shared {
                one
            } else {
                app.world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial::from_color(Vec4::ONE, 0.4))
            };
            let at = Vec3::new((i % 10) as f32 * 1.3 - 6.0, (i / 10) as f32 * 1.3 - 3.5, -12.0 - (i % 7) as f32);
            let t = Transform::from_translation(at).with_rotation(Quat::from_rotation_y(i as f32 * 0.7));
            app.world.spawn((Mesh3d(cube), MeshMaterial3d(material), t));
        }
        app.world.spawn((Camera::default(), Transform::default()));
        app.world.spawn((
            DirectionalLight { illuminance: 2.0, shadows: false, ..Default::default() },
            Transform::from_xyz(1.0, 1.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
        ));
        let image = render_app(&mut app, SIZE, settings(true));
        (image, app.world.resource::<Renderer>().stats().draw_calls)
    };
    let (instanced, instanced_draws) = render(true);
    let (separate, separate_draws) = render(false);
    assert_eq!(instanced_draws, 1);
    assert_eq!(separate_draws, 60);
    assert!(instanced == separate, "instancing changed the image");
}

/// A wall hiding a block of cubes, with a few cubes in front of it; returns the wall.
fn wall_scene(app: &mut App) -> Entity {
    let paint = palette(app);
    let cube = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
    // Wide enough to fill the view: the depth pyramid is conservative where background shows.
    let wall_mesh = Mesh::cuboid(Vec3::new(60.0, 40.0, 0.2));
    let wall_mesh = app.world.resource_mut::<Assets<Mesh>>().add(wall_mesh);
    let wall = app.world.spawn((Mesh3d(wall_mesh), MeshMaterial3d(paint[2]), Transform::from_xyz(0.0, 0.0, -6.0))).id();
    for i in 0..120 {
        let at = Vec3::new((i % 12) as f32 * 0.8 - 4.4, (i / 12 % 5) as f32 * 0.9 - 1.8, -9.0 - (i / 60) as f32 * 2.0);
        app.world.spawn((
            Mesh3d(cube),
            MeshMaterial3d(paint[i % 2]),
            Transform::from_translation(at).with_scale(Vec3::splat(0.5)),
        ));
    }
    for i in 0..6 {
        let at = Vec3::new(i as f32 - 2.5, -1.0, -3.0);
        app.world.spawn((
            Mesh3d(cube),
            MeshMaterial3d(paint[0]),
            Transform::from_translation(at).with_scale(Vec3::splat(0.4)),
        ));
    }
    app.world.spawn((Camera::default(), Transform::default()));
    app.world.spawn((
        DirectionalLight { illuminance: 2.0, shadows: false, ..Default::default() },
        Transform::from_xyz(1.0, 2.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.3 });
    wall
}

fn occlusion_settings(msaa: u32, occlusion: OcclusionCulling, triangles: TriangleCulling) -> RenderSettings {
    RenderSettings { msaa, occlusion_culling: occlusion, triangle_culling: triangles, ..Default::default() }
}

/// Occlusion culling leaves out the cubes behind the wall from the second frame on, and draws
/// them in the very frame the wall moves away; every frame equals the frame drawn without it.
/// The same with triangle culling, which culls the cubes' triangles in both phases.
#[test]
fn occlusion_culling_hides_only_what_is_hidden_and_uncovers_at_once() {
    for (msaa, triangles) in [(1, TriangleCulling::Off), (4, TriangleCulling::Off), (4, TriangleCulling::On)] {
        let mut culled = scene_app();
        let mut reference = scene_app();
        let wall = wall_scene(&mut culled);
        let reference_wall = wall_scene(&mut reference);
        let mut counts = Vec::new();
        for frame in 0..4 {
            if frame == 3 {
                // The wall slides out of view: everything behind it shows this frame.
                for (app, wall) in [(&mut culled, wall), (&mut reference, reference_wall)] {
                    app.world.get_mut::<Transform>(wall).unwrap().translation.x = 200.0;
                }
            }
            let a = render_app(&mut culled, SIZE, occlusion_settings(msaa, OcclusionCulling::On, triangles));
            let b =
                render_app(&mut reference, SIZE, occlusion_settings(msaa, OcclusionCulling::Off, TriangleCulling::Off));
            assert!(a == b, "MSAA {msaa}, {triangles:?}, frame {frame}: occlusion culling changed the image");
            if triangles == TriangleCulling::On && common::gpu().caps.occlusion_culling {
                let counts = culled.world.resource::<Renderer>().triangle_culled_counts().unwrap();
                assert!(counts.is_some_and(|c| c.iter().all(Option::is_some)), "frame {frame}: triangles culled");
            }
            let plan = &culled.world.resource::<Renderer>().stats().plan;
            if !common::gpu().caps.occlusion_culling {
                // GL (WGPU_BACKEND=gl): no depth pyramid there; `On` culls by the view only.
                assert!(!plan.runs(penumbra::render::frame::Pass::OCCLUSION_LATE), "{plan}");
                continue;
            }
            assert!(plan.runs(penumbra::render::frame::Pass::OCCLUSION_LATE), "MSAA {msaa}: occlusion culling ran");
            counts.push(visible_total(&culled).expect("culling ran"));
            // What `OcclusionCulling::Auto` reads back: entries in view the pyramid hid, of the
            // 127 opaque ones (wall, 120 behind it, 6 in front), measured from frame 1 on.
            let mut renderer = culled.world.resource_mut::<Renderer>();
            renderer.finish();
            let hidden = renderer.occlusion_measure().map(|m| (m.hidden, m.entries));
            let expected = match frame {
                0 => None,
                1 | 2 => Some((120, 127)),
                _ => Some((0, 127)),
            };
            assert_eq!(hidden, expected, "MSAA {msaa}, frame {frame}");
        }
        // Frame 0 draws everything in view (it has no history): the wall, 120 cubes behind it
        // and the 4 of the 6 cubes in front that the view reaches. From frame 1 the hidden
        // cubes stay out; when the wall goes, they are back in that frame.
        if common::gpu().caps.occlusion_culling {
            assert_eq!(counts, [125, 5, 5, 124], "MSAA {msaa}: instances drawn per frame");
        }
    }
}

/// Cubes for triangle culling: a far field of cubes too small to cover a sample each (some
/// turned, some mirrored, some double-sided), a row near enough to show three faces each, and
/// cubes crossing the view's edges. Returns the far field's cube count.
fn small_cubes_scene(app: &mut App, origin: Vec3) -> usize {
    let paint = palette(app);
    let two_sided = app.world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial {
        double_sided: true,
        ..StandardMaterial::from_color(Vec4::new(0.9, 0.8, 0.2, 1.0), 0.5)
    });
    let cube = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
    let spawn = |app: &mut App, material: Handle<StandardMaterial>, t: Transform| {
        let t = Transform { translation: t.translation + origin, ..t };
        app.world.spawn((Mesh3d(cube), MeshMaterial3d(material), t));
    };
    let mut far = 0;
    for gx in -20i32..20 {
        for gz in 0..20 {
            let at = Vec3::new(gx as f32 * 3.1, -6.0 + 0.37 * (gz % 3) as f32, -60.0 - gz as f32 * 4.3);
            let mut t = Transform::from_translation(at).with_rotation(Quat::from_rotation_y(0.21 * (gx + gz) as f32));
            t.scale = Vec3::splat(0.2 + 0.15 * ((gx * 7 + gz) % 4) as f32);
            if (gx + gz) % 5 == 0 {
                t.scale.x = -t.scale.x;
            }
            let material = if (gx * 3 + gz) % 7 == 0 { two_sided } else { paint[(gx + gz).rem_euclid(3) as usize] };
            spawn(app, material, t);
            far += 1;
        }
    }
    for i in 0..5 {
        let t = Transform::from_xyz(i as f32 * 1.6 - 3.2, -0.8 + 0.4 * i as f32, -6.0)
            .with_rotation(Quat::from_rotation_x(0.4) * Quat::from_rotation_y(0.3 * i as f32));
        spawn(app, paint[i % 3], t);
    }
    // Across the left and right edges, and one cut by the near plane.
    spawn(app, paint[0], Transform::from_xyz(-5.3, 0.0, -7.0));
    spawn(app, paint[1], Transform::from_xyz(5.3, 0.5, -7.0).with_rotation(Quat::from_rotation_x(0.6)));
    spawn(app, paint[2], Transform::from_xyz(0.3, -0.4, -0.3).with_scale(Vec3::splat(0.5)));
    view_and_lights(app, origin);
    far
}

/// Two frames of each app (occlusion culling draws what was visible last frame early, the rest
/// late) must be byte for byte the same.
fn assert_same_frames(culled: &mut App, reference: &mut App, a: &RenderSettings, b: &RenderSettings, what: &str) {
    for frame in 0..2 {
        let x = render_app(culled, SIZE, a.clone());
        let y = render_app(reference, SIZE, b.clone());
        assert!(x == y, "{what}, frame {frame}: the triangle-culled frame differs from the unculled one");
    }
}

/// Triangle culling draws only triangles that can cover a sample, so its frames equal the
/// frames drawn without any culling, at one and four samples, near and far from the origin,
/// alone and with occlusion culling, on the stress scene (whose spheres stay instanced beside
/// its triangle-culled cubes) and on a field of sub-pixel cubes, most of whose triangles it
/// leaves out.
#[test]
fn triangle_culled_frames_equal_unculled_frames() {
    let far_away = Vec3::new(1.0e5, -3.0e4, 2.0e5);
    for (origin, msaa, occlusion) in [
        (Vec3::ZERO, 1, OcclusionCulling::Off),
        (Vec3::ZERO, 4, OcclusionCulling::Off),
        (far_away, 4, OcclusionCulling::Off),
        (Vec3::ZERO, 4, OcclusionCulling::On),
    ] {
        let triangles = RenderSettings {
            msaa,
            occlusion_culling: occlusion,
            triangle_culling: TriangleCulling::On,
            ..Default::default()
        };
        let reference_settings = RenderSettings { msaa, gpu_culling: false, ..Default::default() };
        let mut culled = scene_app();
        let mut reference = scene_app();
        let far = small_cubes_scene(&mut culled, origin);
        small_cubes_scene(&mut reference, origin);
        let what = format!("origin {origin}, MSAA {msaa}, {occlusion:?}, small cubes");
        assert_same_frames(&mut culled, &mut reference, &triangles, &reference_settings, &what);
        let counts = culled.world.resource::<Renderer>().triangle_culled_counts().unwrap().expect("triangles culled");
        let drawn: u32 = counts.iter().flatten().sum();
        let submitted = 12 * (far + 8) as u32;
        assert!(counts.iter().any(Option::is_some), "the cubes' batches are triangle-culled: {counts:?}");
        // At most three faces of a cube face the camera; the far field's cubes cover a few
        // samples at most.
        assert!(
            drawn > 0 && drawn < submitted / 4,
            "origin {origin}, MSAA {msaa}, {occlusion:?}: {drawn} of {submitted} triangles drawn"
        );
        let visible: u32 = culled.world.resource::<Renderer>().visible_instance_counts().unwrap().unwrap().iter().sum();
        assert!(visible > far as u32 / 2, "{visible} instances visible");

        let mut culled = scene_app();
        let mut reference = scene_app();
        stress_scene(&mut culled, origin);
        stress_scene(&mut reference, origin);
        let what = format!("origin {origin}, MSAA {msaa}, {occlusion:?}, stress scene");
        assert_same_frames(&mut culled, &mut reference, &triangles, &reference_settings, &what);
        let counts = culled.world.resource::<Renderer>().triangle_culled_counts().unwrap().expect("triangles culled");
        assert!(counts.iter().any(Option::is_some) && counts.iter().any(Option::is_none), "{counts:?}");
    }
}
