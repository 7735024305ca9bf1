//! Deferred local lights (`LightWalk::ClusteredCompute`): a compute pass shades local lights for
//! opaque surfaces from the surface each fragment writes out. It must give the image the
//! fragment-shaded clustered path gives, with and without multisampling, for every kind of
//! local light, under blended, alpha-masked and unlit surfaces, and compile the forward shaders
//! without the local-light loop for opaque draws.

use penumbra::engine::scenes::spawn_many_lights;
use penumbra::prelude::*;
use penumbra::render::LightWalk;
use penumbra::render::features::clusters::grid::ClusterConfig;
use penumbra::render::frame::Pass;
use penumbra::render::resources::materials::AlphaKey;
use penumbra::render::{AlphaTest, LocalLights};
use penumbra::render::{RenderSettings, Renderer};

mod common;
use common::{assert_finite_hdr, flip_mean, hdr_of, render_app, scene_app, spawn_mesh};

fn render(
    app: &mut App,
    size: (u32, u32),
    msaa: u32,
    walk: LightWalk,
    clusters: ClusterConfig,
) -> (Vec<u8>, Vec<[f32; 4]>) {
    app.world.remove_resource::<Renderer>();
    let settings = RenderSettings { msaa, light_walk: walk, keep_hdr: true, clusters, ..Default::default() };
    let px = render_app(app, size, settings);
    (px, hdr_of(app))
}

/// The share of pixels whose HDR colour differs by more than 1% in some channel (with a floor
/// of 1e-3 for black).
fn share_differing(a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    let differs = |p: &[f32; 4], q: &[f32; 4]| (0..3).any(|c| (p[c] - q[c]).abs() > 0.01 * p[c].abs().max(1e-3));
    a.iter().zip(b).filter(|(p, q)| differs(p, q)).count() as f32 / a.len() as f32
}

fn assert_same_image(app: &mut App, size: (u32, u32), what: &str) {
    assert_same_image_with(app, size, ClusterConfig::default(), what);
}

fn assert_same_image_with(app: &mut App, size: (u32, u32), clusters: ClusterConfig, what: &str) {
    for msaa in [1, 4] {
        let (fragment, fragment_hdr) = render(app, size, msaa, LightWalk::Clustered, clusters);
        let (compute, compute_hdr) = render(app, size, msaa, LightWalk::ClusteredCompute, clusters);
        assert_finite_hdr(&compute_hdr, what);
        let renderer = app.world.resource::<Renderer>();
        assert_eq!(renderer.shader_error(), None, "{what}");
        let stats = renderer.stats();
        assert!(stats.draw_calls > 0, "{what}: nothing drawn");
        let lit = compute.chunks_exact(4).filter(|p| p[0].max(p[1]).max(p[2]) > 60).count();
        assert!(lit > 100, "{what}: only {lit} brightly lit pixels");
        assert!(stats.plan.runs(Pass::DEFERRED_LIGHTS), "{what}: the compute pass ran");
        let e = flip_mean(&fragment, &compute, size.0, size.1);
        let d = share_differing(&fragment_hdr, &compute_hdr);
        eprintln!("{what}, MSAA {msaa}: FLIP mean {e:.5}, {:.2}% of pixels differ by over 1%", 100.0 * d);
        assert!(e <= 0.01, "{what}, MSAA {msaa}: FLIP mean {e} between compute- and fragment-shaded lights");
        // Without multisampling both shade the same point of each pixel, and differ only by
        // rounding (the two halves of the light are rounded to f16 apart, and the compute pass
        // rebuilds the position from depth): on lavapipe no pixel by over 1%, on an NVIDIA H100
        // a few in 10 000 of the every-kind scene's, while a light dropped from one round of a
        // list makes several times the limit differ. With multisampling, pixels on silhouettes
        // differ: the forward shader shades every fragment at the pixel centre, off the surface
        // for a fragment covering a sample or two, while the compute pass shades each of those
        // samples where it lies.
        let limit = if msaa == 1 { 0.0005 } else { 0.02 };
        assert!(d <= limit, "{what}, MSAA {msaa}: {:.2}% of pixels differ by over 1%", 100.0 * d);
    }
}

#[test]
fn compute_shaded_lights_equal_fragment_shaded_ones_for_1000_lights() {
    let mut app = scene_app();
    spawn_many_lights(&mut app.world, 1000, Some(3.0));
    assert_same_image(&mut app, (192, 108), "1000 point lights");
}

