//! `penumbra view`: the interactive viewer. A winit window; the egui UI ([`overlay`], [`panels`])
//! with its panels docked round a viewport; the scene drawn by the renderer into the viewport's
//! texture, which the UI shows as an image.
//!
//! Each frame: a finished background load ([`loader`]) replaces the scene ([`staged`]) one frame
//! after its import completes (that frame says it is preparing); input moves the orbit camera's
//! goal and the camera eases towards it ([`orbit`]); axes and the selection box become gizmo
//! lines ([`gizmos`]); `App::update` runs the schedules (extraction included); the UI is laid out
//! (the panels edit the world) and decides the viewport; the renderer draws the extracted scene
//! at the viewport's size; an F12 screenshot copies that texture ([`screenshot`]); the UI is
//! painted over the swap-chain image; its actions are carried out. Frames are drawn only when
//! something changes ([`Running::moving`]); a still window sleeps and wakes a few times a second
//! for what comes without input. Resizes reconfigure the surface at the window's physical size;
//! a 0×0 (minimised) window skips frames.

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
use penumbra_engine::animation::AnimationPlayer;
use penumbra_engine::components::GlobalTransform;
use penumbra_engine::import::SceneFile;
use penumbra_render::{GpuContext, RenderScene, RenderSettings, Renderer};
use penumbra_viewer::surface::WindowSurface;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, StartCause, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
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
    // The embedded shaders are parsed while the window and the device come up.
    if settings.shaders == penumbra_render::ShaderSource::Embedded {
        penumbra_render::pipelines::ShaderLibrary::preload_embedded();
    }
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
    /// A button went down while a menu was open: the press and its release belong to the UI.
    ui_press: bool,
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
    viewport: Viewport,
    /// The last frame was not drawn (no surface image, a lost device): tried again at the next
    /// wake.
    missed_frame: bool,
    /// When egui asked to be drawn again (its repaint delay after the last frame).
    repaint_at: Option<Instant>,
    /// The scene was drawn into a viewport image the UI did not show yet.
    image_pending: bool,
    /// A scene just staged (its name, when its load began): logged when its first frame is
    /// presented.
    first_frame_of: Option<(String, Instant)>,
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
            missed_frame: false,
            repaint_at: None,
            image_pending: false,
            first_frame_of: None,
            viewport: Viewport {
                rect: (0, 0, surface.config.width, surface.config.height),
                changed: false,
                target: None,
            },
            surface,
            ctx,
            scene: None,
            loader: Some(Loader::start(self.args.path.as_deref(), &self.args.scene_args)),
            first_load: true,
            input: Input::default(),
            clock: FrameClock { last: now, window_start: now, frames: 0, fps: 0.0, frame_ms: 0.0 },
            overlay,
            ui: UiState::new(!self.args.no_vsync, &self.args.panels),
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
        let Some(loader) = self.loader.as_mut() else { return Ok(()) };
        // The frame the import finishes shows "preparing" (staging and the first frame's shader
        // compiles take a while); the next one stages it.
        if loader.ready.is_none() {
            loader.poll();
            match &loader.ready {
                None => return Ok(()),
                Some(Ok(_)) => {
                    tracing::info!("preparing the first frame of {}", loader.name());
                    return Ok(());
                }
                // A failed import has no first frame to prepare: reported now.
                Some(Err(_)) => {}
            }
        }
        let mut loader = self.loader.take().expect("checked above");
        let outcome = loader.ready.take().expect("checked above");
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
                self.first_frame_of = Some((staged.name.clone(), loader.started));
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
        // Command-line camera, exposure and variant apply to the first scene; later ones get the
        // defaults (their file's camera, else the framed view; metered exposure; their own
        // materials).
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
        Staged::new(file, path, look, env, self.viewport.size(), renderer)
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
        // The viewport's texture and its registration belonged to the old device.
        self.viewport.target = None;
        self.ctx = ctx;
        Ok(())
    }

    fn frame(&mut self, args: &ViewArgs, event_loop: &ActiveEventLoop) -> Result<()> {
        // Cleared once the frame is presented; a frame that returns early is tried again.
        self.missed_frame = true;
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
        let aspect = self.aspect();
        if let Some(s) = self.scene.as_mut() {
            s.advance_camera(dt, aspect);
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
        let ui_view = texture.texture.create_view(&wgpu::TextureViewDescriptor {
            format: Some(self.surface.config.format.remove_srgb_suffix()),
            ..Default::default()
        });
        let size = self.surface.size();
        let format = self.surface.config.format;
        let loading = self
            .loader
            .as_ref()
            .map(|l| (l.name(), l.progress(), l.started.elapsed().as_secs_f32(), l.ready.is_some()));
        let cameras = self.scene.as_ref().map(|s| s.cameras.clone()).unwrap_or_default();
        let through = self.scene.as_ref().and_then(|s| s.through.map(|(i, _)| i));
        let variants = self.scene.as_mut().map(|s| s.variants()).unwrap_or_default();
        let exposure = self.scene.as_mut().and_then(|s| s.exposure_summary());
        let screenshot = std::mem::take(&mut self.screenshot_requested);
        let image = self.overlay.viewport_texture();
        // The first frame with a scene registers the viewport's image after the UI is laid
        // out: it shows from the next frame.
        let (_, _, vw, vh) = self.viewport.rect;
        self.image_pending = self.scene.is_some() && image.is_none() && vw > 0 && vh > 0;
        let (overlay, ui, window, screenshots, recent, viewport) = (
            &mut self.overlay,
            &mut self.ui,
            self.surface.window.clone(),
            &self.screenshots,
            &self.recent.paths,
            &mut self.viewport,
        );
        let (fps, frame_ms) = (self.clock.fps, self.clock.frame_ms);
        let ctx = self.ctx.clone();
        // What the UI shows without a scene; a scene adds its renderer, exposure and image.
        let info = FrameInfo {
            renderer: None,
            fps,
            frame_ms,
            loading,
            recent,
            cameras,
            through,
            variants,
            exposure: None,
            scene_name: "",
            viewport: None,
        };
        let actions = match self.scene.as_mut() {
            Some(s) => {
                let name = s.name.clone();
                s.app.world.resource_scope(|world, mut renderer: Mut<Renderer>| {
                    // The UI first: the docked panels decide the viewport the scene is drawn at.
                    let actions = {
                        let info = FrameInfo {
                            renderer: Some(&renderer),
                            exposure,
                            scene_name: &name,
                            viewport: image,
                            ..info
                        };
                        overlay.run(&window, ui, Some(world), &info)
                    };
                    let pixels = overlay.viewport_pixels(ui).unwrap_or((0, 0, size.0, size.1));
                    viewport.set_rect(pixels, size);
                    let (w, h) = (pixels.2, pixels.3);
                    if w > 0 && h > 0 {
                        let (target, remade) = viewport.target(&ctx.device, format, (w, h));
                        if remade || image.is_none() {
                            overlay.set_viewport_texture(&ctx.device, &target.ui_view);
                        }
                        let scene = world.resource::<RenderScene>();
                        renderer.render(scene, &target.view, format, (w, h));
                        if screenshot {
                            screenshots.capture(&mut renderer, scene, Some(&target.texture), (w, h));
                        }
                    }
                    actions
                })
            }
            None => {
                let actions = overlay.run(&window, ui, None, &info);
                viewport.set_rect(overlay.viewport_pixels(ui).unwrap_or((0, 0, size.0, size.1)), size);
                actions
            }
        };
        overlay.paint(&ctx.device, &ctx.queue, &ui_view, size);
        ctx.queue.present(texture);
        self.missed_frame = false;
        self.repaint_at = self.overlay.repaint_delay().filter(|d| !d.is_zero()).map(|d| Instant::now() + d);
        if let Some((name, started)) = self.first_frame_of.take() {
            tracing::info!(
                "first frame of {name} on screen, {:.2} s after opening it",
                started.elapsed().as_secs_f32()
            );
        }
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
        let (w, h) = self.viewport.size();
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
            Key::Character(c) if ctrl && c.eq_ignore_ascii_case("o") => {
                self.ui.browse(self.recent.paths.first().and_then(|p| p.parent()).map(Into::into))
            }
            Key::Character(c) if ctrl && c.eq_ignore_ascii_case("l") => self.ui.open_dialog = true,
            Key::Character(c) if c.eq_ignore_ascii_case("f") => self.act(Action::FrameScene, args, event_loop),
            _ => {}
        }
    }

    fn on_click(&mut self, at: Vec2) {
        let size = self.viewport.size();
        let at = self.viewport.local(at);
        let now = Instant::now();
        let double =
            self.input.last_click.is_some_and(|(t, p)| now - t < Duration::from_millis(400) && p.distance(at) < 6.0);
        self.input.last_click = if double { None } else { Some((now, at)) };
        let Some(s) = self.scene.as_mut() else { return };
        // Picking casts from the orbit camera: looking through a file camera, it takes over
        // that camera's pose first, so the ray goes through what is on screen.
        s.take_over_file_camera();
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
        // Esc closes the open menu or dialog first; only with nothing open does it quit.
        if let WindowEvent::KeyboardInput { event: key, .. } = &event
            && key.state == ElementState::Pressed
            && key.logical_key == Key::Named(NamedKey::Escape)
            && (r.overlay.popup_open() || r.ui.dialog_open())
        {
            r.overlay.on_window_event(&r.surface.window, &event, r.ui.viewport);
            if r.overlay.popup_open() {
                r.overlay.close_popups();
            } else {
                r.ui.close_dialog();
            }
            r.surface.window.request_redraw();
            return;
        }
        // A press while a menu is open only closes the menu (as desktop menus do): neither it
        // nor its release reaches the scene.
        if let WindowEvent::MouseInput { state, .. } = &event {
            match state {
                ElementState::Pressed if r.overlay.popup_open() => r.input.ui_press = true,
                ElementState::Released if std::mem::take(&mut r.input.ui_press) => {
                    r.overlay.on_window_event(&r.surface.window, &event, r.ui.viewport);
                    (r.input.left, r.input.middle, r.input.right, r.input.press) = (false, false, false, None);
                    r.surface.window.request_redraw();
                    return;
                }
                _ => {}
            }
            if r.input.ui_press {
                r.overlay.on_window_event(&r.surface.window, &event, r.ui.viewport);
                r.surface.window.request_redraw();
                return;
            }
        }
        if r.overlay.on_window_event(&r.surface.window, &event, r.ui.viewport) {
            // egui took it; a button released over a panel still ends a drag.
            if let WindowEvent::MouseInput { state: ElementState::Released, .. } = event {
                (r.input.left, r.input.middle, r.input.right, r.input.press) = (false, false, false, None);
            }
            // What the UI took changes what it shows (a click, a key in a text field).
            r.surface.window.request_redraw();
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
                let h = r.viewport.size().1 as f32;
                if r.input.middle || r.input.right || (r.input.left && r.input.modifiers.shift_key()) {
                    let yfov = s.yfov();
                    s.orbit.pan(d.x, d.y, h, yfov);
                } else if r.input.left {
                    s.orbit.orbit(d.x, d.y, h);
                }
            }
            WindowEvent::MouseWheel { delta, .. } => {
                // One step per wheel event at most: platforms report a notch as one line or as
                // three, and a step is a fixed fraction of the way.
                let notches = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y.clamp(-1.0, 1.0),
                    MouseScrollDelta::PixelDelta(p) => (p.y as f32 / 40.0).clamp(-1.0, 1.0),
                };
                let size = r.viewport.size();
                let cursor = r.viewport.local(r.input.cursor);
                let Some(s) = r.scene.as_mut() else { return };
                s.take_over_file_camera();
                // Toward the surface under the cursor where it is nearer than the orbit's
                // centre, else the point at the centre's distance along the cursor's ray: each
                // step covers a fraction of the way, so the camera never passes either.
                let ray = s.ray_through(cursor, size);
                let at_centre = ray.origin + ray.direction * s.orbit.current.distance;
                let towards = match s.pick(cursor, size) {
                    Some((_, hit)) if hit.distance(ray.origin) < at_centre.distance(ray.origin) => hit,
                    _ => at_centre,
                };
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
                // A still scene is not drawn again until something changes.
                if r.moving() {
                    r.surface.window.request_redraw();
                }
                return;
            }
            _ => {}
        }
        // Input changes what the window shows (hover, a drag, a key): draw the next frame.
        if let Some(r) = self.running.as_mut() {
            r.surface.window.request_redraw();
        }
    }

    fn new_events(&mut self, _event_loop: &ActiveEventLoop, cause: StartCause) {
        if let (StartCause::ResumeTimeReached { .. }, Some(r)) = (cause, self.running.as_mut())
            && r.wants_frame()
        {
            r.surface.window.request_redraw();
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        // Still, the loop sleeps and looks a few times a second for what arrives without input
        // (a load's progress, a shader saved, a screenshot written), sooner where egui asked to
        // be drawn again.
        let idle = Instant::now() + IDLE_WAKE;
        let wake = self.running.as_ref().and_then(|r| r.repaint_at).map_or(idle, |at| at.min(idle));
        event_loop.set_control_flow(ControlFlow::WaitUntil(wake));
    }
}

