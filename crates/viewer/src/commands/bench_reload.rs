//! `penumbra bench --shader-edits N`: hot-reload latency. Copies the shaders to a temporary
//! folder, renders the scene continuously with that folder watched, and every 400 ms rewrites
//! forward.wgsl with a different constant (so no driver cache can serve the new pipeline). Each
//! edit is timed from just before the file write to the end of the first frame drawn with the new
//! shader (GPU work included). Prints median and maximum, and that time in two parts: until the
//! frame with the rebuilt pipelines is submitted (the watcher, composing, validating and creating
//! the pipelines, on the CPU), and from there until the device has drawn it (the driver's shader
//! compile, which CPU rasterisers such as lavapipe do at the first draw, and the frame itself).
//! The scene is lit as `penumbra view` lights it (`--env`, default `auto`), so the variant edited
//! is the one a viewer compiles. With `--shader-dir DIR` the copy is made from DIR's files (the
//! embedded ones fill in what DIR lacks), to measure edited shaders. Before and after the edits
//! it times a fixed single-threaded compiler workload (see [`speed_reference_ms`]), so that each
//! result says how fast the machine was while it was taken.

use std::time::{Duration, Instant};

use anyhow::{Result, anyhow, bail};
use penumbra_render::headless::{ShotSettings, stage_scene};
use penumbra_render::pipelines::shader_library::{EMBEDDED, ShaderDefs, ShaderLibrary};
use penumbra_render::{AdapterRequest, GpuContext, RenderOutput, Renderer, ShaderSource};

use super::bench_measure::percentile;
use crate::cli::BenchArgs;
use crate::scene;

