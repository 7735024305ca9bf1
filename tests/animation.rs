//! glTF animation, skinning and morph targets: InterpolationTest's samplers against values
//! worked out by hand from the file's keyframes; playback driving entities; skinned and morphed
//! models rendered at fixed times against goldens (deformed on the GPU); the deformation pass
//! running only when a pose changes; skins that point past their joints refused.

use std::path::Path;

use penumbra::engine::animation::{AnimatedProperty, AnimationClip, ValueKind};
use penumbra::engine::import::GltfScene;
use penumbra::prelude::*;
use penumbra::render::RenderSettings;
use penumbra::render::frame::Pass;
use penumbra::render::headless::{AnimationShot, CameraChoice, ShotSettings, render_frames, stage_scene};
use penumbra::render::renderer::Renderer;

mod common;
use common::{Tolerance, asset, check_golden, gpu, render_asset, scratch_dir};

fn interpolation_test() -> GltfScene {
    GltfScene::load(&asset("InterpolationTest/InterpolationTest.glb"), &ImportOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
}

fn clip<'a>(scene: &'a GltfScene, name: &str) -> &'a AnimationClip {
    scene.animations().iter().find(|c| c.name == name).unwrap_or_else(|| panic!("no clip {name}"))
}

/// The clip's one channel sampled at `t`.
fn sample(clip: &AnimationClip, t: f32) -> Vec<f32> {
    let c = &clip.channels[0];
    let mut out = vec![0.0; c.sampler.width()];
    c.sampler.sample(t, c.property.value_kind(), &mut out);
    out
}

/// Halfway between keyframes `k` and `k + 1` of the clip's channel.
fn mid(clip: &AnimationClip, k: usize) -> f32 {
    let t = clip.channels[0].sampler.times();
    0.5 * (t[k] + t[k + 1])
}

fn close(a: &[f32], b: &[f32], tol: f32) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
}

fn rotation_z(degrees: f32) -> Vec<f32> {
    Quat::from_rotation_z(degrees.to_radians()).to_array().to_vec()
}

#[test]
fn interpolation_test_samplers_match_hand_computed_values() {
    let scene = interpolation_test();
    assert_eq!(scene.animations().len(), 9);

    // Scale keyframes 1, 0.5, 1, 0.5, 1 at 0.0417, 0.4167, 0.875, 1.25, 1.6667 s.
    let step = clip(&scene, "Step Scale");
    assert_eq!(step.channels[0].property, AnimatedProperty::Scale);
    assert_eq!(sample(step, 0.0), [1.0; 3], "before the first keyframe: the first value");
    assert_eq!(sample(step, mid(step, 1)), [0.5; 3], "STEP holds keyframe 1 until keyframe 2");
    assert_eq!(sample(step, 10.0), [1.0; 3], "after the last keyframe: the last value");
    let linear = clip(&scene, "Linear Scale");
    assert!(close(&sample(linear, mid(linear, 1)), &[0.75; 3], 1e-5), "halfway from 0.5 to 1");
    // CUBICSPLINE with zero tangents is the Hermite basis alone: at s = 1/4,
    // h00 = 2/64 − 3/16 + 1 = 0.84375 and h01 = 0.15625, so 0.5·0.84375 + 1·0.15625 = 0.578125.
    let cubic = clip(&scene, "CubicSpline Scale");
    let t = cubic.channels[0].sampler.times();
    let quarter = t[1] + 0.25 * (t[2] - t[1]);
    assert!(close(&sample(cubic, quarter), &[0.578125; 3], 1e-5), "{:?}", sample(cubic, quarter));
    assert!(close(&sample(cubic, mid(cubic, 1)), &[0.75; 3], 1e-5));

    // Rotations about −Z by 0°, 45°, 90°, 135°, 180° at 0, 0.4167, 0.875, 1.25, 1.7083 s.
    let step = clip(&scene, "Step Rotation");
    assert!(close(&sample(step, mid(step, 1)), &rotation_z(-45.0), 1e-4));
    let linear = clip(&scene, "Linear Rotation");
    let q = sample(linear, mid(linear, 1));
    let expected = rotation_z(-67.5);
    assert!(close(&q, &expected, 1e-4), "slerp halfway from 45° to 90°: {q:?} vs {expected:?}");
    let cubic = clip(&scene, "CubicSpline Rotation");
    let at_key = sample(cubic, cubic.channels[0].sampler.times()[2]);
    assert!(close(&at_key, &rotation_z(-90.0), 1e-4), "a cubic passes through its keyframes");
    let q = Vec4::from_slice(&sample(cubic, mid(cubic, 1)));
    assert!((q.length() - 1.0).abs() < 1e-5, "cubic rotations are renormalised");

    // Translations in y: 6.67 (linear: 6.62), 10, 6, 10, 6.
    let step = clip(&scene, "Step Translation");
    assert!(close(&sample(step, mid(step, 1)), &[0.0, 10.0, 0.0], 1e-4));
    let linear = clip(&scene, "Linear Translation");
    let v = sample(linear, mid(linear, 1));
    assert!((v[1] - 8.0).abs() < 1e-4 && (v[0] + 3.2976).abs() < 1e-3, "{v:?}");
    let cubic = clip(&scene, "CubicSpline Translation");
    let v = sample(cubic, mid(cubic, 1));
    assert!((v[1] - 8.0).abs() < 1e-4, "zero tangents: halfway is the mean ({v:?})");
    assert_eq!(linear.channels[0].property.value_kind(), ValueKind::Linear);
}

