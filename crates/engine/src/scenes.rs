//! Procedural benchmark scenes, built exactly as their shared definition gives them (positions,
//! counts, random sequence, camera), so benchmark figures can be set beside other engines' on the
//! same scenes. Benchmarks and tests spawn them into a world that has the asset stores
//! ([`crate::CorePlugin`]).

use bevy_ecs::world::World;
use glam::{Vec3, Vec4};

use crate::assets::Assets;
pub use crate::color::srgb_to_linear;
use crate::components::{
    AmbientLight, Camera, DirectionalLight, Exposure, Mesh3d, MeshMaterial3d, PointLight, Projection, Transform,
};
use crate::material::StandardMaterial;
use crate::mesh::Mesh;

/// SplitMix64 (Steele, Lea and Flood 2014), the generator the benchmark scenes are defined with.
#[derive(Debug, Clone)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [a, b) with 24 bits of resolution.
    pub fn uniform(&mut self, a: f32, b: f32) -> f32 {
        a + (b - a) * ((self.next_u64() >> 40) as f32 / (1u64 << 24) as f32)
    }
}

fn srgb(r: f32, g: f32, b: f32) -> Vec4 {
    Vec4::new(srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b), 1.0)
}

/// HSL (hue in degrees) to sRGB-encoded RGB.
pub fn hsl_to_srgb(hue: f32, saturation: f32, lightness: f32) -> Vec3 {
    let c = (1.0 - (2.0 * lightness - 1.0).abs()) * saturation;
    let h = hue.rem_euclid(360.0) / 60.0;
    let x = c * (1.0 - (h % 2.0 - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = lightness - c / 2.0;
    Vec3::new(r + m, g + m, b + m)
}

/// EV100 of the benchmark scenes' camera (Bevy's default exposure, which they were defined with).
pub const BENCH_EV100: f32 = 9.7;

/// The seed of the many-lights scene's light sequence.
pub const MANY_LIGHTS_SEED: u64 = 0x5EED_0000_0000_0001;

/// **many-lights**: a 200 × 200 ground plane, 36 spheres, `count` point lights of 20 000 lm
/// scattered over the ground at heights 0.5–3 m with `range` (the scene's is 3 m; `None`
/// derives each range from the intensity), ambient 60 cd/m², and the camera at (0, 160, 160)
/// looking at (0, 0, 25). Returns the light entities in spawn order.
pub fn spawn_many_lights(world: &mut World, count: usize, range: Option<f32>) -> Vec<bevy_ecs::entity::Entity> {
    let plane = world.resource_mut::<Assets<Mesh>>().add(Mesh::plane(200.0));
    let sphere = world.resource_mut::<Assets<Mesh>>().add(Mesh::uv_sphere(2.0, 32, 18));
    let mut materials = world.resource_mut::<Assets<StandardMaterial>>();
    let ground = materials.add(StandardMaterial::from_color(srgb(0.7, 0.7, 0.7), 0.8));
    let ball = materials.add(StandardMaterial::from_color(srgb(0.9, 0.9, 0.9), 0.3));
    world.spawn((Mesh3d(plane), MeshMaterial3d(ground), Transform::default()));
    for i in 0..6 {
        for j in 0..6 {
            let at = Vec3::new(-75.0 + 30.0 * i as f32, 2.0, -75.0 + 30.0 * j as f32);
            world.spawn((Mesh3d(sphere), MeshMaterial3d(ball), Transform::from_translation(at)));
        }
    }
    let mut rng = SplitMix64(MANY_LIGHTS_SEED);
    // 20 000 lm spread evenly over the sphere: lm / 4π candela.
    let intensity = 20_000.0 / (4.0 * std::f32::consts::PI);
    let lights = (0..count)
        .map(|_| {
            let x = rng.uniform(-100.0, 100.0);
            let z = rng.uniform(-100.0, 100.0);
            let y = rng.uniform(0.5, 3.0);
            let hue = rng.uniform(0.0, 360.0);
            let c = hsl_to_srgb(hue, 1.0, 0.5);
            let color = Vec3::new(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z));
            world
                .spawn((
                    PointLight { color, intensity, range, shadows: false },
                    Transform::from_translation(Vec3::new(x, y, z)),
                ))
                .id()
        })
        .collect();
    world.spawn(AmbientLight { color: Vec3::ONE, intensity: 60.0 });
    world.spawn((
        Camera {
            projection: Projection::Perspective { yfov: 45f32.to_radians(), znear: 0.1, aspect_ratio: None },
            exposure: Exposure { ev100: BENCH_EV100 },
            ..Default::default()
        },
        Transform::from_xyz(0.0, 160.0, 160.0).looking_at(Vec3::new(0.0, 0.0, 25.0), Vec3::Y),
    ));
    lights
}

/// The seed of the shadows scene's object sequence.
pub const SHADOWS_SEED: u64 = 0x5EED_0000_0000_0002;

/// **shadows** (Penumbra's own; `penumbra bench shadows`): a 200 × 200 ground plane with 400
/// casters on a 20 × 20 grid 2.5 m apart around the origin (boxes 0.5–3 m tall and spheres of
/// radius 0.3–0.9 m, alternating, jittered by SplitMix64 from [`SHADOWS_SEED`]), a sun of 4 lux
/// at 35° elevation from azimuth 240° (shadows on, the sun's angular radius), ambient 0.3 cd/m²,
/// and the camera at (0, 5, 28) looking at (0, 0, 0) (45° vertical field of view, exposure 1),
/// so that the view runs from casters at the near plane to the horizon through every cascade.
pub fn spawn_shadows_scene(world: &mut World) {
    let plane = world.resource_mut::<Assets<Mesh>>().add(Mesh::plane(200.0));
    let cube = world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
    let sphere = world.resource_mut::<Assets<Mesh>>().add(Mesh::uv_sphere(1.0, 32, 16));
    let mut materials = world.resource_mut::<Assets<StandardMaterial>>();
    let ground = materials.add(StandardMaterial::from_color(srgb(0.7, 0.7, 0.7), 0.9));
    let paint = [srgb(0.8, 0.3, 0.2), srgb(0.3, 0.6, 0.8), srgb(0.85, 0.8, 0.6)]
        .map(|c| materials.add(StandardMaterial::from_color(c, 0.5)));
    world.spawn((Mesh3d(plane), MeshMaterial3d(ground), Transform::default()));
    let mut rng = SplitMix64(SHADOWS_SEED);
    for i in 0..20 {
        for j in 0..20 {
            let x = -23.75 + 2.5 * i as f32 + rng.uniform(-0.5, 0.5);
            let z = -23.75 + 2.5 * j as f32 + rng.uniform(-0.5, 0.5);
            let material = MeshMaterial3d(paint[(i + j) % 3]);
            if (i + j) % 2 == 0 {
                let h = rng.uniform(0.5, 3.0);
                let w = rng.uniform(0.4, 1.2);
                let t = Transform::from_xyz(x, 0.5 * h, z).with_scale(Vec3::new(w, h, w));
                world.spawn((Mesh3d(cube), material, t));
            } else {
                let r = rng.uniform(0.3, 0.9);
                let t = Transform::from_xyz(x, r, z).with_scale(Vec3::splat(r));
                world.spawn((Mesh3d(sphere), material, t));
            }
        }
    }
    let (elevation, azimuth) = (35f32.to_radians(), 240f32.to_radians());
    let towards_sun = Vec3::new(elevation.cos() * azimuth.sin(), elevation.sin(), elevation.cos() * azimuth.cos());
    world.spawn((
        DirectionalLight { illuminance: 4.0, ..Default::default() },
        Transform::from_translation(towards_sun).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    world.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.3 });
    world.spawn((
        Camera {
            projection: Projection::Perspective { yfov: 45f32.to_radians(), znear: 0.1, aspect_ratio: None },
            exposure: Exposure::unit(),
            ..Default::default()
        },
        Transform::from_xyz(0.0, 5.0, 28.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
}

/// How `spawn_many_cubes` places its cubes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CubeLayout {
    /// A square grid 2 m apart on the ground, seen from above at an angle.
    Grid,
    /// A Fibonacci sphere, seen from outside.
    Sphere,
}

/// Marks the cubes the many-cubes scene turns every frame (see [`spin_cubes`]).
#[derive(bevy_ecs::component::Component, Debug, Clone, Copy)]
pub struct Spinning;

/// **many-cubes**: `count` unit cubes sharing one mesh and one material (sRGB (0.8, 0.55, 0.3),
/// roughness 0.5), a 10 000 lux sun from (0.3, 1, 0.6), casting shadows when `shadows` (the
/// `--shadows` recipe; the renderer's shadow settings apply), ambient 200 cd/m², and the camera
/// the layout prescribes. The first `ceil(moving·count)` cubes get [`Spinning`]. Returns the cube
/// entities in index order.
pub fn spawn_many_cubes(
    world: &mut World,
    count: usize,
    layout: CubeLayout,
    moving: f64,
    shadows: bool,
) -> Vec<bevy_ecs::entity::Entity> {
    let cube = world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
    let paint =
        world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial::from_color(srgb(0.8, 0.55, 0.3), 0.5));
    let spinning = (moving.clamp(0.0, 1.0) * count as f64).ceil() as usize;
    // The definition's far planes (6·half + 100) clip nothing: Penumbra's perspective far plane
    // is infinite.
    let (positions, eye, target): (Vec<Vec3>, Vec3, Vec3) = match layout {
        CubeLayout::Grid => {
            let side = (count as f64).sqrt().ceil().max(1.0) as usize;
            let centre = (side as f32 - 1.0) / 2.0;
            let at = |i: usize| Vec3::new(2.0 * ((i % side) as f32 - centre), 0.0, 2.0 * ((i / side) as f32 - centre));
            let half = side as f32;
            ((0..count).map(at).collect(), Vec3::new(0.0, 1.6 * half, 1.6 * half), Vec3::new(0.0, 0.0, 0.25 * half))
        }
        CubeLayout::Sphere => {
            let n = count.max(1) as f32;
            let radius = (2.0 * (n / (4.0 * std::f32::consts::PI)).sqrt()).max(2.0);
            let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
            let at = |i: usize| {
                let y = 1.0 - 2.0 * (i as f32 + 0.5) / n;
                let r = (1.0 - y * y).max(0.0).sqrt();
                let theta = i as f32 * golden;
                radius * Vec3::new(r * theta.cos(), y, r * theta.sin())
            };
            ((0..count).map(at).collect(), Vec3::new(0.0, 0.0, 2.8 * radius), Vec3::ZERO)
        }
    };
    let mut cubes = Vec::with_capacity(count);
    for (i, p) in positions.into_iter().enumerate() {
        let mut e = world.spawn((Mesh3d(cube), MeshMaterial3d(paint), Transform::from_translation(p)));
        if i < spinning {
            e.insert(Spinning);
        }
        cubes.push(e.id());
    }
    world.spawn((
        DirectionalLight { illuminance: 10_000.0, shadows, ..Default::default() },
        Transform::from_xyz(0.3, 1.0, 0.6).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    world.spawn(AmbientLight { color: Vec3::ONE, intensity: 200.0 });
    world.spawn((
        Camera {
            projection: Projection::Perspective { yfov: 45f32.to_radians(), znear: 0.1, aspect_ratio: None },
            exposure: Exposure { ev100: BENCH_EV100 },
            ..Default::default()
        },
        Transform::from_translation(eye).looking_at(target, Vec3::Y),
    ));
    cubes
}

/// The many-cubes scene's motion: each [`Spinning`] cube turns 0.02 rad about the world Y axis,
/// then 0.01 rad about its own X axis, every update, on all cores.
pub fn spin_cubes(mut cubes: bevy_ecs::system::Query<&mut Transform, bevy_ecs::query::With<Spinning>>) {
    let (yaw, pitch) = (glam::Quat::from_rotation_y(0.02), glam::Quat::from_rotation_x(0.01));
    cubes.par_iter_mut().for_each(|mut t| {
        t.rotation = (yaw * t.rotation * pitch).normalize();
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix_matches_the_reference_sequence() {
        // The first outputs of SplitMix64 seeded with 0 (Vigna's reference implementation).
        let mut r = SplitMix64(0);
        assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(r.next_u64(), 0x6E78_9E6A_A1B9_65F4);
    }

    #[test]
    fn hsl_primaries() {
        assert_eq!(hsl_to_srgb(0.0, 1.0, 0.5), Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(hsl_to_srgb(120.0, 1.0, 0.5), Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(hsl_to_srgb(240.0, 1.0, 0.5), Vec3::new(0.0, 0.0, 1.0));
    }
}
