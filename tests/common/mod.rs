//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod golden_scenes;

use std::path::{Path, PathBuf};

/// A test asset under `tests/assets/`.
pub fn asset(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/assets").join(rel)
}

/// A fresh, empty folder for one test's scratch files, under the target directory.
pub fn scratch_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("penumbra-tests").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

use std::sync::OnceLock;

use penumbra::engine::import::{GltfScene, ImportOptions};
use penumbra::render::headless::{ShotSettings, render_frames, stage_scene};
use penumbra::render::{AdapterRequest, GpuContext, RenderSettings, Renderer};

/// One GPU context per test process. Goldens were made on lavapipe's Vulkan driver, so the
/// Vulkan backend is required unless `WGPU_BACKEND` says otherwise; without an adapter the test
/// fails and says what to install.
pub fn gpu() -> GpuContext {
    static CTX: OnceLock<GpuContext> = OnceLock::new();
    CTX.get_or_init(|| {
        let backends = if std::env::var_os("WGPU_BACKEND").is_some() { None } else { Some(wgpu::Backends::VULKAN) };
        // No pipeline cache: a test's outcome must not depend on what earlier runs compiled,
        // nor write to the user's cache folder (tests/render_behaviour.rs tests the cache).
        let pipeline_cache = penumbra::render::PipelineCacheDir::Off;
        GpuContext::new_headless(&AdapterRequest { backends, pipeline_cache, ..Default::default() })
            .unwrap_or_else(|e| panic!("GPU tests need a Vulkan adapter: {e}"))
    })
    .clone()
}

pub struct Shot {
    pub width: u32,
    pub height: u32,
    pub rgba8: Vec<u8>,
}

/// Renders a test asset headless, one frame.
pub fn render_asset(rel: &str, shot: &ShotSettings, settings: RenderSettings) -> Shot {
    let scene = GltfScene::load(&asset(rel), &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let (mut app, size) = stage_scene(&scene, shot).unwrap_or_else(|e| panic!("{e}"));
    let renderer = Renderer::new(gpu(), settings).unwrap_or_else(|e| panic!("{e}"));
    let rgba8 = render_frames(&mut app, renderer, size, 1).unwrap_or_else(|e| panic!("{e}"));
    Shot { width: size.0, height: size.1, rgba8 }
}

/// FLIP thresholds: the mean error over the image and the error at a high *error-weighted*
/// percentile (a wrong region fails even when the mean stays low). The percentile is nv_flip's
/// `get_percentile(p, true)`: the FLIP value below which the fraction `p` of the image's summed
/// error lies, not the value `p` of the pixels are below (`false`); every limit and sensitivity
/// here was measured with it. FLIP spreads one pixel's error over its
/// neighbours (about 65 pixels at the default viewing distance), so at 256 × 256 a single pixel
/// far off already reaches the 99.9th percentile: measured with NormalTangentTest, one
/// highlight pixel 0xA8 against 0xE8 gave 0.27.
#[derive(Debug, Clone, Copy)]
pub struct Tolerance {
    pub mean: f32,
    pub percentile: f32,
    pub at_percentile: f32,
}

impl Default for Tolerance {
    /// Same driver, same inputs: lavapipe is deterministic, so any real change shows up far above
    /// these. They leave room for LLVM choosing other vector widths on another CPU.
    fn default() -> Self {
        Self { mean: 0.01, percentile: 0.999, at_percentile: 0.2 }
    }
}

impl Tolerance {
    /// `self` for a driver other than the goldens' own, where `sensitivity` is what the frame
    /// changes by at `self.percentile` on the goldens' driver when its camera turns a little
    /// (`golden_scenes::TURN_SENSITIVITY`): the limit at the percentile becomes the larger of
    /// the two. The mean's limit stays.
    pub fn across_drivers(self, sensitivity: f32) -> Self {
        Self { at_percentile: self.at_percentile.max(sensitivity), ..self }
    }
}

/// Whether `ctx` is the driver the goldens were made with: Mesa's llvmpipe, through Vulkan
/// (lavapipe) or GL. Elsewhere the golden suite is checked with [`Tolerance::across_drivers`].
pub fn made_the_goldens(ctx: &GpuContext) -> bool {
    ctx.info.name.starts_with("llvmpipe")
}

pub fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/goldens")
}

