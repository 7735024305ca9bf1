//! Headless screenshots: stage a scene in an `App` (spawn it, pick or frame a camera), render N
//! fixed-step frames offscreen, read the pixels back. `penumbra render`, the golden-image tests
//! and users' own screenshot tests all go through here, so they see the same frame.

use bevy_ecs::prelude::*;
use penumbra_engine::animation::{AnimationPlayer, PlayerError};
use penumbra_engine::bounds::Aabb;
use penumbra_engine::components::{Camera, Exposure, GlobalTransform};
use penumbra_engine::environment::Environment;
use penumbra_engine::framing::{framing_camera_from, world_bounds};
use penumbra_engine::import::{GltfCamera, SpawnScene};
use penumbra_engine::{App, CorePlugin, Time};

use crate::metering::ExposureChoice;
use crate::renderer::{Renderer, RendererError};
use crate::{RenderOutput, RenderPlugin};

#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum CameraChoice {
    /// The file's first camera where it has one that sees the scene; otherwise the scene's
    /// bounds framed from [`CameraChoice::THREE_QUARTER`] (over the whole first clip for an
    /// animated scene).
    #[default]
    Auto,
    /// Frame the scene's bounds from a direction: `yaw` degrees about +Y from +Z towards +X,
    /// then `pitch` degrees up.
    Orbit { yaw: f32, pitch: f32 },
    /// The file's camera with this index.
    Gltf(usize),
}

impl CameraChoice {
    /// The default framing: turned 35° from the front (+Z) towards +X and 25° above, the view
    /// sample-model screenshots use. No axis-aligned plane is seen edge-on from it (the
    /// flattest, a plane lying in XZ, shows 42 % of its depth; one facing ±X shows 52 %).
    pub const THREE_QUARTER: CameraChoice = CameraChoice::Orbit { yaw: 35.0, pitch: 25.0 };
    /// Straight from the front, looking down −Z.
    pub const FRONT: CameraChoice = CameraChoice::Orbit { yaw: 0.0, pitch: 0.0 };
}

/// How the staged camera and its exposure were chosen, for `--explain` and the viewer's
/// Stats panel. [`stage_camera`] inserts it as a resource.
#[derive(Resource, Debug, Clone, PartialEq)]
pub struct StagedView {
    pub camera: ViewSource,
    pub exposure: ExposureChoice,
    /// The bounds the view was framed on and metered at (over the first clip for an
    /// animated scene).
    pub bounds: Aabb,
}

/// Where the staged view looks from.
#[derive(Debug, Clone, PartialEq)]
pub enum ViewSource {
    /// A file camera: its glTF index, node name, the number the file has, and whether it was
    /// asked for (`--camera N`) rather than picked by default.
    File { index: usize, name: Option<String>, count: usize, asked: bool },
    /// The scene's bounds framed from a direction, and why not a file camera.
    Framed { yaw: f32, pitch: f32, why: &'static str },
}

impl std::fmt::Display for ViewSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ViewSource::File { index, name, count, asked } => {
                write!(f, "the file's camera {index}")?;
                if let Some(name) = name {
                    write!(f, " \"{name}\"")?;
                }
                let how = if *asked {
                    "asked for"
                } else {
                    "the file's first; --camera orbit:YAW:PITCH frames the scene instead"
                };
                write!(f, " ({how}; the file has {count})")
            }
            ViewSource::Framed { yaw, pitch, why } => {
                write!(f, "the scene framed from yaw {yaw}°, pitch {pitch}° ({why})")
            }
        }
    }
}

#[derive(Debug, Clone)]
pub struct ShotSettings {
    /// `None`: 512 pixels high, as wide as the camera's aspect ratio asks (square otherwise).
    pub size: Option<(u32, u32)>,
    pub camera: CameraChoice,
    /// The exposure, EV100. `None`: metered from the scene's lights ([`crate::metering`]),
    /// EV100 0 for a scene without lights.
    pub exposure_ev100: Option<f32>,
    /// The environment to stage the scene in (metering counts its light).
    pub environment: Option<Environment>,
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
        Self {
            size: None,
            camera: CameraChoice::Auto,
            exposure_ev100: None,
            environment: None,
            animation: None,
            variant: None,
        }
    }
}

/// Largest texture dimension wgpu guarantees on desktop GPUs (and lavapipe's limit).
pub const MAX_SIZE: u32 = 16384;
pub use crate::metering::EV100_RANGE;

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
    let size = stage_into(&mut app, scene, settings)?;
    Ok((app, size))
}

