//! EXT_mesh_gpu_instancing: a node's mesh drawn once per instance, each instance's transform
//! applied before the node's; bad instancing data is an import error naming the attribute (the
//! golden of the Khronos sample is in tests/goldens.rs).

mod common;

use penumbra::engine::components::{GlobalTransform, Mesh3d};
use penumbra::engine::framing::world_bounds;
use penumbra::engine::import::{GltfScene, ImportErrorKind, ImportOptions, load_scene};
use penumbra::prelude::*;

use common::{asset, scratch_dir};

/// The one-triangle fixture of tests/import_errors.rs with instancing on its node: `node_extra`
/// goes into the node, `accessors` after the positions accessor (index 0; buffer view 0 holds
/// the triangle's 36 bytes).
fn instanced_json(node_extra: &str, accessors: &str) -> String {
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["EXT_mesh_gpu_instancing"],
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0 {node_extra}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
  "buffers": [{{"uri": "triangle.bin", "byteLength": 36}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 36}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                  "min": [0,0,0], "max": [1,1,0]}} {accessors}]
}}"#
    )
}

fn write(name: &str, json: &str) -> std::path::PathBuf {
    let dir = scratch_dir(name);
    let bin: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].iter().flat_map(|f| f.to_le_bytes()).collect();
    std::fs::write(dir.join("triangle.bin"), bin).unwrap();
    let path = dir.join("scene.gltf");
    std::fs::write(&path, json).unwrap();
    path
}

fn drawn(world: &mut World) -> Vec<GlobalTransform> {
    let mut q = world.query_filtered::<&GlobalTransform, With<Mesh3d>>();
    q.iter(world).copied().collect()
}

