//! Headless screenshots: stage a scene in an `App` (spawn it, pick or frame a camera), render N
//! fixed-step frames offscreen, read the pixels back. `penumbra render`, the golden-image tests
//! and users' own screenshot tests all go through here, so they see the same frame.

use bevy_ecs::prelude::*;
use penumbra_engine::animation::{AnimationPlayer, PlayerError};
use penumbra_engine::components::{Camera, Exposure};
use penumbra_engine::framing::{framing_camera_from, world_bounds};
use penumbra_engine::import::{GltfCamera, SpawnScene};
use penumbra_engine::{App, CorePlugin, Time};

use crate::renderer::{Renderer, RendererError};
use crate::{RenderOutput, RenderPlugin};

#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum CameraChoice {
    /// Frame the scene's bounds from +Z.
    #[default]
    Auto,
    /// Frame the scene's bounds from a direction: `yaw` degrees about +Y from +Z towards +X,
    /// then `pitch` degrees up.
    Orbit { yaw: f32, pitch: f32 },
    /// The file's camera with this index.
    Gltf(usize),
}

#[derive(Debug, Clone)]
pub struct ShotSettings {
    /// `None`: 512 pixels high, as wide as the camera's aspect ratio asks (square otherwise).
    pub size: Option<(u32, u32)>,
    pub camera: CameraChoice,
    /// Overrides the camera's exposure.
    pub exposure_ev100: Option<f32>,
    /// Poses an animated scene at one time of one clip (paused there). `None`: the scene as
    /// spawned, its first clip playing from time 0 with the fixed step.
    pub animation: Option<AnimationShot>,
    /// KHR_materials_variants: the material variant to show (`None`: each primitive's own).
    pub variant: Option<String>,
}

/// Which animation pose a screenshot shows.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AnimationShot {
    /// A clip's name or index; `None` keeps the active clip (the first).
    pub clip: Option<String>,
    /// Seconds into the clip.
    pub time: f32,
}

impl Default for ShotSettings {
    fn default() -> Self {
        Self { size: None, camera: CameraChoice::Auto, exposure_ev100: None, animation: None, variant: None }
    }
}

/// Largest texture dimension wgpu guarantees on desktop GPUs (and lavapipe's limit).
pub const MAX_SIZE: u32 = 16384;
/// EV100 far outside any real scene (a moonless night is about −3, noon sun 15).
pub const EV100_RANGE: std::ops::RangeInclusive<f32> = -30.0..=40.0;

