//! Hot reload of WGSL from a shader folder, driven through the file watcher as an editor would:
//! a broken shader is reported with its line and the last good pipelines keep drawing; a fixed
//! one is used at once; empty files, rename-over saves and deletions are errors until the file is
//! whole; an edit to an imported module rebuilds exactly the pipelines whose variants import it,
//! and one no variant in use imports is still checked; a reload rebuilds for every file that
//! differs from the shaders in use, whichever file its event named, and an error stands until its
//! own file is fixed; an edit to the split-sum table's shader makes the table again; a headless
//! frame drawn while a shader is broken is an error, not a screenshot.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use penumbra::prelude::*;
use penumbra::render::ReloadReport;
use penumbra::render::headless::HeadlessRunner;
use penumbra::render::pipelines::shader_library::EMBEDDED;
use penumbra::render::{RenderSettings, Renderer, ShaderSource};

mod common;
// Frames here are wanted as drawn, shader errors and all: the tests check the errors themselves.
use common::render_app_despite_shader_errors as render_app;
use common::{brightness, scene_app, scratch_dir, spawn_mesh};

const SIZE: (u32, u32) = (48, 48);

fn shader_folder(name: &str) -> PathBuf {
    let dir = scratch_dir(name);
    for (file, source) in EMBEDDED {
        std::fs::write(dir.join(file), source).unwrap();
    }
    dir
}

/// A lit white quad filling the middle of the frame, rendered with shaders from `dir`.
fn app_with_shaders(dir: &Path) -> App {
    quad_app(dir, StandardMaterial::from_color(Vec4::ONE, 1.0))
}

/// A quad of `material` facing the camera under ambient light, with shaders from `dir`.
fn quad_app(dir: &Path, material: StandardMaterial) -> App {
    let mut app = scene_app();
    let mut quad = Mesh::plane(2.0);
    for p in &mut quad.positions {
        *p = Vec3::new(p.x, -p.z, 0.0);
    }
    quad.normals = vec![Vec3::Z; 4];
    spawn_mesh(&mut app, quad, material, Transform::IDENTITY);
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.8 });
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 0.0, 3.0)));
    let settings = RenderSettings {
        msaa: 1,
        shaders: ShaderSource::Folder { dir: dir.to_path_buf(), watch: true },
        ..Default::default()
    };
    app.insert_resource(Renderer::new(common::gpu(), settings).unwrap());
    app
}

fn renderer(app: &App) -> &Renderer {
    app.world.resource::<Renderer>()
}