#[test]
fn the_player_poses_the_scene_at_the_time_asked_and_plays_on_with_time() {
    let scene = interpolation_test();
    let mut app = App::new();
    app.add_plugins(CorePlugin);
    app.insert_resource(Time::fixed_hz(60.0));
    let root = scene.spawn(&mut app.world);
    let cube = {
        let mut q = app.world.query::<(Entity, &Name)>();
        q.iter(&app.world).find(|(_, n)| n.as_str() == "Cube.009").map(|(e, _)| e).expect("the linear translation cube")
    };
    let linear = clip(&scene, "Linear Translation");
    let halfway = mid(linear, 1);
    let mut player = app.world.get_mut::<AnimationPlayer>(root).expect("the importer adds a player");
    assert_eq!(player.active(), Some(0), "the first clip plays");
    player.play_named("Linear Translation").unwrap();
    player.seek(halfway).unwrap();
    app.update();
    let y = app.world.get::<Transform>(cube).unwrap().translation.y;
    assert!((y - 8.0).abs() < 1e-4, "posed at the seek time: {y}");
    let global = app.world.get::<GlobalTransform>(cube).unwrap().translation().y;
    assert!((global - y).abs() < 1e-4, "propagated the same frame: {global}");
    // One 1/60 s step later the cube has moved on towards keyframe 2 (y falls 10 → 6).
    app.update();
    let later = app.world.get::<Transform>(cube).unwrap().translation.y;
    let t = linear.channels[0].sampler.times();
    let expected = 10.0 - 4.0 * ((halfway + 1.0 / 60.0) - t[1]) / (t[2] - t[1]);
    assert!((later - expected).abs() < 1e-3, "{later} vs {expected}");
}

const SIZE: (u32, u32) = (256, 256);

fn posed(name: &str, rel: &str, clip: Option<&str>, time: f32, camera: CameraChoice) {
    let shot = ShotSettings {
        size: Some(SIZE),
        camera,
        exposure_ev100: None,
        animation: Some(AnimationShot { clip: clip.map(str::to_owned), time }),
        variant: None,
        environment: None,
    };
    let image = render_asset(rel, &shot, RenderSettings::default());
    check_golden(name, &image, Tolerance::default());
}

#[test]
fn simple_skin_bent() {
    posed("SimpleSkin_t1.5", "SimpleSkin/SimpleSkin.gltf", None, 1.5, CameraChoice::FRONT);
}

#[test]
fn simple_morph_blended() {
    posed("SimpleMorph_t1", "SimpleMorph/SimpleMorph.gltf", None, 1.0, CameraChoice::FRONT);
}

#[test]
fn animated_morph_cube_mid_animation() {
    posed(
        "AnimatedMorphCube_t1.6",
        "AnimatedMorphCube/AnimatedMorphCube.glb",
        None,
        // The first target at full weight.
        1.6,
        CameraChoice::Orbit { yaw: 35.0, pitch: 25.0 },
    );
}