/// What staging spawned into an app, for [`SceneBatch`] to take away before the next scene.
#[derive(Resource)]
struct Staged {
    root: Entity,
}

/// The camera [`stage_camera`] spawned to frame the scene (not one of the file's).
#[derive(Component)]
struct FramingCamera;

/// Spawns `scene` into `app` as `settings` ask and stages its camera (see [`stage_scene`]).
fn stage_into(app: &mut App, scene: &impl SpawnScene, settings: &ShotSettings) -> Result<(u32, u32), ShotError> {
    app.insert_resource(Time::fixed_hz(60.0));
    let root = scene.spawn(&mut app.world);
    app.insert_resource(Staged { root });
    if let Some(shot) = &settings.animation {
        pose_animation(&mut app.world, root, shot)?;
    }
    if let Some(name) = &settings.variant {
        penumbra_engine::variants::select_variant(&mut app.world, root, name)?;
    }
    // Left alone where it is the same: the renderer keeps the maps it made from it.
    if app.world.get_resource::<Environment>() != settings.environment.as_ref() {
        match &settings.environment {
            Some(env) => app.world.insert_resource(env.clone()),
            None => drop(app.world.remove_resource::<Environment>()),
        }
    }
    // One update without a renderer (callers stage before inserting it): transforms propagate,
    // nothing is drawn.
    app.update();
    stage_camera(app, settings)
}

/// Screenshots of many scenes on one device and one renderer: the way screenshot-test suites and
/// asset pipelines render thousands of files. The first scene is staged as [`stage_scene`]
/// stages it; each later one replaces it in the same app (the previous scene unloaded with its
/// assets, `import::unload_scene`), so the renderer keeps its device, its compiled pipelines and,
/// where the environment is the same, the maps made from it, and frees and uploads only what the
/// scenes do not share. Each image is what a fresh [`stage_scene`] and [`render_frames`] of the
/// scene gives: what frames carry into the next (automatic exposure's adaptation) is forgotten
/// between scenes.
pub struct SceneBatch {
    app: Option<App>,
    renderer: Option<Renderer>,
}

impl SceneBatch {
    pub fn new(renderer: Renderer) -> Self {
        Self { app: None, renderer: Some(renderer) }
    }

    /// Stages `scene` as `shot` asks, renders `frames` fixed-step frames and returns the last
    /// one's RGBA8 pixels and size. A scene that fails to stage (a missing camera, clip or
    /// variant) leaves the batch ready for the next.
    pub fn render(
        &mut self,
        scene: &impl SpawnScene,
        shot: &ShotSettings,
        frames: u32,
    ) -> Result<(Vec<u8>, (u32, u32)), ShotError> {
        shot.validate()?;
        let app = self.app.get_or_insert_with(|| {
            let mut app = App::new();
            app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
            app
        });
        let mut renderer = match self.renderer.take() {
            Some(renderer) => renderer,
            None => app.world.remove_resource::<Renderer>().expect("the batch holds its renderer"),
        };
        renderer.restart_history();
        if let Some(staged) = app.world.remove_resource::<Staged>() {
            penumbra_engine::import::unload_scene(&mut app.world, staged.root);
            // A root without scene assets (a scene type that records none) still goes.
            let _ = app.world.try_despawn(staged.root);
        }
        let framing: Vec<Entity> = app.world.query_filtered::<Entity, With<FramingCamera>>().iter(&app.world).collect();
        for entity in framing {
            app.world.despawn(entity);
        }
        app.world.remove_resource::<StagedView>();
        let size = match stage_into(app, scene, shot) {
            Ok(size) => size,
            Err(e) => {
                self.renderer = Some(renderer);
                return Err(e);
            }
        };
        let pixels = render_frames(app, renderer, size, frames)?;
        Ok((pixels, size))
    }

