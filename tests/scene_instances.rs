//! A loaded scene is an instance under one root entity: moved by the root's transform, cloned
//! (sharing assets, own entities, same pose and playback), and despawned as a whole.

use penumbra::prelude::*;

mod common;
use common::asset;

fn count<F: bevy_ecs::query::QueryFilter>(world: &mut World) -> usize {
    world.query_filtered::<Entity, F>().iter(world).count()
}

#[test]
fn a_scene_instance_moves_clones_and_despawns_as_a_whole() {
    let mut app = common::scene_app();
    app.insert_resource(Time::fixed_hz(60.0));
    let root = load_scene(&mut app.world, &asset("CesiumMan/CesiumMan.glb"), &ImportOptions::default()).unwrap();
    app.world.get_mut::<Transform>(root).unwrap().translation = Vec3::new(5.0, 0.0, 0.0);
    let mut player = app.world.get_mut::<AnimationPlayer>(root).unwrap();
    player.seek(0.4).unwrap();
    player.set_speed(0.5).unwrap();
    app.update();
    let entities = count::<With<Transform>>(&mut app.world);
    let meshes = count::<With<Mesh3d>>(&mut app.world);
    let mesh_assets = app.world.resource::<Assets<Mesh>>().len();

    // Moving the root moved the whole model: its skinned mesh sits 5 m along +X.
    let skinned_x = |world: &mut World, root: Entity| {
        let mut q = world.query::<(&GlobalTransform, &SkinnedMesh, &ChildOf)>();
        let mut found = None;
        for (g, _, parent) in q.iter(world) {
            let mut up = parent.parent();
            loop {
                if up == root {
                    found = Some(g.translation().x);
                }
                match world.get::<ChildOf>(up) {
                    Some(p) => up = p.parent(),
                    None => break,
                }
            }
        }
        found.expect("a skinned mesh under the root")
    };
    assert!((skinned_x(&mut app.world, root) - 5.0).abs() < 1e-4);

    let copy = clone_scene(&mut app.world, root).expect("load_scene roots can be cloned");
    app.update();
    assert_eq!(count::<With<Mesh3d>>(&mut app.world), 2 * meshes, "the copy has its own entities");
    assert!(app.world.resource::<Assets<Mesh>>().len() <= 2 * mesh_assets);
    assert_eq!(app.world.get::<Transform>(copy).unwrap().translation, Vec3::new(5.0, 0.0, 0.0));
    let (a, b) = (app.world.get::<AnimationPlayer>(root).unwrap(), app.world.get::<AnimationPlayer>(copy).unwrap());
    assert_eq!((a.active(), a.time(), a.speed()), (b.active(), b.time(), b.speed()), "same playback");
    // The copy moves on its own.
    app.world.get_mut::<Transform>(copy).unwrap().translation = Vec3::new(-5.0, 0.0, 0.0);
    app.update();
    assert!((skinned_x(&mut app.world, copy) + 5.0).abs() < 1e-4);
    assert!((skinned_x(&mut app.world, root) - 5.0).abs() < 1e-4);

    // Both draw; despawning the original takes every entity of it and leaves the copy.
    let frame = common::render_app(&mut app, (64, 64), Default::default());
    assert_eq!(frame.len(), 64 * 64 * 4);
    let drawn = app.world.resource::<Renderer>().stats().instances;
    app.world.despawn(root);
    app.update();
    assert_eq!(count::<With<Transform>>(&mut app.world), entities, "only the copy's entities remain");
    assert_eq!(count::<With<Mesh3d>>(&mut app.world), meshes);
    common::render_app(&mut app, (64, 64), Default::default());
    assert_eq!(app.world.resource::<Renderer>().stats().instances * 2, drawn);
    assert!(clone_scene(&mut app.world, root).is_none(), "a despawned root is not cloned");
}

#[test]
fn unloading_an_instance_removes_its_entities_and_assets_and_leaves_the_others() {
    let mut app = common::scene_app();
    let path = common::asset("BoxTextured/BoxTextured.glb");
    let options = ImportOptions::default();
    let first = load_scene(&mut app.world, &path, &options).unwrap();
    let (meshes, materials, images) = (
        app.world.resource::<Assets<Mesh>>().len(),
        app.world.resource::<Assets<StandardMaterial>>().len(),
        app.world.resource::<Assets<Image>>().len(),
    );
    assert!(meshes > 0 && materials > 0 && images > 0);
    let entities = count::<With<Transform>>(&mut app.world);
    let second = clone_scene(&mut app.world, first).unwrap();
    let frame_both = common::render_app(&mut app, (48, 48), Default::default());
    assert!(unload_scene(&mut app.world, first));
    assert_eq!(count::<With<Transform>>(&mut app.world), entities, "only the second instance's entities remain");
    assert_eq!(app.world.resource::<Assets<Mesh>>().len(), meshes);
    assert_eq!(app.world.resource::<Assets<StandardMaterial>>().len(), materials);
    assert_eq!(app.world.resource::<Assets<Image>>().len(), images);
    // The survivor still draws exactly as before (both instances sat in the same place).
    assert_eq!(common::render_app(&mut app, (48, 48), Default::default()), frame_both);
    assert!(unload_scene(&mut app.world, second));
    assert_eq!(count::<With<Transform>>(&mut app.world), 0);
    assert!(app.world.resource::<Assets<Mesh>>().is_empty());
    assert!(app.world.resource::<Assets<StandardMaterial>>().is_empty());
    assert!(app.world.resource::<Assets<Image>>().is_empty());
    assert!(!unload_scene(&mut app.world, second), "already gone");
    common::render_app(&mut app, (48, 48), Default::default());
    assert_eq!(app.world.resource::<Renderer>().memory().textures, 0, "the GPU textures went with the images");
}
