//! The viewer's egui overlay, drawn over the tonemapped frame (never into the scene, so
//! screenshots leave it out): a menu bar (File, View, Camera), the floating panels of
//! [`super::panels`], the shader error until a reload fixes it, the progress of a load and the
//! status line.
//!
//! Data flow: each frame the viewer hands the overlay the main world (panels read it and write
//! edits back as ordinary component and resource changes, so extraction picks them up next
//! frame), the renderer (stats, settings) and what it knows about loading; the overlay returns
//! [`Action`]s for what only the viewer can do (open a file, change renderer settings, take a
//! screenshot, switch cameras). What the panels show across frames lives in [`UiState`].

use bevy_ecs::world::World;
use winit::event::WindowEvent;
use winit::window::Window;

use super::panels;
use super::ui_state::{Action, FrameInfo, UiState};

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
        let consumed = self.state.on_window_event(window, event).consumed;
        // A press over a panel belongs to the panel even where egui does not mark it used.
        let pointer_event = matches!(event, WindowEvent::MouseInput { .. } | WindowEvent::MouseWheel { .. });
        consumed || (pointer_event && self.ctx.is_pointer_over_egui())
    }

    /// Whether a text field has the keyboard (shortcuts must not fire).
    pub fn wants_keyboard(&self) -> bool {
        self.ctx.egui_wants_keyboard_input()
    }

    /// Draws the overlay into `target` (already holding the frame, or cleared when `clear`)
    /// and submits it; returns what the user asked for.
    #[allow(clippy::too_many_arguments)]
    pub fn draw(
        &mut self,
        window: &Window,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        target: &wgpu::TextureView,
        size: (u32, u32),
        clear: bool,
        ui_state: &mut UiState,
        world: Option<&mut World>,
        info: &FrameInfo<'_>,
    ) -> Vec<Action> {
        let raw = self.state.take_egui_input(window);
        let mut actions = Vec::new();
        let mut world = world;
        let mut full = self.ctx.run_ui(raw, |ui| {
            panels::menu_bar(ui, ui_state, info, &mut actions);
            if let Some(world) = world.as_deref_mut() {
                panels::scene_panels(ui, ui_state, world, info, &mut actions);
            }
            panels::messages(ui, ui_state, info, &mut actions);
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
        let load = if clear {
            wgpu::LoadOp::Clear(wgpu::Color { r: 0.02, g: 0.02, b: 0.025, a: 1.0 })
        } else {
            wgpu::LoadOp::Load
        };
        {
            let mut pass = encoder
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("overlay"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: target,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
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
        actions
    }
}
