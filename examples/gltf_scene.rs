//! A glTF model as a scene instance: loaded under its own root entity (moved here as a whole),
//! its animation playing, a camera orbiting it and a light circling it, all as systems. Run with
//! `cargo run --example gltf_scene [-- MODEL.glb]` (default: the CesiumMan test model), or
//! headless with `--headless model.png`.

use std::path::PathBuf;

use penumbra::engine::framing::world_bounds;
use penumbra::prelude::*;

/// The camera's orbit about the model: centre and distance.
#[derive(Component)]
struct OrbitAbout {
    centre: Vec3,
    distance: f32,
}

/// The light that circles the model.
#[derive(Component)]
struct Circling(Vec3);

fn build(app: &mut App, model: &std::path::Path) -> Result<(), ImportError> {
    app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
    let root = load_scene(&mut app.world, model, &ImportOptions::default())?;
    // The whole model moves with its root.
    app.world.get_mut::<Transform>(root).expect("scene roots have a Transform").translation = Vec3::new(0.0, 0.0, -1.0);
    app.update();
    let bounds = world_bounds(&mut app.world);
    let (centre, size) = (bounds.center(), bounds.half_extents().length().max(0.1));
    app.world.spawn((Camera::default(), Transform::IDENTITY, OrbitAbout { centre, distance: 3.0 * size }));
    app.world.spawn((
        PointLight { intensity: 40.0 * size * size, range: None, ..Default::default() },
        Transform::default(),
        Circling(centre + Vec3::Y * size),
    ));
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.2 });
    app.add_systems(Update, (orbit_camera, circle_light));
    Ok(())
}

fn orbit_camera(time: Res<Time>, mut cameras: Query<(&OrbitAbout, &mut Transform)>) {
    let a = 0.3 * time.elapsed_secs();
    for (o, mut t) in &mut cameras {
        let eye = o.centre + o.distance * Vec3::new(a.sin(), 0.35, a.cos());
        *t = Transform::from_translation(eye).looking_at(o.centre, Vec3::Y);
    }
}

fn circle_light(time: Res<Time>, mut lights: Query<(&Circling, &mut Transform)>) {
    let a = -1.2 * time.elapsed_secs();
    for (c, mut t) in &mut lights {
        t.translation = c.0 + Vec3::new(a.cos(), 0.0, a.sin()) * 1.5;
    }
}

fn default_model() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/assets/CesiumMan/CesiumMan.glb")
}

#[cfg_attr(test, allow(dead_code))]
fn main() {
    // The first argument that is not a flag (`--headless x.png` is the screenshot, not the model).
    let model = penumbra::program_args().into_iter().find(|a| !a.starts_with("--")).map(PathBuf::from);
    let mut app = App::new();
    if let Err(e) = build(&mut app, &model.unwrap_or_else(default_model)) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
    penumbra::run(&mut app);
}

#[cfg(test)]
mod tests {
    use super::*;
    use penumbra::engine::import::SceneRoot;

    #[test]
    fn the_model_animates_and_the_camera_orbits_headless() {
        let mut app = App::new();
        build(&mut app, &default_model()).unwrap();
        let roots = app.world.query_filtered::<Entity, With<SceneRoot>>().iter(&app.world).count();
        assert_eq!(roots, 1);
        let dir = std::env::temp_dir();
        let runner = HeadlessRunner {
            size: (96, 96),
            frames: 15,
            screenshots: vec![(1, dir.join("gltf_scene_1.png")), (15, dir.join("gltf_scene_15.png"))],
            ..Default::default()
        };
        let shots = runner.run_on(&mut app).unwrap_or_else(|e| panic!("{e}"));
        assert!(shots[0].chunks_exact(4).filter(|p| p[0] > 60).count() > 50, "the model is in view");
        assert_ne!(shots[0], shots[1]);
    }
}