/// Compares `shot` with `tests/goldens/<name>.png` using FLIP. On failure writes
/// `<name>.actual.png` and `<name>.diff.png` (FLIP error, magma) beside the golden and panics
/// with their paths. `PENUMBRA_UPDATE_GOLDENS=1` rewrites the golden instead.
pub fn check_golden(name: &str, shot: &Shot, tol: Tolerance) {
    check_golden_in(&golden_dir(), name, shot, tol)
}

/// [`check_golden`] against `dir/<name>.png`.
pub fn check_golden_in(dir: &Path, name: &str, shot: &Shot, tol: Tolerance) {
    let golden = dir.join(format!("{name}.png"));
    if std::env::var_os("PENUMBRA_UPDATE_GOLDENS").is_some() {
        // Other drivers are held to llvmpipe's goldens (and its turn sensitivities).
        let ctx = gpu();
        assert!(made_the_goldens(&ctx), "goldens are made on llvmpipe (lavapipe), not on {}", ctx.info.name);
        std::fs::create_dir_all(golden.parent().unwrap()).unwrap();
        image::save_buffer(&golden, &shot.rgba8, shot.width, shot.height, image::ColorType::Rgba8).unwrap();
        eprintln!("updated golden {}", golden.display());
        return;
    }
    if let Err(problem) = compare_with_golden(dir, name, "", shot, tol) {
        panic!("{problem}");
    }
}

/// Compares `shot` with `dir/<name>.png` using FLIP; a failure writes `<name><suffix>.actual.png`
/// and `<name><suffix>.diff.png` (FLIP error, magma) beside the golden and says so. Never
/// rewrites the golden.
pub fn compare_with_golden(dir: &Path, name: &str, suffix: &str, shot: &Shot, tol: Tolerance) -> Result<(), String> {
    let golden = dir.join(format!("{name}.png"));
    let save = |path: &Path, rgba: &[u8]| {
        image::save_buffer(path, rgba, shot.width, shot.height, image::ColorType::Rgba8).unwrap();
    };
    let expected = image::open(&golden)
        .map_err(|e| {
            format!("cannot open golden {} ({e}); run with PENUMBRA_UPDATE_GOLDENS=1 to create it", golden.display())
        })?
        .into_rgba8();
    if (expected.width(), expected.height()) != (shot.width, shot.height) {
        return Err(format!("golden {} has another size", golden.display()));
    }
    let error = flip_error(expected.as_raw(), &shot.rgba8, shot.width, shot.height);
    let mut pool = nv_flip::FlipPool::from_image(&error);
    let mean = pool.mean();
    let at = pool.get_percentile(tol.percentile, true);
    if mean > tol.mean || at > tol.at_percentile {
        let actual = dir.join(format!("{name}{suffix}.actual.png"));
        let diff = dir.join(format!("{name}{suffix}.diff.png"));
        save(&actual, &shot.rgba8);
        let magma = error.apply_color_lut(&nv_flip::magma_lut());
        image::save_buffer(&diff, &magma.to_vec(), shot.width, shot.height, image::ColorType::Rgb8).unwrap();
        return Err(format!(
            "{name}{suffix}: FLIP mean {mean:.5} (limit {}), error-weighted {}th percentile {at:.4} (limit {})\n  expected: {}\n  actual:   {}\n  diff:     {}",
            tol.mean,
            tol.percentile * 100.0,
            tol.at_percentile,
            golden.display(),
            actual.display(),
            diff.display()
        ));
    }
    Ok(())
}

use penumbra::prelude::*;
use penumbra::render::{RenderOutput, RenderPlugin};

/// An empty app with the engine and render plugins, for scenes built in code.
pub fn scene_app() -> App {
    let mut app = App::new();
    app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
    app
}

