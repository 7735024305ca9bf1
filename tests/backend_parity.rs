//! Backend parity: wgpu's GL backend (Mesa's llvmpipe through EGL) draws what Vulkan
//! (lavapipe) draws.
//!
//! - the golden suite: every sample-model, environment and shadow golden
//!   (`common::golden_scenes`) is drawn again on GL and held to the same golden and threshold
//!   as on Vulkan (`golden_tolerance`: llvmpipe's own; a GL driver other than llvmpipe would
//!   get the limits for other drivers);
//! - a lit scene at the default settings gives the same image on both.
//!
//! What GL cannot do is degraded as `Capabilities` documents (no deferred-lights pass; depth
//! rounded at 2⁻²⁴ of 1, which shadow lookups allow for; alpha-masked draws at MSAA 4 shaded
//! once per sample instead of writing a sample mask, so AlphaBlendModeTest's masked bars are
//! also textured and shaded at each sample there). GL renders run one after another on
//! one context: wgpu's GL backend serialises a context behind a lock that gives up after a
//! second, so renders from parallel test threads could time out.

use penumbra::prelude::*;
use penumbra::render::{AdapterRequest, GpuContext, RenderOutput, RenderSettings};

mod common;
use common::{Tolerance, flip_mean, scene_app, spawn_mesh};

const SIZE: (u32, u32) = (96, 72);

/// A lit sphere and box on a floor, no environment: what both backends can draw.
fn scene() -> App {
    let mut app = scene_app();
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.5, 4.0).looking_at(Vec3::ZERO, Vec3::Y)));
    spawn_mesh(
        &mut app,
        Mesh::uv_sphere(0.6, 32, 16),
        StandardMaterial::from_color(Vec4::new(0.9, 0.3, 0.2, 1.0), 0.4),
        Transform::from_xyz(-0.7, 0.0, 0.0),
    );
    spawn_mesh(
        &mut app,
        Mesh::cuboid(Vec3::splat(0.9)),
        StandardMaterial::from_color(Vec4::new(0.2, 0.5, 0.9, 1.0), 0.7),
        Transform::from_xyz(0.8, -0.15, 0.2),
    );
    spawn_mesh(
        &mut app,
        Mesh::plane(6.0),
        StandardMaterial::from_color(Vec4::splat(0.7), 0.9),
        Transform::from_xyz(0.0, -0.6, 0.0),
    );
    app.world.spawn((
        DirectionalLight { illuminance: 3.0, shadows: false, ..Default::default() },
        Transform::from_xyz(1.0, 2.0, 1.5).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    app
}

fn render(ctx: GpuContext) -> (Vec<u8>, u32) {
    let mut app = scene();
    app.insert_resource(Renderer::new(ctx, RenderSettings::default()).unwrap());
    app.insert_resource(RenderOutput::Headless { width: SIZE.0, height: SIZE.1 });
    app.update();
    let r = app.world.resource::<Renderer>();
    (r.read_frame().unwrap(), r.settings().msaa)
}

fn gl() -> GpuContext {
    GpuContext::new_headless(&AdapterRequest { backends: Some(wgpu::Backends::GL), ..Default::default() }).unwrap_or_else(|e| {
        panic!("this test needs wgpu's GL backend (on Debian: apt-get install -y libegl1 libegl-mesa0 libgl1-mesa-dri): {e}")
    })
}

#[test]
fn gl_renders_what_vulkan_renders() {
    let (on_gl, gl_msaa) = render(gl());
    let (on_vulkan, vulkan_msaa) = render(common::gpu());
    let lit = on_gl.chunks_exact(4).filter(|p| p[0] > 100 || p[2] > 100).count();
    assert!(lit > 500, "the GL frame is dark: {lit} lit pixels");
    assert_eq!((gl_msaa, vulkan_msaa), (4, 4), "both keep the default MSAA");
    let e = flip_mean(&on_vulkan, &on_gl, SIZE.0, SIZE.1);
    assert!(e < 0.01, "FLIP mean {e} between GL and Vulkan");
}

/// The golden suite on GL, against the goldens made on Vulkan. All frames are drawn and checked
/// before the test fails, so one run lists every frame that differs (each failure writes its
/// `.actual.png` and `.diff.png` beside the golden, under a `-gl` name).
#[test]
fn golden_suite_on_gl() {
    let ctx = gl();
    let frames = common::golden_scenes::golden_suite();
    let mut failed = Vec::new();
    for make in &frames {
        let mut frame = make();
        let shot = frame.render(ctx.clone());
        let tol = common::golden_scenes::golden_tolerance(&ctx, &frame.name, Tolerance::default());
        if let Err(problem) = common::compare_with_golden(&common::golden_dir(), &frame.name, "-gl", &shot, tol) {
            failed.push(problem);
        }
    }
    assert!(failed.is_empty(), "{} of {} goldens differ on GL:\n{}", failed.len(), frames.len(), failed.join("\n"));
    assert_eq!(frames.len(), 36);
}
