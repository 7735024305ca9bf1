//! [`WindowSurface`]: a window, its wgpu surface and the GPU context made for it; shared by the
//! `penumbra view` viewer and [`crate::window::WindowRunner`]. The surface's size follows the
//! window's physical size (HiDPI-correct); a minimised (0×0) window keeps its configuration and
//! hands out no images until restored; an outdated or lost surface is reconfigured.

use std::sync::Arc;

use anyhow::{Context, Result};
use penumbra_render::{AdapterRequest, GpuContext};
use winit::event_loop::ActiveEventLoop;
use winit::window::{Window, WindowAttributes};

pub struct WindowSurface {
    pub window: Arc<Window>,
    pub surface: wgpu::Surface<'static>,
    pub config: wgpu::SurfaceConfiguration,
    /// False while the window is minimised.
    visible: bool,
}

impl WindowSurface {
    /// Opens a window and a surface on the adapter that can present to it, in an sRGB format.
    /// `view_formats`: extra views of the swap-chain images (the viewer's UI draws through a
    /// non-sRGB one).
    pub fn new(
        event_loop: &ActiveEventLoop,
        attributes: WindowAttributes,
        vsync: bool,
        linear_view: bool,
    ) -> Result<(WindowSurface, GpuContext)> {
        let window = Arc::new(event_loop.create_window(attributes).context("cannot create the window")?);
        let request = AdapterRequest::default();
        let desc =
            GpuContext::instance_descriptor(&request).with_display_handle(Box::new(event_loop.owned_display_handle()));
        let instance = wgpu::Instance::new(desc);
        let surface = instance.create_surface(window.clone()).context("cannot create a surface for the window")?;
        let ctx = GpuContext::with_instance(instance, &request, Some(&surface))?;
        let size = window.inner_size();
        let caps = surface.get_capabilities(&ctx.adapter);
        let format = caps.formats.iter().copied().find(|f| f.is_srgb()).unwrap_or(caps.formats[0]);
        // Copyable where the surface allows it, so a screenshot is the image on screen.
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | (caps.usages & wgpu::TextureUsages::COPY_SRC);
        let config = wgpu::SurfaceConfiguration {
            usage,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: if vsync { wgpu::PresentMode::AutoVsync } else { wgpu::PresentMode::AutoNoVsync },
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes[0],
            color_space: wgpu::SurfaceColorSpace::Auto,
            view_formats: if linear_view { vec![format.remove_srgb_suffix()] } else { Vec::new() },
        };
        surface.configure(&ctx.device, &config);
        Ok((WindowSurface { window, surface, config, visible: true }, ctx))
    }

    /// Follows a window resize; 0×0 (minimised) stops handing out images until restored.
    pub fn resize(&mut self, width: u32, height: u32, device: &wgpu::Device) {
        self.visible = width > 0 && height > 0;
        if self.visible {
            self.config.width = width;
            self.config.height = height;
            self.surface.configure(device, &self.config);
        }
    }

    /// Switches vertical sync (takes effect from the next image).
    pub fn set_vsync(&mut self, vsync: bool, device: &wgpu::Device) {
        self.config.present_mode = if vsync { wgpu::PresentMode::AutoVsync } else { wgpu::PresentMode::AutoNoVsync };
        if self.visible {
            self.surface.configure(device, &self.config);
        }
    }

    pub fn size(&self) -> (u32, u32) {
        (self.config.width, self.config.height)
    }

    /// The next swap-chain image, or `None` this frame (minimised, timed out, occluded, or the
    /// surface was outdated or lost and has been reconfigured for the next one).
    pub fn acquire(&mut self, device: &wgpu::Device) -> Option<wgpu::SurfaceTexture> {
        if !self.visible {
            return None;
        }
        match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => Some(t),
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(device, &self.config);
                None
            }
            _ => None,
        }
    }
}
