//! White furnace: a white sphere (albedo 1) under uniform unit ambient light must reflect exactly
//! the light it receives, whatever its roughness or metalness; measured in the HDR target before
//! tonemapping, it reads 1.0 ± 2 %. A renderer that loses or invents energy fails here.

use penumbra::prelude::*;
use penumbra::render::{RenderOutput, RenderPlugin, RenderSettings, Renderer};

mod common;
use common::gpu;

const SIZE: u32 = 64;

/// Renders one sphere filling most of the frame and returns the HDR pixels inside 85 % of its
/// projected radius.
fn furnace(metallic: f32, roughness: f32) -> Vec<[f32; 4]> {
    let mut app = App::new();
    app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::uv_sphere(1.0, 64, 32));
    let material = app.world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial {
        base_color: Vec4::ONE,
        metallic,
        roughness,
        ..Default::default()
    });
    app.world.spawn((Mesh3d(mesh), MeshMaterial3d(material)));
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 1.0 });
    // The sphere subtends 2·asin(1/3) ≈ 39° of the 45° field of view.
    app.world.spawn((
        Camera { exposure: Exposure::unit(), ..Default::default() },
        Transform::from_xyz(0.0, 0.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    let settings = RenderSettings { msaa: 1, keep_hdr: true, ..Default::default() };
    app.insert_resource(Renderer::new(gpu(), settings).unwrap());
    app.insert_resource(RenderOutput::Headless { width: SIZE, height: SIZE });
    app.update();
    let hdr = app.world.resource::<Renderer>().read_hdr().unwrap();
    let disc = (1.0f32 / 3.0).asin().tan() / 22.5f32.to_radians().tan() * SIZE as f32 / 2.0;
    let c = SIZE as f32 / 2.0;
    hdr.iter()
        .enumerate()
        .filter(|(i, _)| {
            let (x, y) = ((i % SIZE as usize) as f32 + 0.5, (i / SIZE as usize) as f32 + 0.5);
            ((x - c).powi(2) + (y - c).powi(2)).sqrt() < 0.85 * disc
        })
        .map(|(_, p)| *p)
        .collect()
}

fn assert_furnace(metallic: f32, roughness: f32) {
    let px = furnace(metallic, roughness);
    assert!(px.len() > 500, "too few pixels inside the sphere: {}", px.len());
    for p in &px {
        for c in &p[..3] {
            assert!(c.is_finite() && (c - 1.0).abs() <= 0.02, "metallic {metallic} roughness {roughness}: pixel {p:?}");
        }
    }
}

#[test]
fn rough_dielectric_reflects_all_ambient_light() {
    assert_furnace(0.0, 1.0);
}

#[test]
fn smooth_dielectric_reflects_all_ambient_light() {
    assert_furnace(0.0, 0.0);
}

#[test]
fn rough_metal_reflects_all_ambient_light() {
    assert_furnace(1.0, 1.0);
}

#[test]
fn smooth_metal_reflects_all_ambient_light() {
    assert_furnace(1.0, 0.0);
}

#[test]
fn half_rough_half_metal_reflects_all_ambient_light() {
    assert_furnace(0.5, 0.5);
}
