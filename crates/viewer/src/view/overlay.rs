//! The viewer's egui UI: a menu bar (File, View, Camera), the docked panels of
//! [`super::panels`] round the viewport (the scene's texture, shown as an image: the UI is never
//! drawn into the scene, so screenshots leave it out), dialogs, the shader error until a reload
//! fixes it, the progress of a load and the status line. Laid out ([`Overlay::run`]) before the
//! scene is rendered, since the layout decides the viewport's size; painted after
//! ([`Overlay::paint`]). It also decides which input is the UI's ([`Overlay::on_window_event`]).
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
    /// This frame's layout, between [`Overlay::run`] and [`Overlay::paint`].
    pending: Option<egui::FullOutput>,
    /// The viewport's image, once registered.
    viewport_texture: Option<egui::TextureId>,
    /// When egui wants to be drawn again without input (an animation, a tooltip's delay).
    repaint_delay: Option<std::time::Duration>,
    /// Where the pointer is now, in points, from the window's latest event: egui's own position
    /// is the one its last frame saw, and a move and a click can both arrive before the next.
    pointer: Option<egui::Pos2>,
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
        Self { ctx, state, renderer, pending: None, viewport_texture: None, repaint_delay: None, pointer: None }
    }

    /// Feeds a window event to egui; true when the UI used it (the camera should ignore it).
    /// Pointer events belong to the UI unless the pointer is over the viewport (`viewport`, in
    /// points) with no window or popup of egui's above it: egui counts its central panel, which
    /// holds the viewport's image, as its own.
    pub fn on_window_event(&mut self, window: &Window, event: &WindowEvent, viewport: Option<egui::Rect>) -> bool {
        let consumed = self.state.on_window_event(window, event).consumed;
        match event {
            WindowEvent::CursorMoved { position, .. } => {
                let ppp = self.ctx.pixels_per_point();
                self.pointer = Some(egui::pos2(position.x as f32 / ppp, position.y as f32 / ppp));
            }
            WindowEvent::CursorLeft { .. } => self.pointer = None,
            _ => {}
        }
        // Pointer motion always reaches the viewer too: a drag that began over the scene goes on
        // over a panel.
        let pointer_event = matches!(event, WindowEvent::MouseInput { .. } | WindowEvent::MouseWheel { .. });
        if !pointer_event {
            return consumed;
        }
        if self.ctx.egui_is_using_pointer() {
            return true;
        }
        // A click on the menu bar right after a move onto it (no frame between them) is the
        // menu's, though egui's last frame saw the pointer over the scene.
        let Some(pos) = self.pointer.or_else(|| self.ctx.input(|i| i.pointer.latest_pos())) else { return false };
        let over_scene = viewport.is_some_and(|r| r.contains(pos))
            && self.ctx.layer_id_at(pos).is_none_or(|layer| layer.order == egui::Order::Background);
        !over_scene
    }

    /// Whether a menu (or another popup) is open: a click anywhere then only closes it, and
    /// Esc closes it rather than quitting.
    pub fn popup_open(&self) -> bool {
        self.ctx.any_popup_open() || egui::Popup::is_any_open(&self.ctx)
    }

    /// Closes every open menu and popup.
    pub fn close_popups(&self) {
        egui::Popup::close_all(&self.ctx);
    }

    /// Whether a text field has the keyboard (shortcuts must not fire).
    pub fn wants_keyboard(&self) -> bool {
        self.ctx.egui_wants_keyboard_input()
    }

    /// Lays the UI out for this frame (the panels read and edit `world`) and returns what the
    /// user asked for; [`Overlay::paint`] draws it. The viewport's rect is in
    /// `ui_state.viewport` afterwards.
    pub fn run(
        &mut self,
        window: &Window,
        ui_state: &mut UiState,
        world: Option<&mut World>,
        info: &FrameInfo<'_>,
    ) -> Vec<Action> {
        let raw = self.state.take_egui_input(window);
        let mut actions = Vec::new();
        let mut world = world;
        let full = self.ctx.run_ui(raw, |ui| {
            panels::menu_bar(ui, ui_state, info, &mut actions);
            if let Some(world) = world.as_deref_mut() {
                panels::scene_panels(ui, ui_state, world, info, &mut actions);
            }
            panels::viewport(ui, ui_state, info);
            panels::messages(ui, ui_state, info, &mut actions);
        });
        self.state.handle_platform_output(window, full.platform_output.clone());
        self.repaint_delay = full.viewport_output.get(&egui::ViewportId::ROOT).map(|v| v.repaint_delay);
        self.pending = Some(full);
        actions
    }

    /// The viewport's rect in physical pixels (x, y, width, height), as last laid out.
    pub fn viewport_pixels(&self, ui_state: &UiState) -> Option<(u32, u32, u32, u32)> {
        let ppp = self.ctx.pixels_per_point();
        let r = ui_state.viewport?;
        let (x, y) = ((r.min.x * ppp).round().max(0.0), (r.min.y * ppp).round().max(0.0));
        let (w, h) = ((r.width() * ppp).round().max(0.0), (r.height() * ppp).round().max(0.0));
        Some((x as u32, y as u32, w as u32, h as u32))
    }

    /// Shows `view` as the viewport's image: registered the first time, its view replaced after.
    pub fn set_viewport_texture(&mut self, device: &wgpu::Device, view: &wgpu::TextureView) -> egui::TextureId {
        match self.viewport_texture {
            Some(id) => {
                self.renderer.update_egui_texture_from_wgpu_texture(device, view, wgpu::FilterMode::Nearest, id);
                id
            }
            None => {
                let id = self.renderer.register_native_texture(device, view, wgpu::FilterMode::Nearest);
                self.viewport_texture = Some(id);
                id
            }
        }
    }

    /// How soon egui asked to be drawn again after the last layout (`None`: not at all).
    pub fn repaint_delay(&self) -> Option<std::time::Duration> {
        self.repaint_delay.filter(|d| *d < std::time::Duration::MAX)
    }

    pub fn viewport_texture(&self) -> Option<egui::TextureId> {
        self.viewport_texture
    }

    /// Draws the UI laid out by [`Overlay::run`] into `target`, cleared first (the viewport's
    /// image covers the scene's part of it), and submits it.
    pub fn paint(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, target: &wgpu::TextureView, size: (u32, u32)) {
        let Some(mut full) = self.pending.take() else { return };
        let jobs = self.ctx.tessellate(std::mem::take(&mut full.shapes), full.pixels_per_point);
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
        // Black under the viewport: the scene's image blends onto it (premultiplied) unchanged
        // whatever its alpha; the panels are opaque.
        let load = wgpu::LoadOp::Clear(wgpu::Color::BLACK);
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
    }
}