#[test]
fn fox_mid_run() {
    posed("Fox_run_t0.3", "Fox/Fox.glb", Some("Run"), 0.3, CameraChoice::Orbit { yaw: 90.0, pitch: 10.0 });
}

#[test]
fn cesium_man_mid_walk() {
    posed("CesiumMan_t0.7", "CesiumMan/CesiumMan.glb", None, 0.7, CameraChoice::Orbit { yaw: 35.0, pitch: 10.0 });
}

/// Renders `frames` more frames of a staged app and returns whether each ran the deform pass.
fn deform_passes(app: &mut App, frames: usize) -> Vec<bool> {
    (0..frames)
        .map(|_| {
            app.update();
            app.world.resource::<Renderer>().stats().plan.runs(Pass::DEFORM)
        })
        .collect()
}

#[test]
fn the_deformation_pass_runs_only_when_a_pose_changes() {
    let scene = GltfScene::load(&asset("SimpleSkin/SimpleSkin.gltf"), &ImportOptions::default()).unwrap();
    let shot = ShotSettings {
        size: Some((64, 64)),
        // Between keyframes 0° (0 s) and 45° (0.5 s): the pose changes every step.
        animation: Some(AnimationShot { clip: None, time: 0.25 }),
        ..Default::default()
    };
    let (mut app, size) = stage_scene(&scene, &shot).unwrap();
    let renderer = Renderer::new(gpu(), RenderSettings::default()).unwrap();
    let first = render_frames(&mut app, renderer, size, 1).unwrap();
    assert!(app.world.resource::<Renderer>().stats().plan.runs(Pass::DEFORM), "the first frame deforms");
    assert_eq!(deform_passes(&mut app, 3), [false; 3], "a paused pose is not recomputed");
    let still = app.world.resource::<Renderer>().read_frame().unwrap();
    assert_eq!(first, still, "the deformed copy persists");
    let root = app.world.query_filtered::<Entity, With<AnimationPlayer>>().single(&app.world).unwrap();
    app.world.get_mut::<AnimationPlayer>(root).unwrap().resume();
    // The frame after `resume` shows the paused time once more; then the pose moves every step.
    assert_eq!(deform_passes(&mut app, 4), [false, true, true, true], "a playing skin deforms every frame");
    let moving = app.world.resource::<Renderer>().read_frame().unwrap();
    assert_ne!(first, moving, "the pose moved on");

    // A scene without skins or morph targets never plans the pass.
    let plain = GltfScene::load(&asset("BoxTextured/BoxTextured.glb"), &ImportOptions::default()).unwrap();
    let (mut app, size) = stage_scene(&plain, &ShotSettings { size: Some((64, 64)), ..Default::default() }).unwrap();
    render_frames(&mut app, Renderer::new(gpu(), RenderSettings::default()).unwrap(), size, 1).unwrap();
    assert_eq!(deform_passes(&mut app, 2), [false; 2]);
    assert_eq!(app.world.resource::<Renderer>().memory().deform, 4 * 256, "only the empty stand-in buffers");
}

#[test]
fn a_skin_whose_vertices_name_missing_joints_is_refused() {
    let text = std::fs::read_to_string(asset("SimpleSkin/SimpleSkin.gltf")).unwrap();
    // The vertices use joints 0 and 1; leave the skin one.
    let text = text.replace("\"joints\" : [ 1, 2 ]", "\"joints\" : [ 1 ]");
    assert!(!text.contains("[ 1, 2 ]"), "the edit applied");
    let dir = scratch_dir("bad_skin");
    let path = dir.join("OneJoint.gltf");
    std::fs::write(&path, text).unwrap();
    let err = GltfScene::load(Path::new(&path), &ImportOptions::default()).unwrap_err().to_string();
    assert!(err.contains("OneJoint.gltf") && err.contains("skin 0") && err.contains("joint 1"), "{err}");
}

