//! The frame plan leaves out what the scene does not need: for five small scenes, the exact
//! passes that run, the forward shader's feature switches, and the pools that stay empty; the
//! targets left out (HDR colour at MSAA 1, depth for one convex object), with the same image.
//! (A single opaque instance is not GPU-culled: most scenes here have one. A renderer's first
//! frame with lit draws also makes the split-sum table they read: `EnvironmentPrefilter`.)

use penumbra::prelude::*;
use penumbra::render::RenderSettings;
use penumbra::render::features::tonemap;
use penumbra::render::frame::Pass;

mod common;
use common::{render_app, scene_app, spawn_mesh};

const SIZE: (u32, u32) = (32, 32);

fn camera(app: &mut App) {
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y)));
}

fn lit_sphere(app: &mut App) {
    spawn_mesh(app, Mesh::uv_sphere(0.5, 16, 8), StandardMaterial::from_color(Vec4::ONE, 0.5), Transform::default());
}

/// Renders one frame and returns (passes in order, feature switches of every forward variant,
/// the renderer's memory by pool).
fn plan_of(app: App) -> (Vec<Pass>, Vec<String>, penumbra::render::MemoryStats, String) {
    plan_with(app, RenderSettings::default())
}

fn plan_with(
    mut app: App,
    settings: RenderSettings,
) -> (Vec<Pass>, Vec<String>, penumbra::render::MemoryStats, String) {
    plan_of_keeping(&mut app, settings)
}

/// `plan_with` for an app the caller keeps.
fn plan_of_keeping(
    app: &mut App,
    settings: RenderSettings,
) -> (Vec<Pass>, Vec<String>, penumbra::render::MemoryStats, String) {
    render_app(app, SIZE, settings);
    let r = app.world.resource::<Renderer>();
    let passes = r.stats().plan.passes.iter().map(|(p, _)| *p).collect();
    let defs = r.forward_pipeline_keys().iter().flat_map(|k| k.shader_defs().0).map(str::to_string).collect();
    (passes, defs, r.memory(), penumbra::render::explain::explain(r))
}

#[test]
fn an_empty_scene_clears_and_tonemaps_only() {
    let mut app = scene_app();
    camera(&mut app);
    let (passes, defs, mem, explain) = plan_of(app);
    assert_eq!(passes, [Pass::OPAQUE, tonemap::PASS], "{explain}");
    assert!(defs.is_empty(), "no forward pipeline is compiled for an empty scene: {defs:?}");
    assert_eq!((mem.shadows, mem.environment, mem.post), (0, 0, 0), "{explain}");
    assert!(explain.contains("Opaque: clears the targets (no opaque draws)"), "{explain}");
}

fn unlit_triangle() -> App {
    let mut app = scene_app();
    camera(&mut app);
    let triangle = Mesh {
        positions: vec![Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)],
        normals: vec![Vec3::Z; 3],
        ..Default::default()
    };
    let material = StandardMaterial { unlit: true, ..StandardMaterial::from_color(Vec4::ONE, 1.0) };
    spawn_mesh(&mut app, triangle, material, Transform::default());
    app
}

#[test]
fn one_unlit_triangle_compiles_only_the_unlit_shader() {
    let (passes, defs, mem, explain) = plan_of(unlit_triangle());
    assert_eq!(passes, [Pass::OPAQUE, tonemap::PASS], "{explain}");
    assert!(explain.contains("Cull: one opaque instance"), "{explain}");
    assert_eq!(defs, ["UNLIT"], "{explain}");
    assert_eq!(mem.shadows, 0);
    assert_eq!(mem.environment, 0, "unlit draws read no split-sum table: {explain}");
}

