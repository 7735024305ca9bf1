//! `penumbra report`: for every scene of a reference suite × every quality preset, the image
//! error against path-traced references and what the preset costs. Per row: GPU ms (timestamp
//! queries, first pass's beginning to last pass's end, median over the timed frames), CPU ms (median), GPU memory of the main pools, and
//! against the direct-light reference FLIP mean, FLIP 99th percentile and PSNR on linear HDR,
//! then FLIP mean and PSNR against the global-illumination reference.
//!
//! Flow: `suite` reads the manifest and references → each scene is imported once and staged per
//! preset with a fresh renderer (no environment, black clear colour, the file's camera and
//! camera at the exposure that keeps radiance unscaled, exactly as the reference was set up) → a few frames at the reference's size are read
//! back (HDR and display) and compared by `metrics` → the same app is timed at `--timing-size`
//! → a table on stdout, `OUT/LABEL.csv` and the plot `OUT/LABEL.png` (`plot`).
//! The timed frames use the preset's own settings (no HDR colour kept for the comparison), so
//! the GPU ms is the frame a user gets, the quantity of `penumbra bench`'s "GPU frame span" row
//! (bench frames the scene from its default view with the studio environment; report from the
//! file's camera without one, as the references were made).

mod metrics;
mod plot;
mod suite;

use std::fmt::Write as _;
use std::io::Write as _;

use anyhow::{Context, Result, bail};
use penumbra_engine::components::Exposure;
use penumbra_engine::output;
use penumbra_render::headless::{CameraChoice, ShotSettings, stage_scene};
use penumbra_render::{
    AdapterRequest, GpuContext, QualityPreset, RenderOutput, RenderSettings, Renderer, ShaderSource,
};

use crate::cli::{ReportArgs, SceneArgs};
use crate::commands::bench_measure::{percentile, time_frames};
use crate::scene;
use metrics::{ImageError, compare};

/// Frames rendered at the reference's size before reading back: local shadow maps and the
/// timing queries settle over the first frames.
const SETTLE_FRAMES: u32 = 3;

struct Row {
    scene: String,
    preset: QualityPreset,
    gpu_ms: f64,
    cpu_ms: f64,
    gpu_mib: f64,
    direct: ImageError,
    gi: Option<ImageError>,
}

