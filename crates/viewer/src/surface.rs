//! [`WindowSurface`]: a window, its wgpu surface and the GPU context made for it; shared by the
//! `penumbra view` viewer and [`crate::window::WindowRunner`]. The surface's size follows the
//! window's physical size (HiDPI-correct); a minimised (0×0) window keeps its configuration and
//! hands out no images until restored; an outdated surface is reconfigured and a lost one is
//! created anew from the window.
//!
//! After a device loss, [`WindowSurface::replace_device`] makes a new device for the same window.
//!
//! Fault injection, so that tests exercise both recovery paths on any machine
//! (`crates/viewer/tests/window.rs`): with `PENUMBRA_DEBUG_SURFACE_LOSS=N` in the environment
//! every Nth image request reports the surface lost (as a driver does after a display change);
//! with `PENUMBRA_DEBUG_DEVICE_LOSS=N` the Nth request destroys the GPU device.

use std::sync::Arc;

use anyhow::{Context, Result};
use penumbra_render::{AdapterRequest, GpuContext};
use winit::event_loop::ActiveEventLoop;
use winit::window::{Window, WindowAttributes};

pub struct WindowSurface {
    pub window: Arc<Window>,
    pub surface: wgpu::Surface<'static>,
    pub config: wgpu::SurfaceConfiguration,
    /// Kept to create the surface again when it is lost.
    instance: wgpu::Instance,
    /// Kept to make a new instance (and device) after a device loss.
    display: winit::event_loop::OwnedDisplayHandle,
    /// False while the window is minimised.
    visible: bool,
    /// `PENUMBRA_DEBUG_SURFACE_LOSS`: report every Nth request as lost.
    fault_every: Option<u64>,
    /// `PENUMBRA_DEBUG_DEVICE_LOSS`: destroy the device at the Nth request.
    destroy_at: Option<u64>,
    requests: u64,
    /// Times the surface was lost and created again.
    pub recreated: u64,
}

/// What an image request's answer asks of the surface.
#[derive(Debug, PartialEq, Eq)]
enum Recovery {
    /// Nothing: skip this frame (timeout, occluded).
    Skip,
    /// Configure again (outdated: the window changed under it).
    Reconfigure,
    /// Create the surface anew from the window (lost).
    Recreate,
}

