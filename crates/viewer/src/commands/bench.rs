//! `penumbra bench`: how long a scene takes to load and to draw. Prints one table: load to first
//! frame (wall), then per-frame CPU time (prepare and encode, on this thread) and GPU time per
//! pass from timestamp queries, as median and 90th percentile over the timed frames, and the GPU
//! memory of the main pools. Each timed frame waits for the GPU, so frames do not overlap.

use std::time::Instant;

use anyhow::{Result, anyhow};
use penumbra_render::headless::{ShotSettings, stage_scene};
use penumbra_render::{AdapterRequest, GpuContext, RenderOutput, RenderSettings, Renderer};

use crate::cli::BenchArgs;
use crate::scene;

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

pub fn run(args: BenchArgs) -> Result<()> {
    let settings = RenderSettings {
        msaa: args.look.msaa,
        tonemapper: args.look.tonemap.into(),
        gpu_timing: true,
        ..Default::default()
    };
    settings.validate().map_err(|e| anyhow!("--msaa: {e}"))?;
    let shot = ShotSettings { size: Some(args.size), exposure_ev100: args.look.exposure, ..Default::default() };
    shot.validate()?;
    if args.frames == 0 {
        return Err(anyhow!("--frames must be at least 1"));
    }

    let start = Instant::now();
    let ctx = GpuContext::new_headless(&AdapterRequest::default())?;
    let adapter = ctx.describe();
    let timestamps = ctx.caps.timestamps;
    let renderer = Renderer::new(ctx, settings.clone())?;
    let scene = scene::load(args.path.as_deref(), &args.scene_args)?;
    let (mut app, size) = stage_scene(&scene, &shot)?;
    app.insert_resource(renderer);
    app.insert_resource(RenderOutput::Headless { width: size.0, height: size.1 });
    app.update();
    // The first frame is done when its pixels could be read.
    app.world.resource::<Renderer>().read_headless().map_err(|e| anyhow!("{e}"))?;
    let first_frame_ms = start.elapsed().as_secs_f64() * 1e3;

    for _ in 0..args.warmup {
        app.update();
    }
    let mut cpu = Vec::new();
    let mut gpu_total = Vec::new();
    let mut passes: Vec<(&'static str, Vec<f64>)> = Vec::new();
    for _ in 0..args.frames {
        app.update();
        let stats = app.world.resource::<Renderer>().stats().clone();
        cpu.push(stats.cpu_ms);
        gpu_total.push(stats.gpu_total_ms());
        for (label, ms) in &stats.gpu_ms {
            match passes.iter_mut().find(|(l, _)| l == label) {
                Some((_, v)) => v.push(*ms),
                None => passes.push((label, vec![*ms])),
            }
        }
    }
    for v in [&mut cpu, &mut gpu_total].into_iter().chain(passes.iter_mut().map(|(_, v)| v)) {
        v.sort_by(f64::total_cmp);
    }
    let renderer = app.world.resource::<Renderer>();
    let stats = renderer.stats();
    let mem = renderer.memory();
    let name =
        args.path.as_ref().map_or_else(|| "<embedded>/DamagedHelmet.glb".to_owned(), |p| p.display().to_string());
    let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
    println!("adapter   {adapter}");
    println!("scene     {name}");
    println!(
        "settings  {}x{}, MSAA {}, tonemap {:?}, {} warm-up + {} timed frames",
        size.0, size.1, settings.msaa, settings.tonemapper, args.warmup, args.frames
    );
    println!(
        "draws     {} draw calls, {} instances, {} triangles",
        stats.draw_calls, stats.instances, stats.primitives
    );
    println!();
    println!("| measure | median | p90 |");
    println!("|---|---:|---:|");
    println!("| load to first frame (ms, wall) | {first_frame_ms:.1} | |");
    println!("| CPU per frame (ms) | {:.3} | {:.3} |", percentile(&cpu, 0.5), percentile(&cpu, 0.9));
    if timestamps {
        println!("| GPU per frame (ms) | {:.3} | {:.3} |", percentile(&gpu_total, 0.5), percentile(&gpu_total, 0.9));
        for (label, v) in &passes {
            println!("| GPU {label} pass (ms) | {:.3} | {:.3} |", percentile(v, 0.5), percentile(v, 0.9));
        }
    } else {
        println!("| GPU per frame (ms) | n/a (adapter has no timestamp queries) | |");
    }
    println!(
        "| GPU memory (MiB): mesh pool / textures / instances / targets | {:.1} / {:.1} / {:.2} / {:.1} | |",
        mib(mem.mesh_pool),
        mib(mem.textures),
        mib(mem.instances),
        mib(mem.targets)
    );
    Ok(())
}