pub fn run(args: ReportArgs) -> Result<()> {
    if args.frames == 0 {
        bail!("--frames: must be at least 1");
    }
    if !(1..=8192).contains(&args.timing_size.0) || !(1..=8192).contains(&args.timing_size.1) {
        bail!("--timing-size: each side must be 1 to 8192");
    }
    let mut scenes = suite::read_suite(&args.suite)?;
    if !args.scenes.is_empty() {
        if let Some(missing) = args.scenes.iter().find(|n| !scenes.iter().any(|s| &s.name == *n)) {
            bail!("--scenes: {missing:?} is not in {}/suite.txt", args.suite.display());
        }
        scenes.retain(|s| args.scenes.contains(&s.name));
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let ctx = GpuContext::new_headless(&AdapterRequest::default())?;
    let adapter = ctx.adapter.get_info();

    let bar = indicatif::ProgressBar::new((scenes.len() * args.presets.len()) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{elapsed:>4} [{bar:30}] {pos}/{len} {msg}")
            .expect("a valid template")
            .progress_chars("=> "),
    );
    let mut rows = Vec::new();
    for s in &scenes {
        let (reference, size) = suite::read_reference(&s.direct)?;
        let gi = s.gi.as_deref().map(suite::read_reference).transpose()?;
        if let Some((_, gi_size)) = &gi
            && *gi_size != size
        {
            bail!("{}: {gi_size:?}, but the direct reference is {size:?}", s.gi.as_ref().unwrap().display());
        }
        let file = scene::load(Some(&s.path), &SceneArgs::default())?;
        for &preset in &args.presets {
            bar.set_message(format!("{} at {preset}", s.name));
            // PSNR is measured on the HDR colour: keep it even where the frame could skip it.
            let settings = RenderSettings {
                clear_color: [0.0; 3],
                gpu_timing: true,
                keep_hdr: true,
                shaders: match &args.shader_dir {
                    Some(dir) => ShaderSource::Folder { dir: dir.clone(), watch: false },
                    None => ShaderSource::Embedded,
                },
                ..preset.settings()
            };
            let renderer = Renderer::new(ctx.clone(), settings.clone())?;
            // Exposure scale exactly 1: the HDR target holds radiance, as the references do.
            let unit = Some(Exposure::unit().ev100);
            let shot = ShotSettings {
                size: Some(size),
                camera: CameraChoice::Gltf(0),
                exposure_ev100: unit,
                ..Default::default()
            };
            let (mut app, size) = stage_scene(&file, &shot).with_context(|| s.path.display().to_string())?;
            app.insert_resource(renderer);
            app.insert_resource(RenderOutput::Headless { width: size.0, height: size.1 });
            for _ in 0..SETTLE_FRAMES {
                app.update();
            }
            let r = app.world.resource::<Renderer>();
            let hdr: Vec<[f32; 3]> = r.read_hdr()?.into_iter().map(|p| [p[0], p[1], p[2]]).collect();
            let rgb8: Vec<u8> = r.read_frame()?.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
            let direct = compare(&reference, &hdr, &rgb8, size);
            let gi = gi.as_ref().map(|(g, _)| compare(g, &hdr, &rgb8, size));
            if let Some(dir) = &args.images {
                std::fs::create_dir_all(dir)?;
                let reference_png = dir.join(format!("{}.reference.png", s.name));
                let rgb = image::ExtendedColorType::Rgb8;
                output::save_image(&reference_png, &metrics::display_rgb8(&reference), size, rgb)?;
                for (suffix, pixels) in [("png", &rgb8), ("flip.png", &direct.flip_map)] {
                    output::save_image(&dir.join(format!("{}.{preset}.{suffix}", s.name)), pixels, size, rgb)?;
                }
            }

            // Timed as users get the preset: without the HDR colour kept for the error above (on
            // the compute path a frame writes the displayed colour directly, with no tonemap
            // pass), the clear colour the preset has.
            let timed = RenderSettings { gpu_timing: true, shaders: settings.shaders.clone(), ..preset.settings() };
            app.world.resource_mut::<Renderer>().set_settings(timed)?;
            let (w, h) = args.timing_size;
            app.insert_resource(RenderOutput::Headless { width: w, height: h });
            let times = time_frames(&mut app, args.warmup, args.frames);
            // Where the GPU time goes (RUST_LOG=info): the CSV keeps the frame's span only.
            let split: Vec<String> =
                times.passes.iter().map(|(l, v)| format!("{l} {:.3}", percentile(v, 0.5))).collect();
            tracing::info!("{} at {preset}: GPU ms by pass (median): {}", s.name, split.join(", "));
            let cpu: Vec<f64> = (0..times.cpu.len()).map(|i| times.cpu_frame(i)).collect();
            let bytes = app.world.resource::<Renderer>().memory().total();
            rows.push(Row {
                scene: s.name.clone(),
                preset,
                gpu_ms: percentile(&times.gpu_span, 0.5),
                cpu_ms: percentile(&cpu, 0.5),
                gpu_mib: bytes as f64 / 1048576.0,
                direct,
                gi,
            });
            bar.inc(1);
        }
    }
    bar.finish_and_clear();

    let title = format!("{} ({}, {:?})", args.label, adapter.name, adapter.backend);
    let table = table(&rows, &title, args.timing_size);
    print!("{table}");
    let csv_path = args.out.join(format!("{}.csv", args.label));
    output::write_file(&csv_path, |out| out.write_all(csv(&rows).as_bytes()))?;
    let png_path = args.out.join(format!("{}.png", args.label));
    let lines: Vec<plot::Line> = scenes
        .iter()
        .map(|s| plot::Line {
            scene: &s.name,
            points: rows
                .iter()
                .filter(|r| r.scene == s.name)
                .map(|r| (r.preset.name(), r.gpu_ms, r.direct.flip_mean as f64))
                .collect(),
        })
        .collect();
    plot::draw(&png_path, &format!("Error against GPU time: {title}"), "FLIP mean vs Cycles (direct light)", &lines)?;
    let mut out = std::io::stdout();
    writeln!(out, "wrote {} and {}", csv_path.display(), png_path.display())?;
    Ok(())
}

fn table(rows: &[Row], title: &str, timing: (u32, u32)) -> String {
    let mut t = String::new();
    let _ = writeln!(t, "{title}; times at {}x{}, error at the references' size", timing.0, timing.1);
    let _ = writeln!(
        t,
        "{:<10} {:<7} {:>8} {:>8} {:>8} | {:>9} {:>9} {:>9} {:>8} | {:>9} {:>8}",
        "scene",
        "preset",
        "GPU ms",
        "CPU ms",
        "GPU MiB",
        "FLIP mean",
        "FLIP p99",
        "FLIP wp99",
        "PSNR dB",
        "GI FLIP",
        "GI PSNR"
    );
    let _ = writeln!(
        t,
        "{:<10} {:<7} {:>8} {:>8} {:>8} | {:^38} | {:^18}",
        "", "", "", "", "", "vs direct light", "vs global illum."
    );
    for r in rows {
        let (gi_flip, gi_psnr) = r.gi.as_ref().map_or(("-".to_string(), "-".to_string()), |g| {
            (format!("{:.4}", g.flip_mean), format!("{:.2}", g.psnr_db))
        });
        let _ = writeln!(
            t,
            "{:<10} {:<7} {:>8.3} {:>8.3} {:>8.1} | {:>9.4} {:>9.4} {:>9.4} {:>8.2} | {:>9} {:>8}",
            r.scene,
            r.preset.name(),
            r.gpu_ms,
            r.cpu_ms,
            r.gpu_mib,
            r.direct.flip_mean,
            r.direct.flip_p99,
            r.direct.flip_weighted_p99,
            r.direct.psnr_db,
            gi_flip,
            gi_psnr
        );
    }
    t
}

fn csv(rows: &[Row]) -> String {
    let mut c = String::from(
        "scene,preset,gpu_ms,cpu_ms,gpu_mib,flip_mean_direct,flip_p99_direct,flip_weighted_p99_direct,psnr_db_direct,\
         flip_mean_gi,flip_p99_gi,flip_weighted_p99_gi,psnr_db_gi\n",
    );
    for r in rows {
        let gi = r.gi.as_ref().map_or(",,,".to_string(), |g| {
            format!("{:.5},{:.5},{:.5},{:.3}", g.flip_mean, g.flip_p99, g.flip_weighted_p99, g.psnr_db)
        });
        let _ = writeln!(
            c,
            "{},{},{:.4},{:.4},{:.2},{:.5},{:.5},{:.5},{:.3},{gi}",
            r.scene,
            r.preset.name(),
            r.gpu_ms,
            r.cpu_ms,
            r.gpu_mib,
            r.direct.flip_mean,
            r.direct.flip_p99,
            r.direct.flip_weighted_p99,
            r.direct.psnr_db
        );
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The CPU tonemap that makes the references' display images is the GPU's: Penumbra's own
    /// HDR frame through `display_rgb8` is its displayed frame, to the rounding of one step.
    #[test]
    fn the_cpu_tonemap_matches_the_tonemap_pass() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/reference/scenes/spheres.gltf");
        let file = scene::load(Some(&path), &SceneArgs::default()).unwrap();
        let ctx = GpuContext::new_headless(&AdapterRequest::default()).unwrap_or_else(|e| panic!("{e}"));
        let renderer = Renderer::new(ctx, RenderSettings { msaa: 1, keep_hdr: true, ..Default::default() }).unwrap();
        let shot = ShotSettings {
            size: Some((64, 64)),
            camera: CameraChoice::Gltf(0),
            exposure_ev100: Some(-2.0),
            ..Default::default()
        };
        let (mut app, size) = stage_scene(&file, &shot).unwrap();
        app.insert_resource(renderer);
        app.insert_resource(RenderOutput::Headless { width: size.0, height: size.1 });
        app.update();
        let r = app.world.resource::<Renderer>();
        let hdr: Vec<[f32; 3]> = r.read_hdr().unwrap().into_iter().map(|p| [p[0], p[1], p[2]]).collect();
        let gpu: Vec<u8> = r.read_headless().unwrap().chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
        let cpu = metrics::display_rgb8(&hdr);
        let worst = gpu.iter().zip(&cpu).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
        assert!(worst <= 1, "the CPU tonemap differs from the GPU's by {worst} steps");
        // Exposed 2 EV brighter than the references, the highlights reach the curve's shoulder.
        assert!(hdr.iter().any(|p| p[0] > 1.0), "the test must cover the compressed range");
    }
}
