//! OBJ + MTL import: objects, materials mapped to the PBR material, texture options, computed
//! normals, a golden render, and every kind of bad input named with its file (and line).

use std::path::{Path, PathBuf};

use penumbra::engine::import::{ObjScene, SceneFile};
use penumbra::prelude::*;
use penumbra::render::RenderSettings;
use penumbra::render::headless::{CameraChoice, ShotSettings, render_frames, stage_scene};
use penumbra::render::renderer::Renderer;

mod common;
use common::{Tolerance, asset, check_golden, gpu, scratch_dir};

fn scene_path() -> PathBuf {
    asset("ObjScene/scene.obj")
}

/// The spawned scene's objects by name: (mesh, material).
fn spawned(scene: &ObjScene) -> (World, Vec<(String, Mesh, StandardMaterial)>) {
    let mut world = World::new();
    let root = scene.spawn(&mut world);
    let mut q = world.query::<(&Name, &Mesh3d, &MeshMaterial3d, &ChildOf)>();
    let meshes = world.resource::<Assets<Mesh>>();
    let materials = world.resource::<Assets<StandardMaterial>>();
    let mut out: Vec<_> = q
        .iter(&world)
        .filter(|(.., parent)| parent.parent() == root)
        .map(|(name, mesh, material, _)| {
            (name.as_str().to_owned(), meshes.get(mesh.0).unwrap().clone(), materials.get(material.0).unwrap().clone())
        })
        .collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    (world, out)
}

#[test]
fn objects_and_materials_map_to_meshes_and_pbr_materials() {
    let scene = ObjScene::load(&scene_path(), &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let (_world, objects) = spawned(&scene);
    let names: Vec<&str> = objects.iter().map(|o| o.0.as_str()).collect();
    assert_eq!(names, ["ball", "crate", "pane", "strip"]);
    let get = |n: &str| objects.iter().find(|o| o.0 == n).unwrap();

    let (_, crate_mesh, wood) = get("crate");
    assert_eq!(crate_mesh.element_count(), 36, "six quads triangulated");
    assert_eq!(crate_mesh.vertex_count(), 24, "one vertex per distinct position/UV/normal");
    // OBJ's vt (0, 0) is the image's bottom-left: glTF's v = 1.
    assert!(crate_mesh.uv0.iter().any(|uv| *uv == Vec2::new(0.0, 1.0)));
    assert!(crate_mesh.uv0.iter().all(|uv| uv.y == 0.0 || uv.y == 1.0));
    assert_eq!(wood.base_color, Vec4::ONE);
    assert_eq!(wood.metallic, 0.0);
    // Ns 30: α = √(2/32) = 0.25, roughness √α = 0.5.
    assert!((wood.roughness - 0.5).abs() < 1e-6, "{}", wood.roughness);
    let tex = wood.base_color_texture.expect("map_Kd");
    // -s 2 2: u' = 2u, and in flipped v, v' = 2v + (1 − 2 − 0) = 2v − 1.
    assert_eq!((tex.transform.scale, tex.transform.offset), (Vec2::new(2.0, 2.0), Vec2::new(0.0, -1.0)));

    let (_, ball, gold) = get("ball");
    assert_eq!(ball.element_count(), 24);
    assert!(ball.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-5), "computed normals are unit");
    // The octahedron's +X tip (x = 4) gets the mean of its four faces' normals: +X.
    let tip = ball.positions.iter().position(|p| p.x == 4.0).unwrap();
    assert!((ball.normals[tip] - Vec3::X).length() < 1e-5, "{}", ball.normals[tip]);
    assert_eq!((gold.metallic, gold.base_color), (1.0, Vec4::new(1.0, 0.7, 0.3, 1.0)), "black Kd + Ks: a metal");

    let (_, _, glass) = get("pane");
    assert_eq!(glass.alpha_mode, AlphaMode::Blend);
    assert!((glass.base_color.w - 0.4).abs() < 1e-6);
    let (_, _, glow) = get("strip");
    assert_eq!(glow.emissive, Vec3::new(4.0, 1.5, 0.2));
}

