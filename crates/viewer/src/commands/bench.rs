//! `penumbra bench`: how long a scene takes to load and to draw. Prints one table: load to first
//! frame (wall), then per frame: wall time, CPU time (extract, prepare and encode on this thread)
//! and GPU time per pass from timestamp queries, as median and 90th percentile over the timed
//! frames, and the GPU memory of the main pools. Frames are pipelined with at most two in flight
//! and no readback, as interactive rendering runs (and as the Bevy figures the benchmark scenes
//! are compared with were taken).

use std::time::Instant;

use anyhow::{Result, anyhow};
use bevy_ecs::prelude::{Component, Query, With};
use glam::{Quat, Vec3};
use penumbra_engine::components::{DirectionalLight, Transform};
use penumbra_engine::environment::{EnvironmentSource, Sky};
use penumbra_render::headless::{ShotSettings, stage_scene};
use penumbra_render::{RenderOutput, RenderSettings, Renderer};

use super::bench_measure::{percentile, time_frames};
use crate::cli::BenchArgs;
use crate::scene;

pub fn run(args: BenchArgs) -> Result<()> {
    if args.shader_edits > 0 {
        return super::bench_reload::run(&args);
    }
    if args.path.as_deref().is_some_and(|p| p == std::path::Path::new("many-lights") && !p.exists()) {
        return super::bench_lights::run(&args);
    }
    if args.path.as_deref().is_some_and(|p| p == std::path::Path::new("many-cubes") && !p.exists()) {
        return super::bench_cubes::run(&args);
    }
    if args.path.as_deref().is_some_and(|p| p == std::path::Path::new("characters") && !p.exists()) {
        return super::bench_characters::run(&args);
    }
    if args.path.as_deref().is_some_and(|p| p == std::path::Path::new("shadows") && !p.exists()) {
        return super::bench_shadows::run(&args);
    }
    if args.path.as_deref().is_some_and(|p| p == std::path::Path::new("soak") && !p.exists()) {
        return super::bench_soak::run(&args);
    }
    let settings = RenderSettings { gpu_timing: true, ..args.look.render_settings(false, None)? };
    let environment = args.look.environment()?;
    let shot = ShotSettings {
        size: Some(args.size),
        exposure_ev100: args.look.exposure_ev100(),
        variant: args.scene_args.variant.clone(),
        environment: environment.clone().filter(|_| !args.env_churn),
        ..Default::default()
    };
    shot.validate()?;
    if args.frames == 0 {
        return Err(anyhow!("--frames must be at least 1"));
    }

    // Loaded as `render` loads: the device, renderer and pipelines on one thread while the scene
    // is read on this one, so the load time is what a user waits for.
    let start = Instant::now();
    let step = move |what: &str| tracing::info!("{:>7.1} ms  {what}", start.elapsed().as_secs_f64() * 1e3);
    let gpu = super::render::spawn_renderer(settings.clone(), environment.is_some(), step);
    let staged = scene::load(args.path.as_deref(), &args.scene_args)
        .map_err(anyhow::Error::from)
        .and_then(|scene| Ok(stage_scene(&scene, &shot)?));
    // Joined before any error returns (see `render`).
    let renderer = gpu.join().map_err(|_| anyhow!("the GPU setup thread panicked"))?;
    let (mut app, size) = staged?;
    let renderer = renderer?;
    let ctx = renderer.context();
    let adapter = ctx.describe();
    let timestamps = ctx.caps.timestamps;
    let cpu_adapter = ctx.info.device_type == wgpu::DeviceType::Cpu;
    let env_label = match &environment {
        None => "none".to_owned(),
        Some(_) if args.env_churn => "sky, sun turning 1° a frame (prefiltered every frame)".to_owned(),
        Some(_) => {
            format!("--env {}, {}² faces", args.look.env_name(), settings.environment.cube_size_for(cpu_adapter))
        }
    };
    if let Some(mut env) = environment {
        if args.env_churn {
            env.source = EnvironmentSource::Sky(Sky::default());
            app.world.spawn((
                DirectionalLight { illuminance: 3.0, shadows: false, ..Default::default() },
                Transform::IDENTITY.looking_at(Vec3::new(-1.0, -0.6, -0.4), Vec3::Y),
                ChurnSun,
            ));
            app.add_systems(penumbra_engine::Update, turn_sun);
        }
        app.insert_resource(env);
    }
    app.insert_resource(renderer);
    app.insert_resource(RenderOutput::Headless { width: size.0, height: size.1 });
    app.update();
    // The first frame is done when its pixels could be read.
    app.world.resource::<Renderer>().read_frame().map_err(|e| anyhow!("{e}"))?;
    let first_frame_ms = start.elapsed().as_secs_f64() * 1e3;

    let t = time_frames(&mut app, args.warmup, args.frames);
    let (wall, cpu, gpu_total, gpu_span, passes) = (t.wall, t.cpu, t.gpu_total, t.gpu_span, t.passes);
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
    println!("env       {env_label} ({} prefilter runs)", stats.environment_prefilters);
    println!();
    println!("| measure | median | p90 |");
    println!("|---|---:|---:|");
    println!("| load to first frame (ms, wall) | {first_frame_ms:.1} | |");
    println!("| frame, wall (ms) | {:.3} | {:.3} |", percentile(&wall, 0.5), percentile(&wall, 0.9));
    println!("| CPU per frame (ms) | {:.3} | {:.3} |", percentile(&cpu, 0.5), percentile(&cpu, 0.9));
    if timestamps && !gpu_total.is_empty() {
        println!("| GPU per frame (ms) | {:.3} | {:.3} |", percentile(&gpu_total, 0.5), percentile(&gpu_total, 0.9));
        // What `report` times: the passes and whatever lies between them.
        println!(
            "| GPU frame span, first pass start to last pass end (ms) | {:.3} | {:.3} |",
            percentile(&gpu_span, 0.5),
            percentile(&gpu_span, 0.9)
        );
        for (label, v) in &passes {
            println!("| GPU {label} pass (ms) | {:.3} | {:.3} |", percentile(v, 0.5), percentile(v, 0.9));
        }
    } else {
        println!("| GPU per frame (ms) | n/a (adapter has no timestamp queries) | |");
    }
    println!(
        "| GPU memory (MiB): mesh pool / textures / instances / targets / environment | {:.1} / {:.1} / {:.2} / {:.1} / {:.1} | |",
        mib(mem.mesh_pool),
        mib(mem.textures),
        mib(mem.instances),
        mib(mem.targets),
        mib(mem.environment)
    );
    println!("| GPU memory, all pools (MiB) | {:.1} | |", mib(mem.total()));
    // The process's peak: loading included (the decoded images with their chains).
    match penumbra_viewer::soak::peak_resident_bytes() {
        Some(peak) => println!("| host memory, peak resident (MiB) | {:.0} | |", mib(peak)),
        None => println!("| host memory, peak resident (MiB) | n/a (no /proc/self/status) | |"),
    }
    Ok(())
}

/// The sun `--env-churn` adds and turns.
#[derive(Component)]
struct ChurnSun;

/// Turns the sun 1° about +Y each frame: the sky's maps are remade every frame.
fn turn_sun(mut suns: Query<&mut Transform, With<ChurnSun>>) {
    for mut t in &mut suns {
        t.rotation = Quat::from_rotation_y(1f32.to_radians()) * t.rotation;
    }
}
