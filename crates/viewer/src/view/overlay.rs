//! The viewer's egui overlay, drawn over the tonemapped frame (never into the scene). Today it
//! shows one thing: the current shader error, in red, until a reload fixes it. The panels of the
//! full viewer (issue #6) will grow here.

use egui::{Color32, RichText};
use penumbra_render::ShaderError;
use winit::event::WindowEvent;
use winit::window::Window;

pub struct Overlay {
    ctx: egui::Context,
    state: egui_winit::State,
    renderer: egui_wgpu::Renderer,
}

impl Overlay {
    pub fn new(window: &Window, device: &wgpu::Device, format: wgpu::TextureFormat) -> Self {
        let ctx = egui::Context::default();
        let state = egui_winit::State::new(
            ctx.clone(),
            egui::ViewportId::ROOT,
            window,
            Some(window.scale_factor() as f32),
            None,
            Some(device.limits().max_texture_dimension_2d as usize),
        );
        let renderer = egui_wgpu::Renderer::new(device, format, egui_wgpu::RendererOptions::default());
        Self { ctx, state, renderer }
    }

    /// Feeds a window event to egui; true when egui used it (the camera should ignore it).
    pub fn on_window_event(&mut self, window: &Window, event: &WindowEvent) -> bool {
        self.state.on_window_event(window, event).consumed
    }

    /// Draws the overlay into `target` (already holding the frame) and submits it.
    pub fn draw(
        &mut self,
        window: &Window,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        target: &wgpu::TextureView,
        size: (u32, u32),
        shader_error: Option<&ShaderError>,
    ) {
        let raw = self.state.take_egui_input(window);
        let mut full = self.ctx.run_ui(raw, |ui| {
            if let Some(e) = shader_error {
                egui::Frame::new().fill(Color32::from_rgba_unmultiplied(110, 0, 0, 230)).inner_margin(10).show(
                    ui,
                    |ui| {
                        ui.label(
                            RichText::new("Shader error: still drawing with the last good shaders")
                                .color(Color32::WHITE)
                                .strong(),
                        );
                        ui.label(RichText::new(e.to_string()).monospace().color(Color32::WHITE));
                    },
                );
            }
        });
        self.state.handle_platform_output(window, full.platform_output);
        let jobs = self.ctx.tessellate(full.shapes, full.pixels_per_point);
        // epaint asserts (in debug) that every delta is consumed, so drain rather than iterate.
        let mut textures = std::mem::take(&mut full.textures_delta);
        for (id, deltas) in textures.set.drain() {
            for delta in &deltas {
                self.renderer.update_texture(device, queue, id, delta);
            }
        }
        let screen =
            egui_wgpu::ScreenDescriptor { size_in_pixels: [size.0, size.1], pixels_per_point: full.pixels_per_point };
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("overlay") });
        let mut buffers = self.renderer.update_buffers(device, queue, &mut encoder, &jobs, &screen);
        {
            let mut pass = encoder
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("overlay"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: target,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                })
                .forget_lifetime();
            self.renderer.render(&mut pass, &jobs, &screen);
        }
        buffers.push(encoder.finish());
        queue.submit(buffers);
        for id in textures.free.drain() {
            self.renderer.free_texture(&id);
        }
    }
}