#[test]
fn obj_scene_golden() {
    let scene = SceneFile::load(&scene_path(), &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let shot = ShotSettings {
        size: Some((256, 256)),
        camera: CameraChoice::Orbit { yaw: 20.0, pitch: 20.0 },
        ..Default::default()
    };
    let (mut app, size) = stage_scene(&scene, &shot).unwrap();
    let rgba8 = render_frames(&mut app, Renderer::new(gpu(), RenderSettings::default()).unwrap(), size, 1).unwrap();
    check_golden("ObjScene", &common::Shot { width: size.0, height: size.1, rgba8 }, Tolerance::default());
}

/// Copies the test scene into a scratch folder with `edit` applied to (file name, text).
fn edited(name: &str, edit: impl Fn(&str, String) -> String) -> PathBuf {
    let dir = scratch_dir(name);
    for f in ["scene.obj", "scene.mtl", "checker.png"] {
        let src = asset(&format!("ObjScene/{f}"));
        if f.ends_with(".png") {
            std::fs::copy(src, dir.join(f)).unwrap();
        } else {
            std::fs::write(dir.join(f), edit(f, std::fs::read_to_string(src).unwrap())).unwrap();
        }
    }
    dir.join("scene.obj")
}

fn error(path: &Path) -> String {
    ObjScene::load(path, &ImportOptions::default()).unwrap_err().to_string()
}

#[test]
fn bad_obj_input_is_named_with_file_and_line() {
    let syntax =
        edited("obj_syntax", |f, t| if f == "scene.obj" { t.replacen("v 1 -1 -1", "v 1 -1 oops", 1) } else { t });
    let e = error(&syntax);
    assert!(e.contains("scene.obj") && e.contains("line 6"), "{e}");

    let range =
        edited("obj_range", |f, t| if f == "scene.obj" { t.replace("f 15 16 17 18", "f 15 16 17 99") } else { t });
    let e = error(&range);
    // Named on the face's own line, before tobj (which would only name the object's end).
    assert!(e.contains("scene.obj") && e.contains("line 53") && e.contains("index 99 names no vertex"), "{e}");

    let no_mtl =
        edited(
            "obj_no_mtl",
            |f, t| if f == "scene.obj" { t.replace("mtllib scene.mtl", "mtllib gone.mtl") } else { t },
        );
    let e = error(&no_mtl);
    assert!(e.contains("gone.mtl"), "{e}");

    let no_tex =
        edited("obj_no_tex", |f, t| if f == "scene.mtl" { t.replace("checker.png", "missing.png") } else { t });
    let e = error(&no_tex);
    assert!(e.contains("missing.png"), "{e}");

    let outside =
        edited("obj_outside", |f, t| if f == "scene.mtl" { t.replace("checker.png", "../secret.png") } else { t });
    let e = error(&outside);
    assert!(e.contains("outside") && e.contains("secret.png"), "{e}");

    let bad_mtl = edited("obj_bad_mtl", |f, t| if f == "scene.mtl" { t.replace("Ns 400", "Ns shiny") } else { t });
    let e = error(&bad_mtl);
    assert!(e.contains("scene.mtl") && e.contains("line 10"), "{e}");

    let relative =
        edited(
            "obj_relative",
            |f, t| {
                if f == "scene.obj" { t.replace("f 15 16 17 18", "f 15/-9 16/-9 17/-9") } else { t }
            },
        );
    let e = error(&relative);
    assert!(e.contains("scene.obj") && e.contains("line 53") && e.contains("texture coordinate index -9"), "{e}");

    let e = error(&asset("ObjScene/nothing_here.obj"));
    assert!(e.contains("nothing_here.obj"), "{e}");
}

#[test]
fn non_finite_mtl_values_fall_back_to_defaults() {
    let path = edited("obj_nan_mtl", |f, t| {
        if f == "scene.mtl" {
            t.replace("Kd 0.3 0.6 1.0", "Kd nan nan nan").replace("d 0.4", "d nan").replace("Ns 900", "Ns inf")
        } else {
            t
        }
    });
    let scene = ObjScene::load(&path, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let (_world, objects) = spawned(&scene);
    let glass = &objects.iter().find(|o| o.0 == "pane").unwrap().2;
    assert_eq!(glass.base_color, Vec4::ONE, "NaN Kd and d read as absent");
    assert_eq!(glass.alpha_mode, AlphaMode::Opaque);
    assert!(glass.roughness.is_finite());
}