/// With a coarse grid, nearly every 8×8 workgroup of the compute pass finds its pixels in one
/// cluster and walks the list together, 64 lights a round: lists of hundreds take several
/// rounds, the last one partial (the longest here holds 179).
#[test]
fn compute_shaded_lights_equal_fragment_shaded_ones_for_lists_walked_by_whole_workgroups() {
    let mut app = scene_app();
    spawn_many_lights(&mut app.world, 1000, Some(3.0));
    let coarse = ClusterConfig { tiles_x: 2, tiles_y: 2, slices: 4 };
    assert_same_image_with(&mut app, (192, 108), coarse, "1000 point lights in 16 clusters");
    let renderer = app.world.resource::<Renderer>();
    let ctx = renderer.context();
    let lists = renderer.cluster_binner().read_lists(&ctx.device, &ctx.queue).unwrap();
    let longest = lists.iter().map(Vec::len).max().unwrap_or(0);
    assert!(longest > 2 * 64 && longest % 64 != 0, "longest list {longest}");
}

#[test]
fn compute_shaded_lights_equal_fragment_shaded_ones_for_every_kind_under_blended_masked_and_unlit_surfaces() {
    let mut app = scene_app();
    spawn_mesh(
        &mut app,
        Mesh::plane(12.0),
        StandardMaterial::from_color(Vec4::new(0.7, 0.7, 0.7, 1.0), 0.6),
        Transform::default(),
    );
    let metal = StandardMaterial {
        base_color: Vec4::new(0.9, 0.8, 0.6, 1.0),
        metallic: 1.0,
        roughness: 0.2,
        ..Default::default()
    };
    spawn_mesh(&mut app, Mesh::uv_sphere(0.6, 32, 16), metal, Transform::from_xyz(-1.0, 0.6, 0.0));
    let glass = StandardMaterial {
        base_color: Vec4::new(0.3, 0.6, 1.0, 0.4),
        roughness: 0.1,
        alpha_mode: AlphaMode::Blend,
        ..Default::default()
    };
    spawn_mesh(&mut app, Mesh::uv_sphere(0.5, 32, 16), glass, Transform::from_xyz(1.0, 0.5, 1.0));
    // A fence: an upright quad cut out by a checker of alpha, so its edges cross pixels at MSAA 4
    // and only some of their samples carry its surface to the compute pass.
    let fence = common::checker_fence(&mut app);
    let upright = Transform::from_xyz(-1.5, 0.8, 1.2).with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2));
    spawn_mesh(&mut app, Mesh::plane(1.6), fence, upright);
    let unlit = StandardMaterial { base_color: Vec4::new(1.0, 0.2, 0.2, 1.0), unlit: true, ..Default::default() };
    spawn_mesh(&mut app, Mesh::cuboid(Vec3::splat(0.5)), unlit, Transform::from_xyz(0.5, 0.25, -1.5));
    app.world.spawn((
        PointLight { color: Vec3::new(1.0, 0.4, 0.2), intensity: 3.0, ..Default::default() },
        Transform::from_xyz(-2.0, 1.0, 1.0),
    ));
    app.world.spawn((
        SpotLight { intensity: 10.0, inner_cone_angle: 0.2, outer_cone_angle: 0.5, ..Default::default() },
        Transform::from_xyz(1.5, 3.0, 2.0).looking_at(Vec3::new(1.0, 0.0, 0.5), Vec3::Y),
    ));
    app.world.spawn((
        SphereLight { intensity: 2.0, radius: 0.2, ..Default::default() },
        Transform::from_xyz(0.0, 1.6, -0.5),
    ));
    app.world.spawn((
        TubeLight { intensity: 1.0, length: 2.0, radius: 0.03, ..Default::default() },
        Transform::from_xyz(0.0, 0.3, 2.0),
    ));
    app.world.spawn((
        RectLight { luminance: 2.0, width: 1.0, height: 0.6, ..Default::default() },
        Transform::from_xyz(-2.5, 1.2, -1.0).looking_at(Vec3::new(-1.0, 0.3, 0.0), Vec3::Y),
    ));
    app.world.spawn((
        DiskLight { luminance: 3.0, radius: 0.3, ..Default::default() },
        Transform::from_xyz(2.5, 1.8, -1.0).looking_at(Vec3::new(1.0, 0.3, 0.0), Vec3::Y),
    ));
    let profile = common::add_ies_profile(&mut app, &[0.0, 45.0, 90.0], &[0.0, 90.0], &[8.0, 4.0, 0.0, 2.0, 1.0, 0.0]);
    app.world.spawn((
        IesLight::new(profile),
        Transform::from_xyz(2.0, 1.2, 2.0).looking_at(Vec3::new(2.0, 0.0, 2.0), Vec3::Z),
    ));
    app.world.spawn((
        DirectionalLight { illuminance: 0.3, ..Default::default() },
        Transform::default().looking_at(Vec3::new(-0.3, -1.0, -0.4), Vec3::Y),
    ));
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.05 });
    app.world
        .spawn((Camera::default(), Transform::from_xyz(0.0, 3.0, 6.0).looking_at(Vec3::new(0.0, 0.5, 0.0), Vec3::Y)));
    assert_same_image(&mut app, (160, 100), "every kind");
    // Opaque draws compile without the local-light loop; the blended sphere keeps it.
    let renderer = app.world.resource::<Renderer>();
    let keys: Vec<_> = renderer.forward_pipeline_keys();
    assert!(keys.iter().any(|k| k.alpha == AlphaKey::Blend && k.local_lights == LocalLights::Clustered));
    assert!(keys.iter().filter(|k| k.alpha != AlphaKey::Blend).all(|k| k.local_lights == LocalLights::Deferred));
    // The last frame was at MSAA 4: the fence tests its alpha at each sample.
    assert!(keys.iter().any(|k| k.alpha == AlphaKey::Mask && k.alpha_test == AlphaTest::SampleMask), "{keys:?}");
    // Local lights cast shadows (on by default; lights with a size from their centre): the
    // compute pass read their maps and still equals the fragment path. The 24-layer atlas holds
    // four of them here (the spot's one layer and three cubes); the rest light unshadowed.
    assert_eq!(renderer.shadow_frame().local.first_layers.len(), 4);
    assert!(keys.iter().all(|k| k.local_shadows));
}

