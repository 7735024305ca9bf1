//! The `penumbra` binary as users run it: deterministic screenshots, and one clear line (naming
//! the file or flag) for every kind of bad input, with a failing exit status.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn penumbra(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_penumbra")).args(args).output().expect("the binary runs")
}

fn asset(rel: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/assets").join(rel).display().to_string()
}

fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn two_renders_write_identical_bytes() {
    let dir = out_dir("determinism");
    let shots: Vec<Vec<u8>> = ["a.png", "b.png"]
        .iter()
        .map(|name| {
            let out = dir.join(name);
            let o = penumbra(&[
                "render",
                &asset("BoxTextured/BoxTextured.glb"),
                "--out",
                out.to_str().unwrap(),
                "--size",
                "96x64",
                "--camera",
                "orbit:30:20",
            ]);
            assert!(o.status.success(), "{}", stderr(&o));
            std::fs::read(out).unwrap()
        })
        .collect();
    assert_eq!(shots[0], shots[1], "two runs differ");
    let img = image::load_from_memory(&shots[0]).unwrap();
    assert_eq!((img.width(), img.height()), (96, 64));
}

/// `--cpu-shader-compile fast` asks Mesa's llvmpipe for unoptimised shader code (same pixels,
/// quicker compiles); a `GALLIVM_PERF` the user set wins.
#[test]
fn fast_cpu_shader_compiles_draw_the_same_pixels_and_respect_the_users_setting() {
    let dir = out_dir("cpu-compile");
    let shot = |name: &str, extra: &[&str], user_env: bool| {
        let out = dir.join(name);
        let mut args: Vec<&str> = extra.to_vec();
        let scene = asset("BoxTextured/BoxTextured.glb");
        args.extend(["-v", "render", scene.as_str(), "--out", out.to_str().unwrap(), "--size", "64x48"]);
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_penumbra"));
        cmd.args(&args).env_remove("GALLIVM_PERF");
        if user_env {
            cmd.env("GALLIVM_PERF", "no_quad_lod");
        }
        let o = cmd.output().expect("the binary runs");
        assert!(o.status.success(), "{}", stderr(&o));
        (std::fs::read(out).unwrap(), stderr(&o).contains("compile without optimisation (GALLIVM_PERF=nopt)"))
    };
    let (optimized, logged) = shot("optimized.png", &[], false);
    assert!(!logged, "optimised compiles are the default where shaders are not watched");
    let (fast, logged) = shot("fast.png", &["--cpu-shader-compile", "fast"], false);
    assert!(logged, "the fast mode is applied and logged");
    assert_eq!(fast, optimized, "the same pixels either way");
    let (_, logged) = shot("user.png", &["--cpu-shader-compile", "fast"], true);
    assert!(!logged, "a GALLIVM_PERF in the environment is left alone");
    let o = penumbra(&["--cpu-shader-compile", "fastest", "render", "x.glb", "--out", "/tmp/never.png"]);
    assert!(!o.status.success() && stderr(&o).contains("--cpu-shader-compile"), "{}", stderr(&o));
}