    /// The app the last scene was staged in (its [`StagedView`] and renderer, for `--explain`).
    pub fn app(&self) -> Option<&App> {
        self.app.as_ref()
    }
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

/// Chooses (or frames) the camera in an already-updated app and sets its exposure; returns the
/// output size. Records the choices as the [`StagedView`] resource.
pub fn stage_camera(app: &mut App, settings: &ShotSettings) -> Result<(u32, u32), ShotError> {
    let default_height = 512;
    let cameras = file_cameras(&mut app.world);
    let bounds = framing_bounds(app, settings);
    let world = &mut app.world;
    let (choice, why) = match settings.camera {
        CameraChoice::Auto => auto_camera(world, &cameras, &bounds),
        c => (c, "--camera"),
    };
    let (size, view, metered_cameras) = match choice {
        CameraChoice::Gltf(index) => {
            let mut found = None;
            for &(i, entity, aspect) in &cameras {
                if let Some(mut cam) = world.get_mut::<Camera>(entity) {
                    cam.is_active = i == index;
                }
                if i == index {
                    found = Some((entity, aspect));
                }
            }
            let (entity, aspect) = found.ok_or(ShotError::NoSuchCamera { index, count: cameras.len() })?;
            let size = match settings.size {
                Some(size) => size,
                None => size_for_aspect(default_height, aspect.unwrap_or(1.0))?,
            };
            let name = world.get::<penumbra_engine::components::Name>(entity).map(|n| n.as_str().to_owned());
            let asked = settings.camera != CameraChoice::Auto;
            let view = ViewSource::File { index, name, count: cameras.len(), asked };
            (size, view, cameras.iter().map(|c| c.1).collect::<Vec<_>>())
        }
        CameraChoice::Auto | CameraChoice::Orbit { .. } => {
            let (yaw, pitch) = match choice {
                CameraChoice::Orbit { yaw, pitch } => (yaw, pitch),
                _ => (0.0, 0.0),
            };
            let size = settings.size.unwrap_or((default_height, default_height));
            let (y, p) = (yaw.to_radians(), pitch.to_radians());
            let direction = glam::Vec3::new(y.sin() * p.cos(), p.sin(), y.cos() * p.cos());
            let (camera, transform) =
                framing_camera_from(&bounds, direction, 45f32.to_radians(), size.0 as f32 / size.1 as f32);
            let entity = world.spawn((camera, transform, FramingCamera)).id();
            let mut all = vec![entity];
            all.extend(cameras.iter().map(|c| c.1));
            (size, ViewSource::Framed { yaw, pitch, why }, all)
        }
    };
    let exposure = match settings.exposure_ev100 {
        Some(ev100) => ExposureChoice::Given { ev100 },
        None => match crate::metering::meter(world, &bounds) {
            Some(m) => ExposureChoice::Metered(m),
            None => ExposureChoice::Unlit,
        },
    };
    // Authored cameras keep their exposure unless one is given; glTF cameras carry none, so
    // they and the framing camera take the chosen one.
    let given = settings.exposure_ev100.is_some();
    let mut q = world.query::<(Entity, &mut Camera)>();
    for (e, mut c) in q.iter_mut(world) {
        if given || metered_cameras.contains(&e) {
            c.exposure = Exposure { ev100: exposure.ev100() };
        }
    }
    world.insert_resource(StagedView { camera: view, exposure, bounds });
    Ok(size)
}

/// What [`CameraChoice::Auto`] picks: the file's first camera where it sees any of `bounds`,
/// else the three-quarter framing (and why).
fn auto_camera(world: &World, cameras: &[(usize, Entity, Option<f32>)], bounds: &Aabb) -> (CameraChoice, &'static str) {
    match cameras.first() {
        Some(&(index, entity, aspect)) if sees(world, entity, aspect.unwrap_or(1.0), bounds) => {
            (CameraChoice::Gltf(index), "")
        }
        Some(&(index, ..)) => {
            tracing::warn!("the file's camera {index} sees none of the scene: framing the scene instead");
            (CameraChoice::THREE_QUARTER, "the file's camera sees none of the scene")
        }
        None => (CameraChoice::THREE_QUARTER, "the file has no camera"),
    }
}

/// The file camera [`CameraChoice::Auto`] would look through in an app [`stage_camera`]
/// staged, if any (the viewer offers it first while keeping its own orbit camera): the same
/// choice, on the bounds staging framed.
pub fn default_file_camera(app: &mut App) -> Option<usize> {
    let cameras = file_cameras(&mut app.world);
    if cameras.is_empty() {
        return None;
    }
    let bounds = match app.world.get_resource::<StagedView>() {
        Some(view) => view.bounds,
        None => world_bounds(&mut app.world),
    };
    match auto_camera(&app.world, &cameras, &bounds).0 {
        CameraChoice::Gltf(index) => Some(index),
        _ => None,
    }
}

/// The file's cameras: glTF index, entity and aspect ratio, in index order.
fn file_cameras(world: &mut World) -> Vec<(usize, Entity, Option<f32>)> {
    let mut q = world.query::<(Entity, &GltfCamera)>();
    let mut v: Vec<_> = q.iter(world).map(|(e, g)| (g.index, e, g.aspect_ratio)).collect();
    v.sort_by_key(|c| c.0);
    v
}

/// Whether `bounds` can be in `camera`'s view at the aspect ratio it will render at: the box
/// is outside only where all its corners lie beyond one plane of the view volume (x and y within
/// ±w, depth between the near plane and the far one, in reverse-Z clip space), for perspective
/// and orthographic cameras alike.
fn sees(world: &World, camera: Entity, aspect: f32, bounds: &Aabb) -> bool {
    let (Some(cam), Some(g)) = (world.get::<Camera>(camera), world.get::<GlobalTransform>(camera)) else {
        return false;
    };
    if bounds.is_empty() {
        return true;
    }
    let view_from_world = glam::Affine3A::from_rotation_translation(g.rotation(), g.translation()).inverse();
    let clip_from_view = cam.projection.clip_from_view(aspect);
    let (c, h) = (bounds.center(), bounds.half_extents());
    let corners: Vec<glam::Vec4> = (0..8)
        .map(|i| c + h * glam::Vec3::new(sign(i & 1), sign(i & 2), sign(i & 4)))
        .map(|p| clip_from_view * view_from_world.transform_point3(p).extend(1.0))
        .collect();
    let planes: [fn(&glam::Vec4) -> bool; 6] =
        [|v| v.x <= v.w, |v| -v.x <= v.w, |v| v.y <= v.w, |v| -v.y <= v.w, |v| v.z <= v.w, |v| v.z >= 0.0];
    planes.iter().all(|inside| corners.iter().any(inside))
}

fn sign(bit: u32) -> f32 {
    if bit == 0 { -1.0 } else { 1.0 }
}

/// Intervals a clip is cut into when framing an animated scene (poses at both ends count).
const FRAMING_SAMPLES: u32 = 16;

/// The bounds to frame: the scene as staged, or, for a scene whose first clip plays, the union
/// of its poses at [`FRAMING_SAMPLES`] + 1 times over the clip (a walk cycle that leaves its rest
/// pose stays in the frame). The player is put back where it was.
fn framing_bounds(app: &mut App, settings: &ShotSettings) -> Aabb {
    let mut bounds = world_bounds(&mut app.world);
    if settings.animation.is_some() {
        return bounds;
    }
    let mut q = app.world.query::<(Entity, &AnimationPlayer)>();
    let players: Vec<(Entity, f32, f32, bool)> = q
        .iter(&app.world)
        .filter_map(|(e, p)| Some((e, p.active_clip()?.duration(), p.time(), p.is_paused())))
        .filter(|(_, duration, ..)| *duration > 0.0 && duration.is_finite())
        .collect();
    if players.is_empty() {
        return bounds;
    }
    // Sampling updates take no time: the clock ends where it was.
    let saved = app.world.resource::<Time>().clone();
    app.world.resource_mut::<Time>().set_mode(penumbra_engine::TimeMode::Fixed(std::time::Duration::ZERO));
    for k in 0..=FRAMING_SAMPLES {
        for &(e, duration, ..) in &players {
            if let Some(mut p) = app.world.get_mut::<AnimationPlayer>(e) {
                p.pause();
                let _ = p.seek(duration * k as f32 / FRAMING_SAMPLES as f32);
            }
        }
        app.update();
        bounds = bounds.union(&world_bounds(&mut app.world));
    }
    for &(e, _, time, paused) in &players {
        if let Some(mut p) = app.world.get_mut::<AnimationPlayer>(e) {
            let _ = p.seek(time);
            if !paused {
                p.resume();
            }
        }
    }
    // Posed where it was, then the clock put back.
    app.update();
    *app.world.resource_mut::<Time>() = saved;
    bounds
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

    /// A [`SceneBatch`] on a new headless device with this runner's render settings, for
    /// screenshots of many scene files in one process ([`SceneBatch::render`] each).
    pub fn scene_batch(&self) -> Result<SceneBatch, HeadlessError> {
        let ctx = crate::GpuContext::new_headless(&crate::AdapterRequest::default())?;
        Ok(SceneBatch::new(Renderer::new(ctx, self.settings.clone()).map_err(ShotError::from)?))
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