/// Renders frames until `done` holds (the watcher settles within tens of milliseconds).
fn render_until(app: &mut App, what: &str, done: impl Fn(&Renderer) -> bool) -> Vec<u8> {
    let start = Instant::now();
    loop {
        let px = render_app(app, SIZE, RenderSettings::default());
        if done(renderer(app)) {
            return px;
        }
        assert!(start.elapsed() < Duration::from_secs(10), "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn generation(r: &Renderer) -> u64 {
    r.stats().shader_generation
}

fn read(dir: &Path, file: &str) -> String {
    std::fs::read_to_string(dir.join(file)).unwrap()
}

fn forward(dir: &Path) -> String {
    read(dir, "forward.wgsl")
}

/// `source` with an unfinished function after it: a syntax error on its last line.
fn with_syntax_error(source: &str) -> String {
    format!("{source}\nfn broken( {{\n")
}

/// forward.wgsl with its output scaled by `k` (0 makes the quad black).
fn scaled_output(source: &str, k: &str) -> String {
    let edited =
        source.replacen("var out = color * view.exposure;", &format!("var out = color * view.exposure * {k};"), 1);
    assert_ne!(edited, source, "the test's edit must apply");
    edited
}

#[test]
fn a_broken_shader_keeps_the_last_good_image_and_a_fixed_one_is_used() {
    let dir = shader_folder("reload-broken");
    let mut app = app_with_shaders(&dir);
    let good = render_app(&mut app, SIZE, RenderSettings::default());
    assert!(brightness(&good, SIZE.0, 24, 24) > 150.0);
    let original = forward(&dir);

    // A syntax error on a known line.
    let line = original.lines().position(|l| l.contains("var out = color * view.exposure;")).unwrap() + 1;
    let broken = original.replacen("var out = color * view.exposure;", "var out = color * ;", 1);
    std::fs::write(dir.join("forward.wgsl"), &broken).unwrap();
    let px = render_until(&mut app, "the error", |r| r.shader_error().is_some());
    let err = renderer(&app).shader_error().unwrap().clone();
    assert_eq!((err.file.as_str(), err.line as usize), ("forward.wgsl", line), "{err}");
    assert!(err.to_string().starts_with(&format!("forward.wgsl:{line}:")), "{err}");
    assert_eq!(px, good, "frames keep the last good pipelines");

    // Fixed, with a visible change: the new shader is used and the error clears.
    let g = generation(renderer(&app));
    std::fs::write(dir.join("forward.wgsl"), scaled_output(&original, "0.0")).unwrap();
    let px = render_until(&mut app, "the fix", |r| generation(r) > g);
    assert!(renderer(&app).shader_error().is_none(), "the error clears once fixed");
    assert!(brightness(&px, SIZE.0, 24, 24) < 20.0, "the edited shader (output × 0) is in use");
}

/// Headless renders read through `Renderer::read_frame`: a frame drawn while a shader is broken
/// (without the broken pipeline at start, with the last good one after a failed reload) is an
/// error naming the place, not a screenshot; the viewer's own read still gets the frame.
#[test]
fn headless_frames_drawn_with_a_shader_error_are_errors() {
    let dir = shader_folder("reload-headless");
    let original = forward(&dir);
    let broken = scaled_output(&original, "*");
    std::fs::write(dir.join("forward.wgsl"), &broken).unwrap();
    let mut app = app_with_shaders(&dir);
    let shot = dir.join("shot.png");
    let runner = HeadlessRunner::screenshot(&shot, SIZE, 1);
    let err = runner.run_on(&mut app).expect_err("a screenshot without the quad's pipeline");
    assert!(err.to_string().starts_with("forward.wgsl:") && err.to_string().contains("expected"), "{err}");
    assert!(!shot.exists(), "nothing written");

    std::fs::write(dir.join("forward.wgsl"), &original).unwrap();
    let px = render_until(&mut app, "the fixed shader", |r| r.shader_error().is_none());
    assert_eq!(renderer(&app).read_frame().expect("no shader error"), px);
    assert!(brightness(&px, SIZE.0, 24, 24) > 150.0, "the quad is drawn");

    std::fs::write(dir.join("forward.wgsl"), &broken).unwrap();
    let last_good = render_until(&mut app, "the error", |r| r.shader_error().is_some());
    assert_eq!(last_good, px, "the last good pipeline draws on");
    let err = renderer(&app).read_frame().expect_err("the frame is not what the folder's shaders say");
    assert!(err.to_string().starts_with("forward.wgsl:"), "{err}");
    assert!(runner.run_on(&mut app).is_err() && !shot.exists(), "nor is a screenshot");
}

/// A pass the scene does not run still has its file checked on save: an edit that reaches no
/// pipeline in use is composed and validated in its plain variant, so its mistake shows now.
#[test]
fn an_edit_to_a_pass_not_in_use_is_still_checked() {
    let dir = shader_folder("reload-unused-pass");
    let mut app = app_with_shaders(&dir);
    let good = render_app(&mut app, SIZE, RenderSettings::default());
    let file = "deferred_lights.wgsl";
    let source = read(&dir, file);
    let reload = |app: &mut App| app.world.resource_mut::<Renderer>().reload_shaders(&[file.to_owned()]);

    std::fs::write(dir.join(file), format!("{source}\n// edited\n")).unwrap();
    let report = reload(&mut app).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(report.rebuilt, 0, "no local lights: no pipeline of the scene uses {file}");

    let broken = with_syntax_error(&source);
    std::fs::write(dir.join(file), &broken).unwrap();
    let err = reload(&mut app).expect_err("a syntax error in a pass not in use");
    assert_eq!((err.file.as_str(), err.line as usize), (file, broken.lines().count()), "{err}");
    assert_eq!(render_app(&mut app, SIZE, RenderSettings::default()), good, "the frame is as it was");

    std::fs::write(dir.join(file), &source).unwrap();
    assert!(reload(&mut app).is_ok());
    assert!(renderer(&app).shader_error().is_none(), "the error clears once fixed");

    // One save of two files, one of them in use (forward.wgsl rebuilds): the other is checked too.
    let both = ["forward.wgsl".to_owned(), file.to_owned()];
    std::fs::write(dir.join(&both[0]), format!("{}\n// edited\n", forward(&dir))).unwrap();
    std::fs::write(dir.join(file), &broken).unwrap();
    let err = app.world.resource_mut::<Renderer>().reload_shaders(&both).expect_err("the broken file of the two");
    assert_eq!((err.file.as_str(), err.line as usize), (file, broken.lines().count()), "{err}");
    assert_eq!(render_app(&mut app, SIZE, RenderSettings::default()), good, "the frame is as it was");
}

#[test]
fn empty_renamed_and_deleted_files_are_errors_until_the_file_is_whole() {
    let dir = shader_folder("reload-editors");
    let mut app = app_with_shaders(&dir);
    let good = render_app(&mut app, SIZE, RenderSettings::default());
    let original = forward(&dir);
    let path = dir.join("forward.wgsl");

    // Truncate-then-write, seen half way: an empty file.
    std::fs::write(&path, "").unwrap();
    let px = render_until(&mut app, "the empty-file error", |r| r.shader_error().is_some());
    assert!(renderer(&app).shader_error().unwrap().message.contains("empty"));
    assert_eq!(px, good);
    let g = generation(renderer(&app));
    std::fs::write(&path, scaled_output(&original, "0.5")).unwrap();
    render_until(&mut app, "the completed file", |r| generation(r) > g && r.shader_error().is_none());

    // Write a temporary file and rename it over the original.
    let g = generation(renderer(&app));
    let tmp = dir.join(".forward.wgsl.swp");
    std::fs::write(&tmp, scaled_output(&original, "0.0")).unwrap();
    std::fs::rename(&tmp, &path).unwrap();
    let px = render_until(&mut app, "the renamed file", |r| generation(r) > g);
    assert!(brightness(&px, SIZE.0, 24, 24) < 20.0);

    // Delete, then restore.
    std::fs::remove_file(&path).unwrap();
    let px = render_until(&mut app, "the deletion error", |r| r.shader_error().is_some());
    assert!(
        renderer(&app).shader_error().unwrap().message.contains("cannot read"),
        "{}",
        renderer(&app).shader_error().unwrap()
    );
    assert!(brightness(&px, SIZE.0, 24, 24) < 20.0, "still the last good shader");
    let g = generation(renderer(&app));
    std::fs::write(&path, &original).unwrap();
    let px = render_until(&mut app, "the restored file", |r| generation(r) > g && r.shader_error().is_none());
    assert_eq!(px, good, "restored shader, restored image");
}

#[test]
fn an_imported_module_rebuilds_exactly_its_dependents() {
    let dir = shader_folder("reload-imports");
    let mut app = app_with_shaders(&dir);
    // With the HDR target kept, the frame has a tonemap pipeline beside the forward one.
    let mut r = app.world.resource_mut::<Renderer>();
    let settings = RenderSettings { keep_hdr: true, ..r.settings().clone() };
    r.set_settings(settings).unwrap();
    render_app(&mut app, SIZE, RenderSettings::default());
    let forward_pipelines = renderer(&app).forward_pipeline_keys().len();
    assert!(forward_pipelines >= 1);

    // brdf.wgsl is imported by forward.wgsl (through lights.wgsl too) and by brdf_lut.wgsl, which
    // makes the split-sum table lit draws read; not by tonemap.wgsl.
    let brdf = std::fs::read_to_string(dir.join("brdf.wgsl")).unwrap();
    std::fs::write(dir.join("brdf.wgsl"), format!("{brdf}\n// edited\n")).unwrap();
    let report = app.world.resource_mut::<Renderer>().reload_shaders(&["brdf.wgsl".to_owned()]).unwrap();
    assert_eq!(
        report.families,
        [("forward", forward_pipelines), ("environment", 1)],
        "every forward pipeline and the split-sum table's step import brdf.wgsl; the tonemap pipeline does not"
    );
    assert_eq!(report.rebuilt, forward_pipelines + 1);
    assert!(report.untouched >= 1, "the tonemap pipeline is left alone");

    // common.wgsl is imported by both.
    let common = std::fs::read_to_string(dir.join("common.wgsl")).unwrap();
    std::fs::write(dir.join("common.wgsl"), format!("{common}\n// edited\n")).unwrap();
    let report = app.world.resource_mut::<Renderer>().reload_shaders(&["common.wgsl".to_owned()]).unwrap();
    assert_eq!(report.untouched, 0, "every pipeline imports common.wgsl");
}

#[test]
fn a_scene_without_normal_maps_or_local_lights_compiles_neither() {
    let dir = shader_folder("variants");
    let mut app = app_with_shaders(&dir);
    render_app(&mut app, SIZE, RenderSettings::default());
    for key in renderer(&app).forward_pipeline_keys() {
        let defs = key.shader_defs();
        assert!(!defs.0.contains("NORMAL_MAP") && !defs.0.contains("LOCAL_LIGHTS"), "{defs}");
    }
    // A point light appears: pipelines with the local-light code are compiled for it.
    app.world.spawn((PointLight { intensity: 5.0, ..Default::default() }, Transform::from_xyz(0.0, 0.0, 1.0)));
    render_app(&mut app, SIZE, RenderSettings::default());
    assert!(renderer(&app).forward_pipeline_keys().iter().any(|k| k.shader_defs().0.contains("LOCAL_LIGHTS")));
}

#[test]
fn an_edit_to_the_split_sum_table_remakes_the_table() {
    let dir = shader_folder("reload-table");
    // A grey rough metal under ambient light: what it reflects is its split-sum albedo.
    let metal = StandardMaterial { metallic: 1.0, ..StandardMaterial::from_color(Vec4::new(0.5, 0.5, 0.5, 1.0), 0.6) };
    let mut app = quad_app(&dir, metal);
    let before = render_app(&mut app, SIZE, RenderSettings::default());
    let lit = brightness(&before, SIZE.0, SIZE.0 / 2, SIZE.1 / 2);
    assert!(lit > 20.0, "the metal is lit: {lit}");

    // The table's single-scattering scale A, a quarter of what it integrates.
    let table = std::fs::read_to_string(dir.join("brdf_lut.wgsl")).unwrap();
    let edited = table.replacen("vec4<f32>(a / f32(LUT_SAMPLES)", "vec4<f32>(0.25 * a / f32(LUT_SAMPLES)", 1);
    assert_ne!(edited, table, "the test's edit must apply");
    let g = generation(renderer(&app));
    std::fs::write(dir.join("brdf_lut.wgsl"), edited).unwrap();
    let after = render_until(&mut app, "the edited table", |r| generation(r) > g && r.shader_error().is_none());
    let plan = &renderer(&app).stats().plan;
    assert!(plan.runs(penumbra::render::frame::Pass::ENVIRONMENT_PREFILTER), "the table is made again: {plan}");
    let dimmer = brightness(&after, SIZE.0, SIZE.0 / 2, SIZE.1 / 2);
    assert!(dimmer < lit * 0.8, "the new table is what the surface reads: {lit} -> {dimmer}");
}

#[test]
fn pipelines_sharing_a_variant_rebuild_together_and_a_pipeline_error_keeps_them_all() {
    let dir = shader_folder("reload-many");
    let mut app = app_with_shaders(&dir);
    // A double-sided quad behind the single-sided one: the same variant, another pipeline.
    let mut quad = Mesh::plane(1.0);
    for p in &mut quad.positions {
        *p = Vec3::new(p.x, -p.z, 0.0);
    }
    quad.normals = vec![Vec3::Z; 4];
    let material = StandardMaterial { double_sided: true, ..StandardMaterial::from_color(Vec4::ONE, 1.0) };
    spawn_mesh(&mut app, quad, material, Transform::from_xyz(0.0, 0.0, -0.5));
    let good = render_app(&mut app, SIZE, RenderSettings::default());
    let keys = renderer(&app).forward_pipeline_keys();
    assert_eq!(keys.len(), 2, "{keys:?}");
    assert_eq!(keys[0].shader_defs(), keys[1].shader_defs());
    let original = forward(&dir);

    // Composes, but no pipeline can be made from it: the error comes from pipeline creation.
    let renamed = original.replacen("fn fs_main(", "fn fs_renamed(", 1);
    assert_ne!(renamed, original);
    std::fs::write(dir.join("forward.wgsl"), &renamed).unwrap();
    let err = app.world.resource_mut::<Renderer>().reload_shaders(&["forward.wgsl".to_owned()]).unwrap_err();
    assert_eq!(err.file, "forward.wgsl", "{err}");
    assert_eq!(render_app(&mut app, SIZE, RenderSettings::default()), good, "both old pipelines still draw");

    // A resource declared in the shader alone, absent from the pipeline layout: wgpu's error
    // comes as one line naming the binding, without its heading and the pipeline key's dump.
    let anchor = "var out = color * view.exposure;";
    let extra = original.replacen(anchor, "var out = color * view.exposure * extra_binding.x;", 1).replacen(
        "fn shade(",
        "@group(0) @binding(99) var<uniform> extra_binding: vec4<f32>;\n\nfn shade(",
        1,
    );
    std::fs::write(dir.join("forward.wgsl"), &extra).unwrap();
    let err = app.world.resource_mut::<Renderer>().reload_shaders(&["forward.wgsl".to_owned()]).unwrap_err();
    let text = err.to_string();
    assert!(
        text.starts_with("forward.wgsl: ") && text.contains("binding: 99") && text.contains("pipeline layout"),
        "{text}"
    );
    assert!(!text.contains('\n') && !text.contains("label =") && !text.contains("Validation Error"), "{text}");
    assert_eq!(render_app(&mut app, SIZE, RenderSettings::default()), good, "both old pipelines still draw");

    std::fs::write(dir.join("forward.wgsl"), scaled_output(&original, "0.0")).unwrap();
    let report = app.world.resource_mut::<Renderer>().reload_shaders(&["forward.wgsl".to_owned()]).unwrap();
    assert_eq!(report.rebuilt, 2, "both pipelines of the variant");
    let px = render_app(&mut app, SIZE, RenderSettings::default());
    assert!(brightness(&px, SIZE.0, 24, 24) < 20.0, "the edited shader is in use");
}

fn reload(app: &mut App, file: &str) -> Result<ReloadReport, penumbra::render::pipelines::shader_library::ShaderError> {
    app.world.resource_mut::<Renderer>().reload_shaders(&[file.to_owned()])
}

/// An event can name one file while another changed too (a save of several files whose later
/// events arrive after the reload that read them): the reload rebuilds for what differs from the
/// shaders in use, not for what the event named.
#[test]
fn a_reload_rebuilds_for_every_changed_file_whichever_its_event_named() {
    let dir = shader_folder("reload-unnamed");
    let mut app = app_with_shaders(&dir);
    let good = render_app(&mut app, SIZE, RenderSettings::default());
    assert!(brightness(&good, SIZE.0, 24, 24) > 150.0);
    std::fs::write(dir.join("forward.wgsl"), scaled_output(&forward(&dir), "0.0")).unwrap();
    let report = reload(&mut app, "tonemap.wgsl").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(report.files, ["forward.wgsl"]);
    assert_eq!(report.families, [("forward", 1)]);
    let px = render_app(&mut app, SIZE, RenderSettings::default());
    assert!(brightness(&px, SIZE.0, 24, 24) < 20.0, "the edited forward.wgsl is in use");
    // Its own event, later: nothing left to do.
    let report = reload(&mut app, "forward.wgsl").unwrap();
    assert!(report.files.is_empty() && report.rebuilt == 0, "{:?}", report.families);
}

/// The shaders in use are one consistent set: while one file is broken, no other edit is swapped
/// in and the error stands, naming that file; fixing it brings in both.
#[test]
fn an_error_stands_until_its_own_file_is_fixed() {
    let dir = shader_folder("reload-standing");
    let mut app = app_with_shaders(&dir);
    let good = render_app(&mut app, SIZE, RenderSettings::default());
    let file = "deferred_lights.wgsl";
    let source = read(&dir, file);
    let broken = with_syntax_error(&source);
    std::fs::write(dir.join(file), &broken).unwrap();
    let err = reload(&mut app, file).expect_err("a syntax error");
    assert_eq!((err.file.as_str(), err.line as usize), (file, broken.lines().count()), "{err}");

    // A good edit elsewhere: the broken file still fails the reload, the error stays.
    std::fs::write(dir.join("forward.wgsl"), scaled_output(&forward(&dir), "0.0")).unwrap();
    let err = reload(&mut app, "forward.wgsl").expect_err("deferred_lights.wgsl is still broken");
    assert_eq!(err.file, file, "{err}");
    assert_eq!(renderer(&app).shader_error().map(|e| e.file.as_str()), Some(file));
    assert_eq!(render_app(&mut app, SIZE, RenderSettings::default()), good, "the last good shaders draw on");

    std::fs::write(dir.join(file), &source).unwrap();
    let report = reload(&mut app, file).unwrap_or_else(|e| panic!("{e}"));
    // deferred_lights.wgsl is back as the shaders in use have it: forward.wgsl is what changed.
    assert_eq!(report.files, ["forward.wgsl"]);
    assert!(renderer(&app).shader_error().is_none(), "the error clears once its file is fixed");
    let px = render_app(&mut app, SIZE, RenderSettings::default());
    assert!(brightness(&px, SIZE.0, 24, 24) < 20.0, "and the other edit is in use");
}

/// A folder that fails at start (two files declaring one module) runs on the embedded shaders;
/// once fixed, everything the folder changes is used, not only the file fixed.
#[test]
fn a_folder_that_failed_at_start_is_used_whole_once_fixed() {
    let dir = shader_folder("reload-start-broken");
    std::fs::write(dir.join("forward.wgsl"), scaled_output(&forward(&dir), "0.0")).unwrap();
    let backup = "brdf_backup.wgsl";
    std::fs::copy(dir.join("brdf.wgsl"), dir.join(backup)).unwrap();
    let mut app = app_with_shaders(&dir);
    let px = render_app(&mut app, SIZE, RenderSettings::default());
    let err = renderer(&app).shader_error().expect("the duplicate module").clone();
    assert_eq!(err.file, backup, "{err}");
    assert!(brightness(&px, SIZE.0, 24, 24) > 150.0, "the embedded forward.wgsl draws meanwhile");

    std::fs::remove_file(dir.join(backup)).unwrap();
    let report = reload(&mut app, backup).unwrap_or_else(|e| panic!("{e}"));
    assert!(report.files.contains(&"forward.wgsl".to_owned()), "{:?}", report.files);
    assert!(renderer(&app).shader_error().is_none());
    let px = render_app(&mut app, SIZE, RenderSettings::default());
    assert!(brightness(&px, SIZE.0, 24, 24) < 20.0, "the folder's forward.wgsl is in use");
}

/// ies.wgsl is imported by lights.wgsl under IES_LIGHTS only: in a scene without IES lights an
/// edit to it rebuilds nothing, but a mistake in it is still reported at its line.
#[test]
fn a_module_no_variant_in_use_imports_rebuilds_nothing_and_is_still_checked() {
    let dir = shader_folder("reload-unused-module");
    let mut app = app_with_shaders(&dir);
    let good = render_app(&mut app, SIZE, RenderSettings::default());
    let file = "ies.wgsl";
    let source = read(&dir, file);
    std::fs::write(dir.join(file), format!("{source}\n// edited\n")).unwrap();
    let report = reload(&mut app, file).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((report.rebuilt, report.families.len()), (0, 0), "{:?}", report.families);

    let broken = with_syntax_error(&source);
    std::fs::write(dir.join(file), &broken).unwrap();
    let err = reload(&mut app, file).expect_err("a syntax error in a module no variant in use imports");
    assert_eq!((err.file.as_str(), err.line as usize), (file, broken.lines().count()), "{err}");
    assert_eq!(render_app(&mut app, SIZE, RenderSettings::default()), good);
    std::fs::write(dir.join(file), &source).unwrap();
    assert!(reload(&mut app, file).is_ok() && renderer(&app).shader_error().is_none());
}

/// A file of the folder's own (not one of the embedded set) may come and go: deleting it is no
/// error, as nothing falls back to an embedded version of it.
#[test]
fn a_scratch_file_may_come_and_go() {
    let dir = shader_folder("reload-scratch");
    let mut app = app_with_shaders(&dir);
    let good = render_app(&mut app, SIZE, RenderSettings::default());
    let scratch = "scratch.wgsl";
    std::fs::write(dir.join(scratch), "fn scratch() -> f32 { return 1.0; }\n").unwrap();
    let report = reload(&mut app, scratch).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((report.files.as_slice(), report.rebuilt), ([scratch.to_owned()].as_slice(), 0));
    std::fs::remove_file(dir.join(scratch)).unwrap();
    let report = reload(&mut app, scratch).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(report.files, [scratch]);
    assert!(renderer(&app).shader_error().is_none());
    assert_eq!(render_app(&mut app, SIZE, RenderSettings::default()), good);
}

/// A module of the folder's own that forward.wgsl imports, deleted: the pipelines that imported
/// it are rebuilt and fail where they use it, instead of running on with the deleted code.
#[test]
fn a_deleted_module_fails_its_importer_until_it_is_back() {
    let dir = shader_folder("reload-deleted-module");
    let mut app = app_with_shaders(&dir);
    let good = render_app(&mut app, SIZE, RenderSettings::default());
    let module = "#define_import_path test::extra\n\nfn scale() -> f32 {\n    return 0.0;\n}\n";
    std::fs::write(dir.join("extra.wgsl"), module).unwrap();
    let original = forward(&dir);
    let import = "#import penumbra::view::{View, eye_direction}";
    assert!(original.contains(import), "the test's edit must apply");
    let edited =
        scaled_output(&original, "extra::scale()").replacen(import, &format!("{import}\n#import test::extra"), 1);
    // naga_oil reports a missing module where the code uses it.
    let line = edited.lines().position(|l| l.contains("extra::scale()")).unwrap() + 1;
    std::fs::write(dir.join("forward.wgsl"), &edited).unwrap();
    reload(&mut app, "forward.wgsl").unwrap_or_else(|e| panic!("{e}"));
    let dark = render_app(&mut app, SIZE, RenderSettings::default());
    assert!(brightness(&dark, SIZE.0, 24, 24) < 20.0, "extra::scale() is in use");

    std::fs::remove_file(dir.join("extra.wgsl")).unwrap();
    let err = reload(&mut app, "extra.wgsl").expect_err("forward.wgsl imports the deleted module");
    assert_eq!((err.file.as_str(), err.line as usize), ("forward.wgsl", line), "{err}");
    assert!(err.message.contains("test::extra"), "{err}");
    assert_eq!(render_app(&mut app, SIZE, RenderSettings::default()), dark, "the last good pipeline draws on");

    std::fs::write(dir.join("extra.wgsl"), module).unwrap();
    reload(&mut app, "extra.wgsl").unwrap_or_else(|e| panic!("{e}"));
    assert!(renderer(&app).shader_error().is_none());
    std::fs::write(dir.join("forward.wgsl"), &original).unwrap();
    reload(&mut app, "forward.wgsl").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(render_app(&mut app, SIZE, RenderSettings::default()), good);
}
