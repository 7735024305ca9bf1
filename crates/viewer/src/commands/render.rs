//! `penumbra render`: scenes to images. One scene (`--out FILE`): the GPU context and pipelines
//! are created on a second thread while the scene file is read and decoded, since on a 2-core
//! machine neither needs the other until the first frame (an error on either side waits for the
//! other, so the process never exits while the driver is still setting up); at the end the scene
//! and the device are freed on two threads. Many scenes (`--out-dir DIR`): one device and one
//! renderer for all of them ([`SceneBatch`]), the next scenes read and decoded on other threads
//! ([`Prefetch`], [`read_ahead`] of them) while the current one renders; a scene that fails is
//! reported and the rest go on.
//! `-v` logs the time at each step.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Result, anyhow, bail};
use penumbra_engine::output;
use penumbra_render::headless::{SceneBatch, ShotError, ShotSettings, render_frames, stage_scene};
use penumbra_render::{AdapterRequest, GpuContext, Renderer};

use super::prefetch::Prefetch;
use crate::cli::RenderArgs;
use crate::scene;

/// Scenes read ahead of the one rendering: a quarter of the cores (each scene's images decode in
/// parallel too), one to four. One scene's decoding can take longer than rendering it
/// (DamagedHelmet's five 2048² images: about 0.2 s on a 16-core host, a 512² frame a tenth of
/// that), so several are read at once to keep the GPU busy; each one ahead holds its decoded
/// images.
fn read_ahead() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get() / 4).clamp(1, 4)
}

pub fn run(args: RenderArgs) -> Result<()> {
    let settings = args.look.render_settings(false, None)?;
    let shot = ShotSettings {
        size: args.size,
        camera: args.camera,
        exposure_ev100: args.look.exposure_ev100(),
        animation: args.animation_shot(),
        variant: args.scene_args.variant.clone(),
        environment: None,
    };
    shot.validate()?;
    match (&args.out, &args.out_dir, args.paths.as_slice()) {
        (Some(out), _, [path]) => render_one(&args, path, out, settings, shot),
        (Some(_), _, paths) => {
            bail!("--out names one image, for one scene; give --out-dir DIR to render {} scenes", paths.len())
        }
        (None, Some(dir), _) => render_many(&args, dir, settings, shot),
        (None, None, _) => bail!("give --out FILE (one scene) or --out-dir DIR"),
    }
}

fn render_one(
    args: &RenderArgs,
    path: &Path,
    out: &Path,
    settings: penumbra_render::RenderSettings,
    mut shot: ShotSettings,
) -> Result<()> {
    let start = Instant::now();
    let step = move |what: &str| tracing::info!("{:>7.1} ms  {what}", start.elapsed().as_secs_f64() * 1e3);
    // Where the image goes is checked before anything is rendered: a bad name costs no render.
    output::image_format(out)?;
    output::check_destination(out)?;
    let gpu = spawn_renderer(settings, args.look.env_name() != "none", step);
    let staged = (|| -> Result<_> {
        let scene = scene::load(Some(path), &args.scene_args)?;
        step("scene decoded");
        shot.environment = args.look.environment()?;
        step("environment read");
        let (app, size) = stage_scene(&scene, &shot)?;
        step("scene staged");
        Ok((scene, app, size))
    })();
    // Joined before any error returns: exiting while the driver still initialises on that
    // thread runs the process's exit handlers under it (lavapipe could then hang for good in
    // LLVM's set-up). A bad scene is reported before a GPU error.
    let renderer = gpu.join().map_err(|_| anyhow!("the GPU setup thread panicked"))?;
    let (scene, mut app, size) = staged?;
    let renderer = renderer?;
    let pixels = render_frames(&mut app, renderer, size, args.frames)?;
    step("rendered and read back");
    output::save_image(out, &pixels, size, image::ExtendedColorType::Rgba8)?;
    step("image written");
    if args.explain {
        explain(&app);
    }
    // Freeing is part of the command's time: the decoded images (over 100 MB for DamagedHelmet)
    // go on a second thread while the device and its textures go on this one (`-v` times it;
    // docs/performance.md, "A headless screenshot"). Leaving them to the process's exit instead
    // was slower on lavapipe and on an NVIDIA H200.
    let renderer = app.world.remove_resource::<Renderer>();
    let world = std::mem::take(&mut app.world);
    let freer = std::thread::spawn(move || drop((world, scene)));
    drop(renderer);
    freer.join().map_err(|_| anyhow!("freeing the scene panicked"))?;
    step("freed");
    Ok(())
}

/// The GPU context and the renderer, made on a thread of their own: neither needs the scene
/// until the first frame. The shader library is parsed on a third thread meanwhile, and the
/// pipelines every frame with these settings runs are compiled before the thread ends
/// (`Renderer::warm_up`; `environment`: whether scenes will have one), while the scene is
/// still being read. `step` logs each stage's time (`-v`).
pub(super) fn spawn_renderer(
    settings: penumbra_render::RenderSettings,
    environment: bool,
    step: impl Fn(&str) + Send + 'static,
) -> std::thread::JoinHandle<Result<Renderer>> {
    if settings.shaders == penumbra_render::ShaderSource::Embedded {
        penumbra_render::pipelines::ShaderLibrary::preload_embedded();
    }
    std::thread::spawn(move || {
        let ctx = GpuContext::new_headless(&AdapterRequest::default())?;
        step("GPU context");
        let mut renderer = Renderer::new(ctx, settings)?;
        step("renderer ready");
        renderer.warm_up(environment);
        step("pipelines warmed up");
        Ok(renderer)
    })
}

