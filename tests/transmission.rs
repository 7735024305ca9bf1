//! KHR_materials_transmission and KHR_materials_volume: what lies behind a transmissive surface
//! is seen through it (features/transmission). Each scene is a pane facing the camera in front
//! of an unlit backdrop of known radiance, measured in the HDR target before tonemapping (no
//! lights, no environment: the pane reflects nothing, so what it shows is what it transmits).

use penumbra::prelude::*;
use penumbra::render::frame::Pass;
use penumbra::render::{RenderSettings, Renderer};

mod common;
use common::{hdr_of, render_app, scene_app, spawn_mesh};

const SIZE: u32 = 64;

/// A square of `size` at depth `z` facing the camera (+Z).
fn pane(app: &mut App, size: f32, z: f32, x: f32, material: StandardMaterial) {
    let facing = Transform::from_xyz(x, 0.0, z).with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2));
    spawn_mesh(app, Mesh::plane(size), material, facing);
}

/// An unlit backdrop filling the view: `left` radiance for x < 0, `right` for x ≥ 0.
fn backdrop(app: &mut App, left: Vec3, right: Vec3) {
    for (x, c) in [(-10.0, left), (10.0, right)] {
        let material = StandardMaterial { unlit: true, ..StandardMaterial::from_color(c.extend(1.0), 1.0) };
        pane(app, 20.0, -3.0, x, material);
    }
}

fn glass(base: Vec3) -> StandardMaterial {
    StandardMaterial {
        base_color: base.extend(1.0),
        metallic: 0.0,
        roughness: 0.0,
        transmission: 1.0,
        ..Default::default()
    }
}

