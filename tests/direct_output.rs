//! Direct output: a frame whose HDR colour nothing reads (MSAA 1, no post-processing, no
//! environment background, no blended draws, no gizmos, no deferred lights, no HDR readback)
//! has no HDR target and no tonemap pass; the forward shader tonemaps and draws into the output.
//!
//! - For every tonemapper, the direct frame equals the frame through the HDR target and the
//!   tonemap pass (within 2 of 255: the HDR path rounds radiance to f16 first), clear colour
//!   included (the CPU applies the curve to it).
//! - Into an output format the hardware does not sRGB-encode, the shader encodes: the same bytes.
//! - A blended draw, bloom or `keep_hdr` brings the HDR target and the tonemap pass back, and
//!   `read_hdr` says why it fails on a direct frame.
//! - With MSAA and `MsaaResolve::Display` a frame is direct too: each sample is tonemapped and
//!   the display colours are averaged (in linear light, through an sRGB target), where the
//!   default resolve averages radiance and then tonemaps (an edge pixel half covered by a
//!   surface brighter than white is white after the default resolve, mid-grey after this one).

use penumbra::prelude::*;
use penumbra::render::features::{bloom, tonemap};
use penumbra::render::frame::Pass;
use penumbra::render::{BloomSettings, PostSettings};
use penumbra::render::{MsaaResolve, RenderOutput, RenderScene, RenderSettings, Tonemapper};

mod common;
use common::{render_app, scene_app, spawn_mesh};

const SIZE: (u32, u32) = (48, 40);

