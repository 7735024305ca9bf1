//! `penumbra bench shadows`: the shadows scene (`penumbra_engine::scenes::spawn_shadows_scene`)
//! at each shadow atlas size and filter. Per setting: GPU time of each cascade's caster pass and
//! of the forward pass (timestamp queries), CPU time, the atlas's memory, and the image error
//! (FLIP mean) against the 4096²/PCSS frame of the same scene; a row without shadows gives the
//! baseline cost.

use anyhow::{Result, anyhow};
use penumbra_engine::scenes::spawn_shadows_scene;
use penumbra_render::frame::Pass;
use penumbra_render::passes::shadows::{ShadowFilter, ShadowSettings};
use penumbra_render::{AdapterRequest, GpuContext, RenderOutput, RenderPlugin, RenderSettings, Renderer};

use super::bench::{percentile, time_frames};
use super::bench_lights::flip_mean;
use crate::cli::BenchArgs;

/// Atlas sizes measured, in texels per layer.
const ATLAS_SIZES: [u32; 3] = [1024, 2048, 4096];

struct Row {
    setting: String,
    layers: usize,
    per_cascade_ms: Option<f64>,
    shadows_ms: Option<f64>,
    forward_ms: Option<f64>,
    gpu_ms: Option<f64>,
    cpu_ms: f64,
    atlas_mib: f64,
    flip: f32,
}

fn app_with(
    ctx: &GpuContext,
    settings: RenderSettings,
    shadows: bool,
    size: (u32, u32),
) -> Result<penumbra_engine::App> {
    let mut app = penumbra_engine::App::new();
    app.add_plugins(penumbra_engine::CorePlugin).add_plugins(RenderPlugin);
    spawn_shadows_scene(&mut app.world);
    if !shadows {
        let mut q = app.world.query::<&mut penumbra_engine::components::DirectionalLight>();
        for mut l in q.iter_mut(&mut app.world) {
            l.shadows = false;
        }
    }
    app.insert_resource(Renderer::new(ctx.clone(), settings)?);
    app.insert_resource(RenderOutput::Headless { width: size.0, height: size.1 });
    Ok(app)
}

fn frame(app: &mut penumbra_engine::App) -> Result<Vec<u8>> {
    app.update();
    app.world.resource::<Renderer>().read_headless().map_err(|e| anyhow!("{e}"))
}

pub fn run(args: &BenchArgs) -> Result<()> {
    if args.frames == 0 {
        return Err(anyhow!("--frames must be at least 1"));
    }
    let base = RenderSettings { gpu_timing: true, ..args.look.render_settings(false, None)? };
    let ctx = GpuContext::new_headless(&AdapterRequest::default())?;
    let limit = ctx.device.limits().max_texture_dimension_2d;
    let reference_settings = ShadowSettings { atlas_size: 4096.min(limit), filter: ShadowFilter::Pcss, ..base.shadows };
    let reference = frame(&mut app_with(
        &ctx,
        RenderSettings { gpu_timing: false, shadows: reference_settings, ..base.clone() },
        true,
        args.size,
    )?)?;
    let mut cases: Vec<(String, bool, ShadowSettings)> = vec![("no shadows".to_owned(), false, base.shadows)];
    for filter in [ShadowFilter::Pcf, ShadowFilter::Pcss] {
        for atlas_size in ATLAS_SIZES.into_iter().filter(|s| *s <= limit) {
            let name = format!("{atlas_size}², {filter:?}");
            cases.push((name, true, ShadowSettings { atlas_size, filter, ..base.shadows }));
        }
    }
    let mut rows = Vec::new();
    for (setting, on, shadows) in cases {
        let mut app = app_with(&ctx, RenderSettings { shadows, ..base.clone() }, on, args.size)?;
        let t = time_frames(&mut app, args.warmup, args.frames);
        let renderer = app.world.resource::<Renderer>();
        let layers = renderer.shadow_frame().rendered_layers();
        let median = |v: Option<&[f64]>| v.filter(|v| !v.is_empty()).map(|v| percentile(v, 0.5));
        let shadow_passes: Vec<f64> =
            t.passes.iter().filter(|(l, _)| l.starts_with("shadow ")).filter_map(|(_, v)| median(Some(v))).collect();
        let shadows_ms = (!shadow_passes.is_empty()).then(|| shadow_passes.iter().sum::<f64>());
        let atlas_mib = renderer.memory().shadows as f64 / 1048576.0;
        assert_eq!(renderer.stats().plan.runs(Pass::Shadows), layers > 0);
        let image = frame(&mut app)?;
        rows.push(Row {
            setting,
            layers,
            per_cascade_ms: shadows_ms.map(|s| s / shadow_passes.len() as f64),
            shadows_ms,
            forward_ms: median(t.pass("forward")),
            gpu_ms: median(Some(&t.gpu_total)),
            cpu_ms: percentile(&t.cpu, 0.5),
            atlas_mib,
            flip: flip_mean(&reference, &image, args.size),
        });
    }
    let ms = |v: Option<f64>| v.map_or("n/a".to_owned(), |v| format!("{v:.3}"));
    println!("adapter   {}", ctx.describe());
    println!(
        "scene     shadows (scenes.rs): 200 m ground, 400 boxes and spheres, a 4 lux sun at 35° with the sun's angular size"
    );
    println!(
        "settings  {}x{}, MSAA {}, {} cascades to {} m (λ {}), {} warm-up + {} timed frames; FLIP mean against the {}²/PCSS frame",
        args.size.0,
        args.size.1,
        base.msaa,
        base.shadows.cascades,
        base.shadows.max_distance,
        base.shadows.split_lambda,
        args.warmup,
        args.frames,
        reference_settings.atlas_size,
    );
    println!();
    println!(
        "| setting | cascades rendered | GPU per cascade (ms) | GPU shadow passes (ms) | GPU forward (ms) | GPU frame (ms) | CPU render (ms) | atlas (MiB) | FLIP mean vs reference |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &rows {
        println!(
            "| {} | {} | {} | {} | {} | {} | {:.3} | {:.1} | {:.4} |",
            r.setting,
            r.layers,
            ms(r.per_cascade_ms),
            ms(r.shadows_ms),
            ms(r.forward_ms),
            ms(r.gpu_ms),
            r.cpu_ms,
            r.atlas_mib,
            r.flip
        );
    }
    println!();
    println!("Spot and point lights cast no shadows yet: no per-local-shadow column.");
    Ok(())
}
