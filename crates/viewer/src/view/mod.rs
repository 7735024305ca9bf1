//! `penumbra view`: a window showing a scene with a basic orbit camera. The full viewer (egui
//! panels, picking, drag-and-drop) is issue #6; this is the window loop it will grow from.
//!
//! Each frame: input moves the orbit camera's goal; `App::update` runs the schedules (extraction
//! included); the renderer draws the extracted scene into the swap-chain image. Resizes
//! reconfigure the surface at the window's physical size; a 0×0 (minimised) window skips frames.

mod orbit;
mod overlay;

use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};
use bevy_ecs::entity::Entity;
use bevy_ecs::world::Mut;
use glam::{Vec2, Vec3};
use penumbra_engine::animation::{AnimationPlayer, Repeat};
use penumbra_engine::components::{Camera, GlobalTransform, Projection, Transform};
use penumbra_engine::environment::Environment;
use penumbra_engine::framing::world_bounds;
use penumbra_engine::import::SceneFile;
use penumbra_engine::{App, Time, TimeMode};
use penumbra_render::headless::{CameraChoice, ShotSettings, stage_scene};
use penumbra_render::{GpuContext, RenderOutput, RenderScene, RenderSettings, Renderer};
use penumbra_viewer::surface::WindowSurface;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, ModifiersState, NamedKey};
use winit::window::{Window, WindowId};

use crate::cli::ViewArgs;
use crate::scene;
use orbit::{OrbitCamera, OrbitState};
use overlay::Overlay;