#[derive(Debug, thiserror::Error)]
pub enum ShotError {
    #[error("--camera {index}: the scene has {count} camera(s){}", if *.count > 0 { format!(" (valid: 0..{})", .count - 1) } else { String::new() })]
    NoSuchCamera { index: usize, count: usize },
    #[error("--size {0}x{1}: each side must be between 1 and {MAX_SIZE}")]
    Size(u32, u32),
    #[error(
        "the camera's aspect ratio {aspect} gives no image of at most {MAX_SIZE} pixels a side with both sides at least 1; give --size WxH"
    )]
    DerivedSize { aspect: f32 },
    #[error("--exposure {0}: must be a finite EV100 between {lo} and {hi}", lo = EV100_RANGE.start(), hi = EV100_RANGE.end())]
    Exposure(f32),
    #[error("--animation/--time: {0}")]
    Animation(#[from] PlayerError),
    #[error("--animation/--time: the scene has no animations")]
    NoAnimations,
    #[error(transparent)]
    Variant(#[from] penumbra_engine::variants::VariantError),
    #[error(transparent)]
    Render(#[from] RendererError),
}

impl ShotSettings {
    pub fn validate(&self) -> Result<(), ShotError> {
        if let Some((w, h)) = self.size
            && !((1..=MAX_SIZE).contains(&w) && (1..=MAX_SIZE).contains(&h))
        {
            return Err(ShotError::Size(w, h));
        }
        if let Some(ev) = self.exposure_ev100
            && !(ev.is_finite() && EV100_RANGE.contains(&ev))
        {
            return Err(ShotError::Exposure(ev));
        }
        Ok(())
    }
}

/// An app with the scene spawned and one active camera; returns it with the output size.
pub fn stage_scene(scene: &impl SpawnScene, settings: &ShotSettings) -> Result<(App, (u32, u32)), ShotError> {
    settings.validate()?;
    let mut app = App::new();
    app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
    app.insert_resource(Time::fixed_hz(60.0));
    let root = scene.spawn(&mut app.world);
    if let Some(shot) = &settings.animation {
        pose_animation(&mut app.world, root, shot)?;
    }
    if let Some(name) = &settings.variant {
        penumbra_engine::variants::select_variant(&mut app.world, root, name)?;
    }
    // One update without a renderer: transforms propagate, nothing is drawn.
    app.update();
    let size = stage_camera(&mut app, settings)?;
    Ok((app, size))
}

/// Pauses the scene's player at `shot`'s clip and time.
pub fn pose_animation(world: &mut World, root: Entity, shot: &AnimationShot) -> Result<(), ShotError> {
    let mut player = world.get_mut::<AnimationPlayer>(root).ok_or(ShotError::NoAnimations)?;
    if let Some(clip) = &shot.clip {
        match clip.parse::<usize>() {
            Ok(index) => player.play(index)?,
            Err(_) => player.play_named(clip)?,
        };
    }
    player.pause();
    // Held, not looped: `--time` at the clip's end shows its last pose, not its first.
    player.set_repeat(penumbra_engine::animation::Repeat::Once);
    player.seek(shot.time)?;
    Ok(())
}

/// Chooses (or frames) the camera in an already-updated app; returns the output size.
pub fn stage_camera(app: &mut App, settings: &ShotSettings) -> Result<(u32, u32), ShotError> {
    let world = &mut app.world;
    let default_height = 512;
    let size = match settings.camera {
        CameraChoice::Gltf(index) => {
            let mut q = world.query::<(&mut Camera, &GltfCamera)>();
            let count = q.iter(world).count();
            let mut found = None;
            for (mut cam, g) in q.iter_mut(world) {
                cam.is_active = g.index == index;
                if g.index == index {
                    found = Some(g.aspect_ratio);
                }
            }
            let aspect = found.ok_or(ShotError::NoSuchCamera { index, count })?.unwrap_or(1.0);
            match settings.size {
                Some(size) => size,
                None => size_for_aspect(default_height, aspect)?,
            }
        }
        CameraChoice::Auto | CameraChoice::Orbit { .. } => {
            let size = settings.size.unwrap_or((default_height, default_height));
            let bounds = world_bounds(world);
            let direction = match settings.camera {
                CameraChoice::Orbit { yaw, pitch } => {
                    let (yaw, pitch) = (yaw.to_radians(), pitch.to_radians());
                    glam::Vec3::new(yaw.sin() * pitch.cos(), pitch.sin(), yaw.cos() * pitch.cos())
                }
                _ => glam::Vec3::Z,
            };
            let (camera, transform) =
                framing_camera_from(&bounds, direction, 45f32.to_radians(), size.0 as f32 / size.1 as f32);
            world.spawn((camera, transform));
            size
        }
    };
    if let Some(ev100) = settings.exposure_ev100 {
        let mut q = world.query::<&mut Camera>();
        for mut c in q.iter_mut(world) {
            c.exposure = Exposure { ev100 };
        }
    }
    Ok(size)
}

/// The default output size for a camera of `aspect` (width / height): `height` tall, or, where
/// the width would pass [`MAX_SIZE`], as wide as that and as tall as the aspect gives. An aspect
/// so extreme that a side rounds to 0 pixels is an error asking for `--size`.
pub fn size_for_aspect(height: u32, aspect: f32) -> Result<(u32, u32), ShotError> {
    let bad = || ShotError::DerivedSize { aspect };
    if !(aspect.is_finite() && aspect > 0.0) {
        return Err(bad());
    }
    let (w, h) = (height as f64 * aspect as f64, height as f64);
    let fit = (MAX_SIZE as f64 / w).min(MAX_SIZE as f64 / h).min(1.0);
    let (w, h) = ((w * fit).round(), (h * fit).round());
    if w < 1.0 || h < 1.0 {
        return Err(bad());
    }
    Ok((w as u32, h as u32))
}

/// Renders `frames` fixed-step updates of a staged app and returns the last frame's RGBA8, or
/// the shader error that left something out of it ([`Renderer::read_frame`]).
pub fn render_frames(app: &mut App, renderer: Renderer, size: (u32, u32), frames: u32) -> Result<Vec<u8>, ShotError> {
    app.insert_resource(renderer);
    app.insert_resource(RenderOutput::Headless { width: size.0, height: size.1 });
    for _ in 0..frames.max(1) {
        app.update();
    }
    Ok(app.world.resource::<Renderer>().read_frame()?)
}

/// Runs a scripted app headless: `frames` fixed-step updates rendered offscreen at `size`,
/// saving the frames listed in `screenshots` as PNGs. Add it as a plugin and call `App::run`
/// (the same program can add a window runner instead), or call [`HeadlessRunner::run_on`] to
/// get the pixels back in a test.
#[derive(Debug, Clone)]
pub struct HeadlessRunner {
    pub size: (u32, u32),
    pub frames: u32,
    /// Fixed step, updates per second.
    pub hz: f64,
    /// (frame number from 1, file): frames to save.
    pub screenshots: Vec<(u32, std::path::PathBuf)>,
    pub settings: crate::RenderSettings,
}

impl Default for HeadlessRunner {
    /// One frame at 640×360, stepped at 60 Hz, nothing saved.
    fn default() -> Self {
        Self { size: (640, 360), frames: 1, hz: 60.0, screenshots: Vec::new(), settings: Default::default() }
    }
}

impl HeadlessRunner {
    /// Renders `frames` frames and saves the last one to `out`.
    pub fn screenshot(out: impl Into<std::path::PathBuf>, size: (u32, u32), frames: u32) -> Self {
        let frames = frames.max(1);
        Self { size, frames, screenshots: vec![(frames, out.into())], ..Default::default() }
    }

    /// Runs the frames on `app` and returns the RGBA8 pixels of each listed screenshot frame, in
    /// order (the files are written too).
    pub fn run_on(&self, app: &mut App) -> Result<Vec<Vec<u8>>, HeadlessError> {
        let (w, h) = self.size;
        ShotSettings { size: Some(self.size), ..Default::default() }.validate()?;
        if !(self.hz.is_finite() && self.hz > 0.0) {
            return Err(HeadlessError::Step(self.hz));
        }
        if !app.world.contains_resource::<Renderer>() {
            let ctx = crate::GpuContext::new_headless(&crate::AdapterRequest::default())?;
            app.insert_resource(Renderer::new(ctx, self.settings.clone()).map_err(ShotError::from)?);
        }
        app.insert_resource(Time::fixed_hz(self.hz));
        app.insert_resource(RenderOutput::Headless { width: w, height: h });
        let mut shots = Vec::new();
        // A screenshot asked for after `frames` extends the run to it rather than going missing.
        let last = self.screenshots.iter().map(|(f, _)| *f).max().unwrap_or(0).max(self.frames).max(1);
        for frame in 1..=last {
            app.update();
            for (_, path) in self.screenshots.iter().filter(|(f, _)| *f == frame) {
                let pixels = app.world.resource::<Renderer>().read_frame().map_err(ShotError::from)?;
                penumbra_engine::output::save_image(path, &pixels, (w, h), image::ExtendedColorType::Rgba8)
                    .map_err(|e| HeadlessError::Write { path: path.clone(), reason: e.reason })?;
                shots.push(pixels);
            }
        }
        Ok(shots)
    }
}

#[derive(Debug, thiserror::Error)]
pub enum HeadlessError {
    #[error(transparent)]
    Shot(#[from] ShotError),
    #[error(transparent)]
    Context(#[from] crate::ContextError),
    #[error("the headless step must be a positive number of updates per second, not {0}")]
    Step(f64),
    #[error("cannot write {}: {reason}", path.display())]
    Write { path: std::path::PathBuf, reason: String },
}

impl penumbra_engine::Plugin for HeadlessRunner {
    fn build(&self, app: &mut App) {
        let runner = self.clone();
        app.set_runner(move |mut app| {
            if let Err(e) = runner.run_on(&mut app) {
                eprintln!("error: {e}");
                std::process::exit(1);
            }
            for (_, path) in &runner.screenshots {
                println!("wrote {}", path.display());
            }
        });
    }
}