pub fn run(args: &BenchArgs) -> Result<()> {
    // The environment `penumbra view` would show (`--env auto`: the studio gradient for a scene
    // without one); read before the temporary folder exists, so a bad `--env` leaves nothing.
    let environment = args.look.environment()?;
    let dir = std::env::temp_dir().join(format!("penumbra-reload-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let mut original = String::new();
    for (file, embedded) in EMBEDDED {
        let source = match &args.look.shader_dir {
            Some(from) if from.join(file).exists() => {
                std::fs::read_to_string(from.join(file)).map_err(|e| anyhow!("{}: {e}", from.join(file).display()))?
            }
            _ => embedded.to_string(),
        };
        std::fs::write(dir.join(file), &source)?;
        if *file == "forward.wgsl" {
            original = source;
        }
    }
    let anchor = "var out = color * view.exposure;";
    if !original.contains(anchor) {
        bail!("forward.wgsl no longer contains `{anchor}`; update the reload benchmark's edit");
    }
    let mut settings = args.look.render_settings(true, None)?;
    settings.shaders = ShaderSource::Folder { dir: dir.clone(), watch: true };
    let ctx = GpuContext::new_headless(&AdapterRequest::default())?;
    let adapter = ctx.describe();
    let renderer = Renderer::new(ctx, settings.clone())?;
    let scene = scene::load(args.path.as_deref(), &args.scene_args)?;
    let shot = ShotSettings {
        size: Some(args.size),
        exposure_ev100: args.look.exposure_ev100(),
        variant: args.scene_args.variant.clone(),
        environment: environment.clone(),
        ..Default::default()
    };
    let (mut app, size) = stage_scene(&scene, &shot)?;
    let env_label = environment.as_ref().map_or("none".to_owned(), |_| format!("--env {}", args.look.env_name()));
    app.insert_resource(renderer);
    app.insert_resource(RenderOutput::Headless { width: size.0, height: size.1 });
    // The shader generation the frame drew with, and when it was submitted.
    let frame = |app: &mut penumbra_engine::App| {
        app.update();
        let submitted = Instant::now();
        let r = app.world.resource::<Renderer>();
        let _ = r.context().device.poll(wgpu::PollType::wait_indefinitely());
        (r.stats().shader_generation, submitted)
    };
    frame(&mut app);
    // A folder whose shaders do not build would time reloads of nothing (no pipeline to rebuild).
    if let Some(e) = app.world.resource::<Renderer>().shader_error() {
        bail!("the shaders to edit do not build: {e}");
    }

    // Each edit a new constant, different from every earlier run's too (the driver's on-disk
    // cache outlives the process): the new pipeline cannot come from any cache. Steps of 1e-7
    // stay distinct in f32 near 1.
    let nonce =
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs() % 50_000) * 20;
    let reference_before = speed_reference_ms()?;
    let mut latencies = Vec::new();
    let mut submitted_after = Vec::new();
    for edit in 1..=args.shader_edits {
        let k = 1.0 - (nonce + edit as u64) as f64 * 1e-7;
        let source = original.replacen(anchor, &format!("var out = color * view.exposure * {k:.7};"), 1);
        let (before, _) = frame(&mut app);
        let start = Instant::now();
        std::fs::write(dir.join("forward.wgsl"), source)?;
        loop {
            let (generation, submitted) = frame(&mut app);
            let reloaded = generation > before;
            if let Some(e) = app.world.resource::<Renderer>().shader_error() {
                bail!("edit {edit} did not compile: {e}");
            }
            if reloaded {
                submitted_after.push((submitted - start).as_secs_f64() * 1e3);
                break;
            }
            if start.elapsed() > Duration::from_secs(30) {
                return Err(anyhow!("edit {edit}: no reload within 30 s"));
            }
        }
        latencies.push(start.elapsed().as_secs_f64() * 1e3);
        std::thread::sleep(Duration::from_millis(400));
    }
    let reference_after = speed_reference_ms()?;
    let _ = std::fs::remove_dir_all(&dir);
    let on_device: Vec<f64> = latencies.iter().zip(&submitted_after).map(|(total, cpu)| total - cpu).collect();
    println!("adapter   {adapter}");
    println!(
        "scene     {}",
        args.path.as_ref().map_or("<embedded>/DamagedHelmet.glb".into(), |p| p.display().to_string())
    );
    println!("settings  {}x{}, MSAA {}, {} edits of forward.wgsl", size.0, size.1, settings.msaa, latencies.len());
    println!("env       {env_label}");
    println!(
        "speed     composing the embedded forward.wgsl (lit, textured variant) took {reference_before:.2} ms before \
         the edits and {reference_after:.2} ms after (median of 9; the machine's single-thread speed)"
    );
    println!();
    println!("| measure | median | max |");
    println!("|---|---:|---:|");
    for (measure, values) in [
        ("file write to first frame with the new shader (ms)", &latencies),
        ("of which: until that frame is submitted, rebuilt pipelines and all (ms)", &submitted_after),
        ("of which: from submission until the device has drawn it, driver compile included (ms)", &on_device),
    ] {
        println!("| {measure} | {:.1} | {:.1} |", percentile(values, 0.5), percentile(values, 1.0));
    }
    Ok(())
}

/// The machine's single-thread speed, in the milliseconds one compose of the embedded forward.wgsl
/// takes (its lit variant with every material texture and image-based lighting; modules already
/// parsed, as on a reload): a compiler's work, like the LLVM code generation that dominates a
/// reload on a CPU rasteriser. A shared machine's speed drifts (docs/shaders.md, "Reload
/// latency"), and this tells which phase a latency was measured in. Fixed input, so it does not
/// depend on the scene, the folder or the edits.
fn speed_reference_ms() -> Result<f64> {
    let defs = ["BASE_COLOR_TEXTURE", "METALLIC_ROUGHNESS_TEXTURE", "NORMAL_MAP", "EMISSIVE_TEXTURE", "IBL"]
        .into_iter()
        .fold(ShaderDefs::default(), |defs, def| defs.with(def, true));
    let mut library = ShaderLibrary::embedded()?;
    // The first compose parses and derives the imported modules; a reload's finds them done.
    library.compose("forward.wgsl", &defs)?;
    let times: Vec<f64> = (0..9)
        .map(|_| {
            let start = Instant::now();
            library.compose("forward.wgsl", &defs).map(|_| start.elapsed().as_secs_f64() * 1e3)
        })
        .collect::<Result<_, _>>()?;
    Ok(percentile(&times, 0.5))
}