fn recovery(status: &wgpu::CurrentSurfaceTexture) -> Recovery {
    match status {
        wgpu::CurrentSurfaceTexture::Outdated => Recovery::Reconfigure,
        wgpu::CurrentSurfaceTexture::Lost => Recovery::Recreate,
        _ => Recovery::Skip,
    }
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
        let display = event_loop.owned_display_handle();
        let (instance, surface, ctx) = Self::device_for(&window, &display)?;
        let size = window.inner_size();
        let caps = surface.get_capabilities(&ctx.adapter);
        let format = caps.formats.iter().copied().find(|f| f.is_srgb()).unwrap_or(caps.formats[0]);
        // Copyable where the surface allows it, so a screenshot is the image on screen.
        // COPY_DST where offered: the visibility buffer's shading pass copies its displayed
        // colour in (`--raster compute`; without it that frame keeps an HDR target and tonemaps).
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | (caps.usages & (wgpu::TextureUsages::COPY_SRC | wgpu::TextureUsages::COPY_DST));
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
        let env = |name| std::env::var(name).ok().and_then(|v| v.parse::<u64>().ok()).filter(|&n| n > 0);
        let fault_every = env("PENUMBRA_DEBUG_SURFACE_LOSS");
        if let Some(n) = fault_every {
            tracing::warn!(
                "PENUMBRA_DEBUG_SURFACE_LOSS: every {n}th surface image request will report the surface lost"
            );
        }
        let destroy_at = env("PENUMBRA_DEBUG_DEVICE_LOSS");
        if let Some(n) = destroy_at {
            tracing::warn!("PENUMBRA_DEBUG_DEVICE_LOSS: the GPU device will be destroyed at surface image request {n}");
        }
        let surface = WindowSurface {
            window,
            surface,
            config,
            instance,
            display,
            visible: true,
            fault_every,
            destroy_at,
            requests: 0,
            recreated: 0,
        };
        Ok((surface, ctx))
    }

    /// A new instance, a surface for `window` and a device that can present to it.
    fn device_for(
        window: &Arc<Window>,
        display: &winit::event_loop::OwnedDisplayHandle,
    ) -> Result<(wgpu::Instance, wgpu::Surface<'static>, GpuContext)> {
        let request = AdapterRequest::default();
        let desc = GpuContext::instance_descriptor(&request).with_display_handle(Box::new(display.clone()));
        let instance = wgpu::Instance::new(desc);
        let surface = instance.create_surface(window.clone()).context("cannot create a surface for the window")?;
        let ctx = GpuContext::with_instance(instance.clone(), &request, Some(&surface))?;
        Ok((instance, surface, ctx))
    }

    /// After a device loss: a new device for the same window, and the surface configured on it
    /// (the format kept where the new adapter offers it). The caller hands the context to its
    /// renderer ([`penumbra_render::Renderer::replace_device`]) and remakes its UI's GPU side.
    pub fn replace_device(&mut self) -> Result<GpuContext> {
        let (instance, surface, ctx) = Self::device_for(&self.window, &self.display)?;
        let caps = surface.get_capabilities(&ctx.adapter);
        if !caps.formats.contains(&self.config.format) {
            self.config.format = caps.formats.iter().copied().find(|f| f.is_srgb()).unwrap_or(caps.formats[0]);
            if !self.config.view_formats.is_empty() {
                self.config.view_formats = vec![self.config.format.remove_srgb_suffix()];
            }
        }
        // Old surface (and swap chain) first: a window has one swap chain at a time.
        self.surface = surface;
        self.instance = instance;
        if self.visible {
            self.surface.configure(&ctx.device, &self.config);
        }
        tracing::info!("the window has a new GPU device: {}", ctx.describe());
        Ok(ctx)
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
    /// surface was outdated or lost and has been reconfigured or recreated for the next one).
    pub fn acquire(&mut self, device: &wgpu::Device) -> Option<wgpu::SurfaceTexture> {
        if !self.visible {
            return None;
        }
        self.requests += 1;
        if self.destroy_at == Some(self.requests) {
            tracing::warn!("PENUMBRA_DEBUG_DEVICE_LOSS: destroying the GPU device");
            device.destroy();
            return None;
        }
        let injected = self.fault_every.is_some_and(|n| self.requests.is_multiple_of(n));
        let status = if injected { wgpu::CurrentSurfaceTexture::Lost } else { self.surface.get_current_texture() };
        let action = match status {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => return Some(t),
            other => recovery(&other),
        };
        match action {
            Recovery::Skip => {}
            Recovery::Reconfigure => self.surface.configure(device, &self.config),
            Recovery::Recreate => self.recreate(device),
        }
        None
    }

    /// A lost surface cannot be configured again (wgpu's contract): make a new one for the same
    /// window. If that fails the old one stays and the next frame tries again.
    fn recreate(&mut self, device: &wgpu::Device) {
        match self.instance.create_surface(self.window.clone()) {
            Ok(surface) => {
                // The assignment drops the old surface (and its swap chain) before the new one
                // is configured: a window has one swap chain at a time.
                self.surface = surface;
                self.surface.configure(device, &self.config);
                self.recreated += 1;
                tracing::info!("the window surface was lost; created it again ({} times so far)", self.recreated);
            }
            Err(e) => tracing::error!("the window surface was lost and cannot be created again yet: {e}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lost_surfaces_are_recreated_and_outdated_ones_reconfigured() {
        assert_eq!(recovery(&wgpu::CurrentSurfaceTexture::Lost), Recovery::Recreate);
        assert_eq!(recovery(&wgpu::CurrentSurfaceTexture::Outdated), Recovery::Reconfigure);
        assert_eq!(recovery(&wgpu::CurrentSurfaceTexture::Timeout), Recovery::Skip);
        assert_eq!(recovery(&wgpu::CurrentSurfaceTexture::Occluded), Recovery::Skip);
    }
}
