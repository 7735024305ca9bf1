//! A scene written as Rust, rendered headless to a PNG: the pattern for screenshot tests of your
//! own scenes. Run with `cargo run --example headless_screenshot -- out.png`.

use penumbra::prelude::*;
use penumbra::render::{AdapterRequest, GpuContext, RenderOutput, RenderPlugin, RenderSettings, Renderer};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "headless_screenshot.png".into());
    let mut app = App::new();
    app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
    app.insert_resource(Time::fixed_hz(60.0));

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

    let renderer = Renderer::new(GpuContext::new_headless(&AdapterRequest::default())?, RenderSettings::default())?;
    app.insert_resource(renderer);
    app.insert_resource(RenderOutput::Headless { width: 640, height: 360 });
    app.update();
    let pixels = app.world.resource::<Renderer>().read_headless()?;
    image::save_buffer(&out, &pixels, 640, 360, image::ColorType::Rgba8)?;
    println!("wrote {out}");
    Ok(())
}
