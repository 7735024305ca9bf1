//! Hundreds of moving point lights over a field of spheres: every light is a plain entity whose
//! `Transform` a system moves each frame; the renderer bins them into clusters on the GPU. Run
//! with `cargo run --example spinning_lights [-- --lights 512]` (or `--headless lights.png`).

use penumbra::engine::scenes::{SplitMix64, hsl_to_srgb, srgb_to_linear};
use penumbra::prelude::*;

/// A light's orbit: radius, height, angular speed and phase.
#[derive(Component)]
struct Orbit {
    radius: f32,
    height: f32,
    speed: f32,
    phase: f32,
}

fn build(app: &mut App, lights: usize) {
    app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
    let plane = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::plane(60.0));
    let ball = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::ico_sphere(1.0, 3));
    let mut materials = app.world.resource_mut::<Assets<StandardMaterial>>();
    let ground = materials.add(StandardMaterial::from_color(Vec4::new(0.5, 0.5, 0.5, 1.0), 0.7));
    let white = materials.add(StandardMaterial::from_color(Vec4::new(0.9, 0.9, 0.9, 1.0), 0.25));
    app.world.spawn((Mesh3d(plane), MeshMaterial3d(ground), Transform::IDENTITY));
    for i in -3..=3 {
        for j in -3..=3 {
            let at = Vec3::new(6.0 * i as f32, 1.0, 6.0 * j as f32);
            app.world.spawn((Mesh3d(ball), MeshMaterial3d(white), Transform::from_translation(at)));
        }
    }
    let mut rng = SplitMix64(42);
    for _ in 0..lights {
        let c = hsl_to_srgb(rng.uniform(0.0, 360.0), 1.0, 0.5);
        let color = Vec3::new(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z));
        let orbit = Orbit {
            radius: rng.uniform(2.0, 28.0),
            height: rng.uniform(0.3, 2.5),
            speed: rng.uniform(-0.6, 0.6),
            phase: rng.uniform(0.0, std::f32::consts::TAU),
        };
        // 400 lm each, reaching 5 m: bright pools, short enough to keep cluster lists short.
        let light =
            PointLight { color, intensity: 400.0 / (4.0 * std::f32::consts::PI), range: Some(5.0), shadows: false };
        app.world.spawn((light, Transform::default(), orbit));
    }
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.5 });
    app.world.spawn((
        Camera { exposure: Exposure { ev100: 4.0 }, ..Default::default() },
        Transform::from_xyz(0.0, 22.0, 34.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    app.add_systems(Update, move_lights);
}

fn move_lights(time: Res<Time>, mut lights: Query<(&Orbit, &mut Transform)>) {
    let t = time.elapsed_secs();
    lights.par_iter_mut().for_each(|(o, mut transform)| {
        let a = o.phase + o.speed * t;
        transform.translation = Vec3::new(o.radius * a.cos(), o.height, o.radius * a.sin());
    });
}

#[cfg_attr(test, allow(dead_code))]
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let lights = args.iter().position(|a| a == "--lights").and_then(|i| args.get(i + 1)?.parse().ok()).unwrap_or(300);
    let mut app = App::new();
    build(&mut app, lights);
    penumbra::run(&mut app);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_hundred_lights_move_headless() {
        let mut app = App::new();
        build(&mut app, 300);
        let dir = std::env::temp_dir();
        let runner = HeadlessRunner {
            size: (96, 64),
            frames: 20,
            screenshots: vec![(1, dir.join("spinning_lights_1.png")), (20, dir.join("spinning_lights_20.png"))],
            ..Default::default()
        };
        let shots = runner.run_on(&mut app).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(app.world.resource::<Renderer>().stats().lights, 301, "every light (and the ambient) is drawn");
        assert_ne!(shots[0], shots[1], "the lights moved");
    }
}
