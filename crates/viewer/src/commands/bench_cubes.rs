//! `penumbra bench many-cubes`: the many-cubes scene of `notes/bench-scenes.md` for each cube
//! count in `--count` and each moving fraction in `--moving`. Per row, medians over the timed
//! frames of the CPU time split by stage (main world: user systems and transform propagation;
//! extract; prepare, encode and submit in the renderer), GPU time from timestamp queries, the
//! instance bytes uploaded and the draw calls issued. Frames are pipelined (at most two in
//! flight, no readback), as interactive rendering runs.

use std::collections::VecDeque;
use std::time::Instant;

use anyhow::{Result, anyhow};
use bevy_ecs::schedule::ScheduleLabel;
use penumbra_engine::scenes::{BENCH_EV100, CubeLayout, spawn_many_cubes, spin_cubes};
use penumbra_render::{AdapterRequest, Extract, GpuContext, RenderOutput, RenderPlugin, RenderSettings, Renderer};

use super::bench::{bound_frames_in_flight, percentile};
use crate::cli::{BenchArgs, LayoutArg};

#[derive(Default)]
struct Samples {
    main: Vec<f64>,
    extract: Vec<f64>,
    prepare: Vec<f64>,
    upload: Vec<f64>,
    encode: Vec<f64>,
    submit: Vec<f64>,
    cpu: Vec<f64>,
    wall: Vec<f64>,
    gpu: Vec<f64>,
    gpu_cull: Vec<f64>,
    gpu_cull_late: Vec<f64>,
    gpu_hzb: Vec<f64>,
    gpu_forward_late: Vec<f64>,
    gpu_forward: Vec<f64>,
    gpu_tonemap: Vec<f64>,
    instance_bytes: Vec<f64>,
}

struct Row {
    count: usize,
    moving: f64,
    median: [f64; 16],
    draw_calls: u32,
    instances: u32,
    /// After GPU culling, in the last frame (`None`: not culled).
    visible: Option<u32>,
    instances_mib: f64,
}

pub fn run(args: &BenchArgs) -> Result<()> {
    if args.frames == 0 {
        return Err(anyhow!("--frames must be at least 1"));
    }
    if args.count.is_empty() || args.moving.is_empty() {
        return Err(anyhow!("--count and --moving: give at least one value each"));
    }
    let layout = match args.layout {
        LayoutArg::Grid => CubeLayout::Grid,
        LayoutArg::Sphere => CubeLayout::Sphere,
    };
    let settings = RenderSettings { gpu_timing: true, ..args.look.render_settings(false, None)? };
    let ctx = GpuContext::new_headless(&AdapterRequest::default())?;
    let mut rows = Vec::new();
    for &count in &args.count {
        for &moving in &args.moving {
            let mut app = penumbra_engine::App::new();
            app.add_plugins(penumbra_engine::CorePlugin).add_plugins(RenderPlugin);
            app.add_systems(penumbra_engine::Update, spin_cubes);
            spawn_many_cubes(&mut app.world, count, layout, moving);
            app.insert_resource(Renderer::new(ctx.clone(), settings.clone())?);
            app.insert_resource(RenderOutput::Headless { width: args.size.0, height: args.size.1 });
            let s = time_frames(&mut app, args.warmup, args.frames);
            let renderer = app.world.resource::<Renderer>();
            let stats = renderer.stats();
            let med = |v: &[f64]| if v.is_empty() { f64::NAN } else { percentile(v, 0.5) };
            rows.push(Row {
                count,
                moving,
                median: [
                    med(&s.main),
                    med(&s.extract),
                    med(&s.prepare),
                    med(&s.encode),
                    med(&s.submit),
                    med(&s.cpu),
                    med(&s.wall),
                    med(&s.gpu),
                    med(&s.instance_bytes),
                    med(&s.gpu_cull),
                    med(&s.gpu_forward),
                    med(&s.gpu_tonemap),
                    med(&s.upload),
                    med(&s.gpu_hzb),
                    med(&s.gpu_cull_late),
                    med(&s.gpu_forward_late),
                ],
                draw_calls: stats.draw_calls,
                instances: stats.instances,
                visible: renderer.visible_instance_counts()?.map(|c| c.iter().sum()),
                instances_mib: renderer.memory().instances as f64 / 1048576.0,
            });
        }
    }
    println!("adapter   {}", ctx.describe());
    println!(
        "scene     many-cubes (notes/bench-scenes.md), {:?} layout: one shared 1 m cube mesh and material, a 10 000 lux sun without shadows, ambient 200 cd/m²",
        layout
    );
    println!(
        "settings  {}x{}, MSAA {}, GPU culling {}, occlusion culling {:?}, tonemap {:?} (for Bevy's TonyMcMapface), EV100 {BENCH_EV100}, {} warm-up + {} timed frames, at most 2 in flight",
        args.size.0,
        args.size.1,
        settings.msaa,
        if settings.gpu_culling { "on" } else { "off" },
        settings.occlusion_culling,
        settings.tonemapper,
        args.warmup,
        args.frames
    );
    println!();
    println!(
        "| cubes | moving | CPU main world (ms) | CPU extract (ms) | CPU prepare (ms) (of which instance upload) | CPU encode (ms) | CPU submit (ms) | CPU frame (ms) | GPU cull / forward / depth pyramid / cull late / forward late / tonemap (ms) | GPU frame (ms) | frame, wall (ms) | instance bytes uploaded | draw calls | instances submitted | after GPU culling | GPU MiB instances and draw lists |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &rows {
        let [
            main,
            extract,
            prepare,
            encode,
            submit,
            cpu,
            wall,
            gpu,
            bytes,
            cull,
            forward,
            tonemap,
            upload,
            hzb,
            cull_late,
            forward_late,
        ] = r.median;
        let ms = |v: f64| if v.is_nan() { "-".to_owned() } else { format!("{v:.3}") };
        let passes = format!(
            "{} / {} / {} / {} / {} / {}",
            ms(cull),
            ms(forward),
            ms(hzb),
            ms(cull_late),
            ms(forward_late),
            ms(tonemap)
        );
        let gpu = ms(gpu);
        println!(
            "| {} | {} | {main:.3} | {extract:.3} | {prepare:.3} ({upload:.3}) | {encode:.3} | {submit:.3} | {cpu:.3} | {passes} | {gpu} | {wall:.3} | {bytes:.0} | {} | {} | {} | {:.1} |",
            r.count,
            r.moving,
            r.draw_calls,
            r.instances,
            r.visible.map_or("not culled".to_owned(), |v| v.to_string()),
            r.instances_mib
        );
    }
    Ok(())
}

