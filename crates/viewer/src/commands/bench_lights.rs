//! `penumbra bench many-lights`: the many-lights benchmark scene (crates/engine/src/scenes.rs) at
//! each light count in `--lights`. Per count: GPU time of the binning passes and of shading, CPU
//! time per frame, light and cluster statistics, and the image error of the range window (FLIP
//! mean of the clustered image against the same frame with unbounded lights, at `--error-size`).

use anyhow::{Result, anyhow};
use penumbra_engine::scenes::{BENCH_EV100, spawn_many_lights};
use penumbra_render::LightWalk;
use penumbra_render::{AdapterRequest, GpuContext, RenderOutput, RenderPlugin, RenderSettings, Renderer};

use super::bench_measure::{flip_mean, percentile, recipe_settings, time_frames};
use penumbra_render::features::clusters::BINNING_PASS;

use crate::cli::BenchArgs;

struct Row {
    lights: usize,
    clusters_ms: Option<f64>,
    forward_ms: Option<f64>,
    /// With the visibility buffer (`--raster compute`): its raster and shading passes.
    raster_ms: Option<(f64, f64)>,
    /// The deferred-lights compute pass and its composite (`--light-walk compute`).
    deferred_ms: Option<f64>,
    /// Whether local lights were shaded in compute (`auto` decides per scene).
    compute: bool,
    gpu_ms: Option<f64>,
    wall_ms: f64,
    update_ms: f64,
    cpu_ms: f64,
    bound_ms: f64,
    /// The CPU's bound on list entries over the cluster count: what `auto` decides by.
    bound_per_cluster: f64,
    mean_per_cluster: f64,
    mean_per_occupied: f64,
    max_per_cluster: usize,
    lights_mib: f64,
    clusters_mib: f64,
    /// GPU memory of every pool, MiB.
    gpu_mib: f64,
    /// Peak resident host memory while the timed scene was built and drawn, MiB.
    host_peak_mib: Option<f64>,
    window_flip: f32,
}

fn app_with(
    ctx: &GpuContext,
    settings: RenderSettings,
    lights: usize,
    range: Option<f32>,
    size: (u32, u32),
) -> Result<penumbra_engine::App> {
    let mut app = penumbra_engine::App::new();
    app.add_plugins(penumbra_engine::CorePlugin).add_plugins(RenderPlugin);
    spawn_many_lights(&mut app.world, lights, range);
    app.insert_resource(Renderer::new(ctx.clone(), settings)?);
    app.insert_resource(RenderOutput::Headless { width: size.0, height: size.1 });
    Ok(app)
}

fn one_frame(
    ctx: &GpuContext,
    settings: RenderSettings,
    lights: usize,
    range: Option<f32>,
    size: (u32, u32),
) -> Result<Vec<u8>> {
    let mut app = app_with(ctx, settings, lights, range, size)?;
    app.update();
    app.world.resource::<Renderer>().read_frame().map_err(|e| anyhow!("{e}"))
}

