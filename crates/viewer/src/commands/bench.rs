//! `penumbra bench`: how long a scene takes to load and to draw. Prints one table: load to first
//! frame (wall), then per frame: wall time, CPU time (extract, prepare and encode on this thread)
//! and GPU time per pass from timestamp queries, as median and 90th percentile over the timed
//! frames, and the GPU memory of the main pools. Frames are pipelined with at most two in flight
//! and no readback, as interactive rendering runs (and as Bevy's numbers in
//! shared/notes/bench-scenes.md were taken).

use std::collections::VecDeque;
use std::time::Instant;

use anyhow::{Result, anyhow};
use bevy_ecs::prelude::{Component, Query, With};
use bevy_ecs::schedule::ScheduleLabel;
use glam::{Quat, Vec3};
use penumbra_engine::components::{DirectionalLight, Transform};
use penumbra_engine::environment::{EnvironmentSource, Sky};
use penumbra_render::headless::{ShotSettings, stage_scene};
use penumbra_render::{AdapterRequest, GpuContext, RenderOutput, RenderSettings, Renderer};

use crate::cli::BenchArgs;
use crate::scene;

/// Keeps at most `max` frames in flight by waiting for the oldest submission.
pub fn bound_frames_in_flight(
    app: &mut penumbra_engine::App,
    in_flight: &mut VecDeque<wgpu::SubmissionIndex>,
    max: usize,
) {
    let renderer = app.world.resource::<Renderer>();
    if let Some(s) = renderer.last_submission() {
        in_flight.push_back(s.clone());
    }
    while in_flight.len() > max {
        let oldest = in_flight.pop_front().expect("non-empty");
        let _ = renderer.context().device.poll(wgpu::PollType::Wait { submission_index: Some(oldest), timeout: None });
    }
    if max == 0 {
        let _ = renderer.context().device.poll(wgpu::PollType::wait_indefinitely());
    }
}

/// Per-frame timings over the timed frames, in frame order.
pub struct FrameTimes {
    pub wall: Vec<f64>,
    pub cpu: Vec<f64>,
    /// `app.update()` on this thread: extraction, prepare and encode (not the GPU wait).
    pub update: Vec<f64>,
    pub gpu_total: Vec<f64>,
    /// First pass's beginning to last pass's end, per frame (see `FrameTimings::span_ms`).
    pub gpu_span: Vec<f64>,
    pub passes: Vec<(&'static str, Vec<f64>)>,
    /// The CPU frame split: the main world's stages (user systems, propagation), extraction,
    /// the renderer's prepare (and of it the instance upload), encode and submit.
    pub main: Vec<f64>,
    pub extract: Vec<f64>,
    pub prepare: Vec<f64>,
    pub instance_upload: Vec<f64>,
    pub submit: Vec<f64>,
    pub instance_bytes: Vec<f64>,
}

impl FrameTimes {
    pub fn pass(&self, label: &str) -> Option<&[f64]> {
        self.passes.iter().find(|(l, _)| *l == label).map(|(_, v)| v.as_slice())
    }