#[test]
fn the_split_sum_table_is_made_once_for_lit_draws() {
    let mut app = scene_app();
    camera(&mut app);
    lit_sphere(&mut app);
    render_app(&mut app, SIZE, RenderSettings::default());
    let passes =
        |app: &App| app.world.resource::<Renderer>().stats().plan.passes.iter().map(|(p, _)| *p).collect::<Vec<_>>();
    assert_eq!(passes(&app)[0], Pass::ENVIRONMENT_PREFILTER);
    app.update();
    assert!(!passes(&app).contains(&Pass::ENVIRONMENT_PREFILTER), "made again: {:?}", passes(&app));
}

#[test]
fn one_unlit_triangle_at_msaa_1_draws_straight_into_the_output() {
    let (passes, defs, mem, explain) = plan_with(unlit_triangle(), RenderSettings { msaa: 1, ..Default::default() });
    assert_eq!(passes, [Pass::OPAQUE], "{explain}");
    // The headless output is Rgba8Unorm: the shader encodes sRGB itself (Renderer::render_headless).
    assert_eq!(defs, ["ENCODE_SRGB", "TONEMAP_IN_FORWARD", "TONEMAP_NEUTRAL", "UNLIT"], "{explain}");
    assert_eq!(mem.targets, 0, "no HDR colour, and one triangle needs no depth: {explain}");
    assert!(explain.contains("Tonemap: nothing reads the HDR colour"), "{explain}");
    assert!(explain.contains("no depth target"), "{explain}");
}

#[test]
fn only_meshes_with_vertex_colours_interpolate_them() {
    let red = Vec4::new(1.0, 0.0, 0.0, 1.0);
    let mut renders = Vec::new();
    for (colors, interpolated) in [(vec![], false), (vec![Vec4::ONE; 3], false), (vec![red; 3], true)] {
        let mut app = unlit_triangle();
        let mut meshes = app.world.resource_mut::<Assets<Mesh>>();
        let handle = meshes.iter().next().expect("the triangle").0;
        meshes.get_mut(handle).expect("live").colors = colors;
        let (_, defs, _, explain) = plan_of_keeping(&mut app, RenderSettings::default());
        assert_eq!(defs.contains(&"VERTEX_COLORS".to_string()), interpolated, "{defs:?} {explain}");
        renders.push(render_app(&mut app, SIZE, RenderSettings::default()));
    }
    assert_eq!(renders[0], renders[1], "white vertex colours change nothing");
    let centre = ((SIZE.1 / 2 * SIZE.0 + SIZE.0 / 2) * 4) as usize;
    let white = &renders[0][centre..centre + 3];
    assert!(white[0] > 200 && white[0] == white[1] && white[1] == white[2], "{white:?}");
    assert!(renders[2][centre] > 200 && renders[2][centre + 1] < 10, "{:?}", &renders[2][centre..centre + 4]);
}