/// CesiumMan walking, rendered `frames` frames from time 0.5 s with its root at `origin`; the
/// camera frames the first pose. Returns every frame.
fn walk_frames(origin: Vec3, settings: RenderSettings, frames: usize) -> Vec<Vec<u8>> {
    let scene = GltfScene::load(&asset("CesiumMan/CesiumMan.glb"), &ImportOptions::default()).unwrap();
    let mut app = common::scene_app();
    app.insert_resource(Time::fixed_hz(60.0));
    let root = scene.spawn(&mut app.world);
    app.world.get_mut::<Transform>(root).unwrap().translation = origin;
    let mut player = app.world.get_mut::<AnimationPlayer>(root).unwrap();
    player.seek(0.5).unwrap();
    app.update();
    let shot = ShotSettings {
        size: Some((128, 128)),
        camera: CameraChoice::Orbit { yaw: 60.0, pitch: 5.0 },
        ..Default::default()
    };
    penumbra::render::headless::stage_camera(&mut app, &shot).unwrap();
    (0..frames).map(|_| common::render_app(&mut app, (128, 128), settings.clone())).collect()
}

#[test]
fn culling_skinned_draws_by_their_posed_bounds_loses_nothing() {
    // Walking moves the legs and arms outside the bind pose's box; culled frames must equal
    // frames drawn without culling.
    let culled = walk_frames(Vec3::ZERO, RenderSettings::default(), 6);
    let all = walk_frames(Vec3::ZERO, RenderSettings { gpu_culling: false, ..Default::default() }, 6);
    for (i, (a, b)) in culled.iter().zip(&all).enumerate() {
        assert!(a == b, "frame {i} differs with culling");
    }
    assert!(culled[0] != culled[5], "the character walked");
}

#[test]
fn a_skinned_character_far_from_the_origin_looks_as_at_the_origin() {
    // Joint matrices are relative to the skinned entity (computed in f64), so the pose itself is
    // exact far away (unit test in components::skin); what remains is f32 placement of the
    // character and the camera, spaced 1 mm apart at 10 km, 8 mm at 100 km and 6 cm at 1000 km:
    // sub-pixel shifts of a 2 m figure 128 pixels high. Measured FLIP means: 0.0039 at 10 km,
    // 0.030 at 141 km, 0.079 at 1000 km (where the whole figure moves by up to 4 pixels).
    let near = walk_frames(Vec3::ZERO, RenderSettings::default(), 1);
    for (far, limit) in
        [(Vec3::new(1.0e4, 0.0, 0.0), 0.01), (Vec3::new(1.0e5, 0.0, -1.0e5), 0.05), (Vec3::new(0.0, 1.0e6, 0.0), 0.1)]
    {
        let image = walk_frames(far, RenderSettings::default(), 1);
        let flip = common::flip_mean(&near[0], &image[0], 128, 128);
        assert!(flip < limit, "at {far}: FLIP {flip} from the character at the origin (limit {limit})");
    }
}