fn scene() -> App {
    let mut app = scene_app();
    app.world.spawn((
        Camera { exposure: Exposure::unit(), ..Default::default() },
        Transform::from_xyz(0.0, 0.0, 5.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    app
}

/// Renders `app` and returns its HDR pixels (radiance: the camera's exposure is 1).
fn render(app: &mut App, msaa: u32) -> Vec<[f32; 4]> {
    render_app(app, (SIZE, SIZE), RenderSettings { msaa, keep_hdr: true, ..Default::default() });
    hdr_of(app)
}

fn at(px: &[[f32; 4]], x: u32, y: u32) -> Vec3 {
    let p = px[(y * SIZE + x) as usize];
    Vec3::new(p[0], p[1], p[2])
}

fn close(a: Vec3, b: Vec3, tolerance: f32) -> bool {
    (a - b).abs().max_element() <= tolerance * b.max_element()
}

/// A clear thin pane shows the backdrop, less what its surface reflects (4 % head-on at IOR
/// 1.5); a tinted one multiplies it by its base colour; a pane with no transmission hides it.
/// (The scene's default ambient light adds the pane's own reflection, 4 % of it.)
#[test]
fn a_thin_pane_shows_what_is_behind_it_tinted_by_its_colour() {
    let backdrop_radiance = Vec3::new(0.2, 0.5, 0.8);
    for msaa in [1, 4] {
        let mut app = scene();
        backdrop(&mut app, backdrop_radiance, backdrop_radiance);
        pane(&mut app, 2.0, 0.0, 0.0, glass(Vec3::ONE));
        let px = render(&mut app, msaa);
        assert_eq!(app.world.resource::<Renderer>().shader_error(), None);
        let centre = at(&px, SIZE / 2, SIZE / 2);
        assert!(close(centre, backdrop_radiance * 0.96, 0.02), "msaa {msaa}: through the pane {centre}");
        assert!(close(at(&px, 2, 2), backdrop_radiance, 0.001), "msaa {msaa}: beside the pane {}", at(&px, 2, 2));
    }
    let tint = Vec3::new(1.0, 0.5, 0.25);
    let mut app = scene();
    backdrop(&mut app, Vec3::ONE, Vec3::ONE);
    pane(&mut app, 2.0, 0.0, 0.0, glass(tint));
    let centre = at(&render(&mut app, 1), SIZE / 2, SIZE / 2);
    assert!(close(centre, tint * 0.96, 0.02), "tinted: {centre}");

    let opaque = |behind: Vec3| {
        let mut app = scene();
        backdrop(&mut app, behind, behind);
        pane(&mut app, 2.0, 0.0, 0.0, StandardMaterial { transmission: 0.0, ..glass(Vec3::ONE) });
        at(&render(&mut app, 1), SIZE / 2, SIZE / 2)
    };
    let (bright, dark) = (opaque(Vec3::ONE), opaque(Vec3::ZERO));
    assert!(close(bright, dark, 1e-4), "a pane without transmission hides the backdrop: {bright} against {dark}");
}

/// KHR_materials_volume: light crossing the volume keeps attenuation colour ^ (thickness /
/// attenuation distance) of itself (Beer's law), the thickness scaled by the node's scale.
#[test]
fn a_volume_attenuates_by_beers_law() {
    let through = |thickness: f32, distance: f32, scale: f32| {
        let mut app = scene();
        backdrop(&mut app, Vec3::ONE, Vec3::ONE);
        let material = StandardMaterial {
            thickness,
            attenuation_distance: distance,
            attenuation_color: Vec3::new(0.5, 0.25, 1.0),
            ..glass(Vec3::ONE)
        };
        let facing = Transform::from_xyz(0.0, 0.0, 0.0)
            .with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
            .with_scale(Vec3::splat(scale));
        spawn_mesh(&mut app, Mesh::plane(2.0 / scale), material, facing);
        at(&render(&mut app, 1), SIZE / 2, SIZE / 2)
    };
    let thin = through(0.0, 1.0, 1.0);
    let one = through(1.0, 1.0, 1.0);
    assert!(close(one, thin * Vec3::new(0.5, 0.25, 1.0), 0.02), "one distance: {one} against {thin}");
    let half = through(0.5, 1.0, 1.0);
    let expected = thin * Vec3::new(0.5f32.sqrt(), 0.5, 1.0);
    assert!(close(half, expected, 0.02), "half a distance: {half} against {expected}");
    // Thickness 0.5 in a node scaled by 2 is 1 world unit.
    let scaled = through(0.5, 1.0, 2.0);
    assert!(close(scaled, one, 0.02), "scaled node: {scaled} against {one}");
    let infinite = through(1.0, f32::INFINITY, 1.0);
    assert!(close(infinite, thin, 0.01), "no attenuation distance: {infinite} against {thin}");
}

/// A rough pane blurs what is behind it (a coarser level of the copy): across the backdrop's
/// sharp edge, a smooth pane's pixels jump from one side's radiance to the other's, a rough
/// one's go through values between them.
#[test]
fn a_rough_pane_blurs_what_is_behind_it() {
    let edge = |roughness: f32| {
        let mut app = scene();
        backdrop(&mut app, Vec3::ZERO, Vec3::ONE);
        pane(&mut app, 3.0, 0.0, 0.0, StandardMaterial { roughness, ..glass(Vec3::ONE) });
        let px = render(&mut app, 1);
        // Pixels of the middle row that are neither side's radiance.
        (0..SIZE).filter(|&x| (0.05..0.9).contains(&at(&px, x, SIZE / 2).y)).count()
    };
    let (smooth, rough) = (edge(0.0), edge(0.8));
    assert!(smooth <= 2, "a smooth pane keeps the edge sharp: {smooth} pixels between");
    assert!(rough >= 6, "a rough pane blurs it: {rough} pixels between (smooth: {smooth})");
}

/// What the method does with a transmissive surface behind another: the copy is taken once,
/// before any transmissive surface is drawn, so through the nearer pane one sees the opaque
/// scene behind both, not the farther pane (documented in docs/scenes.md). The farther pane is
/// seen where the nearer one does not cover it.
#[test]
fn a_transmissive_surface_behind_another_is_not_seen_through_it() {
    let mut app = scene();
    backdrop(&mut app, Vec3::ONE, Vec3::ONE);
    // Green glass behind, over the whole middle; clear glass in front, over the left half only.
    pane(&mut app, 3.0, -1.0, 0.0, glass(Vec3::new(0.0, 1.0, 0.0)));
    pane(&mut app, 2.0, 0.5, -1.0, glass(Vec3::ONE));
    let px = render(&mut app, 4);
    let behind_only = at(&px, SIZE / 2 + 8, SIZE / 2);
    assert!(behind_only.x < 0.05 && behind_only.y > 0.8, "the green pane alone: {behind_only}");
    let both = at(&px, SIZE / 2 - 4, SIZE / 2);
    assert!(both.x > 0.85 && both.y > 0.85, "through the clear pane, the backdrop, not the green pane: {both}");
    let plan = &app.world.resource::<Renderer>().stats().plan;
    assert!(plan.runs(Pass::TRANSMISSION), "{plan}");
}

/// The copy and its pass exist only in frames that draw a transmissive surface.
#[test]
fn the_copy_exists_only_in_frames_with_transmissive_draws() {
    let mut app = scene();
    backdrop(&mut app, Vec3::ONE, Vec3::ONE);
    render(&mut app, 1);
    let renderer = app.world.resource::<Renderer>();
    assert!(!renderer.stats().plan.runs(Pass::TRANSMISSION));
    let without = renderer.memory().post;
    pane(&mut app, 2.0, 0.0, 0.0, glass(Vec3::ONE));
    render(&mut app, 1);
    let renderer = app.world.resource::<Renderer>();
    assert!(renderer.stats().plan.runs(Pass::TRANSMISSION));
    // 64² of RGBA16F with its mip chain.
    assert!(renderer.memory().post >= without + 64 * 64 * 8, "{} against {without}", renderer.memory().post);
    let explain = penumbra::render::explain::explain(renderer);
    assert!(explain.contains("Transmission: transmissive draws see the scene behind them"), "{explain}");
}

/// A light behind a transmissive pane shines through it towards the eye (the transmitted lobe
/// about the light's mirrored direction); behind an opaque pane it lights nothing the eye sees.
#[test]
fn a_light_behind_a_pane_shines_through_it() {
    let lit = |transmission: f32| {
        let mut app = scene();
        // A black backdrop: what the pane shows comes from the light alone.
        backdrop(&mut app, Vec3::ZERO, Vec3::ZERO);
        pane(&mut app, 2.0, 0.0, 0.0, StandardMaterial { transmission, roughness: 0.5, ..glass(Vec3::ONE) });
        app.world.spawn((PointLight { intensity: 10.0, ..Default::default() }, Transform::from_xyz(0.0, 0.0, -1.0)));
        at(&render(&mut app, 1), SIZE / 2, SIZE / 2)
    };
    let (through, opaque) = (lit(1.0), lit(0.0));
    assert!(through.min_element() > 0.05, "the light shines through: {through}");
    assert!(opaque.max_element() < 0.02, "an opaque pane lit from behind: {opaque}");
}

/// KHR_materials_dispersion: through a slanted volume, red and blue refract by different IORs
/// and land on different sides of the backdrop's edge (colour fringes); without dispersion
/// every pixel stays grey.
#[test]
fn dispersion_splits_colours_at_an_edge() {
    let fringe = |dispersion: f32| {
        let mut app = scene();
        backdrop(&mut app, Vec3::ZERO, Vec3::ONE);
        let material = StandardMaterial { thickness: 1.0, ior: 1.8, dispersion, ..glass(Vec3::ONE) };
        let slanted = Transform::from_xyz(0.0, 0.0, 0.0)
            .with_rotation(Quat::from_rotation_y(0.6) * Quat::from_rotation_x(std::f32::consts::FRAC_PI_2));
        spawn_mesh(&mut app, Mesh::plane(3.0), material, slanted);
        let px = render(&mut app, 1);
        (0..SIZE).map(|x| at(&px, x, SIZE / 2)).map(|c| (c.x - c.z).abs()).fold(0.0, f32::max)
    };
    let (none, some) = (fringe(0.0), fringe(8.0));
    assert!(none < 0.01, "without dispersion the edge stays grey: {none}");
    assert!(some > 0.1, "with dispersion red and blue part: {some}");
}