/// A fence's material: a pale blue cut out (alpha mask 0.5, both sides) by an 8×8 checker of
/// alpha, so its edges cross pixels and shadow-map texels.
pub fn checker_fence(app: &mut App) -> StandardMaterial {
    let checker: Vec<u8> =
        (0..64u32).flat_map(|i| [200, 220, 255, if (i % 8 + i / 8) % 2 == 0 { 255 } else { 0 }]).collect();
    let image = app.world.resource_mut::<Assets<Image>>().add(Image {
        width: 8,
        height: 8,
        rgba8: checker,
        label: "alpha checker".into(),
        mips: None,
        compressed: None,
    });
    StandardMaterial {
        base_color_texture: Some(TextureRef::new(image)),
        alpha_mode: AlphaMode::Mask(0.5),
        double_sided: true,
        ..StandardMaterial::from_color(Vec4::ONE, 0.5)
    }
}

/// Runs one update of `app`, rendering headless at `size` (a renderer is attached on first use),
/// and returns the tonemapped sRGB RGBA8 pixels. A shader error fails the test: some draw was
/// left out of the frame, or drawn by older shaders (`Renderer::read_frame`).
pub fn render_app(app: &mut App, size: (u32, u32), settings: RenderSettings) -> Vec<u8> {
    render_app_despite_shader_errors(app, size, settings);
    app.world.resource::<Renderer>().read_frame().unwrap_or_else(|e| panic!("{e}"))
}

/// [`render_app`] for tests of shader errors: the frame as drawn, whatever failed to compile.
pub fn render_app_despite_shader_errors(app: &mut App, size: (u32, u32), settings: RenderSettings) -> Vec<u8> {
    if !app.world.contains_resource::<Renderer>() {
        app.insert_resource(Renderer::new(gpu(), settings).unwrap());
    }
    app.insert_resource(RenderOutput::Headless { width: size.0, height: size.1 });
    app.update();
    app.world.resource::<Renderer>().read_headless().unwrap()
}

/// The last frame's HDR colour (linear, exposed, before tonemapping).
pub fn hdr_of(app: &App) -> Vec<[f32; 4]> {
    app.world.resource::<Renderer>().read_hdr().unwrap()
}

/// Spawns a mesh with a material; returns the entity.
pub fn spawn_mesh(app: &mut App, mesh: Mesh, material: StandardMaterial, transform: Transform) -> Entity {
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(mesh);
    let material = app.world.resource_mut::<Assets<StandardMaterial>>().add(material);
    app.world.spawn((Mesh3d(mesh), MeshMaterial3d(material), transform)).id()
}

/// Luminance-ish brightness (mean of RGB, 0..255) of the pixel at (x, y).
pub fn brightness(rgba: &[u8], width: u32, x: u32, y: u32) -> f32 {
    let i = ((y * width + x) * 4) as usize;
    (rgba[i] as f32 + rgba[i + 1] as f32 + rgba[i + 2] as f32) / 3.0
}

/// FLIP mean error between two RGBA8 images of the same size.
pub fn flip_mean(a: &[u8], b: &[u8], width: u32, height: u32) -> f32 {
    nv_flip::FlipPool::from_image(&flip_error(a, b, width, height)).mean()
}

/// FLIP's error-weighted percentile (0.999: the 99.9th; see [`Tolerance`]) between two RGBA8
/// images.
pub fn flip_weighted_percentile(a: &[u8], b: &[u8], width: u32, height: u32, percentile: f32) -> f32 {
    nv_flip::FlipPool::from_image(&flip_error(a, b, width, height)).get_percentile(percentile, true)
}

fn flip_error(a: &[u8], b: &[u8], width: u32, height: u32) -> nv_flip::FlipImageFloat {
    let rgb = |rgba: &[u8]| rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect::<Vec<u8>>();
    let reference = nv_flip::FlipImageRgb8::with_data(width, height, &rgb(a));
    let test = nv_flip::FlipImageRgb8::with_data(width, height, &rgb(b));
    nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE)
}

/// Panics if any HDR value is NaN, infinite, negative or above f16's largest finite value.
pub fn assert_finite_hdr(hdr: &[[f32; 4]], what: &str) {
    for (i, p) in hdr.iter().enumerate() {
        for c in &p[..3] {
            assert!(c.is_finite() && *c >= 0.0 && *c <= 65504.0, "{what}: pixel {i} is {p:?}");
        }
    }
}