/// A ribbon of `segments` quads along +X, each quad's vertices bound to its own joint (70 %) and
/// the next (30 %), coloured by position, with `targets` morph targets each lifting every
/// `targets`-th quad.
fn ribbon(segments: usize, targets: usize) -> Mesh {
    let mut mesh = Mesh::default();
    let mut morph: Vec<MorphTarget> = (0..targets).map(|_| MorphTarget::default()).collect();
    for i in 0..segments {
        let x = 0.1 * i as f32;
        let base = mesh.positions.len() as u32;
        for (dx, y) in [(0.0, 0.0), (0.1, 0.0), (0.1, 1.0), (0.0, 1.0)] {
            mesh.positions.push(Vec3::new(x + dx, y, 0.0));
            mesh.normals.push(Vec3::Z);
            mesh.colors.push(Vec4::new(i as f32 / segments as f32, y, 1.0 - i as f32 / segments as f32, 1.0));
            mesh.joints.push([i as u16, ((i + 1) % segments) as u16, 0, 0]);
            mesh.weights.push(Vec4::new(0.7, 0.3, 0.0, 0.0));
            for (t, target) in morph.iter_mut().enumerate() {
                let hit = i % targets == t;
                target.positions.push(if hit { Vec3::new(0.0, 0.4 * y, 0.0) } else { Vec3::ZERO });
                target.normals.push(if hit { Vec3::new(0.3, 0.2 * y, 0.0) } else { Vec3::ZERO });
            }
        }
        mesh.indices.get_or_insert_with(Vec::new).extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    mesh.morph_targets = morph;
    mesh
}

/// Renders the lit ribbon from a fixed camera: skinned and morphed on the GPU when
/// `gpu_deformed` is set, else as a static mesh whose positions and normals the CPU deformed.
fn ribbon_frame(gpu_deformed: bool) -> Vec<u8> {
    let (segments, targets) = (300, 40);
    let mut app = common::scene_app();
    app.insert_resource(Time::fixed_hz(60.0));
    let joints: Vec<Entity> = (0..segments)
        .map(|i| {
            let x = 0.1 * i as f32;
            let t = Transform::from_xyz(x, 0.5 * (0.1 * i as f32).sin(), 0.0).with_rotation(
                Quat::from_rotation_z(0.3 * (0.07 * i as f32).cos())
                    * Quat::from_rotation_y(0.6 * (0.05 * i as f32).sin()),
            );
            app.world.spawn(t).id()
        })
        .collect();
    let inverse_bindposes: Vec<Mat4> =
        (0..segments).map(|i| Mat4::from_translation(Vec3::new(-0.1 * i as f32, 0.0, 0.0))).collect();
    let weights: Vec<f32> = (0..targets).map(|t| (t as f32 * 0.37).sin()).collect();
    // Lit and glossy, so normals show: the default key light and ambient term light it.
    let paint = StandardMaterial::from_color(Vec4::ONE, 0.4);
    let mesh = ribbon(segments, targets);
    let skin = SkinnedMesh { inverse_bindposes: inverse_bindposes.into(), joints };
    let entity = common::spawn_mesh(&mut app, mesh.clone(), paint.clone(), Transform::IDENTITY);
    app.world.entity_mut(entity).insert((skin, MorphWeights(weights.clone())));
    app.world.spawn((
        Camera::default(),
        Transform::from_xyz(15.0, 0.5, 10.5).looking_at(Vec3::new(15.0, 0.5, 0.0), Vec3::Y),
    ));
    app.update();
    if !gpu_deformed {
        let matrices = app.world.get::<JointMatrices>(entity).unwrap().0.clone();
        let (positions, normals) =
            (mesh.deformed_positions(&matrices, &weights), mesh.deformed_normals(&matrices, &weights));
        let mut posed = Mesh { positions, normals, ..mesh };
        posed.joints.clear();
        posed.weights.clear();
        posed.morph_targets.clear();
        app.world.despawn(entity);
        common::spawn_mesh(&mut app, posed, paint, Transform::IDENTITY);
    }
    common::render_app(&mut app, (512, 128), RenderSettings::default())
}

#[test]
fn gpu_skinning_of_300_joints_and_40_morph_targets_equals_the_cpu_reference() {
    // Positions and normals (lit, glossy): the joints turn about Y as well as Z, and the morph
    // targets bend normals too.
    let gpu_frame = ribbon_frame(true);
    let cpu_frame = ribbon_frame(false);
    let covered = gpu_frame.chunks_exact(4).filter(|p| p[0] > 60 || p[2] > 60).count();
    assert!(covered > 5_000, "the ribbon covers {covered} pixels");
    // Same positions and normals up to float summation order: at most a few pixels differ.

    let differing = gpu_frame.chunks_exact(4).zip(cpu_frame.chunks_exact(4)).filter(|(a, b)| a != b).count();
    let flip = common::flip_mean(&gpu_frame, &cpu_frame, 512, 128);
    assert!(flip < 0.002 && differing < 100, "FLIP {flip}, {differing} pixels differ");
}

/// The ribbon at rest, drawn as a static mesh (no skin, no morph targets).
fn static_ribbon_frame(mesh: Mesh) -> Vec<u8> {
    let mut app = common::scene_app();
    let unlit = StandardMaterial { unlit: true, ..StandardMaterial::from_color(Vec4::ONE, 1.0) };
    let plain = Mesh { joints: Vec::new(), weights: Vec::new(), morph_targets: Vec::new(), ..mesh };
    common::spawn_mesh(&mut app, plain, unlit, Transform::IDENTITY);
    app.world.spawn((
        Camera::default(),
        Transform::from_xyz(15.0, 0.5, 10.5).looking_at(Vec3::new(15.0, 0.5, 0.0), Vec3::Y),
    ));
    common::render_app(&mut app, (512, 128), RenderSettings::default())
}

#[test]
fn a_deformed_draw_follows_mesh_edits_and_returns_to_rest_when_its_pose_goes() {
    let (segments, targets) = (40, 4);
    let mut app = common::scene_app();
    let joints: Vec<Entity> =
        (0..segments).map(|i| app.world.spawn(Transform::from_xyz(0.1 * i as f32, 0.3, 0.0)).id()).collect();
    let inverse_bindposes: Vec<Mat4> =
        (0..segments).map(|i| Mat4::from_translation(Vec3::new(-0.1 * i as f32, 0.0, 0.0))).collect();
    let unlit = StandardMaterial { unlit: true, ..StandardMaterial::from_color(Vec4::ONE, 1.0) };
    let mesh = ribbon(segments, targets);
    let entity = common::spawn_mesh(&mut app, mesh.clone(), unlit, Transform::IDENTITY);
    let skin = SkinnedMesh { inverse_bindposes: inverse_bindposes.into(), joints };
    app.world.entity_mut(entity).insert((skin, MorphWeights(vec![1.0; targets])));
    app.world.spawn((
        Camera::default(),
        Transform::from_xyz(15.0, 0.5, 10.5).looking_at(Vec3::new(15.0, 0.5, 0.0), Vec3::Y),
    ));
    let posed = common::render_app(&mut app, (512, 128), RenderSettings::default());
    let rest = static_ribbon_frame(mesh.clone());
    assert_ne!(posed, rest, "lifted 0.3 m and morphed");

    // Editing the mesh asset (here: the ribbon twice as long) re-deforms the new content.
    let handle = app.world.get::<Mesh3d>(entity).unwrap().0;
    let longer: Vec<Vec3> = mesh.positions.iter().map(|p| Vec3::new(2.0 * p.x, p.y, p.z)).collect();
    app.world.resource_mut::<Assets<Mesh>>().get_mut(handle).unwrap().positions = longer.clone();
    let edited = common::render_app(&mut app, (512, 128), RenderSettings::default());
    let matrices = app.world.get::<JointMatrices>(entity).unwrap().0.clone();
    let edited_mesh = Mesh { positions: longer, ..mesh.clone() };
    let reference = Mesh { positions: edited_mesh.deformed_positions(&matrices, &[1.0; 4]), ..edited_mesh.clone() };
    assert_eq!(edited, static_ribbon_frame(reference), "the edited mesh, deformed");

    // Without skin and weights the draw is its mesh at rest again.
    app.world.entity_mut(entity).remove::<(SkinnedMesh, JointMatrices, MorphWeights)>();
    let bare = common::render_app(&mut app, (512, 128), RenderSettings::default());
    assert_eq!(bare, static_ribbon_frame(edited_mesh), "no pose: the bind pose");
}

#[test]
fn nan_weights_and_joints_leave_no_nan_in_the_frame() {
    let (segments, targets) = (20, 4);
    let mut app = common::scene_app();
    let joints: Vec<Entity> = (0..segments)
        .map(|i| {
            // Every third joint is NaN or infinite, every fourth scaled to nothing.
            let t = match i % 4 {
                0 => Transform::from_xyz(f32::NAN, 0.0, 0.0),
                1 => Transform::from_scale(Vec3::ZERO),
                2 => Transform::from_xyz(f32::INFINITY, 1e30, 0.0),
                _ => Transform::from_xyz(0.1 * i as f32, 0.0, 0.0),
            };
            app.world.spawn(t).id()
        })
        .collect();
    let inverse_bindposes: Vec<Mat4> = vec![Mat4::IDENTITY; segments];
    let mesh = ribbon(segments, targets);
    let entity = common::spawn_mesh(&mut app, mesh, StandardMaterial::from_color(Vec4::ONE, 0.5), Transform::IDENTITY);
    let skin = SkinnedMesh { inverse_bindposes: inverse_bindposes.into(), joints };
    app.world.entity_mut(entity).insert((skin, MorphWeights(vec![f32::NAN, f32::INFINITY, -1e30, 0.5])));
    app.world
        .spawn((Camera::default(), Transform::from_xyz(1.0, 0.5, 4.0).looking_at(Vec3::new(1.0, 0.5, 0.0), Vec3::Y)));
    common::render_app(&mut app, (128, 64), RenderSettings::default());
    common::assert_finite_hdr(&common::hdr_of(&app), "NaN and infinite poses");
}
