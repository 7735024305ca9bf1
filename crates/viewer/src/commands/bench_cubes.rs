//! `penumbra bench many-cubes`: the many-cubes benchmark scene (crates/engine/src/scenes.rs) for
//! each cube count in `--count` and each moving fraction in `--moving`. Per row, medians over the
//! timed frames of the CPU time split by stage (main world: user systems and transform
//! propagation; extract; prepare, encode and submit in the renderer), GPU time from timestamp
//! queries, the instance bytes uploaded and the draw calls issued. Frames are pipelined (at most
//! two in flight, no readback), as interactive rendering runs.

use anyhow::{Result, anyhow};
use penumbra_engine::scenes::{BENCH_EV100, CubeLayout, spawn_many_cubes, spin_cubes};
use penumbra_render::{AdapterRequest, GpuContext, RenderOutput, RenderPlugin, Renderer};

use super::bench_measure::{percentile, recipe_settings, step_camera, time_frames};
use crate::cli::{BenchArgs, LayoutArg};

struct Row {
    count: usize,
    moving: f64,
    median: [f64; 19],
    draw_calls: u32,
    instances: u32,
    /// After GPU culling, in the last frame (`None`: not culled).
    visible: Option<u32>,
    /// Triangles the triangle-culled batches drew (triangle culling ran in the last frame).
    triangles: Option<u32>,
    instances_mib: f64,
    /// GPU memory of every pool, MiB.
    gpu_mib: f64,
    /// Peak resident host memory while the row was built and timed, MiB (`None`: unknown).
    host_peak_mib: Option<f64>,
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
    let settings = recipe_settings(args)?;
    let ctx = GpuContext::new_headless(&AdapterRequest::default())?;
    let mut rows = Vec::new();
    for &count in &args.count {
        for &moving in &args.moving {
            let peak_is_row = penumbra_viewer::soak::reset_peak_resident();
            let mut app = penumbra_engine::App::new();
            app.add_plugins(penumbra_engine::CorePlugin).add_plugins(RenderPlugin);
            app.add_systems(penumbra_engine::Update, spin_cubes);
            spawn_many_cubes(&mut app.world, count, layout, moving, args.shadows);
            if args.shadows {
                app.add_systems(penumbra_engine::Update, step_camera);
            }
            app.insert_resource(Renderer::new(ctx.clone(), settings.clone())?);
            app.insert_resource(RenderOutput::Headless { width: args.size.0, height: args.size.1 });
            let t = time_frames(&mut app, args.warmup, args.frames);
            let renderer = app.world.resource::<Renderer>();
            let stats = renderer.stats();
            let med = |v: &[f64]| percentile(v, 0.5);
            let pass = |label| t.pass(label).map_or(f64::NAN, med);
            let encode: Vec<f64> = t.cpu.iter().zip(&t.prepare).map(|(c, p)| c - p).collect();
            let cpu: Vec<f64> = (0..t.cpu.len()).map(|i| t.cpu_frame(i)).collect();
            rows.push(Row {
                count,
                moving,
                median: [
                    med(&t.main),
                    med(&t.extract),
                    med(&t.prepare),
                    med(&encode),
                    med(&t.submit),
                    med(&cpu),
                    med(&t.wall),
                    med(&t.gpu_total),
                    med(&t.instance_bytes),
                    pass("cull"),
                    pass("forward"),
                    pass("tonemap"),
                    med(&t.instance_upload),
                    pass("depth pyramid"),
                    pass("cull late"),
                    pass("forward late"),
                    pass("visibility raster"),
                    pass("visibility shade"),
                    // One timed pass per cascade (and one label for local maps): their sum.
                    t.passes
                        .iter()
                        .filter(|(label, v)| label.starts_with("shadow ") && !v.is_empty())
                        .map(|(_, v)| med(v))
                        .reduce(|a, b| a + b)
                        .unwrap_or(f64::NAN),
                ],
                draw_calls: stats.draw_calls,
                instances: stats.instances,
                visible: renderer.visible_instance_counts()?.map(|c| c.iter().sum()),
                triangles: renderer.triangle_culled_counts()?.map(|c| c.iter().flatten().sum()),
                instances_mib: renderer.memory().instances as f64 / 1048576.0,
                gpu_mib: renderer.memory().total() as f64 / 1048576.0,
                host_peak_mib: penumbra_viewer::soak::peak_resident_bytes()
                    .filter(|_| peak_is_row)
                    .map(|b| b as f64 / 1048576.0),
            });
        }
    }
    println!("adapter   {}", ctx.describe());
    println!(
        "scene     many-cubes (notes/bench-scenes.md), {:?} layout: one shared 1 m cube mesh and material, a 10 000 lux sun {}, ambient 200 cd/m²",
        layout,
        if args.shadows {
            "casting shadows, the camera stepping 25 cm sideways each frame (every cascade redraws)"
        } else {
            "without shadows"
        }
    );
    println!(
        "settings  {}x{}, MSAA {} ({:?} resolve), GPU culling {}, occlusion culling {:?}, triangle culling {:?}, raster {:?}, tonemap {:?} (for Bevy's TonyMcMapface), EV100 {BENCH_EV100}, {} warm-up + {} timed frames, at most 2 in flight",
        args.size.0,
        args.size.1,
        settings.msaa,
        settings.msaa_resolve,
        if settings.gpu_culling { "on" } else { "off" },
        settings.occlusion_culling,
        settings.triangle_culling,
        settings.raster,
        settings.tonemapper,
        args.warmup,
        args.frames
    );
    println!();
    println!(
        "| cubes | moving | CPU main world (ms) | CPU extract (ms) | CPU prepare (ms) (of which instance upload) | CPU encode (ms) | CPU submit (ms) | CPU frame (ms) | GPU cull / shadows / forward / depth pyramid / cull late / forward late / tonemap (ms) | GPU frame (ms) | frame, wall (ms) | instance bytes uploaded | draw calls | instances submitted | after GPU culling | triangles after triangle culling | GPU MiB instances and draw lists | GPU MiB, all pools | host MiB, peak |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
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
            raster,
            shade,
            shadows,
        ] = r.median;
        let ms = |v: f64| if v.is_nan() { "-".to_owned() } else { format!("{v:.3}") };
        let passes = format!(
            "{} / {} / {} / {} / {} / {} / {}",
            ms(cull),
            ms(shadows),
            // The forward pass, or the visibility buffer's raster + shade (`--raster compute`).
            if forward.is_nan() && !raster.is_nan() { format!("{} + {}", ms(raster), ms(shade)) } else { ms(forward) },
            ms(hzb),
            ms(cull_late),
            ms(forward_late),
            ms(tonemap)
        );
        let gpu = ms(gpu);
        println!(
            "| {} | {} | {main:.3} | {extract:.3} | {prepare:.3} ({upload:.3}) | {encode:.3} | {submit:.3} | {cpu:.3} | {passes} | {gpu} | {wall:.3} | {bytes:.0} | {} | {} | {} | {} | {:.1} | {:.1} | {} |",
            r.count,
            r.moving,
            r.draw_calls,
            r.instances,
            r.visible.map_or("not culled".to_owned(), |v| v.to_string()),
            r.triangles.map_or("-".to_owned(), |v| v.to_string()),
            r.instances_mib,
            r.gpu_mib,
            r.host_peak_mib.map_or("-".to_owned(), |v| format!("{v:.0}"))
        );
    }
    Ok(())
}