/// `mesh` alone in front of the camera, rendered (MSAA 4), and the same with a second instance
/// far behind the camera (culled, so the image cannot change, but two instances keep depth).
fn alone_and_with_company(mesh: Mesh, material: StandardMaterial) -> [(Vec<u8>, u64); 2] {
    [false, true].map(|company| {
        let mut app = scene_app();
        camera(&mut app);
        app.world.spawn((
            DirectionalLight { shadows: false, ..Default::default() },
            Transform::from_xyz(1.0, 2.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
        ));
        let mesh = app.world.resource_mut::<Assets<Mesh>>().add(mesh.clone());
        let material = app.world.resource_mut::<Assets<StandardMaterial>>().add(material.clone());
        app.world.spawn((Mesh3d(mesh), MeshMaterial3d(material), Transform::default()));
        if company {
            app.world.spawn((Mesh3d(mesh), MeshMaterial3d(material), Transform::from_xyz(0.0, 0.0, 50.0)));
        }
        let pixels = render_app(&mut app, SIZE, RenderSettings::default());
        (pixels, app.world.resource::<Renderer>().memory().targets)
    })
}

#[test]
fn one_convex_object_needs_no_depth_and_draws_the_same_image() {
    let material = StandardMaterial::from_color(Vec4::new(0.8, 0.6, 0.4, 1.0), 0.4);
    let [(alone, alone_bytes), (with, with_bytes)] = alone_and_with_company(Mesh::uv_sphere(0.8, 24, 12), material);
    let depth = (SIZE.0 * SIZE.1 * 4 * 4) as u64;
    assert_eq!(alone_bytes + depth, with_bytes, "only the depth target is left out");
    assert_eq!(alone, with, "the image does not change");
    assert!(alone.chunks_exact(4).any(|p| p[0] > 100), "the sphere is lit");
}

#[test]
fn overlapping_front_faces_keep_depth() {
    let material = StandardMaterial::from_color(Vec4::ONE, 0.5);
    // Not convex.
    let [(_, torus), _] = alone_and_with_company(Mesh::torus(0.7, 0.25, 24, 12), material.clone());
    // Convex, but both faces drawn.
    let double_sided = StandardMaterial { double_sided: true, ..material };
    let [(_, cube), _] = alone_and_with_company(Mesh::cuboid(Vec3::ONE), double_sided);
    let depth = (SIZE.0 * SIZE.1 * 4 * 4) as u64;
    for (what, bytes) in [("torus", torus), ("double-sided cube", cube)] {
        assert!(bytes >= depth, "{what}: {bytes} bytes of targets, no depth");
    }
}

#[test]
fn a_lit_scene_without_shadows_has_no_shadow_pass_or_lookups() {
    let mut app = scene_app();
    camera(&mut app);
    lit_sphere(&mut app);
    app.world.spawn((
        DirectionalLight { shadows: false, ..Default::default() },
        Transform::from_xyz(1.0, 2.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    let (passes, defs, mem, explain) = plan_of(app);
    assert_eq!(passes, [Pass::ENVIRONMENT_PREFILTER, Pass::OPAQUE, tonemap::PASS], "{explain}");
    assert!(explain.contains("split-sum table, made once (no environment"), "{explain}");
    assert!(defs.is_empty(), "the base lit shader: {defs:?}");
    assert_eq!(mem.shadows, 0, "no shadow atlas without a shadowed light");
    assert_eq!(mem.environment, 64 * 64 * 8, "no environment maps, only the 64² split-sum table");
    assert!(explain.contains("Shadows: no shadowed light's casters"), "{explain}");
}

#[test]
fn one_directional_shadow_caster_adds_the_shadow_pass_and_lookups() {
    let mut app = scene_app();
    camera(&mut app);
    lit_sphere(&mut app);
    spawn_mesh(
        &mut app,
        Mesh::plane(6.0),
        StandardMaterial::from_color(Vec4::ONE, 0.8),
        Transform::from_xyz(0.0, -0.5, 0.0),
    );
    app.world.spawn((DirectionalLight::default(), Transform::from_xyz(1.0, 2.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y)));
    let (passes, defs, mem, explain) = plan_of(app);
    assert_eq!(
        passes,
        [Pass::ENVIRONMENT_PREFILTER, Pass::CULL, Pass::SHADOWS, Pass::OPAQUE, tonemap::PASS],
        "{explain}"
    );
    assert_eq!(defs, ["SHADOWS"], "{explain}");
    assert!(mem.shadows > 0);
}

#[test]
fn local_lights_only_bin_clusters_and_compile_the_clustered_walk() {
    let mut app = scene_app();
    camera(&mut app);
    lit_sphere(&mut app);
    for x in [-1.0, 1.0] {
        app.world.spawn((PointLight { shadows: false, ..Default::default() }, Transform::from_xyz(x, 1.0, 1.0)));
    }
    let (passes, defs, mem, explain) = plan_of(app);
    assert_eq!(passes, [Pass::ENVIRONMENT_PREFILTER, Pass::CLUSTER_BIN, Pass::OPAQUE, tonemap::PASS], "{explain}");
    assert_eq!(defs, ["CLUSTERED_LIGHTS", "LOCAL_LIGHTS"], "{explain}");
    assert_eq!(mem.shadows, 0);
}