/// `LightWalk::Auto` (the default) keeps short cluster lists in the fragment shader and moves
/// long ones to the compute pass, and back when the lights thin out.
#[test]
fn the_automatic_walk_moves_long_lists_to_compute_and_back() {
    let settings = RenderSettings { msaa: 1, keep_hdr: true, ..Default::default() };
    assert_eq!(settings.light_walk, LightWalk::Auto);
    let runs_compute = |app: &App| app.world.resource::<Renderer>().stats().plan.runs(Pass::DEFERRED_LIGHTS);
    let mut app = scene_app();
    spawn_many_lights(&mut app.world, 1000, Some(3.0));
    render_app(&mut app, (96, 54), settings.clone());
    assert!(!runs_compute(&app), "1000 lights over the stadium: short lists, fragment shader");
    let mut app = scene_app();
    let lights = spawn_many_lights(&mut app.world, 10_000, Some(3.0));
    render_app(&mut app, (96, 54), settings.clone());
    assert!(runs_compute(&app), "10 000 lights: long lists, compute");
    for e in &lights[..9_500] {
        app.world.despawn(*e);
    }
    render_app(&mut app, (96, 54), settings);
    assert!(!runs_compute(&app), "500 lights left: back to the fragment shader");
    assert_eq!(app.world.resource::<Renderer>().shader_error(), None);
}

/// The compute walk at MSAA 4 on a grid whose tile edges fall inside pixels (tiles of 2⅔
/// pixels) equals the same walk on a single cluster, whose list holds every light, bit for bit.
/// (The deferred pass shades each sample where it lies and looks up the pixel centre's cluster;
/// that candidate boxes reach far enough for it is checked on the CPU twin, where a miss is
/// not left to chance: grid.rs, `points_a_light_reaches_find_it_from_a_sample_away`.)
#[test]
fn samples_shaded_off_their_pixel_centre_find_every_light() {
    let render = |(tiles_x, tiles_y, slices): (u32, u32, u32)| {
        let mut app = scene_app();
        spawn_many_lights(&mut app.world, 1000, Some(3.0));
        let clusters = ClusterConfig { tiles_x, tiles_y, slices };
        let frame = render_app(
            &mut app,
            (128, 72),
            RenderSettings {
                msaa: 4,
                clusters,
                keep_hdr: true,
                light_walk: LightWalk::ClusteredCompute,
                ..Default::default()
            },
        );
        assert!(app.world.resource::<Renderer>().stats().plan.runs(Pass::DEFERRED_LIGHTS));
        frame
    };
    let fine = render((48, 27, 32));
    let single = render((1, 1, 1));
    let differing = fine.chunks_exact(4).zip(single.chunks_exact(4)).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "{differing} pixels differ between tiles of 2⅔ pixels and one cluster");
}