/// How often a still viewer wakes to look for changes that come without input.
const IDLE_WAKE: Duration = Duration::from_millis(250);

impl Running {
    /// Whether the next frame can differ from this one with no input: the camera still easing,
    /// an animation playing, automatic exposure adapting, egui animating, a screenshot asked
    /// for, a viewport image not shown yet, the viewport's size changed.
    fn moving(&mut self) -> bool {
        if std::mem::take(&mut self.viewport.changed) {
            return true;
        }
        if self.screenshot_requested || self.image_pending || self.ctx.is_lost() {
            return true;
        }
        if self.overlay.repaint_delay().is_some_and(|d| d.is_zero()) {
            return true;
        }
        if self.loader.as_ref().is_some_and(|l| l.ready.is_some()) {
            return true;
        }
        let Some(s) = self.scene.as_mut() else { return false };
        if s.orbit.current != s.orbit.goal || self.settings.post.auto_exposure.is_some() {
            return true;
        }
        let mut q = s.app.world.query::<&AnimationPlayer>();
        q.iter(&s.app.world).any(|p| p.active().is_some() && !p.is_paused() && !p.is_finished())
    }

    /// While still: whether something arrived that the window must show. A load's progress
    /// (at the wake rate), a shader reload, a screenshot written, the status line's end.
    fn wants_frame(&mut self) -> bool {
        if self.loader.is_some() || self.screenshots.in_flight() > 0 || self.missed_frame {
            return true;
        }
        // egui asked to be drawn again by now (a tooltip's delay, a caret's blink).
        if self.repaint_at.is_some_and(|at| Instant::now() >= at) {
            self.repaint_at = None;
            return true;
        }
        if self.ui.status.as_ref().is_some_and(|(_, posted)| posted.elapsed() >= ui_state::STATUS_SHOWN) {
            self.ui.status = None;
            return true;
        }
        let Some(s) = self.scene.as_mut() else { return false };
        s.app.world.resource_mut::<Renderer>().poll_shader_changes().is_some()
    }
}

