//! The smallest scene: a cube turning under a sun. Run it in a window with
//! `cargo run --example hello_cube`, or headless with `-- --headless cube.png`.

use penumbra::prelude::*;

/// Marks the cube the `spin` system turns.
#[derive(Component)]
struct Spin;

fn build(app: &mut App) {
    app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
    app.add_systems(Startup, setup).add_systems(Update, spin);
}

fn setup(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>, mut materials: ResMut<Assets<StandardMaterial>>) {
    let cube = meshes.add(Mesh::cuboid(Vec3::ONE));
    let paint = materials.add(StandardMaterial::from_color(Vec4::new(0.8, 0.3, 0.1, 1.0), 0.4));
    commands.spawn((Mesh3d(cube), MeshMaterial3d(paint), Transform::IDENTITY, Spin));
    commands.spawn((
        DirectionalLight { illuminance: 4.0, ..Default::default() },
        Transform::IDENTITY.looking_at(Vec3::new(-1.0, -2.0, -1.5), Vec3::Y),
    ));
    commands.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.3 });
    commands.spawn((Camera::default(), Transform::from_xyz(1.5, 1.5, 3.0).looking_at(Vec3::ZERO, Vec3::Y)));
}

/// Half a turn a second, whatever the frame rate.
fn spin(time: Res<Time>, mut cubes: Query<&mut Transform, With<Spin>>) {
    for mut t in &mut cubes {
        t.rotate_y(0.5 * std::f32::consts::PI * time.delta_secs());
    }
}

#[cfg_attr(test, allow(dead_code))]
fn main() {
    let mut app = App::new();
    build(&mut app);
    penumbra::run(&mut app);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cube_turns_headless() {
        let mut app = App::new();
        build(&mut app);
        let dir = std::env::temp_dir();
        let runner = HeadlessRunner {
            size: (96, 64),
            frames: 30,
            screenshots: vec![(1, dir.join("hello_cube_1.png")), (30, dir.join("hello_cube_30.png"))],
            ..Default::default()
        };
        let shots = runner.run_on(&mut app).unwrap_or_else(|e| panic!("{e}"));
        let centre = |s: &[u8]| s[(32 * 96 + 48) * 4..][..3].to_vec();
        assert!(centre(&shots[0]).iter().any(|&c| c > 40), "the cube is lit at the centre");
        assert_ne!(shots[0], shots[1], "half a second later the cube has turned");
    }
}