#[test]
fn camera_aspect_sets_the_default_size() {
    let dir = out_dir("aspect");
    let out = dir.join("cam.png");
    let o = penumbra(&["render", &asset("Cameras/Cameras.gltf"), "--out", out.to_str().unwrap(), "--camera", "0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(out).unwrap();
    assert_eq!(img.height(), 512);
    assert_eq!(img.width(), 512, "the sample's perspective camera has aspect ratio 1.0");
}

#[test]
fn a_broken_file_fails_with_its_name() {
    let dir = out_dir("broken");
    let bad = dir.join("broken.gltf");
    std::fs::write(&bad, "{ not json").unwrap();
    let o = penumbra(&["render", bad.to_str().unwrap(), "--out", dir.join("x.png").to_str().unwrap()]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("broken.gltf") && e.contains("not a valid glTF"), "{e}");
    assert!(!dir.join("x.png").exists(), "no output on failure");
}

#[test]
fn a_missing_file_fails_with_its_name() {
    let o = penumbra(&["render", "/nonexistent/scene.glb", "--out", "/tmp/never.png"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("/nonexistent/scene.glb"), "{}", stderr(&o));
}

#[test]
fn a_render_whose_scene_fails_waits_for_its_gpu_set_up() {
    // The device is made on a second thread while the scene loads. Returning the scene's error
    // at once exited the process while the driver was still initialising there, which could hang
    // lavapipe in LLVM's set-up under the exit handlers.
    let o = penumbra(&["-v", "render", "/nonexistent/scene.glb", "--out", "/tmp/never.png"]);
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("/nonexistent/scene.glb"), "{e}");
    // The scene's error is the one reported, so a missing adapter shows only here.
    let ready = e.find("renderer ready").unwrap_or_else(|| {
        panic!("the GPU set-up did not finish (no GPU adapter? on Debian: apt-get install mesa-vulkan-drivers): {e}")
    });
    assert!(ready < e.find("penumbra: /nonexistent").unwrap(), "the error came before the GPU set-up ended: {e}");
}

#[test]
fn out_of_range_settings_name_their_flag() {
    let scene = asset("BoxTextured/BoxTextured.glb");
    let cases: [(&[&str], &str); 16] = [
        (&["--msaa", "3"], "--msaa"),
        (&["--shadow-slope-bias", "17"], "--shadow-slope-bias"),
        (&["--shadow-normal-bias", "20"], "--shadow-normal-bias"),
        (&["--quality", "extreme"], "--quality"),
        (&["--light-cutoff", "0"], "--light-cutoff"),
        (&["--quality", "low", "--cascades", "9"], "--cascades"),
        (&["--env-size", "100"], "--env-size"),
        (&["--env-intensity", "-1"], "--env-intensity"),
        (&["--background", "blurred", "--background-blur", "3"], "--background-blur"),
        (&["--bloom=2"], "--bloom"),
        (&["--auto-exposure", "--ev-range", "5:1"], "--ev-range"),
        (&["--env", "/nonexistent/sky.hdr"], "/nonexistent/sky.hdr"),
        (&["--size", "0x10"], "--size"),
        (&["--size", "20000x10"], "--size"),
        (&["--exposure", "1e9"], "--exposure"),
        (&["--camera", "7"], "--camera 7"),
    ];
    for (extra, flag) in cases {
        let mut args = vec!["render", scene.as_str(), "--out", "/tmp/penumbra-never.png"];
        args.extend_from_slice(extra);
        let o = penumbra(&args);
        assert!(!o.status.success(), "{extra:?} was accepted");
        assert!(stderr(&o).contains(flag), "{extra:?}: {}", stderr(&o));
    }
    let o = penumbra(&["render", &scene, "--out", "/tmp/x.png", "--size", "big"]);
    assert!(!o.status.success() && stderr(&o).contains("--size"), "{}", stderr(&o));
}

#[test]
fn explain_prints_the_plan_and_quality_presets_change_it() {
    let dir = out_dir("explain");
    let out = dir.join("plan.png");
    let run = |quality: &str| {
        let o = penumbra(&[
            "render",
            &asset("BoxTextured/BoxTextured.glb"),
            "--out",
            out.to_str().unwrap(),
            "--size",
            "32x32",
            "--env",
            "none",
            "--explain",
            "--quality",
            quality,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        String::from_utf8(o.stdout).unwrap()
    };
    let low = run("low");
    assert!(low.contains("Frame plan") && low.contains("Opaque: opaque or masked draws exist"), "{low}");
    assert!(low.contains("- Background: no environment to show"), "{low}");
    assert!(low.contains("MSAA 1: BASE_COLOR_TEXTURE"), "low renders without MSAA: {low}");
    let high = run("high");
    assert!(high.contains("MSAA 4: BASE_COLOR_TEXTURE"), "{high}");
    // The flag alone overrides the preset.
    let o = penumbra(&[
        "render",
        &asset("BoxTextured/BoxTextured.glb"),
        "--out",
        out.to_str().unwrap(),
        "--size",
        "32x32",
        "--explain",
        "--quality",
        "low",
        "--msaa",
        "4",
    ]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("MSAA 4:"), "{}", stderr(&o));
}

#[test]
fn the_reload_benchmark_refuses_shaders_that_do_not_build() {
    let dir = out_dir("broken-shaders");
    let shaders = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders/forward.wgsl");
    let broken = std::fs::read_to_string(shaders).unwrap() + "\nfn broken( {\n";
    std::fs::write(dir.join("forward.wgsl"), broken).unwrap();
    let o = penumbra(&["bench", "--shader-edits", "1", "--size", "16x16", "--shader-dir", dir.to_str().unwrap()]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("the shaders to edit do not build") && e.contains("forward.wgsl:"), "{e}");
}

/// A headless render whose shaders do not build fails with the error's place and writes nothing:
/// the frame would lack every draw of the broken pipeline (an image of the background alone).
#[test]
fn a_render_with_a_broken_shader_fails_with_its_line() {
    let dir = out_dir("render-broken-shader");
    let original = include_str!("../../../shaders/forward.wgsl");
    let anchor = "var out = color * view.exposure;";
    let line = original.lines().position(|l| l.contains(anchor)).expect("the anchor is in forward.wgsl") + 1;
    let broken = original.replacen(anchor, "var out = color * view.exposure * ;", 1);
    std::fs::write(dir.join("forward.wgsl"), broken).unwrap();
    let out = dir.join("x.png");
    let scene = asset("BoxTextured/BoxTextured.glb");
    let o = penumbra(&[
        "render",
        &scene,
        "--out",
        out.to_str().unwrap(),
        "--size",
        "16x16",
        "--shader-dir",
        dir.to_str().unwrap(),
    ]);
    assert!(!o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains(&format!("forward.wgsl:{line}:")) && e.contains("expected expression"), "{e}");
    assert!(!out.exists(), "no image of a frame with draws missing");
}

#[test]
fn the_reload_benchmark_splits_its_latency_at_the_submission() {
    let o = penumbra(&["bench", "--shader-edits", "1", "--size", "16x16"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout).to_string();
    // Each row: | measure | median | max |; with one edit the median is that edit.
    let row = |prefix: &str| -> f64 {
        let line = out.lines().find(|l| l.starts_with(&format!("| {prefix}"))).unwrap_or_else(|| panic!("{out}"));
        line.split('|').nth(2).unwrap().trim().parse().unwrap()
    };
    let total = row("file write to first frame");
    let submitted = row("of which: until that frame is submitted");
    let on_device = row("of which: from submission");
    assert!(submitted > 0.0 && on_device > 0.0, "{out}");
    assert!((submitted + on_device - total).abs() <= 0.15, "the parts add up to the whole: {out}");
    // The machine's speed before and after the edits, as two compile times.
    let speed = out.lines().find(|l| l.starts_with("speed ")).unwrap_or_else(|| panic!("{out}"));
    let times: Vec<f64> = speed.split_whitespace().filter_map(|w| w.parse().ok()).collect();
    assert!(times.len() == 2 && times.iter().all(|t| t.is_finite() && *t > 0.0), "{speed}");
}

#[test]
fn view_without_a_display_points_to_render() {
    let o = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .arg("view")
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("no display") && e.contains("penumbra render"), "{e}");
}

#[test]
fn gif_is_a_turntable_round_the_scene() {
    use image::AnimationDecoder;
    let out = out_dir("gif").join("turn.gif");
    let o = penumbra(&[
        "gif",
        "--out",
        out.to_str().unwrap(),
        "--frames",
        "6",
        "--size",
        "64x48",
        "--seconds",
        "1.2",
        "--background",
        "color",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let decoder =
        image::codecs::gif::GifDecoder::new(std::io::BufReader::new(std::fs::File::open(&out).unwrap())).unwrap();
    let frames = decoder.into_frames().collect_frames().expect("a valid GIF");
    assert_eq!(frames.len(), 6);
    let mut previous: Option<Vec<u8>> = None;
    for (i, f) in frames.iter().enumerate() {
        let (num, den) = f.delay().numer_denom_ms();
        assert_eq!(num / den, 200, "frame {i}: delay");
        let img = f.buffer();
        assert_eq!(img.dimensions(), (64, 48));
        // The model (what differs from the clear colour in the corner) stays whole and centred.
        let bg = *img.get_pixel(0, 0);
        let differs =
            |p: &image::Rgba<u8>| p.0.iter().zip(bg.0).take(3).any(|(a, b)| (*a as i32 - b as i32).abs() > 12);
        let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0, 0);
        for (x, y, p) in img.enumerate_pixels() {
            if differs(p) {
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            }
        }
        assert!(
            x0 > 0 && y0 > 0 && x1 < 63 && y1 < 47,
            "frame {i}: the model leaves the frame ({x0},{y0})-({x1},{y1})"
        );
        let centre = ((x0 + x1) as f32 / 2.0, (y0 + y1) as f32 / 2.0);
        assert!((centre.0 - 32.0).abs() < 6.0 && (centre.1 - 24.0).abs() < 6.0, "frame {i}: off centre {centre:?}");
        let raw = img.as_raw().clone();
        assert!(previous.as_ref() != Some(&raw), "frame {i} equals the frame before: the camera did not turn");
        previous = Some(raw);
    }
    for bad in [["--frames", "1"], ["--seconds", "0"], ["--pitch", "95"], ["--size", "0x10"]] {
        let o = penumbra(&["gif", "--out", out.to_str().unwrap(), bad[0], bad[1]]);
        assert!(!o.status.success() && stderr(&o).contains(bad[0]), "{bad:?}: {}", stderr(&o));
    }
}

/// `--variant NAME` shows a file's material variant (KHR_materials_variants): the image differs
/// from the file's own materials; a name the file lacks is refused with the file's variants
/// listed, and no image is written.
#[test]
fn variant_flag_switches_materials_and_refuses_unknown_names() {
    let dir = out_dir("variants");
    let render = |variant: Option<&str>, name: &str| {
        let out = dir.join(name);
        let scene = asset("VariantsTest/VariantsTest.gltf");
        let mut args = vec!["render", scene.as_str(), "--out", out.to_str().unwrap(), "--size", "48x48"];
        if let Some(v) = variant {
            args.extend(["--variant", v]);
        }
        let o = penumbra(&args);
        (o, out)
    };
    let (own, own_path) = render(None, "own.png");
    assert!(own.status.success(), "{}", stderr(&own));
    let (blue, blue_path) = render(Some("Blue metal"), "blue.png");
    assert!(blue.status.success(), "{}", stderr(&blue));
    assert_ne!(std::fs::read(own_path).unwrap(), std::fs::read(blue_path).unwrap(), "the variant changes the image");
    let (bad, bad_path) = render(Some("Purple"), "bad.png");
    assert!(!bad.status.success());
    assert!(
        stderr(&bad).contains(
            "--variant Purple: the scene has no variant of that name (its variants: Red plastic, Blue metal, Green velvet)"
        ),
        "{}",
        stderr(&bad)
    );
    assert!(!bad_path.exists(), "nothing written for a refused variant");
}

/// What every output gets: the format checked before rendering (an existing file with an
/// unsupported extension is left as it was; before, it was emptied to 0 bytes), a failed write
/// an error with the operating system's reason and a failing status (before, `/dev/full` exited
/// 0 for small images), and no partial file left in the folder.
#[test]
fn outputs_are_written_whole_or_not_at_all() {
    let dir = out_dir("outputs");
    let scene = asset("BoxTextured/BoxTextured.glb");
    let render = |out: &Path| penumbra(&["render", &scene, "--out", out.to_str().unwrap(), "--size", "48x32"]);

    let webp = dir.join("photo.webp");
    std::fs::write(&webp, b"an existing photo").unwrap();
    let o = render(&webp);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("photo.webp: .webp is not an image format Penumbra writes"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&webp).unwrap(), b"an existing photo");

    let jpeg = dir.join("photo.jpg");
    std::fs::write(&jpeg, b"an older photo").unwrap();
    let o = render(&jpeg);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(image::open(&jpeg).unwrap().width(), 48, "an RGBA frame is written as JPEG without alpha");

    let o = render(&dir.join("missing/out.png"));
    assert!(!o.status.success());
    assert!(stderr(&o).contains("missing/out.png: its folder"), "{}", stderr(&o));

    #[cfg(target_os = "linux")]
    {
        let o = render(Path::new("/dev/full"));
        assert!(!o.status.success(), "a write to a full device must fail");
        assert!(stderr(&o).contains("cannot write /dev/full: No space left on device"), "{}", stderr(&o));
        let o = penumbra(&["gif", &scene, "--out", "/dev/full", "--size", "16x16", "--frames", "2"]);
        assert!(!o.status.success(), "a GIF written to a full device must fail");
        assert!(stderr(&o).contains("cannot write /dev/full: No space left on device"), "{}", stderr(&o));
    }

    let gif = dir.join("turn.png");
    let o = penumbra(&["gif", &scene, "--out", gif.to_str().unwrap(), "--size", "16x16", "--frames", "2"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("name the output *.gif"), "{}", stderr(&o));
    assert!(!gif.exists());

    let leftovers: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".partial"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// A glTF with one camera of the given aspect ratio over a triangle.
fn scene_with_camera_aspect(dir: &Path, aspect: &str) -> PathBuf {
    let bin: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].iter().flat_map(|f| f.to_le_bytes()).collect();
    std::fs::write(dir.join("triangle.bin"), bin).unwrap();
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0}}, {{"camera": 0, "translation": [0.3, 0.3, 3]}}],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.5, "znear": 0.1, "aspectRatio": {aspect}}}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
  "buffers": [{{"uri": "triangle.bin", "byteLength": 36}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}}]}}"#
    );
    let path = dir.join(format!("aspect-{aspect}.gltf"));
    std::fs::write(&path, json).unwrap();
    path
}