pub fn run(args: &BenchArgs) -> Result<()> {
    if args.frames == 0 {
        return Err(anyhow!("--frames must be at least 1"));
    }
    if args.lights.is_empty() {
        return Err(anyhow!("--lights: give at least one count"));
    }
    let base = recipe_settings(args)?;
    let ctx = GpuContext::new_headless(&AdapterRequest::default())?;
    let range = args.light_range.0;
    let mut rows = Vec::new();
    for &n in &args.lights {
        let peak_is_row = penumbra_viewer::soak::reset_peak_resident();
        let mut app = app_with(&ctx, base.clone(), n, range, args.size)?;
        let t = time_frames(&mut app, args.warmup, args.frames);
        let host_peak_mib =
            penumbra_viewer::soak::peak_resident_bytes().filter(|_| peak_is_row).map(|b| b as f64 / 1048576.0);
        let renderer = app.world.resource::<Renderer>();
        let lists = renderer.cluster_binner().read_lists(&ctx.device, &ctx.queue).map_err(|e| anyhow!("{e}"))?;
        let total: usize = lists.iter().map(Vec::len).sum();
        let occupied = lists.iter().filter(|l| !l.is_empty()).count();
        let mem = renderer.memory();
        // The window's error: same frame, every light unbounded (brute force), smaller size.
        let small = RenderSettings { gpu_timing: false, ..base.clone() };
        let windowed = one_frame(&ctx, small.clone(), n, range, args.error_size)?;
        let unbounded = one_frame(
            &ctx,
            RenderSettings { light_walk: LightWalk::AllUnbounded, ..small },
            n,
            range,
            args.error_size,
        )?;
        let median = |v: Option<&[f64]>| v.filter(|v| !v.is_empty()).map(|v| percentile(v, 0.5));
        rows.push(Row {
            lights: n,
            // Binning is one compute pass (see `BINNING_PASS`).
            clusters_ms: median(t.pass(BINNING_PASS)),
            forward_ms: median(t.pass("forward")),
            raster_ms: median(t.pass("visibility raster")).zip(median(t.pass("visibility shade"))),
            compute: renderer.stats().plan.runs(penumbra_render::frame::Pass::DEFERRED_LIGHTS),
            deferred_ms: median(t.pass("deferred lights")).map(|d| d + median(t.pass("composite")).unwrap_or(0.0)),
            gpu_ms: median(Some(&t.gpu_total)),
            wall_ms: percentile(&t.wall, 0.5),
            update_ms: percentile(&t.update, 0.5),
            cpu_ms: percentile(&t.cpu, 0.5),
            bound_ms: renderer.cluster_binner().last_bound_ms,
            bound_per_cluster: renderer.cluster_binner().index_bound() as f64 / lists.len().max(1) as f64,
            mean_per_cluster: total as f64 / lists.len().max(1) as f64,
            mean_per_occupied: total as f64 / occupied.max(1) as f64,
            max_per_cluster: lists.iter().map(Vec::len).max().unwrap_or(0),
            lights_mib: mem.lights as f64 / 1048576.0,
            clusters_mib: mem.clusters as f64 / 1048576.0,
            gpu_mib: mem.total() as f64 / 1048576.0,
            host_peak_mib,
            window_flip: flip_mean(&unbounded, &windowed, args.error_size),
        });
    }
    let ms = |v: Option<f64>| v.map_or("n/a".to_owned(), |v| format!("{v:.3}"));
    println!("adapter   {}", ctx.describe());
    println!(
        "scene     many-lights (notes/bench-scenes.md): 200 m ground, 36 spheres, point lights of 20 000 lm, range {}",
        range.map_or("auto (from intensity, cutoff 1/4096)".to_owned(), |r| format!("{r} m"))
    );
    println!(
        "settings  {}x{}, MSAA {} ({:?} resolve), light walk {:?}, raster {:?}, clusters {}x{}x{}, tonemap {:?} (for Bevy's TonyMcMapface), EV100 {BENCH_EV100}, ambient 60 cd/m², {} warm-up + {} timed frames; window error at {}x{}",
        args.size.0,
        args.size.1,
        base.msaa,
        base.msaa_resolve,
        base.light_walk,
        base.raster,
        base.clusters.tiles_x,
        base.clusters.tiles_y,
        base.clusters.slices,
        base.tonemapper,
        args.warmup,
        args.frames,
        args.error_size.0,
        args.error_size.1
    );
    println!();
    println!(
        "| lights | lights shaded in | GPU binning (ms) | GPU forward, or raster + shade in compute (ms) | GPU deferred lights + composite (ms) | GPU frame (ms) | frame, wall (ms) | CPU update (ms) | CPU render (ms) | CPU list bound (ms, when recomputed) | bound per cluster | lights/cluster mean (occupied) | max | GPU MiB lights / clusters | GPU MiB, all pools | host MiB, peak | window FLIP mean |"
    );
    println!("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &rows {
        println!(
            "| {} | {} | {} | {} | {} | {} | {:.3} | {:.3} | {:.3} | {:.2} | {:.1} | {:.2} ({:.1}) | {} | {:.2} / {:.2} | {:.1} | {} | {:.4} |",
            r.lights,
            match (r.raster_ms, r.compute) {
                (Some(_), _) => "visibility buffer",
                (None, true) => "compute",
                (None, false) => "fragments",
            },
            ms(r.clusters_ms),
            match r.raster_ms {
                Some((raster, shade)) => format!("{raster:.3} + {shade:.3}"),
                None => ms(r.forward_ms),
            },
            ms(r.deferred_ms),
            ms(r.gpu_ms),
            r.wall_ms,
            r.update_ms,
            r.cpu_ms,
            r.bound_ms,
            r.bound_per_cluster,
            r.mean_per_cluster,
            r.mean_per_occupied,
            r.max_per_cluster,
            r.lights_mib,
            r.clusters_mib,
            r.gpu_mib,
            r.host_peak_mib.map_or("-".to_owned(), |v| format!("{v:.0}")),
            r.window_flip
        );
    }
    Ok(())
}
