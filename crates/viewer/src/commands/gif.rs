//! `penumbra gif`: a turntable as an animated GIF. The scene is framed once for every direction
//! of the turn (the largest framing distance over the circle, so nothing leaves the frame as
//! the camera goes round); each frame moves the camera a step round the vertical axis through
//! the scene's centre, advances time by one frame's share of `--seconds` (animations play
//! along), renders headless and reads back. Frames are quantised and written by `image`'s GIF
//! encoder as they come, so memory holds one frame, not the whole animation.

use std::io::{IsTerminal, Write};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use bevy_ecs::entity::Entity;
use glam::{Quat, Vec3};
use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame, RgbaImage};
use penumbra_engine::components::{Camera, Transform};
use penumbra_engine::framing::{framing_camera_from, world_bounds};
use penumbra_engine::output;
use penumbra_engine::{Time, TimeMode};
use penumbra_render::headless::{CameraChoice, ShotSettings, stage_scene};
use penumbra_render::{AdapterRequest, GpuContext, RenderOutput, Renderer};

use crate::cli::GifArgs;
use crate::scene;

fn validate(args: &GifArgs) -> Result<()> {
    if !(2..=1000).contains(&args.frames) {
        bail!("--frames {}: must be 2 to 1000", args.frames);
    }
    let (w, h) = args.size;
    if !(1..=4096).contains(&w) || !(1..=4096).contains(&h) {
        bail!("--size {w}x{h}: each side must be 1 to 4096");
    }
    if !(args.seconds.is_finite() && (0.1..=600.0).contains(&args.seconds)) {
        bail!("--seconds {}: must be 0.1 to 600", args.seconds);
    }
    if !(args.pitch.is_finite() && (-89.0..=89.0).contains(&args.pitch)) {
        bail!("--pitch {}: must be -89 to 89 degrees", args.pitch);
    }
    Ok(())
}

pub fn run(args: GifArgs) -> Result<()> {
    validate(&args)?;
    output::check_destination(&args.out)?;
    if !args.out.extension().is_some_and(|e| e.eq_ignore_ascii_case("gif")) && !output::is_device(&args.out) {
        bail!("{}: `penumbra gif` writes GIF files; name the output *.gif", args.out.display());
    }
    let settings = args.look.render_settings(false, None)?;
    let size = args.size;
    let scene = scene::load(args.path.as_deref(), &args.scene_args)?;
    let shot = ShotSettings {
        size: Some(size),
        camera: CameraChoice::Orbit { yaw: 0.0, pitch: args.pitch },
        exposure_ev100: args.look.exposure_ev100(),
        animation: None,
        variant: args.scene_args.variant.clone(),
        environment: args.look.environment()?,
    };
    let (mut app, _) = stage_scene(&scene, &shot)?;
    let step = args.seconds / args.frames as f32;
    app.world.resource_mut::<Time>().set_mode(TimeMode::Fixed(Duration::from_secs_f32(step)));
    let (camera, start) = {
        let mut q = app.world.query::<(Entity, &Camera, &Transform)>();
        let (e, _, t) = q.iter(&app.world).find(|(_, c, _)| c.is_active).context("no active camera")?;
        (e, *t)
    };
    let (center, radius) = turn_radius(&mut app.world, &start, args.pitch, size);
    let offset = (start.translation - center).normalize_or(Vec3::Z) * radius;

    let ctx = GpuContext::new_headless(&AdapterRequest::default())?;
    app.insert_resource(Renderer::new(ctx, settings)?);
    app.insert_resource(RenderOutput::Headless { width: size.0, height: size.1 });

    // Frames are encoded as they are rendered, into a file that replaces `--out` only when the
    // last frame is in (a failed render or write leaves no partial GIF and an old file intact).
    let delay = Delay::from_saturating_duration(Duration::from_secs_f32(step));
    let progress = Progress::new(args.frames);
    let mut failed = None;
    let written = output::write_file(&args.out, |out| {
        let mut encoder = GifEncoder::new_with_speed(out, 10);
        encoder.set_repeat(Repeat::Infinite).map_err(std::io::Error::other)?;
        for i in 0..args.frames {
            let turn = Quat::from_rotation_y(std::f32::consts::TAU * i as f32 / args.frames as f32);
            if let Some(mut t) = app.world.get_mut::<Transform>(camera) {
                t.translation = center + turn * offset;
                t.rotation = turn * start.rotation;
            }
            app.update();
            let pixels = match app.world.resource::<Renderer>().read_frame() {
                Ok(pixels) => pixels,
                Err(e) => {
                    let message = e.to_string();
                    failed = Some(anyhow::Error::from(e));
                    return Err(std::io::Error::other(message));
                }
            };
            let image = RgbaImage::from_raw(size.0, size.1, pixels)
                .ok_or_else(|| std::io::Error::other("read back the wrong number of pixels"))?;
            encoder.encode_frame(Frame::from_parts(image, 0, 0, delay)).map_err(|e| match e {
                image::ImageError::IoError(io) => io,
                other => std::io::Error::other(other),
            })?;
            progress.show(i + 1);
        }
        Ok(())
    });
    if let Some(e) = failed {
        return Err(e);
    }
    written?;
    progress.finish(&args.out);
    Ok(())
}

/// The scene's centre and the camera distance that keeps the whole scene in frame from every
/// direction of the turn (the start's direction sets the elevation).
fn turn_radius(world: &mut bevy_ecs::world::World, start: &Transform, pitch: f32, size: (u32, u32)) -> (Vec3, f32) {
    let bounds = world_bounds(world);
    let center = if bounds.is_empty() { Vec3::ZERO } else { bounds.center() };
    let aspect = size.0 as f32 / size.1 as f32;
    let pitch = pitch.to_radians();
    let radius = (0..16)
        .map(|k| {
            let yaw = std::f32::consts::TAU * k as f32 / 16.0;
            let direction = Vec3::new(yaw.sin() * pitch.cos(), pitch.sin(), yaw.cos() * pitch.cos());
            let (_, t) = framing_camera_from(&bounds, direction, 45f32.to_radians(), aspect);
            (t.translation - center).length()
        })
        .fold((start.translation - center).length(), f32::max);
    (center, radius)
}

/// A one-line progress bar on a terminal's stderr; silent when stderr is not a terminal.
struct Progress {
    total: u32,
    terminal: bool,
}

impl Progress {
    fn new(total: u32) -> Progress {
        Progress { total, terminal: std::io::stderr().is_terminal() }
    }

    fn show(&self, done: u32) {
        if !self.terminal {
            return;
        }
        const WIDTH: u32 = 30;
        let filled = (done * WIDTH / self.total) as usize;
        let bar = format!("{}{}", "#".repeat(filled), ".".repeat(WIDTH as usize - filled));
        let _ = write!(std::io::stderr(), "\rrendering [{bar}] {done}/{}", self.total);
    }

    fn finish(&self, out: &std::path::Path) {
        if self.terminal {
            eprintln!();
        }
        eprintln!("wrote {} ({} frames)", out.display(), self.total);
    }
}