/// A size derived from file data is checked as `--size` is: a camera 40 times wider than tall
/// asked for a 20480-pixel-wide image without `--size`, and wgpu's validation panicked. Now the
/// default image fits within the 16384 limit at the camera's shape, and a shape no image can
/// have is an error asking for `--size`.
#[test]
fn sizes_derived_from_a_files_camera_are_validated() {
    let dir = out_dir("derived-size");
    let out = dir.join("wide.png");
    let wide = scene_with_camera_aspect(&dir, "40");
    let o = penumbra(&["render", wide.to_str().unwrap(), "--camera", "0", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(&out).unwrap();
    assert_eq!((img.width(), img.height()), (16384, 410));

    let thin = scene_with_camera_aspect(&dir, "1e-6");
    let o = penumbra(&["render", thin.to_str().unwrap(), "--camera", "0", "--out", out.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("aspect ratio 0.000001 gives no image") && stderr(&o).contains("--size"),
        "{}",
        stderr(&o)
    );
}

/// Running out of GPU memory is an error saying what was asked for, what it needed and what
/// would fit, not wgpu's panic: `--size 16384x16384` at MSAA 4 in a process limited to 10 GB of
/// address space (lavapipe's GPU memory is the process's).
#[cfg(target_os = "linux")]
#[test]
fn out_of_gpu_memory_is_an_error_with_what_would_fit() {
    let dir = out_dir("oom");
    let out = dir.join("big.png");
    let command = format!(
        "ulimit -v 10000000 && exec '{}' render '{}' --size 16384x16384 --msaa 4 --out '{}'",
        env!("CARGO_BIN_EXE_penumbra"),
        asset("BoxTextured/BoxTextured.glb"),
        out.display()
    );
    let o = Command::new("sh").args(["-c", &command]).output().unwrap();
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        err.contains("the frame's targets for 16384x16384 at MSAA 4 need 10.0 GiB of GPU memory")
            && err.contains("MSAA 1 (--msaa 1) needs 2.0 GiB"),
        "{err}"
    );
    assert!(!out.exists());
}

/// A headless command never goes looking for a display: Mesa's Vulkan device-select layer
/// connected to the Wayland display named in the environment, and libwayland printed
/// "error: XDG_RUNTIME_DIR is invalid or not set in the environment." twice on every run.
#[test]
fn headless_commands_print_no_display_errors() {
    let dir = out_dir("no-display");
    let o = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(["render", &asset("BoxTextured/BoxTextured.glb"), "--size", "16x16", "--out"])
        .arg(dir.join("a.png"))
        .env("WAYLAND_DISPLAY", "wayland-0")
        .env("DISPLAY", ":99")
        .env_remove("XDG_RUNTIME_DIR")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stderr(&o), "", "a headless render prints nothing");
}

/// Output that says only what matters: a file with the same problem in every mesh gets one
/// warning per kind with a count (49 lines for MetalRoughSpheresNoTextures's degenerate triangles
/// before; `-v` still lists them all), and no colour codes when stderr is not a terminal.
#[test]
fn warnings_are_one_line_per_kind_and_uncoloured_off_a_terminal() {
    let dir = out_dir("warning-summary");
    let out = dir.join("spheres.png");
    let scene = asset("MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.glb");
    let run = |extra: &[&str]| {
        let mut args = vec!["render", scene.as_str(), "--size", "32x32", "--out", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        penumbra(&args)
    };
    let o = run(&[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(!err.contains('\u{1b}'), "colour codes off a terminal: {err:?}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(lines[0].contains("degenerate triangles") && lines[0].contains("more like it; `-v` lists them"), "{err}");
    let verbose = stderr(&run(&["-v"]));
    let listed = verbose.lines().filter(|l| l.contains("degenerate triangles")).count();
    assert!(listed > 10, "-v lists every primitive's warning: {listed}");
}

/// The help says what the commands take: `render` reads OBJ too, and the top-level help does not
/// open with a paragraph about LLVM.
#[test]
fn help_texts_say_what_the_commands_take() {
    let top = String::from_utf8_lossy(&penumbra(&["--help"]).stdout).into_owned();
    assert!(!top.contains("LLVM"), "{top}");
    let render = String::from_utf8_lossy(&penumbra(&["render", "--help"]).stdout).into_owned();
    assert!(render.contains(".gltf, .glb or .obj"), "{render}");
}

/// `--look reference` is a path tracer's raw output in one flag: radiance × 1, no environment,
/// a black background, no tonemapping (UnlitTest's orange, linear (1, 0.2176, 0), is sRGB
/// (255, 128, 0) exactly); `--background-color` sets the clear colour, linear or sRGB hex.
#[test]
fn the_reference_look_and_the_background_colour() {
    let dir = out_dir("look");
    let scene = asset("UnlitTest/UnlitTest.glb");
    let pixels = |extra: &[&str]| {
        let out = dir.join("look.png");
        let mut args = vec!["render", scene.as_str(), "--size", "64x64", "--out", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        let o = penumbra(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        let img = image::open(&out).unwrap().to_rgba8();
        [img.get_pixel(0, 0).0, img.get_pixel(16, 32).0]
    };
    let [background, orange] = pixels(&["--look", "reference"]);
    assert_eq!(background, [0, 0, 0, 255]);
    assert_eq!(orange, [255, 128, 0, 255]);
    let [background, orange] = pixels(&[]);
    assert_ne!(background, [0, 0, 0, 255], "the default look draws the environment");
    assert_ne!(orange, [255, 128, 0, 255], "the default look tonemaps");
    assert_eq!(pixels(&["--look", "reference", "--background-color", "#ff8000"])[0], [255, 128, 0, 255]);
    assert_eq!(pixels(&["--look", "reference", "--background-color", "0,0,1"])[0], [0, 0, 255, 255]);
    // Radiance like the scene's: the default look exposes and tonemaps it too.
    let tonemapped = pixels(&["--env", "none", "--background-color", "0,0,1"])[0];
    assert!(tonemapped[2] > 200 && tonemapped[2] < 255, "{tonemapped:?}");
    assert_eq!(pixels(&["--look", "reference", "--tonemap", "neutral"])[0], [0, 0, 0, 255]);
    let o = penumbra(&["render", &scene, "--out", "x.png", "--background-color", "1,2"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--background-color"), "{}", stderr(&o));
}

/// `--explain` says which view and which exposure a render used, and why (issue 47): a file
/// without a camera is framed from the raised three-quarter view, one with a camera is seen
/// through it, and a sun-lit file is metered (a 6,830 lux sun: EV100 11.7 with its sky), a
/// given exposure wins.
#[test]
fn explain_says_how_the_view_and_the_exposure_were_chosen() {
    let dir = out_dir("explain-view");
    let out = dir.join("x.png");
    let explain = |scene: &str, extra: &[&str]| {
        let mut args = vec!["render", scene, "--size", "48x48", "--explain", "--out", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        let o = penumbra(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        let line = |key: &str| {
            text.lines().find(|l| l.starts_with(key)).unwrap_or_else(|| panic!("no {key}:\n{text}")).to_owned()
        };
        (line("View: "), line("Exposure: "))
    };
    let sun = asset("Defaults/SunLit.gltf");
    let (view, exposure) = explain(&sun, &[]);
    assert_eq!(view, "View: the scene framed from yaw 35°, pitch 25° (the file has no camera)");
    assert!(exposure.starts_with("Exposure: EV100 11.") && exposure.contains("metered"), "{exposure}");
    let (view, exposure) = explain(&sun, &["--exposure", "3", "--camera", "front"]);
    assert_eq!(view, "View: the scene framed from yaw 0°, pitch 0° (--camera)");
    assert_eq!(exposure, "Exposure: EV100 3.00, given");
    let (view, exposure) = explain(&asset("Cameras/Cameras.gltf"), &[]);
    assert!(view.starts_with("View: the file's camera 0") && view.contains("the file has 2"), "{view}");
    assert!(exposure.contains("EV100 0 (the scene has no lights"), "{exposure}");
}

/// `--explain` says what the textures take on the GPU and what transcoding KTX2 / Basis
/// Universal textures to a block format saved (every Vulkan driver Penumbra targets, lavapipe
/// included, samples BC7, ASTC or ETC2; without one the textures would be RGBA8 and save nothing).
#[test]
fn explain_says_what_texture_compression_saved() {
    let dir = out_dir("explain-textures");
    let out = dir.join("x.png");
    let scene = asset("BoxTexturedKtx2/BoxTextured-uastc.gltf");
    let o = penumbra(&["render", &scene, "--size", "48x48", "--explain", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    let textures = text.lines().find(|l| l.trim_start().starts_with("textures ")).unwrap_or_else(|| panic!("{text}"));
    // 256×256 with its 9 levels: 349,524 bytes as RGBA8; 87,408 in 16-byte blocks (a quarter,
    // but the 2×2 and 1×1 levels take a whole block each).
    assert!(textures.contains("85.4 KiB"), "{textures}");
    assert!(text.contains("(textures as RGBA8 would take 341.3 KiB: block compression saves 256.0 KiB)"), "{text}");
}

/// `render A B C --out-dir DIR`: each scene's image in DIR, named after it, the same pixels as
/// rendering it alone; a scene that fails is named and the rest are still written; the exit
/// status says some failed; two scenes of one name are refused before anything renders.
#[test]
fn render_writes_many_scenes_into_a_folder() {
    let dir = out_dir("batch");
    let broken = dir.join("broken.gltf");
    std::fs::write(&broken, "{ not json").unwrap();
    let scenes = [
        asset("BoxTextured/BoxTextured.glb"),
        broken.display().to_string(),
        asset("SimpleInstancing/SimpleInstancing.glb"),
        asset("BoxTexturedKtx2/BoxTextured-uastc.gltf"),
    ];
    let images = dir.join("images");
    let mut args = vec!["render"];
    args.extend(scenes.iter().map(String::as_str));
    args.extend(["--out-dir", images.to_str().unwrap(), "--size", "64x48", "--camera", "orbit:30:20"]);
    let o = penumbra(&args);
    let (out, err) = (String::from_utf8_lossy(&o.stdout), stderr(&o));
    assert!(!o.status.success(), "one scene failed: {out}");
    assert!(err.contains("broken.gltf") && err.contains("1 of 4 scenes failed"), "{err}");
    assert!(out.contains("3 of 4 scenes rendered") && out.contains("ms per scene"), "{out}");
    for (scene, name) in
        [(&scenes[0], "BoxTextured"), (&scenes[2], "SimpleInstancing"), (&scenes[3], "BoxTextured-uastc")]
    {
        let batched = image::open(images.join(format!("{name}.png"))).unwrap().to_rgba8();
        let alone = dir.join(format!("{name}-alone.png"));
        let o = penumbra(&[
            "render",
            scene,
            "--out",
            alone.to_str().unwrap(),
            "--size",
            "64x48",
            "--camera",
            "orbit:30:20",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(batched == image::open(&alone).unwrap().to_rgba8(), "{name}: the batch drew other pixels");
    }
    assert!(!images.join("broken.png").exists());
    // Two scenes that would write one image.
    let o = penumbra(&["render", &scenes[0], &scenes[0], "--out-dir", images.to_str().unwrap()]);
    assert!(!o.status.success() && stderr(&o).contains("would both be written to"), "{}", stderr(&o));
    // --out is for one scene.
    let o = penumbra(&["render", &scenes[0], &scenes[2], "--out", "x.png"]);
    assert!(!o.status.success() && stderr(&o).contains("--out-dir"), "{}", stderr(&o));
}

/// `--raster auto` is the default, and `--explain` says where opaque draws went and the first
/// reason that decided it.
#[test]
fn explain_names_where_opaque_draws_were_rasterised_and_why() {
    let dir = out_dir("raster-why");
    let explain = |scene: &str, extra: &[&str]| {
        let out = dir.join("x.png");
        let mut args = vec!["render", scene, "--out", out.to_str().unwrap(), "--size", "64x64", "--explain"];
        args.extend(extra);
        let o = penumbra(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let boxed = asset("BoxTextured/BoxTextured.glb");
    // lavapipe is no GPU with few graphics units: auto stays on the forward pass.
    let default = explain(&boxed, &[]);
    assert!(default.contains("--raster auto: this GPU's rasteriser keeps up with its shaders"), "{default}");
    assert!(explain(&boxed, &["--raster", "hardware"]).contains("--raster hardware"));
    let compute = explain(&boxed, &["--raster", "compute"]);
    assert!(compute.contains("visibility-raster") && compute.contains("--raster compute"), "{compute}");
    // Masked and blended draws: a hybrid frame, the blended ones drawn by the forward pass over
    // the visibility buffer's samples.
    let blended = explain(&asset("AlphaBlendModeTest/AlphaBlendModeTest.glb"), &["--raster", "compute"]);
    assert!(blended.contains("VisibilityRaster:") && blended.contains("VisibilityOverlay:"), "{blended}");
    assert!(blended.contains("blended draws or gizmo lines: the forward pass draws them over"), "{blended}");
    // Transmissive draws: a hybrid frame whose shading pass runs first, into the copy they read.
    let transmissive = explain(&asset("TransmissionTest/TransmissionTest.glb"), &["--raster", "compute"]);
    let at = |name: &str| transmissive.find(name).unwrap_or_else(|| panic!("{name}: {transmissive}"));
    assert!(at("VisibilityShade: ") < at("Transmission: ") && at("Transmission: ") < at("VisibilityOverlay: "));
    assert!(transmissive.contains("into the transmission copy's level 0"), "{transmissive}");
    let ran = |line: &str| line.trim_start().split_once(". ").is_some_and(|(n, _)| n.parse::<u32>().is_ok());
    assert!(!transmissive.lines().any(|l| ran(l) && l.contains(". Opaque: ")), "{transmissive}");
}
