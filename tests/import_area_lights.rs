//! PENUMBRA_lights_area: rectangle, disk, sphere and tube lights on glTF nodes, with the units
//! and orientation of the light components; every malformed entry fails naming its field.

use penumbra::engine::import::{ImportOptions, load_scene};
use penumbra::prelude::*;

mod common;
use common::{asset, scene_app, scratch_dir};

fn node_json(ext: &str) -> String {
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["PENUMBRA_lights_area"],
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"translation": [0, 2, 0], "rotation": [-0.70710678, 0, 0, 0.70710678],
              "extensions": {{"PENUMBRA_lights_area": {ext}}}}}]
}}"#
    )
}

fn load(name: &str, ext: &str) -> Result<App, String> {
    let path = scratch_dir(name).join("scene.gltf");
    std::fs::write(&path, node_json(ext)).unwrap();
    let mut app = scene_app();
    load_scene(&mut app.world, &path, &ImportOptions::default()).map_err(|e| e.to_string())?;
    app.update();
    Ok(app)
}

#[test]
fn the_reference_area_scene_spawns_its_three_lights() {
    let mut app = scene_app();
    load_scene(&mut app.world, &asset("../reference/scenes/area.gltf"), &ImportOptions::default()).unwrap();
    app.update();
    let mut rects = app.world.query::<(&RectLight, &GlobalTransform)>();
    let (rect, at) = rects.single(&app.world).unwrap();
    assert_eq!((rect.luminance, rect.width, rect.height), (3.0, 1.2, 0.6));
    assert_eq!(rect.color, Vec3::new(1.0, 0.95, 0.9));
    // Placed at (-1.5, 2.2, 1.2), its −Z aimed at (-0.3, 0, 0).
    let facing = at.0.transform_vector3(Vec3::NEG_Z).normalize();
    let want = (Vec3::new(-0.3, 0.0, 0.0) - Vec3::new(-1.5, 2.2, 1.2)).normalize();
    assert!(facing.dot(want) > 0.9999, "{facing} vs {want}");
    let mut disks = app.world.query::<&DiskLight>();
    assert_eq!(disks.single(&app.world).unwrap().radius, 0.3);
    let mut spheres = app.world.query::<&SphereLight>();
    let s = spheres.single(&app.world).unwrap();
    assert_eq!((s.intensity, s.radius, s.shadows), (1.5, 0.12, true));
}

#[test]
fn a_tube_light_takes_its_defaults_and_its_options() {
    let mut app =
        load("area_tube", r#"{"shape": "tube", "intensity": 20, "length": 1.5, "range": 4, "shadows": false}"#)
            .unwrap();
    let mut q = app.world.query::<&TubeLight>();
    let t = *q.single(&app.world).unwrap();
    assert_eq!((t.intensity, t.length, t.range, t.shadows), (20.0, 1.5, Some(4.0), false));
    assert_eq!(t.radius, TubeLight::default().radius);
    assert_eq!(t.color, Vec3::ONE);
}

#[test]
fn malformed_area_lights_name_the_field() {
    let cases = [
        (r#"{"shape": "blob", "luminance": 1}"#, "PENUMBRA_lights_area.shape"),
        (r#"{"luminance": 1, "width": 1, "height": 1}"#, "PENUMBRA_lights_area.shape"),
        (r#"{"shape": "rect", "luminance": 1, "height": 1}"#, "PENUMBRA_lights_area.width: is missing"),
        (r#"{"shape": "rect", "luminance": -1, "width": 1, "height": 1}"#, "PENUMBRA_lights_area.luminance"),
        (r#"{"shape": "disk", "luminance": 1, "radius": 0}"#, "PENUMBRA_lights_area.radius"),
        (r#"{"shape": "sphere", "intensity": 1, "radius": 0.1, "color": [1, 1]}"#, "PENUMBRA_lights_area.color"),
        (r#"{"shape": "sphere", "intensity": 1, "radius": 0.1, "shadows": 3}"#, "PENUMBRA_lights_area.shadows"),
        (r#"{"shape": "tube", "intensity": 1, "length": 1, "range": -2}"#, "PENUMBRA_lights_area.range"),
    ];
    for (i, (ext, want)) in cases.into_iter().enumerate() {
        let err = load(&format!("area_bad{i}"), ext).err().unwrap_or_else(|| panic!("{ext} was accepted"));
        assert!(err.contains(want) && err.contains("scene.gltf") && err.contains("nodes[0]"), "{ext}: {err}");
    }
}
