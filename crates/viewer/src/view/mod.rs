//! `penumbra view`: the interactive viewer. A winit window; the scene drawn by the renderer
//! into the swap-chain image; the egui overlay ([`overlay`], [`panels`]) drawn over it.
//!
//! Each frame: a finished background load ([`loader`]) replaces the scene ([`staged`]); input
//! moves the orbit camera's goal and the camera eases towards it ([`orbit`]); axes and the
//! selection box become gizmo lines ([`gizmos`]); `App::update`
//! runs the schedules (extraction included); the renderer draws the extracted scene; an F12
//! screenshot copies that image before the overlay draws ([`screenshot`]); the overlay's
//! actions are carried out. Resizes reconfigure the surface at the window's physical size; a
//! 0×0 (minimised) window skips frames.

mod gizmos;
mod loader;
mod orbit;
mod overlay;
mod panels;
mod recent;
mod screenshot;
mod staged;
mod ui_state;

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use bevy_ecs::world::Mut;
use glam::Vec2;
use penumbra_engine::components::GlobalTransform;
use penumbra_engine::import::SceneFile;
use penumbra_render::{GpuContext, RenderScene, RenderSettings, Renderer};
use penumbra_viewer::surface::WindowSurface;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, ModifiersState, NamedKey};
use winit::window::{Window, WindowId};

use crate::cli::ViewArgs;
use loader::Loader;
use orbit::OrbitState;
use overlay::Overlay;
use recent::RecentFiles;
use screenshot::Screenshots;
use staged::{FirstLook, Staged};
use ui_state::{Action, FrameInfo, UiState};