pub fn run(args: ViewArgs) -> Result<()> {
    #[cfg(all(unix, not(target_os = "macos")))]
    if std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none() {
        bail!(
            "no display: DISPLAY and WAYLAND_DISPLAY are unset, so `penumbra view` cannot open a window. \
             For a headless screenshot use `penumbra render SCENE --out shot.png`"
        );
    }
    // Running from a checkout: watch its shaders so edits show up live.
    let repository = std::path::Path::new(penumbra_render::pipelines::shader_library::REPOSITORY_SHADER_DIR);
    let settings = args.look.render_settings(true, repository.is_dir().then(|| repository.to_path_buf()))?;
    let scene = scene::load(args.path.as_deref(), &args.scene_args)?;
    let event_loop = EventLoop::new().map_err(|e| {
        anyhow!("cannot open a window ({e}). For a headless screenshot use `penumbra render SCENE --out shot.png`")
    })?;
    let mut viewer = Viewer { args, scene, settings, running: None, error: None };
    event_loop.run_app(&mut viewer).context("window event loop")?;
    match viewer.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

struct Viewer {
    args: ViewArgs,
    scene: SceneFile,
    settings: RenderSettings,
    running: Option<Running>,
    error: Option<anyhow::Error>,
}

struct Input {
    cursor: Vec2,
    left: bool,
    middle: bool,
    right: bool,
    modifiers: ModifiersState,
}

struct Running {
    surface: WindowSurface,
    app: App,
    camera: Entity,
    orbit: OrbitCamera,
    home: OrbitState,
    input: Input,
    last_frame: Instant,
    overlay: Overlay,
}

impl Viewer {
    fn start(&mut self, event_loop: &ActiveEventLoop) -> Result<Running> {
        let title = format!("penumbra — {}", self.scene.path().display());
        let attributes =
            Window::default_attributes().with_title(title).with_inner_size(winit::dpi::LogicalSize::new(1280, 800));
        // egui blends in gamma space, so it draws through a non-sRGB view of the same image.
        let (surface, ctx) = WindowSurface::new(event_loop, attributes, !self.args.no_vsync, true)?;
        let config = &surface.config;

        let shot = ShotSettings {
            size: Some((config.width, config.height)),
            camera: self.args.camera,
            exposure_ev100: self.args.look.exposure,
            animation: None,
        };
        let (mut app, _) = stage_scene(&self.scene, &shot)?;
        if let Some(env) = self.args.look.environment()? {
            app.insert_resource(env);
        }
        app.world.resource_mut::<Time>().set_mode(TimeMode::Real);
        // The orbit camera starts where the staged camera (auto-framed or the file's) looks from.
        app.update();
        let bounds = world_bounds(&mut app.world);
        let (camera, state) = {
            let mut q = app.world.query::<(Entity, &Camera, &GlobalTransform)>();
            let (e, _, g) =
                q.iter(&app.world).find(|(_, c, _)| c.is_active).ok_or_else(|| anyhow!("no active camera"))?;
            let eye = g.translation();
            let target = if bounds.is_empty() {
                eye + g.forward()
            } else {
                // The point along the view ray nearest the scene's centre.
                let t = (bounds.center() - eye).dot(g.forward()).max(1e-3);
                eye + g.forward() * t
            };
            (e, OrbitState::looking_at(eye, target))
        };
        if !matches!(self.args.camera, CameraChoice::Auto | CameraChoice::Orbit { .. }) {
            // Orbiting a file's camera would move its node; drive a free camera from its pose.
            let cam = *app.world.get::<Camera>(camera).expect("queried");
            app.world.get_mut::<Camera>(camera).expect("queried").is_active = false;
            let free = app.world.spawn((Camera { is_active: true, ..cam }, state.transform())).id();
            return self.finish(surface, app, free, state, ctx);
        }
        self.finish(surface, app, camera, state, ctx)
    }

    fn finish(
        &self,
        surface: WindowSurface,
        mut app: App,
        camera: Entity,
        state: OrbitState,
        ctx: GpuContext,
    ) -> Result<Running> {
        let overlay = Overlay::new(&surface.window, &ctx.device, surface.config.format.remove_srgb_suffix());
        app.insert_resource(Renderer::new(ctx, self.settings.clone())?);
        app.insert_resource(RenderOutput::External);
        Ok(Running {
            surface,
            app,
            camera,
            orbit: OrbitCamera::new(state),
            home: state,
            input: Input {
                cursor: Vec2::ZERO,
                left: false,
                middle: false,
                right: false,
                modifiers: ModifiersState::empty(),
            },
            last_frame: Instant::now(),
            overlay,
        })
    }
}

impl Running {
    fn yfov(&self) -> f32 {
        match self.app.world.get::<Camera>(self.camera).map(|c| c.projection) {
            Some(Projection::Perspective { yfov, .. }) => yfov,
            _ => 45f32.to_radians(),
        }
    }

    /// The point under the cursor on the plane through the orbit target facing the camera.
    fn cursor_point(&self) -> Option<Vec3> {
        let (w, h) = (self.surface.config.width as f32, self.surface.config.height as f32);
        let t = self.orbit.goal.transform();
        let tan = (0.5 * self.yfov()).tan();
        let ndc = Vec2::new(2.0 * self.input.cursor.x / w - 1.0, 1.0 - 2.0 * self.input.cursor.y / h);
        let dir = t.rotation * Vec3::new(ndc.x * tan * w / h, ndc.y * tan, -1.0);
        Some(t.translation + dir * self.orbit.goal.distance)
    }

    fn frame(&mut self) {
        let now = Instant::now();
        let dt = (now - self.last_frame).as_secs_f32();
        self.last_frame = now;
        let transform = self.orbit.update(dt);
        if let Some(mut t) = self.app.world.get_mut::<Transform>(self.camera) {
            *t = transform;
        }
        self.app.update();
        let device = self.app.world.resource::<Renderer>().context().device.clone();
        let Some(texture) = self.surface.acquire(&device) else { return };
        let view = texture.texture.create_view(&wgpu::TextureViewDescriptor::default());
        let ui_view = texture.texture.create_view(&wgpu::TextureViewDescriptor {
            format: Some(self.surface.config.format.remove_srgb_suffix()),
            ..Default::default()
        });
        let size = self.surface.size();
        let format = self.surface.config.format;
        let window = self.surface.window.clone();
        let overlay = &mut self.overlay;
        let before = self.app.world.get_resource::<Environment>().cloned();
        let mut env = before.clone();
        // The scene's player (the first, for a single loaded scene), edited as a copy.
        let mut animated = {
            let mut q = self.app.world.query::<(bevy_ecs::entity::Entity, &AnimationPlayer)>();
            q.iter(&self.app.world).next().map(|(e, p)| (e, p.clone()))
        };
        let playback_before = animated.as_ref().map(|(_, p)| playback(p));
        self.app.world.resource_scope(|world, mut renderer: Mut<Renderer>| {
            let scene = world.resource::<RenderScene>();
            renderer.render(scene, &view, format, size);
            let ctx = renderer.context().clone();
            let error = renderer.shader_error();
            let player = animated.as_mut().map(|(_, p)| p);
            overlay.draw(&window, &ctx.device, &ctx.queue, &ui_view, size, error, &mut env, player);
            ctx.queue.present(texture);
        });
        // The panels' edits reach the renderer and the animation system as ordinary changes.
        if env != before {
            self.set_environment(env);
        }
        if let (Some((root, edited)), Some(before)) = (animated, playback_before)
            && playback(&edited) != before
            && let Some(mut p) = self.app.world.get_mut::<AnimationPlayer>(root)
        {
            p.copy_playback(&edited);
        }
    }

    fn set_environment(&mut self, env: Option<Environment>) {
        match env {
            Some(e) => self.app.world.insert_resource(e),
            None => {
                self.app.world.remove_resource::<Environment>();
            }
        }
    }
}

/// What the animation panel can change in a player.
fn playback(p: &AnimationPlayer) -> (Option<usize>, f32, f32, bool, Repeat) {
    (p.active(), p.time(), p.speed(), p.is_paused(), p.repeat())
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
        if r.overlay.on_window_event(&r.surface.window, &event) {
            return;
        }
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                let device = r.app.world.resource::<Renderer>().context().device.clone();
                r.surface.resize(size.width, size.height, &device);
            }
            WindowEvent::ModifiersChanged(m) => r.input.modifiers = m.state(),
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => match event.logical_key
            {
                Key::Named(NamedKey::Escape) => event_loop.exit(),
                Key::Character(c) if c.eq_ignore_ascii_case("f") => r.orbit.goal = r.home,
                _ => {}
            },
            WindowEvent::MouseInput { state, button, .. } => {
                let down = state == ElementState::Pressed;
                match button {
                    MouseButton::Left => r.input.left = down,
                    MouseButton::Middle => r.input.middle = down,
                    MouseButton::Right => r.input.right = down,
                    _ => {}
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                let p = Vec2::new(position.x as f32, position.y as f32);
                let d = p - r.input.cursor;
                r.input.cursor = p;
                let h = r.surface.config.height as f32;
                if r.input.middle || r.input.right || (r.input.left && r.input.modifiers.shift_key()) {
                    let yfov = r.yfov();
                    r.orbit.pan(d.x, d.y, h, yfov);
                } else if r.input.left {
                    r.orbit.orbit(d.x, d.y, h);
                }
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let notches = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                let towards = r.cursor_point();
                r.orbit.zoom(notches, towards);
            }
            WindowEvent::DroppedFile(path) => {
                // An environment map dropped on the window replaces the environment's source.
                let mut env = r.app.world.get_resource::<Environment>().cloned();
                let status = overlay::load_environment(&mut env, &path);
                if status.is_ok() {
                    r.set_environment(env);
                } else if let Err(e) = &status {
                    tracing::error!("{e}");
                }
                r.overlay.set_env_status(status);
            }
            WindowEvent::RedrawRequested => {
                r.frame();
                r.surface.window.request_redraw();
            }
            _ => {}
        }
    }
}