/// Warm-up frames unpipelined, then timed frames with at most two in flight; every sample
/// vector sorted ascending.
fn time_frames(app: &mut penumbra_engine::App, warmup: u32, frames: u32) -> Samples {
    for _ in 0..warmup {
        app.update();
        bound_frames_in_flight(app, &mut VecDeque::new(), 0);
    }
    let (extract, render) = (Extract.intern(), penumbra_render::Render.intern());
    let mut s = Samples::default();
    let mut in_flight = VecDeque::new();
    let mut last_gpu_frame = 0;
    let mut last = Instant::now();
    for _ in 0..frames {
        let stages = app.update_timed();
        let stage = |label| stages.iter().filter(|(l, _)| *l == label).map(|(_, ms)| ms).sum::<f64>();
        let main: f64 = stages.iter().filter(|(l, _)| *l != extract && *l != render).map(|(_, ms)| ms).sum();
        bound_frames_in_flight(app, &mut in_flight, 2);
        let now = Instant::now();
        s.wall.push((now - last).as_secs_f64() * 1e3);
        last = now;
        let stats = app.world.resource::<Renderer>().stats();
        s.main.push(main);
        s.extract.push(stage(extract));
        s.prepare.push(stats.prepare_ms);
        s.upload.push(stats.instance_upload_ms);
        s.encode.push(stats.cpu_ms - stats.prepare_ms);
        s.submit.push(stats.submit_ms);
        s.cpu.push(main + stage(extract) + stats.cpu_ms + stats.submit_ms);
        s.instance_bytes.push(stats.instance_bytes_uploaded as f64);
        if let Some(t) = stats.gpu.as_ref().filter(|t| t.frame > last_gpu_frame) {
            last_gpu_frame = t.frame;
            s.gpu.push(t.passes.iter().map(|(_, ms)| ms).sum());
            for (label, v) in [
                ("cull", &mut s.gpu_cull),
                ("cull late", &mut s.gpu_cull_late),
                ("depth pyramid", &mut s.gpu_hzb),
                ("forward late", &mut s.gpu_forward_late),
                ("forward", &mut s.gpu_forward),
                ("tonemap", &mut s.gpu_tonemap),
            ] {
                if let Some((_, ms)) = t.passes.iter().find(|(l, _)| *l == label) {
                    v.push(*ms);
                }
            }
        }
    }
    app.world.resource_mut::<Renderer>().finish();
    for v in [
        &mut s.main,
        &mut s.extract,
        &mut s.prepare,
        &mut s.encode,
        &mut s.submit,
        &mut s.cpu,
        &mut s.wall,
        &mut s.gpu,
        &mut s.instance_bytes,
        &mut s.gpu_cull,
        &mut s.gpu_forward,
        &mut s.gpu_tonemap,
        &mut s.upload,
        &mut s.gpu_hzb,
        &mut s.gpu_cull_late,
        &mut s.gpu_forward_late,
    ] {
        v.sort_by(f64::total_cmp);
    }
    s
}