pub fn run(args: ViewArgs) -> Result<()> {
    #[cfg(all(unix, not(target_os = "macos")))]
    if std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none() {
        bail!(
            "no display: DISPLAY and WAYLAND_DISPLAY are unset, so `penumbra view` cannot open a window. \
             For a headless screenshot use `penumbra render SCENE --out shot.png`"
        );
    }
    // Running from a checkout: watch its shaders so edits show up live.
    let settings = args.look.render_settings(true, crate::cli::repository_shaders())?;
    // Flags are checked before the window opens, so a bad one is an error line, not a window.
    args.look.environment()?;
    let event_loop = EventLoop::new().map_err(|e| {
        anyhow!("cannot open a window ({e}). For a headless screenshot use `penumbra render SCENE --out shot.png`")
    })?;
    let mut viewer = Viewer { args, settings, running: None, error: None };
    event_loop.run_app(&mut viewer).context("window event loop")?;
    match viewer.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

struct Viewer {
    args: ViewArgs,
    settings: RenderSettings,
    running: Option<Running>,
    error: Option<anyhow::Error>,
}

#[derive(Default)]
struct Input {
    cursor: Vec2,
    left: bool,
    middle: bool,
    right: bool,
    modifiers: ModifiersState,
    /// Where the left button went down, and whether the pointer has moved since (a click
    /// selects; a drag orbits).
    press: Option<(Vec2, bool)>,
    last_click: Option<(Instant, Vec2)>,
}

/// Smoothed frame rate for the stats panel.
struct FrameClock {
    last: Instant,
    window_start: Instant,
    frames: u32,
    fps: f32,
    frame_ms: f32,
}

struct Running {
    surface: WindowSurface,
    ctx: GpuContext,
    scene: Option<Staged>,
    loader: Option<Loader>,
    /// The first load's failure ends the viewer (there is no scene to keep showing).
    first_load: bool,
    input: Input,
    clock: FrameClock,
    overlay: Overlay,
    ui: UiState,
    recent: RecentFiles,
    screenshots: Screenshots,
    screenshot_requested: bool,
    can_copy_surface: bool,
    settings: RenderSettings,
    /// Spaces out attempts to replace a lost device.
    device_retry: penumbra_render::RetryBackoff,
}

impl Viewer {
    fn start(&mut self, event_loop: &ActiveEventLoop) -> Result<Running> {
        let title = "penumbra".to_owned();
        let (w, h) = self.args.size;
        let attributes =
            Window::default_attributes().with_title(title).with_inner_size(winit::dpi::LogicalSize::new(w, h));
        // egui blends in gamma space, so it draws through a non-sRGB view of the same image.
        let (surface, ctx) = WindowSurface::new(event_loop, attributes, !self.args.no_vsync, true)?;
        let overlay = Overlay::new(&surface.window, &ctx.device, surface.config.format.remove_srgb_suffix());
        let now = Instant::now();
        let screenshot_dir = self.args.screenshot_dir.clone().unwrap_or_else(|| PathBuf::from("."));
        Ok(Running {
            can_copy_surface: surface.config.usage.contains(wgpu::TextureUsages::COPY_SRC),
            surface,
            ctx,
            scene: None,
            loader: Some(Loader::start(self.args.path.as_deref(), &self.args.scene_args)),
            first_load: true,
            input: Input::default(),
            clock: FrameClock { last: now, window_start: now, frames: 0, fps: 0.0, frame_ms: 0.0 },
            overlay,
            ui: UiState::new(!self.args.no_vsync),
            recent: RecentFiles::load(),
            screenshots: Screenshots::new(screenshot_dir),
            screenshot_requested: false,
            settings: self.settings.clone(),
            device_retry: Default::default(),
        })
    }
}

impl Running {
    /// Takes a finished load: a new scene replaces the current one; a failure leaves it.
    fn poll_loader(&mut self, args: &ViewArgs) -> Result<()> {
        let Some(outcome) = self.loader.as_ref().and_then(Loader::poll) else { return Ok(()) };
        let loader = self.loader.take().expect("polled");
        let first = std::mem::replace(&mut self.first_load, false);
        let imported = loader.started.elapsed().as_secs_f32();
        let staging = Instant::now();
        let staged =
            outcome.map_err(anyhow::Error::msg).and_then(|file| self.stage(&file, loader.path.clone(), args, first));
        match staged {
            Ok(staged) => {
                // The import ran beside the window; staging (spawning, the renderer) blocks it.
                let staged_in = staging.elapsed().as_secs_f32();
                tracing::info!("loaded {}: imported in {imported:.2} s, staged in {staged_in:.2} s", staged.name);
                if let Some(p) = &staged.path {
                    self.recent.add(p);
                }
                self.surface.window.set_title(&format!("penumbra — {}", staged.name));
                self.ui.selected = None;
                self.ui.load_error = None;
                self.scene = Some(staged);
                Ok(())
            }
            Err(e) if first => Err(e),
            Err(e) => {
                tracing::error!("{e:#}");
                self.ui.load_error = Some(format!("{e:#}"));
                Ok(())
            }
        }
    }

    fn stage(&mut self, file: &SceneFile, path: Option<PathBuf>, args: &ViewArgs, first: bool) -> Result<Staged> {
        for w in file_warnings(file) {
            tracing::warn!("{w}");
        }
        // Command-line camera, exposure and variant apply to the first scene; later ones are
        // framed and show their own materials.
        let look = if first {
            FirstLook {
                camera: args.camera,
                exposure_ev100: args.look.exposure_ev100(),
                variant: args.scene_args.variant.clone(),
            }
        } else {
            FirstLook::default()
        };
        // The environment carries over from the scene before (the panel may have changed it).
        let env = match &self.scene {
            Some(s) => s.app.world.get_resource().cloned(),
            None => args.look.environment()?,
        };
        let renderer = Renderer::new(self.ctx.clone(), self.settings.clone())?;
        Staged::new(file, path, look, env, self.surface.size(), renderer)
    }

    fn open(&mut self, path: PathBuf, args: &ViewArgs) {
        if let Some(l) = &self.loader {
            self.ui.set_status(format!("still loading {}", l.name()));
            return;
        }
        self.loader = Some(Loader::start(Some(&path), &args.scene_args));
    }

    /// After a device loss: a new device for the window, the UI's GPU side made again, and the
    /// scene's renderer moved onto it (it rebuilds every GPU resource from the render world).
    fn replace_device(&mut self) -> Result<()> {
        let ctx = self.surface.replace_device()?;
        self.overlay = Overlay::new(&self.surface.window, &ctx.device, self.surface.config.format.remove_srgb_suffix());
        if let Some(s) = self.scene.as_mut() {
            s.app.world.resource_mut::<Renderer>().replace_device(ctx.clone())?;
        }
        self.can_copy_surface = self.surface.config.usage.contains(wgpu::TextureUsages::COPY_SRC);
        self.ctx = ctx;
        Ok(())
    }

    fn frame(&mut self, args: &ViewArgs, event_loop: &ActiveEventLoop) -> Result<()> {
        // wgpu reports a lost device from its maintenance: poll, then look.
        let _ = self.ctx.device.poll(wgpu::PollType::Poll);
        if self.ctx.is_lost() {
            if !self.device_retry.due() {
                // Without a device nothing presents, so nothing paces the loop: wait a little.
                std::thread::sleep(Duration::from_millis(20));
                return Ok(());
            }
            if let Err(e) = self.replace_device() {
                self.device_retry.failed();
                let wait = self.device_retry.delay();
                tracing::error!("the GPU device was lost and cannot be replaced yet ({e:#}); trying again in {wait:?}");
                return Ok(());
            }
            self.device_retry.reset();
        }
        self.poll_loader(args)?;
        let now = Instant::now();
        let dt = (now - self.clock.last).as_secs_f32();
        self.clock.last = now;
        self.clock.frames += 1;
        let window = now - self.clock.window_start;
        if window >= Duration::from_millis(500) {
            self.clock.fps = self.clock.frames as f32 / window.as_secs_f32();
            self.clock.frame_ms = 1e3 / self.clock.fps.max(1e-3);
            (self.clock.frames, self.clock.window_start) = (0, now);
        }
        for outcome in self.screenshots.finished() {
            match outcome {
                Ok(p) => {
                    tracing::info!("saved screenshot {}", p.display());
                    self.ui.set_status(format!("saved {}", p.display()));
                }
                Err(e) => {
                    tracing::error!("{e}");
                    self.ui.set_status(e);
                }
            }
        }
        if let Some(s) = self.scene.as_mut() {
            s.advance_camera(dt);
            // A screenshot is the scene without the UI: the frame it copies draws no selection
            // box and no axes (they come back the next frame).
            let shot = self.screenshot_requested;
            let request = gizmos::GizmoRequest {
                world_axes: self.ui.world_axes && !shot,
                local_axes: self.ui.local_axes && !shot,
                selected: self.ui.selected.filter(|_| !shot),
                camera: s.camera,
            };
            gizmos::update(&mut s.app.world, &request);
            s.app.update();
        }
        let Some(texture) = self.surface.acquire(&self.ctx.device) else { return Ok(()) };
        let view = texture.texture.create_view(&wgpu::TextureViewDescriptor::default());
        let ui_view = texture.texture.create_view(&wgpu::TextureViewDescriptor {
            format: Some(self.surface.config.format.remove_srgb_suffix()),
            ..Default::default()
        });
        let size = self.surface.size();
        let format = self.surface.config.format;
        let loading = self.loader.as_ref().map(|l| (l.name(), l.progress(), l.started.elapsed().as_secs_f32()));
        let cameras = self.scene.as_ref().map(|s| s.cameras.clone()).unwrap_or_default();
        let through = self.scene.as_ref().and_then(|s| s.through.map(|(i, _)| i));
        let variants = self.scene.as_mut().map(|s| s.variants()).unwrap_or_default();
        let screenshot = std::mem::take(&mut self.screenshot_requested);
        let (overlay, ui, window, screenshots, recent) =
            (&mut self.overlay, &mut self.ui, self.surface.window.clone(), &self.screenshots, &self.recent.paths);
        let (fps, frame_ms) = (self.clock.fps, self.clock.frame_ms);
        let copy = self.can_copy_surface;
        let ctx = self.ctx.clone();
        let actions = match self.scene.as_mut() {
            Some(s) => {
                let name = s.name.clone();
                s.app.world.resource_scope(|world, mut renderer: Mut<Renderer>| {
                    let scene = world.resource::<RenderScene>();
                    renderer.render(scene, &view, format, size);
                    if screenshot {
                        screenshots.capture(&mut renderer, scene, copy.then_some(&texture.texture), size);
                    }
                    let info = FrameInfo {
                        renderer: Some(&renderer),
                        fps,
                        frame_ms,
                        loading,
                        recent,
                        cameras,
                        through,
                        variants,
                        scene_name: &name,
                    };
                    overlay.draw(&window, &ctx.device, &ctx.queue, &ui_view, size, false, ui, Some(world), &info)
                })
            }
            None => {
                let info = FrameInfo {
                    renderer: None,
                    fps,
                    frame_ms,
                    loading,
                    recent,
                    cameras,
                    through,
                    variants,
                    scene_name: "",
                };
                overlay.draw(&window, &ctx.device, &ctx.queue, &ui_view, size, true, ui, None, &info)
            }
        };
        ctx.queue.present(texture);
        for action in actions {
            self.act(action, args, event_loop);
        }
        self.sync_gpu_timing();
        Ok(())
    }

    fn act(&mut self, action: Action, args: &ViewArgs, event_loop: &ActiveEventLoop) {
        let aspect = self.aspect();
        match action {
            Action::Open(path) => self.open(path, args),
            Action::Screenshot => self.screenshot_requested = true,
            Action::Settings(s) => {
                let Some(scene) = self.scene.as_mut() else { return };
                let mut renderer = scene.app.world.resource_mut::<Renderer>();
                match renderer.set_settings(s.clone()) {
                    Ok(()) => self.settings = s,
                    Err(e) => self.ui.set_status(e.to_string()),
                }
            }
            Action::LookThrough(index) => {
                if let Some(s) = self.scene.as_mut()
                    && let Err(e) = s.look_through(index)
                {
                    self.ui.set_status(e.to_string());
                }
            }
            Action::Variant(name) => {
                if let Some(s) = self.scene.as_mut()
                    && let Err(e) = s.select_variant(name.as_deref())
                {
                    self.ui.set_status(e.to_string());
                }
            }
            Action::FrameScene => {
                if let Some(s) = self.scene.as_mut() {
                    s.take_over_file_camera();
                    s.orbit.goal = s.framing_goal(aspect);
                }
            }
            Action::Focus(e) => {
                if let Some(s) = self.scene.as_mut() {
                    let bounds = penumbra_engine::framing::entity_bounds(&s.app.world, e);
                    let center = match bounds {
                        Some(b) => b.center(),
                        None => match s.app.world.get::<GlobalTransform>(e) {
                            Some(g) => g.translation(),
                            None => return,
                        },
                    };
                    s.take_over_file_camera();
                    let eye = s.orbit.goal.transform().translation;
                    s.orbit.goal = OrbitState::looking_at(eye, center);
                }
            }
            Action::Vsync(on) => {
                self.surface.set_vsync(on, &self.ctx.device);
            }
            Action::Quit => event_loop.exit(),
        }
    }

    /// GPU timestamps cost a little, so they run only while the stats panel shows them.
    fn sync_gpu_timing(&mut self) {
        let want = self.ui.show_stats;
        if self.settings.gpu_timing != want {
            self.settings.gpu_timing = want;
            if let Some(s) = self.scene.as_mut() {
                let _ = s.app.world.resource_mut::<Renderer>().set_settings(self.settings.clone());
            }
        }
    }

    fn aspect(&self) -> f32 {
        let (w, h) = self.surface.size();
        w.max(1) as f32 / h.max(1) as f32
    }

    fn on_key(&mut self, key: &Key, event_loop: &ActiveEventLoop, args: &ViewArgs) {
        let ctrl = self.input.modifiers.control_key();
        match key {
            Key::Named(NamedKey::Escape) => event_loop.exit(),
            Key::Named(NamedKey::F1) => self.ui.show_stats ^= true,
            Key::Named(NamedKey::F2) => self.ui.world_axes ^= true,
            Key::Named(NamedKey::F3) => self.ui.local_axes ^= true,
            Key::Named(NamedKey::F12) => self.screenshot_requested = true,
            Key::Character(c) if ctrl && c.eq_ignore_ascii_case("o") => self.ui.open_dialog = true,
            Key::Character(c) if c.eq_ignore_ascii_case("f") => self.act(Action::FrameScene, args, event_loop),
            _ => {}
        }
    }

    fn on_click(&mut self, at: Vec2) {
        let size = self.surface.size();
        let now = Instant::now();
        let double =
            self.input.last_click.is_some_and(|(t, p)| now - t < Duration::from_millis(400) && p.distance(at) < 6.0);
        self.input.last_click = if double { None } else { Some((now, at)) };
        let Some(s) = self.scene.as_mut() else { return };
        let hit = s.pick(at, size);
        // The box round it shows the selection; View > Inspector shows what it is (opening the
        // panel on every click would cover the scene in a small window).
        self.ui.selected = hit.map(|(e, _)| e);
        if double && let Some((_, point)) = hit {
            // Focus: the clicked point becomes the orbit's centre, the camera stays where it is.
            s.take_over_file_camera();
            let eye = s.orbit.goal.transform().translation;
            s.orbit.goal = OrbitState::looking_at(eye, point);
        }
    }
}

fn file_warnings(file: &SceneFile) -> &[String] {
    match file {
        SceneFile::Gltf(g) => &g.warnings,
        SceneFile::Obj(o) => &o.warnings,
    }
}

impl ApplicationHandler for Viewer {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        match self.start(event_loop) {
            Ok(r) => {
                r.surface.window.request_redraw();
                self.running = Some(r);
            }
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(r) = self.running.as_mut() else { return };
        let args = &self.args;
        if r.overlay.on_window_event(&r.surface.window, &event) {
            // egui took it; a button released over a panel still ends a drag.
            if let WindowEvent::MouseInput { state: ElementState::Released, .. } = event {
                (r.input.left, r.input.middle, r.input.right, r.input.press) = (false, false, false, None);
            }
            return;
        }
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => r.surface.resize(size.width, size.height, &r.ctx.device),
            WindowEvent::ModifiersChanged(m) => r.input.modifiers = m.state(),
            WindowEvent::KeyboardInput { event, .. }
                if event.state == ElementState::Pressed && !event.repeat && !r.overlay.wants_keyboard() =>
            {
                r.on_key(&event.logical_key, event_loop, args);
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let down = state == ElementState::Pressed;
                match button {
                    MouseButton::Left => {
                        r.input.left = down;
                        if down {
                            r.input.press = Some((r.input.cursor, false));
                        } else if let Some((at, false)) = r.input.press.take() {
                            r.on_click(at);
                        }
                    }
                    MouseButton::Middle => r.input.middle = down,
                    MouseButton::Right => r.input.right = down,
                    _ => {}
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                let p = Vec2::new(position.x as f32, position.y as f32);
                let d = p - r.input.cursor;
                r.input.cursor = p;
                if let Some((start, moved)) = r.input.press.as_mut() {
                    *moved |= start.distance(p) > 3.0;
                }
                let dragging = r.input.middle || r.input.right || r.input.left;
                let Some(s) = r.scene.as_mut() else { return };
                if dragging {
                    s.take_over_file_camera();
                }
                let h = r.surface.config.height as f32;
                if r.input.middle || r.input.right || (r.input.left && r.input.modifiers.shift_key()) {
                    let yfov = s.yfov();
                    s.orbit.pan(d.x, d.y, h, yfov);
                } else if r.input.left {
                    s.orbit.orbit(d.x, d.y, h);
                }
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let notches = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                let size = r.surface.size();
                let cursor = r.input.cursor;
                let Some(s) = r.scene.as_mut() else { return };
                s.take_over_file_camera();
                // Zoom toward the point under the cursor (on the plane through the target).
                let ray = s.ray_through(cursor, size);
                let towards = ray.origin + ray.direction * s.orbit.current.distance;
                s.orbit.zoom(notches, Some(towards));
            }
            WindowEvent::DroppedFile(path) => {
                // Scene files open as scenes; anything else dropped is tried as an environment map.
                if SceneFile::is_scene_path(&path) {
                    r.open(path, args);
                } else if let Some(s) = r.scene.as_mut() {
                    // Anything else is tried as an environment map.
                    let mut env = s.app.world.get_resource().cloned();
                    let status = panels::load_environment(&mut env, &path);
                    match (&status, env) {
                        (Ok(_), Some(env)) => s.app.world.insert_resource(env),
                        (Err(e), _) => tracing::error!("{e}"),
                        _ => {}
                    }
                    r.ui.env_status = Some(status);
                    r.ui.show_environment = true;
                }
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = r.frame(args, event_loop) {
                    self.error = Some(e);
                    event_loop.exit();
                    return;
                }
                r.surface.window.request_redraw();
            }
            _ => {}
        }
    }
}
