//! Extraction reads what the main world's change feed lists: these check that every way a
//! drawable entity changes reaches `changed_draws`, once, and that nothing else does.
use super::*;
use crate::RenderPlugin;
use glam::Vec3;
use penumbra_engine::components::{ChildOf, Transform, Visibility};
use penumbra_engine::{App, CorePlugin};

fn app() -> App {
    let mut app = App::new();
    app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
    app
}

fn handles(app: &mut App) -> (penumbra_engine::Handle<Mesh>, penumbra_engine::Handle<StandardMaterial>) {
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
    let material = app.world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial::default());
    (mesh, material)
}

fn changed(app: &App) -> Vec<Entity> {
    let mut list = app.world.resource::<RenderScene>().changed_draws.clone();
    list.sort();
    list
}

fn draw(app: &App, e: Entity) -> DrawItem {
    app.world.resource::<RenderScene>().draws.get(e).cloned().expect("extracted")
}

#[test]
fn a_still_frame_lists_nothing_and_a_move_lists_the_mover_once() {
    // Above PARALLEL_EXTRACT_MIN, so the frame that moves them all reads on all cores.
    let mut app = app();
    let (mesh, material) = handles(&mut app);
    let cubes: Vec<Entity> = (0..25_000)
        .map(|i| {
            app.world.spawn((Mesh3d(mesh), MeshMaterial3d(material), Transform::from_xyz(i as f32, 0.0, 0.0))).id()
        })
        .collect();
    let mut cubes = cubes;
    cubes.sort();
    app.update();
    assert!(changed(&app) == cubes, "spawned: each listed once");
    app.update();
    assert!(changed(&app).is_empty());
    for &c in &cubes {
        app.world.get_mut::<Transform>(c).unwrap().translation.y = 2.0;
    }
    app.update();
    assert!(changed(&app) == cubes);
    assert_eq!(draw(&app, cubes[7]).world_from_local.translation.y, 2.0);
    app.world.get_mut::<Transform>(cubes[3]).unwrap().translation.y = 5.0;
    app.update();
    assert_eq!(changed(&app), vec![cubes[3]]);
    assert_eq!(draw(&app, cubes[3]).world_from_local.translation.y, 5.0);
}

#[test]
fn entities_spawned_before_the_renderer_existed_are_extracted() {
    let mut app = App::new();
    app.add_plugins(CorePlugin);
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
    let early = app.world.spawn((Mesh3d(mesh), Transform::default())).id();
    app.update();
    app.add_plugins(RenderPlugin);
    app.update();
    assert_eq!(changed(&app), vec![early]);
    assert!(draw(&app, early).visible);
}

#[test]
fn inserting_a_mesh_or_material_lists_the_entity_once() {
    let mut app = app();
    let (mesh, material) = handles(&mut app);
    let other = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::splat(2.0)));
    let cube = app.world.spawn((Mesh3d(mesh), Transform::default())).id();
    app.update();
    app.world.entity_mut(cube).insert(Mesh3d(other));
    app.update();
    assert_eq!(changed(&app), vec![cube]);
    assert_eq!(draw(&app, cube).mesh, other);
    // Material, mesh and placement in one frame: still one entry.
    app.world.entity_mut(cube).insert((MeshMaterial3d(material), Mesh3d(mesh)));
    app.world.get_mut::<Transform>(cube).unwrap().translation.x = 1.0;
    app.update();
    assert_eq!(changed(&app), vec![cube]);
    let item = draw(&app, cube);
    assert_eq!((item.mesh, item.material), (mesh, Some(material)));
    assert_eq!(item.world_from_local.translation.x, 1.0);
}

