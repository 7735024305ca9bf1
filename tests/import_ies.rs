//! EXT_lights_ies in glTF: profiles by URI beside the scene or embedded in a buffer view, placed
//! by nodes with a multiplier and a colour, oriented by the node; and every way such a file can
//! be wrong gives an import error naming the file, the profile and the problem.

use penumbra::engine::import::{ImportErrorKind, ImportOptions, load_scene};
use penumbra::prelude::*;
use penumbra::render::RenderSettings;

mod common;
use common::{floor_radiance, hdr_of, render_app, scene_app, scratch_dir, top_down};

/// Axially symmetric, 0–90°: 800 cd straight down falling to 0 at the horizon.
const LAMP: &str = "IESNA:LM-63-2002\n[MANUFAC] test\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 20\n0 45 90\n0\n800 400 0\n";

/// A scene whose one node hangs 0.5 m up, turned to point down (−Z to −Y), holding IES light 0.
fn scene_json(profiles: &str, node_ext: &str, extra_root: &str) -> String {
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["EXT_lights_ies"],
  "extensionsRequired": ["EXT_lights_ies"],
  "extensions": {{"EXT_lights_ies": {{"lights": [{profiles}]}}}},
  {extra_root}
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"translation": [0, 0.5, 0], "rotation": [-0.70710678, 0, 0, 0.70710678],
              "extensions": {{"EXT_lights_ies": {node_ext}}}}}]
}}"#
    )
}

fn write(name: &str, json: &str, lamp: Option<&str>) -> std::path::PathBuf {
    let dir = scratch_dir(name);
    if let Some(text) = lamp {
        std::fs::write(dir.join("lamp.ies"), text).unwrap();
    }
    let path = dir.join("scene.gltf");
    std::fs::write(&path, json).unwrap();
    path
}

#[test]
fn a_profile_beside_the_scene_lights_the_floor_as_the_node_points_it() {
    let json = scene_json(
        r#"{"uri": "lamp.ies", "name": "lamp"}"#,
        r#"{"light": 0, "multiplier": 0.01, "color": [1.0, 0.5, 2.0]}"#,
        "",
    );
    let path = write("ies_uri", &json, Some(LAMP));
    let mut app = scene_app();
    let pixel_world = top_down(&mut app, 1.0);
    load_scene(&mut app.world, &path, &ImportOptions::default()).unwrap();
    let mut lights = app.world.query::<&IesLight>();
    let light = *lights.single(&app.world).unwrap();
    assert_eq!((light.scale, light.color), (0.01, Vec3::new(1.0, 0.5, 1.0)), "colour clamped to [0, 1]");
    let profiles = app.world.resource::<Assets<IesProfile>>();
    assert_eq!(profiles.get(light.profile).unwrap().label, "scene.gltf#lamp");
    render_app(&mut app, (32, 32), RenderSettings { msaa: 1, keep_hdr: true, ..Default::default() });
    let hdr = hdr_of(&app);
    // Straight below and 45° out: 800 and 400 cd, times 0.01 and the colour.
    for (x, y) in [(16, 16), (24, 16)] {
        let p = pixel_world(x, y, 32);
        let d = Vec3::new(0.0, 0.5, 0.0) - p;
        let gamma = d.normalize().dot(Vec3::Y).acos().to_degrees();
        let candela = 8.0 * (1.0 - gamma / 90.0);
        for (c, tint) in [(0, 1.0), (1, 0.5)] {
            let want = floor_radiance(d.normalize(), candela * tint / d.length_squared());
            let got = hdr[(y * 32 + x) as usize][c];
            assert!((got - want).abs() <= 0.02 * want, "pixel ({x}, {y}) channel {c}: {got}, expected {want}");
        }
    }
}

#[test]
fn a_profile_in_a_buffer_view_loads() {
    // The profile's bytes sit in a buffer after 4 bytes of something else.
    let extra = format!(
        r#""buffers": [{{"uri": "lamp.bin", "byteLength": {}}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 4, "byteLength": {}}}],"#,
        LAMP.len() + 4,
        LAMP.len()
    );
    let json = scene_json(r#"{"bufferView": 0, "mimeType": "application/x-ies-lm-63"}"#, r#"{"light": 0}"#, &extra);
    let path = write("ies_view", &json, None);
    std::fs::write(path.with_file_name("lamp.bin"), [b"0000".as_slice(), LAMP.as_bytes()].concat()).unwrap();
    let mut app = scene_app();
    load_scene(&mut app.world, &path, &ImportOptions::default()).unwrap();
    let mut lights = app.world.query::<&IesLight>();
    let light = *lights.single(&app.world).unwrap();
    let profile = app.world.resource::<Assets<IesProfile>>().get(light.profile).unwrap().clone();
    assert_eq!((profile.label.as_str(), profile.candela.as_slice()), ("scene.gltf#ies0", &[800.0, 400.0, 0.0][..]));
}

#[test]
fn bad_ies_references_name_the_file_the_profile_and_the_problem() {
    let lamp = r#"{"uri": "lamp.ies", "name": "lamp"}"#;
    let cases: Vec<(&str, String, Option<&str>, &str)> = vec![
        ("ies_missing", scene_json(lamp, r#"{"light": 0}"#, ""), None, "IES profile 0 (lamp.ies)"),
        (
            "ies_malformed",
            scene_json(lamp, r#"{"light": 0}"#, ""),
            Some("IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n1 x\n"),
            "scene.gltf#lamp:7: expected candela values #2",
        ),
        ("ies_index", scene_json(lamp, r#"{"light": 3}"#, ""), Some(LAMP), "nodes[0].extensions.EXT_lights_ies.light"),
        (
            "ies_multiplier",
            scene_json(lamp, r#"{"light": 0, "multiplier": -2}"#, ""),
            Some(LAMP),
            "multiplier: must be a number ≥ 0",
        ),
        (
            "ies_outside",
            scene_json(r#"{"uri": "../lamp.ies"}"#, r#"{"light": 0}"#, ""),
            Some(LAMP),
            "outside the scene's folder",
        ),
        (
            "ies_both",
            scene_json(r#"{}"#, r#"{"light": 0}"#, ""),
            Some(LAMP),
            "exactly one of \"uri\" and \"bufferView\"",
        ),
        (
            "ies_mime",
            scene_json(r#"{"bufferView": 0}"#, r#"{"light": 0}"#, ""),
            Some(LAMP),
            "must be \"application/x-ies-lm-63\"",
        ),
    ];
    for (name, json, lamp_text, want) in cases {
        let path = write(name, &json, lamp_text);
        let mut app = App::new();
        app.add_plugins(CorePlugin);
        let err = load_scene(&mut app.world, &path, &ImportOptions::default()).expect_err(name);
        let msg = err.to_string();
        assert!(msg.starts_with(&path.display().to_string()), "{name}: {msg}");
        assert!(msg.contains(want), "{name}: {msg:?} should say {want:?}");
        assert!(app.world.resource::<Assets<IesProfile>>().is_empty(), "{name}: a failed load left profiles");
        if name == "ies_missing" {
            assert!(matches!(err.kind, ImportErrorKind::IesProfile { index: 0, .. }), "{err}");
        }
    }
}