    /// Every stage of the CPU frame on this thread: main world, extraction, prepare and encode,
    /// and submission.
    pub fn cpu_frame(&self, i: usize) -> f64 {
        self.main[i] + self.extract[i] + self.cpu[i] + self.submit[i]
    }
}

/// Runs `warmup` unpipelined frames, then `frames` pipelined ones (at most two in flight).
pub fn time_frames(app: &mut penumbra_engine::App, warmup: u32, frames: u32) -> FrameTimes {
    for _ in 0..warmup {
        app.update();
        bound_frames_in_flight(app, &mut VecDeque::new(), 0);
    }
    let mut in_flight = VecDeque::new();
    let mut wall = Vec::new();
    let mut cpu = Vec::new();
    let mut update = Vec::new();
    let mut gpu_total = Vec::new();
    let mut gpu_span = Vec::new();
    let mut passes: Vec<(&'static str, Vec<f64>)> = Vec::new();
    let (mut main, mut extract, mut prepare, mut instance_upload, mut submit, mut instance_bytes) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (extract_stage, render_stage) = (penumbra_render::Extract.intern(), penumbra_render::Render.intern());
    let mut last_gpu_frame = 0;
    let mut record_gpu = |stats: &penumbra_render::FrameStats, gpu_total: &mut Vec<f64>, gpu_span: &mut Vec<f64>| {
        let Some(t) = stats.gpu.as_ref().filter(|t| t.frame > last_gpu_frame) else { return };
        last_gpu_frame = t.frame;
        gpu_total.push(t.passes.iter().map(|(_, ms)| ms).sum());
        gpu_span.push(t.span_ms);
        for (label, ms) in &t.passes {
            match passes.iter_mut().find(|(l, _)| l == label) {
                Some((_, v)) => v.push(*ms),
                None => passes.push((label, vec![*ms])),
            }
        }
    };
    let mut last = Instant::now();
    for _ in 0..frames {
        let t = Instant::now();
        let stages = app.update_timed();
        update.push(t.elapsed().as_secs_f64() * 1e3);
        let stage = |pick: &dyn Fn(bool, bool) -> bool| -> f64 {
            stages.iter().filter(|(l, _)| pick(*l == extract_stage, *l == render_stage)).map(|(_, ms)| ms).sum()
        };
        main.push(stage(&|e, r| !e && !r));
        extract.push(stage(&|e, _| e));
        bound_frames_in_flight(app, &mut in_flight, 2);
        let now = Instant::now();
        wall.push((now - last).as_secs_f64() * 1e3);
        last = now;
        let stats = app.world.resource::<Renderer>().stats().clone();
        cpu.push(stats.cpu_ms);
        prepare.push(stats.prepare_ms);
        instance_upload.push(stats.instance_upload_ms);
        submit.push(stats.submit_ms);
        instance_bytes.push(stats.instance_bytes_uploaded as f64);
        record_gpu(&stats, &mut gpu_total, &mut gpu_span);
    }
    app.world.resource_mut::<Renderer>().finish();
    let stats = app.world.resource::<Renderer>().stats().clone();
    record_gpu(&stats, &mut gpu_total, &mut gpu_span);
    // Unsorted, in frame order, so that samples of one frame can be summed (`cpu_frame`);
    // `percentile` sorts what it is given.
    FrameTimes {
        wall,
        cpu,
        update,
        gpu_total,
        gpu_span,
        passes,
        main,
        extract,
        prepare,
        instance_upload,
        submit,
        instance_bytes,
    }
}

/// Settings for the scenes of notes/bench-scenes.md (`many-cubes`, `many-lights`): GPU timing;
/// display colours resolved unless `--msaa-resolve` says otherwise, since the recipe draws
/// without an HDR target; and opaque draws rasterised where they run fastest unless `--raster`
/// says otherwise (`Raster::Auto`: in compute on the H100 and H200).
pub fn recipe_settings(args: &BenchArgs) -> Result<RenderSettings> {
    let mut settings = RenderSettings { gpu_timing: true, ..args.look.render_settings(false, None)? };
    if args.look.msaa_resolve.is_none() {
        settings.msaa_resolve = penumbra_render::MsaaResolve::Display;
    }
    if args.look.raster.is_none() {
        settings.raster = penumbra_render::renderer::Raster::Auto;
    }
    Ok(settings)
}

/// The `p` quantile (0..=1) of `samples`, in any order; NaN when there are none.
pub fn percentile(samples: &[f64], p: f64) -> f64 {
    if samples.is_empty() {
        return f64::NAN;
    }
    let mut sorted = samples.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

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
    let shot = ShotSettings { size: Some(args.size), exposure_ev100: args.look.exposure, ..Default::default() };
    shot.validate()?;
    if args.frames == 0 {
        return Err(anyhow!("--frames must be at least 1"));
    }

    let start = Instant::now();
    let ctx = GpuContext::new_headless(&AdapterRequest::default())?;
    let adapter = ctx.describe();
    let timestamps = ctx.caps.timestamps;
    let cpu_adapter = ctx.info.device_type == wgpu::DeviceType::Cpu;
    let renderer = Renderer::new(ctx, settings.clone())?;
    let scene = scene::load(args.path.as_deref(), &args.scene_args)?;
    let (mut app, size) = stage_scene(&scene, &shot)?;
    let environment = args.look.environment()?;
    let env_label = match &environment {
        None => "none".to_owned(),
        Some(_) if args.env_churn => "sky, sun turning 1° a frame (prefiltered every frame)".to_owned(),
        Some(_) => format!("--env {}, {}² faces", args.look.env, settings.environment.cube_size_for(cpu_adapter)),
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
    let (wall, cpu, gpu_total, passes) = (t.wall, t.cpu, t.gpu_total, t.passes);
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