/// Where the scene is drawn: the window less the menu bar and the docked panels, in physical
/// pixels, and the texture the renderer draws it into (shown by the overlay as an image).
#[derive(Default)]
struct Viewport {
    /// x, y, width, height in the window, as the UI last laid it out.
    rect: (u32, u32, u32, u32),
    /// The rect changed in the last layout: the camera (its aspect, its fitted field of view)
    /// takes it on the next frame.
    changed: bool,
    target: Option<ViewportTarget>,
}

struct ViewportTarget {
    texture: wgpu::Texture,
    /// What the renderer draws into (the surface's format, sRGB-encoding on write).
    view: wgpu::TextureView,
    /// The same texels without sRGB decoding, for egui, which blends and samples its images
    /// as the encoded values.
    ui_view: wgpu::TextureView,
    size: (u32, u32),
}

impl Viewport {
    /// Takes the rect the UI laid out; a change is logged (window tests read where the scene is).
    fn set_rect(&mut self, rect: (u32, u32, u32, u32), window: (u32, u32)) {
        if rect != self.rect {
            let (x, y, w, h) = rect;
            tracing::info!(
                "viewport at ({x}, {y}), {w}x{h} of the {}x{} window (left {x}, right {})",
                window.0,
                window.1,
                window.0.saturating_sub(x + w)
            );
            self.rect = rect;
            self.changed = true;
        }
    }

    fn size(&self) -> (u32, u32) {
        (self.rect.2.max(1), self.rect.3.max(1))
    }

    /// A window position relative to the viewport's corner.
    fn local(&self, p: Vec2) -> Vec2 {
        p - Vec2::new(self.rect.0 as f32, self.rect.1 as f32)
    }

    /// The texture for a frame of `size` (made again when the size or format changes); whether
    /// it is new.
    fn target(
        &mut self,
        device: &wgpu::Device,
        format: wgpu::TextureFormat,
        size: (u32, u32),
    ) -> (&ViewportTarget, bool) {
        let fits = self.target.as_ref().is_some_and(|t| t.size == size && t.texture.format() == format);
        if !fits {
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("viewport"),
                size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::COPY_DST,
                view_formats: &[format.remove_srgb_suffix()],
            });
            let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
            let ui_view = texture.create_view(&wgpu::TextureViewDescriptor {
                format: Some(format.remove_srgb_suffix()),
                ..Default::default()
            });
            self.target = Some(ViewportTarget { texture, view, ui_view, size });
        }
        (self.target.as_ref().expect("made above"), !fits)
    }
}