/// A lit sphere on a floor under a sun and a point light (radiance from 0 to above 1, so the
/// curves compress the highlights), with a masked quad; the clear colour shows around them.
fn lit_scene() -> App {
    let mut app = scene_app();
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.2, 3.5).looking_at(Vec3::ZERO, Vec3::Y)));
    spawn_mesh(
        &mut app,
        Mesh::uv_sphere(0.6, 24, 12),
        StandardMaterial::from_color(Vec4::ONE, 0.3),
        Transform::default(),
    );
    spawn_mesh(
        &mut app,
        Mesh::plane(3.0),
        StandardMaterial::from_color(Vec4::new(0.8, 0.5, 0.3, 1.0), 0.8),
        Transform::from_xyz(0.0, -0.6, 0.0),
    );
    let masked = StandardMaterial {
        alpha_mode: AlphaMode::Mask(0.5),
        ..StandardMaterial::from_color(Vec4::new(0.2, 0.9, 0.3, 0.7), 0.5)
    };
    spawn_mesh(&mut app, Mesh::plane(0.6), masked, Transform::from_xyz(0.9, 0.2, 0.5));
    app.world.spawn((
        DirectionalLight { illuminance: 4.0, shadows: false, ..Default::default() },
        Transform::from_xyz(1.0, 2.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    app.world.spawn((
        PointLight { intensity: 12.0, shadows: false, ..Default::default() },
        Transform::from_xyz(-0.8, 1.0, 1.0),
    ));
    app
}

fn settings(tonemapper: Tonemapper, keep_hdr: bool) -> RenderSettings {
    // A clear colour past the curves' knee in blue.
    RenderSettings { msaa: 1, tonemapper, keep_hdr, clear_color: [0.3, 0.6, 2.5], ..Default::default() }
}

fn passes(app: &App) -> Vec<Pass> {
    app.world.resource::<Renderer>().stats().plan.passes.iter().map(|(p, _)| *p).collect()
}

/// Largest and mean absolute difference per channel.
fn difference(a: &[u8], b: &[u8]) -> (u8, f64) {
    assert_eq!(a.len(), b.len());
    let max = a.iter().zip(b).map(|(x, y)| x.abs_diff(*y)).max().unwrap_or(0);
    let mean = a.iter().zip(b).map(|(x, y)| x.abs_diff(*y) as f64).sum::<f64>() / a.len() as f64;
    (max, mean)
}

#[test]
fn direct_output_equals_the_tonemap_pass_for_every_tonemapper() {
    for tonemapper in [Tonemapper::Neutral, Tonemapper::Aces, Tonemapper::None] {
        let mut direct_app = lit_scene();
        let direct = render_app(&mut direct_app, SIZE, settings(tonemapper, false));
        assert!(!passes(&direct_app).contains(&tonemap::PASS), "{tonemapper:?}: {:?}", passes(&direct_app));
        let r = direct_app.world.resource::<Renderer>();
        assert_eq!(r.memory().targets, (SIZE.0 * SIZE.1 * 4) as u64, "depth only, no HDR target");
        let defs: Vec<_> = r.forward_pipeline_keys().iter().flat_map(|k| k.shader_defs().0).collect();
        assert!(defs.contains(&"TONEMAP_IN_FORWARD"), "{defs:?}");

        let mut hdr_app = lit_scene();
        let through_hdr = render_app(&mut hdr_app, SIZE, settings(tonemapper, true));
        assert!(passes(&hdr_app).contains(&tonemap::PASS), "keep_hdr keeps the pass");

        let (max, mean) = difference(&direct, &through_hdr);
        assert!(max <= 2 && mean < 0.2, "{tonemapper:?}: differs by up to {max} (mean {mean:.3})");
        // The scene is really there: lit pixels, the clear colour, and bright blue compressed.
        let corner = &direct[..4];
        assert!(corner[2] > corner[1] && corner[1] > corner[0], "{tonemapper:?}: clear colour {corner:?}");
        let distinct: std::collections::HashSet<_> = direct.chunks_exact(4).collect();
        assert!(distinct.len() > 30, "{tonemapper:?}: only {} colours", distinct.len());
    }
}

/// Renders one frame of `app` into a fresh texture of `format`, through `Renderer::render`.
fn render_into(app: &mut App, format: wgpu::TextureFormat) -> Vec<u8> {
    app.insert_resource(RenderOutput::External);
    app.update();
    let ctx = app.world.resource::<Renderer>().context().clone();
    let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("test output"),
        size: wgpu::Extent3d { width: SIZE.0, height: SIZE.1, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let view = texture.create_view(&Default::default());
    app.world.resource_scope(|world, mut renderer: Mut<Renderer>| {
        renderer.render(world.resource::<RenderScene>(), &view, format, SIZE);
    });
    penumbra::render::gpu::readback::read_texture(&ctx.device, &ctx.queue, &texture, 4).unwrap()
}

#[test]
fn a_unorm_output_is_srgb_encoded_by_the_shader() {
    let mut srgb_app = lit_scene();
    let srgb = render_app(&mut srgb_app, SIZE, settings(Tonemapper::Neutral, false));
    for keep_hdr in [false, true] {
        let mut app = lit_scene();
        app.insert_resource(Renderer::new(common::gpu(), settings(Tonemapper::Neutral, keep_hdr)).unwrap());
        let unorm = render_into(&mut app, wgpu::TextureFormat::Rgba8Unorm);
        assert_eq!(passes(&app).contains(&tonemap::PASS), keep_hdr);
        let (max, mean) = difference(&srgb, &unorm);
        assert!(max <= 2 && mean < 0.2, "keep_hdr {keep_hdr}: differs by up to {max} (mean {mean:.3})");
    }
}

#[test]
fn what_reads_hdr_colour_brings_the_hdr_target_back() {
    let mut app = lit_scene();
    render_app(&mut app, SIZE, settings(Tonemapper::Neutral, false));
    // The first frame with lit draws makes the split-sum table (EnvironmentPrefilter).
    assert_eq!(passes(&app), [Pass::ENVIRONMENT_PREFILTER, Pass::CULL, Pass::CLUSTER_BIN, Pass::OPAQUE]);
    let e = app.world.resource::<Renderer>().read_hdr().unwrap_err().to_string();
    assert!(e.contains("keep_hdr"), "{e}");

    // A blended draw: blending is in linear HDR, before the curve.
    let glass = StandardMaterial {
        alpha_mode: AlphaMode::Blend,
        ..StandardMaterial::from_color(Vec4::new(0.3, 0.3, 1.0, 0.5), 0.2)
    };
    let pane = spawn_mesh(&mut app, Mesh::plane(0.5), glass, Transform::from_xyz(-0.5, 0.8, 0.8));
    render_app(&mut app, SIZE, settings(Tonemapper::Neutral, false));
    assert!(passes(&app).contains(&tonemap::PASS), "{:?}", passes(&app));
    assert!(common::hdr_of(&app).iter().any(|p| p[2] > 0.0), "HDR colour readable again");

    app.world.despawn(pane);
    render_app(&mut app, SIZE, settings(Tonemapper::Neutral, false));
    assert!(!passes(&app).contains(&tonemap::PASS), "direct again once the blended draw is gone");

    let bloom =
        PostSettings { bloom: Some(BloomSettings { strength: 0.1, ..Default::default() }), ..Default::default() };
    app.world
        .resource_mut::<Renderer>()
        .set_settings(RenderSettings { post: bloom, ..settings(Tonemapper::Neutral, false) })
        .unwrap();
    render_app(&mut app, SIZE, settings(Tonemapper::Neutral, false));
    assert!(passes(&app).contains(&tonemap::PASS) && passes(&app).contains(&bloom::PASS), "{:?}", passes(&app));
}

/// A surface of exposed radiance 4 (emissive, over a black clear) covering the left of the frame up to
/// x = 20.5 pixels, seen by an orthographic camera whose world units are pixels: the pixels of
/// column 20 have two of their four standard samples (x + 0.125 and x + 0.375) covered.
fn half_covered_column(resolve: MsaaResolve) -> (Vec<u8>, App) {
    let mut app = scene_app();
    let projection = Projection::Orthographic { xmag: Some(16.0), ymag: 16.0, znear: 0.1, zfar: 100.0 };
    app.world.spawn((Camera { projection, ..Default::default() }, Transform::from_xyz(0.0, 0.0, 10.0)));
    // A light, so no default key light is added; the black metal reflects nothing.
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.0 });
    let (left, right) = (-40.0, 20.5 - 16.0);
    let quad = Mesh {
        positions: vec![
            Vec3::new(left, -40.0, 0.0),
            Vec3::new(right, -40.0, 0.0),
            Vec3::new(right, 40.0, 0.0),
            Vec3::new(left, 40.0, 0.0),
        ],
        normals: vec![Vec3::Z; 4],
        indices: Some(vec![0, 1, 2, 0, 2, 3]),
        ..Default::default()
    };
    let glowing = StandardMaterial {
        base_color: Vec4::new(0.0, 0.0, 0.0, 1.0),
        metallic: 1.0,
        emissive: Vec3::splat(4.8),
        ..Default::default()
    };
    spawn_mesh(&mut app, quad, glowing, Transform::IDENTITY);
    let settings = RenderSettings {
        msaa: 4,
        msaa_resolve: resolve,
        tonemapper: Tonemapper::None,
        clear_color: [0.0; 3],
        ..Default::default()
    };
    let frame = render_app(&mut app, (32, 32), settings);
    (frame, app)
}

#[test]
fn resolving_display_colours_averages_tonemapped_samples_and_needs_no_hdr_target() {
    let (display, display_app) = half_covered_column(MsaaResolve::Display);
    assert!(!passes(&display_app).contains(&tonemap::PASS), "{:?}", passes(&display_app));
    let r = display_app.world.resource::<Renderer>();
    // One 4-byte sRGB colour per sample, no depth (one convex surface), no HDR target.
    assert_eq!(r.memory().targets, 32 * 32 * 4 * 4);
    let (radiance, radiance_app) = half_covered_column(MsaaResolve::Radiance);
    assert!(passes(&radiance_app).contains(&tonemap::PASS));
    let red = |frame: &[u8], x: usize| frame[(16 * 32 + x) * 4];
    for (name, frame) in [("display", &display), ("radiance", &radiance)] {
        assert_eq!((red(frame, 5), red(frame, 19), red(frame, 21)), (255, 255, 0), "{name}: inside and outside");
    }
    // Radiance 4 (emissive 4.8 at the default exposure, 1/1.2) on two samples of four: the
    // mean radiance, 2, is still white after the curve; the mean of the samples' display colours (1 and 0) is
    // 0.5 in linear light, 188 in sRGB.
    assert_eq!(red(&radiance, 20), 255);
    assert!((187..=189).contains(&red(&display, 20)), "display resolve: {}", red(&display, 20));
}