#[test]
fn the_sample_draws_all_125_instances() {
    let scene = GltfScene::load(&asset("SimpleInstancing/SimpleInstancing.glb"), &ImportOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let mut app = App::new();
    app.add_plugins(CorePlugin);
    scene.spawn(&mut app.world);
    app.update();
    let placed = drawn(&mut app.world);
    assert_eq!(placed.len(), 125, "one drawn entity per instance");
    // A 5×5×5 grid: five distinct positions along each axis.
    for axis in 0..3 {
        let mut v: Vec<i64> = placed.iter().map(|g| (g.translation()[axis] * 1000.0).round() as i64).collect();
        v.sort();
        v.dedup();
        assert_eq!(v.len(), 5, "axis {axis}: {v:?}");
    }
    let b = world_bounds(&mut app.world);
    assert!(b.half_extents().min_element() > 1.0, "{b:?}");
}

#[test]
fn instances_are_placed_before_the_nodes_transform() {
    // Two instances at x = 0 and x = 2, the second scaled 2×, under a node moved to z = 5 and
    // turned 90° about +Y (+X becomes −Z).
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let json = instanced_json(
        &format!(
            r#", "translation": [0, 0, 5], "rotation": [0, {s}, 0, {s}],
               "extensions": {{"EXT_mesh_gpu_instancing": {{"attributes": {{"TRANSLATION": 1, "SCALE": 2}}}}}}"#
        ),
        r#", {"bufferView": 1, "componentType": 5126, "count": 2, "type": "VEC3"},
             {"bufferView": 2, "componentType": 5126, "count": 2, "type": "VEC3"}"#,
    )
    .replace(
        r#""bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}]"#,
        r#""bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 1, "byteOffset": 0, "byteLength": 24}, {"buffer": 1, "byteOffset": 24, "byteLength": 24}]"#,
    )
    .replace(
        r#""buffers": [{"uri": "triangle.bin", "byteLength": 36}]"#,
        r#""buffers": [{"uri": "triangle.bin", "byteLength": 36}, {"uri": "instances.bin", "byteLength": 48}]"#,
    );
    let path = write("instancing-order", &json);
    let instances: Vec<u8> =
        [0.0f32, 0.0, 0.0, 2.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0].iter().flat_map(|f| f.to_le_bytes()).collect();
    std::fs::write(path.with_file_name("instances.bin"), instances).unwrap();
    let mut app = App::new();
    app.add_plugins(CorePlugin);
    load_scene(&mut app.world, &path, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    app.update();
    let mut placed = drawn(&mut app.world);
    placed.sort_by(|a, b| b.translation().z.total_cmp(&a.translation().z));
    assert_eq!(placed.len(), 2);
    let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-5;
    assert!(close(placed[0].translation(), Vec3::new(0.0, 0.0, 5.0)), "{:?}", placed[0].translation());
    assert!(close(placed[1].translation(), Vec3::new(0.0, 0.0, 3.0)), "{:?}", placed[1].translation());
    // The second instance's scale, turned with the node.
    let x_axis = placed[1].0.matrix3.x_axis;
    assert!(close(Vec3::from(x_axis), Vec3::new(0.0, 0.0, -2.0)), "{x_axis:?}");
}

fn load_error(name: &str, json: &str) -> String {
    let path = write(name, json);
    let mut app = App::new();
    app.add_plugins(CorePlugin);
    let before = app.world.entities().count_spawned();
    let err = load_scene(&mut app.world, &path, &ImportOptions::default()).expect_err("must fail");
    assert_eq!(app.world.entities().count_spawned(), before, "a failed load left entities behind");
    assert!(matches!(err.kind, ImportErrorKind::Malformed(_) | ImportErrorKind::Accessor { .. }), "{err}");
    let msg = err.to_string();
    assert!(msg.starts_with(&path.display().to_string()), "the error names the file: {msg}");
    msg
}

#[test]
fn bad_instancing_data_is_an_error_naming_the_attribute() {
    let ext =
        |attributes: &str| format!(r#", "extensions": {{"EXT_mesh_gpu_instancing": {{"attributes": {attributes}}}}}"#);
    // An accessor the file does not have.
    let msg = load_error("instancing-index", &instanced_json(&ext(r#"{"TRANSLATION": 9}"#), ""));
    assert!(msg.contains("EXT_mesh_gpu_instancing.attributes.TRANSLATION is accessor 9, but the file has 1"), "{msg}");
    // Attributes of different counts.
    let two = r#", {"bufferView": 0, "componentType": 5126, "count": 2, "type": "VEC3"}"#;
    let msg = load_error("instancing-counts", &instanced_json(&ext(r#"{"TRANSLATION": 0, "SCALE": 1}"#), two));
    assert!(msg.contains("has attributes of different counts (TRANSLATION: 3, SCALE: 2)"), "{msg}");
    // A rotation of three components.
    let msg = load_error("instancing-type", &instanced_json(&ext(r#"{"ROTATION": 0}"#), ""));
    assert!(msg.contains("attributes.ROTATION") && msg.contains("expected 4 components"), "{msg}");
    // Not an index at all; no attributes object.
    let msg = load_error("instancing-not-index", &instanced_json(&ext(r#"{"SCALE": "x"}"#), ""));
    assert!(msg.contains("attributes.SCALE is \"x\", not an accessor index"), "{msg}");
    let msg = load_error(
        "instancing-no-attributes",
        &instanced_json(r#", "extensions": {"EXT_mesh_gpu_instancing": {}}"#, ""),
    );
    assert!(msg.contains("has no attributes object"), "{msg}");
}

#[test]
fn non_finite_and_non_unit_instances_are_repaired_with_a_warning() {
    let json = instanced_json(
        r#", "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"ROTATION": 1}}}"#,
        r#", {"bufferView": 1, "componentType": 5126, "count": 2, "type": "VEC4"}"#,
    )
    .replace(
        r#""bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}]"#,
        r#""bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 1, "byteOffset": 0, "byteLength": 32}]"#,
    )
    .replace(
        r#""buffers": [{"uri": "triangle.bin", "byteLength": 36}]"#,
        r#""buffers": [{"uri": "triangle.bin", "byteLength": 36}, {"uri": "rotations.bin", "byteLength": 32}]"#,
    );
    let path = write("instancing-repair", &json);
    let rotations: Vec<u8> =
        [0.0f32, 0.0, 0.0, 2.0, f32::NAN, 0.0, 0.0, 1.0].iter().flat_map(|f| f.to_le_bytes()).collect();
    std::fs::write(path.with_file_name("rotations.bin"), rotations).unwrap();
    let scene = GltfScene::load(&path, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let joined = scene.warnings.join("\n");
    assert!(joined.contains("1 instance(s) with non-finite values"), "{joined}");
    assert!(joined.contains("1 instance rotation(s) were not unit quaternions"), "{joined}");
    let mut app = App::new();
    app.add_plugins(CorePlugin);
    scene.spawn(&mut app.world);
    app.update();
    for g in drawn(&mut app.world) {
        assert!(g.0.is_finite() && (g.rotation().length() - 1.0).abs() < 1e-5, "{g:?}");
    }
}

#[test]
fn instances_count_against_the_node_limit() {
    // SimpleInstancing: 1 node and 125 instances of a one-primitive mesh.
    let mut options = ImportOptions::default();
    options.limits.apply("nodes=100").unwrap();
    let err = GltfScene::load(&asset("SimpleInstancing/SimpleInstancing.glb"), &options).expect_err("over the limit");
    match &err.kind {
        ImportErrorKind::LimitExceeded { name, .. } => {
            assert_eq!(*name, penumbra::engine::import::Limit::Nodes, "{err}")
        }
        _ => panic!("expected the node limit, got: {err}"),
    }
    assert!(err.to_string().contains("EXT_mesh_gpu_instancing"), "{err}");
    options.limits.apply("nodes=126").unwrap();
    GltfScene::load(&asset("SimpleInstancing/SimpleInstancing.glb"), &options).unwrap_or_else(|e| panic!("{e}"));
}
