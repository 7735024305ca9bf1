//! [`WindowRunner`]: runs a scripted [`App`] in a window, the windowed twin of
//! `penumbra_render::headless::HeadlessRunner`, so one program can do either.
//!
//! Each redraw: `App::update` (the user's systems, propagation, extraction) with `Time` on the
//! wall clock, then the renderer draws the extracted scene into the swap-chain image and presents
//! it. The surface follows the window's physical size (HiDPI-correct); a minimised (0×0) window
//! keeps updating without drawing; `Esc` or the close button ends the loop.

use anyhow::{Context, Result, anyhow};
use bevy_ecs::world::Mut;
use penumbra_engine::{App, Plugin, Time, TimeMode};
use penumbra_render::{RenderOutput, RenderScene, RenderSettings, Renderer};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

use crate::surface::WindowSurface;

/// Runs the app in a window until it is closed. Add it as a plugin, then call `App::run`.
#[derive(Debug, Clone)]
pub struct WindowRunner {
    pub title: String,
    /// Logical size (the framebuffer is this times the display's scale factor).
    pub size: (u32, u32),
    pub vsync: bool,
    pub settings: RenderSettings,
}

impl Default for WindowRunner {
    fn default() -> Self {
        Self { title: "penumbra".into(), size: (1280, 720), vsync: true, settings: RenderSettings::default() }
    }
}

impl Plugin for WindowRunner {
    fn build(&self, app: &mut App) {
        let runner = self.clone();
        app.set_runner(move |app| {
            if let Err(e) = runner.run(app) {
                eprintln!("error: {e:#}");
                std::process::exit(1);
            }
        });
    }
}

impl WindowRunner {
    /// Runs `app` until the window closes.
    pub fn run(self, app: App) -> Result<()> {
        #[cfg(all(unix, not(target_os = "macos")))]
        if std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none() {
            anyhow::bail!(
                "no display (DISPLAY and WAYLAND_DISPLAY are unset): run this program headless instead \
                 (penumbra::render::headless::HeadlessRunner)"
            );
        }
        let event_loop = EventLoop::new().map_err(|e| anyhow!("cannot open a window: {e}"))?;
        let mut handler = Handler { runner: self, app: Some(app), running: None, error: None };
        event_loop.run_app(&mut handler).context("window event loop")?;
        handler.error.map_or(Ok(()), Err)
    }
}

struct Handler {
    runner: WindowRunner,
    app: Option<App>,
    running: Option<Running>,
    error: Option<anyhow::Error>,
}

struct Running {
    surface: WindowSurface,
    app: App,
    /// Spaces out attempts to replace a lost device.
    device_retry: penumbra_render::RetryBackoff,
}

impl Handler {
    fn start(&mut self, event_loop: &ActiveEventLoop) -> Result<Running> {
        let mut app = self.app.take().ok_or_else(|| anyhow!("the app was already started"))?;
        let (w, h) = self.runner.size;
        let attributes = Window::default_attributes()
            .with_title(self.runner.title.clone())
            .with_inner_size(winit::dpi::LogicalSize::new(w, h));
        let (surface, ctx) = WindowSurface::new(event_loop, attributes, self.runner.vsync, false)?;
        app.insert_resource(Renderer::new(ctx, self.runner.settings.clone())?);
        app.insert_resource(RenderOutput::External);
        app.world.resource_mut::<Time>().set_mode(TimeMode::Real);
        Ok(Running { surface, app, device_retry: Default::default() })
    }
}

impl Running {
    fn frame(&mut self) {
        if self.app.world.resource::<Renderer>().is_device_lost() {
            if !self.device_retry.due() {
                // Without a device nothing presents, so nothing paces the loop: wait a little.
                std::thread::sleep(std::time::Duration::from_millis(20));
                return;
            }
            let replaced = self.surface.replace_device().and_then(|ctx| {
                self.app.world.resource_mut::<Renderer>().replace_device(ctx).map_err(anyhow::Error::from)
            });
            if let Err(e) = replaced {
                self.device_retry.failed();
                let wait = self.device_retry.delay();
                tracing::error!("the GPU device was lost and cannot be replaced yet ({e:#}); trying again in {wait:?}");
                return;
            }
            self.device_retry.reset();
        }
        self.app.update();
        let device = self.app.world.resource::<Renderer>().context().device.clone();
        let Some(texture) = self.surface.acquire(&device) else { return };
        let view = texture.texture.create_view(&wgpu::TextureViewDescriptor::default());
        let (size, format) = (self.surface.size(), self.surface.config.format);
        self.app.world.resource_scope(|world, mut renderer: Mut<Renderer>| {
            renderer.render(world.resource::<RenderScene>(), &view, format, size);
            renderer.context().queue.present(texture);
        });
    }
}

impl ApplicationHandler for Handler {
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
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::KeyboardInput { event, .. }
                if event.state == ElementState::Pressed && event.logical_key == Key::Named(NamedKey::Escape) =>
            {
                event_loop.exit()
            }
            WindowEvent::Resized(size) => {
                let device = r.app.world.resource::<Renderer>().context().device.clone();
                r.surface.resize(size.width, size.height, &device);
            }
            WindowEvent::RedrawRequested => {
                r.frame();
                r.surface.window.request_redraw();
            }
            _ => {}
        }
    }
}
