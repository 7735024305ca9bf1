//! Every sample model in `tests/assets` imports, and the things each one exists to exercise
//! arrive in the world: cameras, lights, scenes, sparse data, primitive modes, tangents.

use penumbra::engine::import::{GltfCamera, ImportOptions, load_scene};
use penumbra::prelude::*;

mod common;
use common::asset;

fn load(rel: &str) -> App {
    load_with(rel, &ImportOptions::default())
}

fn load_with(rel: &str, options: &ImportOptions) -> App {
    let mut app = App::new();
    app.add_plugins(CorePlugin);
    load_scene(&mut app.world, &asset(rel), options).unwrap_or_else(|e| panic!("{e}"));
    app.update();
    app
}

fn count<C: Component>(app: &mut App) -> usize {
    app.world.query::<&C>().iter(&app.world).count()
}

#[test]
fn every_sample_model_imports() {
    let mut n = 0;
    for dir in std::fs::read_dir(asset("")).unwrap() {
        let dir = dir.unwrap().path();
        if !dir.is_dir() {
            continue;
        }
        let name = dir.file_name().unwrap().to_str().unwrap().to_owned();
        for f in std::fs::read_dir(&dir).unwrap() {
            let f = f.unwrap().path();
            if matches!(f.extension().and_then(|e| e.to_str()), Some("gltf" | "glb")) {
                let mut app = load(f.strip_prefix(asset("")).unwrap().to_str().unwrap());
                assert!(count::<Mesh3d>(&mut app) > 0, "{name} spawned no meshes");
                n += 1;
            }
        }
    }
    assert!(n >= 20, "only {n} models found");
}

#[test]
fn cameras_sample_spawns_both_projections_inactive() {
    let mut app = load("Cameras/Cameras.gltf");
    let mut q = app.world.query::<(&Camera, &GltfCamera)>();
    let cams: Vec<_> = q.iter(&app.world).map(|(c, g)| (c.projection, c.is_active, g.index)).collect();
    assert_eq!(cams.len(), 2);
    assert!(cams.iter().any(|c| matches!(c.0, Projection::Perspective { .. })));
    assert!(cams.iter().any(|c| matches!(c.0, Projection::Orthographic { .. })));
    assert!(cams.iter().all(|c| !c.1), "imported cameras start inactive");
}

#[test]
fn lamp_sample_brings_its_punctual_lights() {
    let mut app = load("LightsPunctualLamp/LightsPunctualLamp.gltf");
    let lights = count::<PointLight>(&mut app) + count::<SpotLight>(&mut app) + count::<DirectionalLight>(&mut app);
    assert!(lights >= 1, "no lights spawned");
}

#[test]
fn multiple_scenes_default_and_chosen() {
    fn spawned_geometry(app: &mut App) -> Vec<Vec3> {
        let mut q = app.world.query::<&Mesh3d>();
        let handles: Vec<_> = q.iter(&app.world).map(|m| m.0).collect();
        assert_eq!(handles.len(), 1);
        app.world.resource::<Assets<Mesh>>().get(handles[0]).unwrap().positions.clone()
    }
    // The file's default is scene 1; scene 0 shows a different mesh.
    let mut default = load("MultipleScenes/MultipleScenes.gltf");
    let mut one =
        load_with("MultipleScenes/MultipleScenes.gltf", &ImportOptions { scene: Some(1), ..Default::default() });
    let mut zero =
        load_with("MultipleScenes/MultipleScenes.gltf", &ImportOptions { scene: Some(0), ..Default::default() });
    assert_eq!(spawned_geometry(&mut default), spawned_geometry(&mut one));
    assert_ne!(spawned_geometry(&mut default), spawned_geometry(&mut zero));
}

#[test]
fn sparse_accessor_substitutes_values() {
    let app = load("SimpleSparseAccessor/SimpleSparseAccessor.gltf");
    let meshes = app.world.resource::<Assets<Mesh>>();
    let (_, mesh) = meshes.iter().next().unwrap();
    // The sample's sparse block lifts some vertices to y = 4 (its README shows the raised bars).
    let max_y = mesh.positions.iter().map(|p| p.y).fold(f32::MIN, f32::max);
    assert!(max_y > 3.0, "sparse values were not applied (max y {max_y})");
}

#[test]
fn primitive_modes_normalise_to_lists() {
    let app = load("MeshPrimitiveModes/MeshPrimitiveModes.gltf");
    let meshes = app.world.resource::<Assets<Mesh>>();
    let topologies: std::collections::HashSet<_> = meshes.iter().map(|(_, m)| m.topology).collect();
    assert_eq!(topologies.len(), 3, "points, lines and triangles: {topologies:?}");
    for (_, m) in meshes.iter() {
        m.validate().unwrap();
    }
}

#[test]
fn missing_tangents_are_generated_for_normal_maps() {
    let app = load("NormalTangentTest/NormalTangentTest.glb");
    let meshes = app.world.resource::<Assets<Mesh>>();
    for (_, m) in meshes.iter() {
        assert_eq!(m.tangents.len(), m.positions.len(), "tangents missing");
        assert!(m.tangents.iter().all(|t| t.w.abs() == 1.0 && t.is_finite()));
    }
}

#[test]
fn uris_with_spaces_resolve() {
    let app = load("BoxWithSpaces/Box With Spaces.gltf");
    assert!(!app.world.resource::<Assets<Image>>().is_empty());
}