/// The white, fully rough floor's radiance under a light arriving along `l` with illuminance
/// `e` (perpendicular to the light), seen from straight above: Penumbra's BRDF written out
/// (glTF's metal-rough model; the diffuse base gets what the specular layer's directional
/// albedo leaves, `brdf.wgsl`'s `diffuse_share`).
pub fn floor_radiance(l: Vec3, e: f32) -> f32 {
    let n = Vec3::Y;
    let v = Vec3::Y;
    let n_dot_l = n.dot(l);
    if n_dot_l <= 0.0 {
        return 0.0;
    }
    let h = (l + v).normalize();
    let v_dot_h = v.dot(h).clamp(0.0, 1.0);
    let fresnel = 0.04 + 0.96 * (1.0 - v_dot_h).powi(5);
    let pi = std::f32::consts::PI;
    // α = 1: D = 1/π; height-correlated Smith V = 0.5 / (N·L + N·V).
    let spec = fresnel * (1.0 / pi) * (0.5 / (n_dot_l + 1.0));
    let diffuse = (1.0 - dielectric_albedo_from_above()) / pi;
    (diffuse + spec) * e * n_dot_l
}

/// The directional albedo of a fully rough dielectric's specular layer (F0 0.04) seen along its
/// normal: Karis's split-sum fit (A, B) at N·V = 1, roughness 1, with Fdez-Agüera's multiple
/// scattering, as `brdf.wgsl` computes it.
fn dielectric_albedo_from_above() -> f32 {
    let (a, b) = (-1.04 * 0.015 + 0.468, 1.04 * 0.015 - 0.018);
    let fss_ess = 0.04 * a + b;
    let ems = 1.0 - (a + b);
    let f_avg = 0.04 + 0.96 / 21.0;
    fss_ess + ems * fss_ess * f_avg / (1.0 - ems * f_avg)
}

/// An orthographic camera looking straight down at a white floor, `half` metres each side of
/// the centre, rendering `size`² pixels: returns the world position at the centre of pixel (x, y).
pub fn top_down(app: &mut App, half: f32) -> impl Fn(u32, u32, u32) -> Vec3 + use<> {
    spawn_mesh(app, Mesh::plane(4.0 * half), StandardMaterial::from_color(Vec4::ONE, 1.0), Transform::default());
    app.world.spawn((
        Camera {
            projection: Projection::Orthographic { xmag: Some(half), ymag: half, znear: 0.1, zfar: 100.0 },
            // HDR values are then radiance itself.
            exposure: Exposure::unit(),
            ..Default::default()
        },
        Transform::from_xyz(0.0, 10.0, 0.0).looking_at(Vec3::ZERO, Vec3::NEG_Z),
    ));
    move |x, y, size| {
        let u = (x as f32 + 0.5) / size as f32 * 2.0 - 1.0;
        let v = (y as f32 + 0.5) / size as f32 * 2.0 - 1.0;
        // Looking down with −Z up on screen: screen x is world +X, screen y down is world +Z.
        Vec3::new(u * half, 0.0, v * half)
    }
}

/// An IES LM-63-2002 type C profile: `candela[h * vertical.len() + v]` at the given angles
/// (degrees), added to the app's assets.
pub fn add_ies_profile(app: &mut App, vertical: &[f32], horizontal: &[f32], candela: &[f32]) -> Handle<IesProfile> {
    let join = |xs: &[f32]| xs.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" ");
    let text = format!(
        "IESNA:LM-63-2002\n[TEST] written by the test\nTILT=NONE\n1 -1 1 {} {} 1 2 0 0 0\n1 1 0\n{}\n{}\n{}\n",
        vertical.len(),
        horizontal.len(),
        join(vertical),
        join(horizontal),
        join(candela)
    );
    let profile = IesProfile::parse(&text, "test.ies").unwrap();
    app.world.resource_mut::<Assets<IesProfile>>().add(profile)
}
