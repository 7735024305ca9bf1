//! A scene written as Rust, rendered headless to a PNG, and a screenshot test of it: the pattern
//! for testing your own scenes. `cargo run --example headless_screenshot -- --headless out.png`
//! writes the image (without `--headless` it opens a window); `cargo test --example
//! headless_screenshot` runs the test below, which is what to copy into your own `tests/`.
//!
//! Screenshot tests stay deterministic because `HeadlessRunner` steps `Time` by a fixed amount
//! (60 Hz): frame N always shows the same simulated state. Render small (a few hundred pixels)
//! and assert on what the picture must show; for whole-image comparisons against a stored golden
//! use a perceptual metric (Penumbra's own tests use FLIP through the `nv-flip` crate).

use penumbra::prelude::*;

fn scene(app: &mut App) {
    app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
    let sphere = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::uv_sphere(1.0, 48, 24));
    let floor = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::plane(8.0));
    let mut materials = app.world.resource_mut::<Assets<StandardMaterial>>();
    let gold = materials.add(StandardMaterial {
        base_color: Vec4::new(1.0, 0.78, 0.34, 1.0),
        metallic: 1.0,
        roughness: 0.3,
        ..Default::default()
    });
    let clay = materials.add(StandardMaterial::from_color(Vec4::new(0.6, 0.6, 0.65, 1.0), 0.8));
    app.world.spawn((Mesh3d(sphere), MeshMaterial3d(gold), Transform::from_xyz(0.0, 1.0, 0.0)));
    app.world.spawn((Mesh3d(floor), MeshMaterial3d(clay), Transform::IDENTITY));
    app.world.spawn((
        DirectionalLight { illuminance: 3.0, ..Default::default() },
        Transform::IDENTITY.looking_at(Vec3::new(-1.0, -2.0, -1.0), Vec3::Y),
    ));
    app.world.spawn((PointLight { intensity: 20.0, ..Default::default() }, Transform::from_xyz(2.0, 2.5, 2.0)));
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.2 });
    app.world
        .spawn((Camera::default(), Transform::from_xyz(0.0, 2.5, 6.0).looking_at(Vec3::new(0.0, 0.8, 0.0), Vec3::Y)));
}

#[cfg_attr(test, allow(dead_code))]
fn main() {
    let mut app = App::new();
    scene(&mut app);
    penumbra::run(&mut app);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Linear-ish brightness of pixel (x, y) of an RGBA8 image `width` wide.
    fn brightness(rgba: &[u8], width: u32, x: u32, y: u32) -> f32 {
        let p = &rgba[((y * width + x) * 4) as usize..][..3];
        (p[0] as f32 + p[1] as f32 + p[2] as f32) / (3.0 * 255.0)
    }

    #[test]
    fn the_gold_sphere_stands_lit_on_the_floor() {
        let mut app = App::new();
        scene(&mut app);
        let (w, h) = (160, 90);
        let out = std::env::temp_dir().join("headless_screenshot.png");
        // No GPU adapter is an error that says what to install, never a skipped test.
        let shots = HeadlessRunner::screenshot(&out, (w, h), 1).run_on(&mut app).unwrap_or_else(|e| panic!("{e}"));
        let image = &shots[0];
        let sphere = brightness(image, w, w / 2, h / 3);
        let sky = brightness(image, w, 4, 2);
        let floor = brightness(image, w, w / 2, h - 3);
        assert!(sphere > 0.3, "the sphere is lit ({sphere})");
        assert!(sky < 0.1, "nothing is drawn above the horizon ({sky})");
        assert!(floor > sky, "the floor is lit ({floor} vs {sky})");
        // Gold: red above blue at the sphere's centre.
        let p = &image[(((h / 3) * w + w / 2) * 4) as usize..][..3];
        assert!(p[0] > p[2], "{p:?}");
        assert!(out.exists());
    }
}