fn explain(app: &penumbra_engine::App) {
    if let Some(view) = app.world.get_resource::<penumbra_render::headless::StagedView>() {
        println!("View: {}\nExposure: {}", view.camera, view.exposure);
    }
    print!("{}", penumbra_render::explain::explain(app.world.resource::<Renderer>()));
}

/// Each scene's image in `dir`: its file name with `.png` (two scenes of one name are an error
/// before anything renders).
fn outputs(paths: &[PathBuf], dir: &Path) -> Result<Vec<PathBuf>> {
    let mut seen = std::collections::HashMap::new();
    paths
        .iter()
        .map(|p| {
            let stem = p.file_stem().ok_or_else(|| anyhow!("{}: not a file name", p.display()))?;
            // The whole stem, dots and all: `model.draco.glb` is `model.draco.png`.
            let mut name = stem.to_os_string();
            name.push(".png");
            let out = dir.join(name);
            if let Some(other) = seen.insert(out.clone(), p) {
                bail!("{} and {} would both be written to {}", other.display(), p.display(), out.display());
            }
            Ok(out)
        })
        .collect()
}

fn render_many(
    args: &RenderArgs,
    dir: &Path,
    settings: penumbra_render::RenderSettings,
    mut shot: ShotSettings,
) -> Result<()> {
    let start = Instant::now();
    let outs = outputs(&args.paths, dir)?;
    std::fs::create_dir_all(dir).map_err(|e| anyhow!("cannot make {}: {e}", dir.display()))?;
    for out in &outs {
        output::check_destination(out)?;
    }
    shot.environment = args.look.environment()?;
    // The device comes up while the first scene is read; the next ones are read while the one
    // before renders.
    let step = move |what: &str| tracing::info!("{:>7.1} ms  {what}", start.elapsed().as_secs_f64() * 1e3);
    let gpu = spawn_renderer(settings, shot.environment.is_some(), step);
    let (paths, scene_args) = (args.paths.clone(), args.scene_args.clone());
    let scenes = Prefetch::new(paths.len(), read_ahead(), move |i| scene::load(Some(&paths[i]), &scene_args));
    let renderer = gpu.join().map_err(|_| anyhow!("the GPU setup thread panicked"))?;
    let mut batch = SceneBatch::new(renderer?);
    let (mut done, mut failed, mut first_ms, mut rest_ms) = (0, 0, None, Vec::new());
    // The first scene's time counts from the start: reading it is most of it.
    let mut last = start;
    let outcome = (|| -> Result<()> {
        for ((path, out), loaded) in args.paths.iter().zip(&outs).zip(scenes) {
            let written = match loaded.map_err(anyhow::Error::msg).and_then(|r| Ok(r?)) {
                Err(e) => Err(e),
                Ok(scene) => match batch.render(&scene, &shot, args.frames) {
                    // The device is gone or broken: nothing after this would render.
                    Err(e @ ShotError::Render(_)) => {
                        return Err(anyhow!(e).context(format!("{}: the renderer failed", path.display())));
                    }
                    Err(e) => Err(e.into()),
                    Ok((pixels, size)) => {
                        output::save_image(out, &pixels, size, image::ExtendedColorType::Rgba8).map_err(Into::into)
                    }
                },
            };
            let ms = last.elapsed().as_secs_f64() * 1e3;
            last = Instant::now();
            match written {
                Ok(()) => {
                    println!("{} -> {} ({ms:.0} ms)", path.display(), out.display());
                    if args.explain
                        && let Some(app) = batch.app()
                    {
                        explain(app);
                    }
                    match first_ms {
                        None => first_ms = Some(ms),
                        Some(_) => rest_ms.push(ms),
                    }
                    done += 1;
                }
                Err(e) => {
                    eprintln!("penumbra: {}: {e:#}", path.display());
                    failed += 1;
                }
            }
        }
        Ok(())
    })();
    outcome?;
    let total = start.elapsed().as_secs_f64();
    let mut summary = format!("{done} of {} scenes rendered in {total:.2} s", args.paths.len());
    if let Some(first) = first_ms {
        summary += &format!(" (the first {first:.0} ms");
        if !rest_ms.is_empty() {
            let mean = rest_ms.iter().sum::<f64>() / rest_ms.len() as f64;
            summary += &format!(", then {mean:.0} ms per scene");
        }
        summary += ")";
    }
    println!("{summary}");
    if failed > 0 {
        bail!("{failed} of {} scenes failed (above)", args.paths.len());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_scene_is_written_under_its_whole_stem() {
        let dir = Path::new("shots");
        let outs = outputs(&["a/model.draco.glb".into(), "b/model.glb".into()], dir).unwrap();
        assert_eq!(outs, [dir.join("model.draco.png"), dir.join("model.png")]);
        let e = outputs(&["a/x.glb".into(), "b/x.gltf".into()], dir).unwrap_err();
        assert!(e.to_string().contains("would both be written to"), "{e}");
    }
}
