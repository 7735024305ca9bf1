//! `penumbra render`: one scene, one PNG. The GPU context and pipelines are created on a second
//! thread while the scene file is read and decoded, since on a 2-core machine neither needs the
//! other until the first frame (an error on either side waits for the other, so the process never
//! exits while the driver is still setting up); at the end the scene and the device are freed on
//! two threads.
//! `-v` logs the time at each step.

use std::time::Instant;

use anyhow::{Result, anyhow};
use penumbra_engine::output;
use penumbra_render::headless::{ShotSettings, render_frames, stage_scene};
use penumbra_render::{AdapterRequest, GpuContext, Renderer};

use crate::cli::RenderArgs;
use crate::scene;

pub fn run(args: RenderArgs) -> Result<()> {
    let start = Instant::now();
    let step = move |what: &str| tracing::info!("{:>7.1} ms  {what}", start.elapsed().as_secs_f64() * 1e3);
    let settings = args.look.render_settings(false, None)?;
    let mut shot = ShotSettings {
        size: args.size,
        camera: args.camera,
        exposure_ev100: args.look.exposure_ev100(),
        animation: args.animation_shot(),
        variant: args.scene_args.variant.clone(),
        environment: None,
    };
    shot.validate()?;
    // Where the image goes is checked before anything is rendered: a bad name costs no render.
    output::image_format(&args.out)?;
    output::check_destination(&args.out)?;
    let gpu = std::thread::spawn(move || -> Result<Renderer> {
        let ctx = GpuContext::new_headless(&AdapterRequest::default())?;
        step("GPU context");
        let renderer = Renderer::new(ctx, settings)?;
        step("renderer ready");
        Ok(renderer)
    });
    let staged = (|| -> Result<_> {
        let scene = scene::load(Some(&args.path), &args.scene_args)?;
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
    output::save_image(&args.out, &pixels, size, image::ExtendedColorType::Rgba8)?;
    step("image written");
    if args.explain {
        if let Some(view) = app.world.get_resource::<penumbra_render::headless::StagedView>() {
            println!("View: {}\nExposure: {}", view.camera, view.exposure);
        }
        print!("{}", penumbra_render::explain::explain(app.world.resource::<Renderer>()));
    }
    // Freeing is part of the command's time: the decoded images (over 100 MB for DamagedHelmet)
    // go on a second thread while the device and its textures go on this one (`-v` times it;
    // docs/performance.md, "A headless screenshot").
    let renderer = app.world.remove_resource::<Renderer>();
    let world = std::mem::take(&mut app.world);
    let freer = std::thread::spawn(move || drop((world, scene)));
    drop(renderer);
    freer.join().map_err(|_| anyhow!("freeing the scene panicked"))?;
    step("freed");
    Ok(())
}