#[test]
fn hierarchy_changes_reach_the_children() {
    let mut app = app();
    let (mesh, _) = handles(&mut app);
    let parent = app.world.spawn((Transform::from_xyz(10.0, 0.0, 0.0), Visibility::Inherited)).id();
    let child = app.world.spawn((Mesh3d(mesh), Transform::from_xyz(1.0, 0.0, 0.0), ChildOf(parent))).id();
    let other_parent = app.world.spawn(Transform::from_xyz(0.0, 5.0, 0.0)).id();
    app.update();
    assert_eq!(draw(&app, child).world_from_local.translation.x, 11.0);
    // Moving the parent moves the child.
    app.world.get_mut::<Transform>(parent).unwrap().translation.x = 20.0;
    app.update();
    assert_eq!(changed(&app), vec![child]);
    assert_eq!(draw(&app, child).world_from_local.translation.x, 21.0);
    // Hiding the parent hides the child.
    *app.world.get_mut::<Visibility>(parent).unwrap() = Visibility::Hidden;
    app.update();
    assert_eq!(changed(&app), vec![child]);
    assert!(!draw(&app, child).visible);
    // A new parent places the child anew.
    app.world.entity_mut(child).insert(ChildOf(other_parent));
    app.update();
    assert_eq!(changed(&app), vec![child]);
    let item = draw(&app, child);
    assert_eq!(item.world_from_local.translation, glam::Vec3A::new(1.0, 5.0, 0.0));
    assert!(item.visible);
    // Unparented: its own transform alone.
    app.world.entity_mut(child).remove::<ChildOf>();
    app.update();
    assert_eq!(changed(&app), vec![child]);
    assert_eq!(draw(&app, child).world_from_local.translation, glam::Vec3A::new(1.0, 0.0, 0.0));
}

#[test]
fn despawning_and_spawning_between_frames_lists_each_live_entity_once() {
    let mut app = app();
    let (mesh, material) = handles(&mut app);
    let spawn = |app: &mut App| app.world.spawn((Mesh3d(mesh), MeshMaterial3d(material), Transform::default())).id();
    let first: Vec<Entity> = (0..1000).map(|_| spawn(&mut app)).collect();
    app.update();
    // Churn within one frame: despawned entities' indices go to new ones, some of which go
    // again; hooks and propagation both list the survivors.
    for &e in &first {
        app.world.despawn(e);
    }
    let second: Vec<Entity> = (0..1000).map(|_| spawn(&mut app)).collect();
    for &e in &second[..500] {
        app.world.despawn(e);
    }
    let third: Vec<Entity> = (0..600).map(|_| spawn(&mut app)).collect();
    app.update();
    let mut live: Vec<Entity> = second[500..].iter().chain(&third).copied().collect();
    live.sort();
    let listed = changed(&app);
    let mut unique = listed.clone();
    unique.dedup();
    assert_eq!(listed.len(), unique.len(), "an entity listed twice");
    assert!(listed == live, "{} listed, {} live", listed.len(), live.len());
    let scene = app.world.resource::<RenderScene>();
    assert_eq!(scene.draws.len(), live.len());
    assert!(live.iter().all(|&e| scene.draws.get(e).is_some()));
}

#[test]
fn a_feed_nobody_drains_stops_growing_and_is_read_whole() {
    let mut feed = DrawChanges::default();
    let _ = feed.drain();
    let e = Entity::from_raw_u32(5).unwrap();
    for _ in 0..(1 << 24) + 1 {
        feed.record(e);
    }
    let (lists, everything) = feed.drain();
    assert!(everything, "overflowed: the reader reads every drawable entity");
    assert!(lists.len() <= 1);
}

#[test]
fn a_placement_removed_and_inserted_again_is_drawn_again() {
    let mut app = app();
    let (mesh, _) = handles(&mut app);
    let cube = app.world.spawn((Mesh3d(mesh), Transform::from_xyz(3.0, 0.0, 0.0))).id();
    app.update();
    app.world.entity_mut(cube).remove::<GlobalTransform>();
    app.update();
    assert!(app.world.resource::<RenderScene>().draws.get(cube).is_none());
    app.world.entity_mut(cube).insert(GlobalTransform::default());
    app.update();
    assert_eq!(changed(&app), vec![cube]);
    assert!(app.world.resource::<RenderScene>().draws.get(cube).is_some());
}
