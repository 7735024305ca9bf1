//! Backend parity: the same scene on wgpu's GL backend (Mesa's llvmpipe through EGL) and on
//! Vulkan (lavapipe) gives the same image within the golden threshold, at the default settings.
//! GL cannot do everything (see `Renderer`'s `degrade_for_backend`): multisampled frames come
//! out black there, so it renders MSAA 1 and says so; this test fails if that degradation stops
//! working (a black frame) or the backends drift apart.

use penumbra::prelude::*;
use penumbra::render::{AdapterRequest, GpuContext, RenderOutput, RenderSettings};

mod common;
use common::{flip_mean, scene_app, spawn_mesh};

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
    (r.read_headless().unwrap(), r.settings().msaa)
}

#[test]
fn gl_renders_what_vulkan_renders() {
    let gl = GpuContext::new_headless(&AdapterRequest { backends: Some(wgpu::Backends::GL), name: None })
        .unwrap_or_else(|e| panic!("this test needs wgpu's GL backend (on Debian: apt-get install -y libegl1 libegl-mesa0 libgl1-mesa-dri): {e}"));
    let (on_gl, gl_msaa) = render(gl);
    let (on_vulkan, vulkan_msaa) = render(common::gpu());
    let lit = on_gl.chunks_exact(4).filter(|p| p[0] > 100 || p[2] > 100).count();
    assert!(lit > 500, "the GL frame is dark: {lit} lit pixels");
    assert_eq!((gl_msaa, vulkan_msaa), (1, 4), "GL degrades to MSAA 1; Vulkan keeps the default");
    let e = flip_mean(&on_vulkan, &on_gl, SIZE.0, SIZE.1);
    // The golden threshold; MSAA 1 against 4 differs only along edges.
    assert!(e < 0.05, "FLIP mean {e} between GL and Vulkan");
}
