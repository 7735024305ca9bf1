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

use std::path::PathBuf;

use bevy_ecs::entity::Entity;
use bevy_ecs::world::World;
use egui::{Color32, RichText};
use penumbra_engine::import::ProgressSnapshot;
use penumbra_render::{RenderSettings, Renderer};
use winit::event::WindowEvent;
use winit::window::Window;

use super::panels;

/// What the user asked for that the viewer carries out after the frame.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    Open(PathBuf),
    Screenshot,
    Settings(RenderSettings),
    /// Look through the file's camera of this glTF index (`None`: the orbit camera).
    LookThrough(Option<usize>),
    FrameScene,
    Focus(Entity),
    Vsync(bool),
    Quit,
}

/// Panel state that persists across frames.
pub struct UiState {
    pub show_stats: bool,
    pub show_tree: bool,
    pub show_inspector: bool,
    pub show_settings: bool,
    pub show_environment: bool,
    /// F2: the world's axes at the origin; F3: every object's local axes.
    pub world_axes: bool,
    pub local_axes: bool,
    pub selected: Option<Entity>,
    pub open_dialog: bool,
    pub open_path: String,
    pub env_path: String,
    pub env_status: Option<Result<String, String>>,
    /// The last outcome worth telling: a failed load stays until dismissed.
    pub load_error: Option<String>,
    /// A passing message (screenshot saved, …) and when it was posted; shown for a few seconds.
    pub status: Option<(String, std::time::Instant)>,
    pub vsync: bool,
}

impl UiState {
    pub fn set_status(&mut self, message: impl Into<String>) {
        self.status = Some((message.into(), std::time::Instant::now()));
    }

    pub fn new(vsync: bool) -> UiState {
        UiState {
            show_stats: false,
            // Only the menu bar at first: the scene gets the whole window until a panel is asked for.
            show_tree: false,
            show_inspector: false,
            show_settings: false,
            show_environment: false,
            world_axes: false,
            local_axes: false,
            selected: None,
            open_dialog: false,
            open_path: String::new(),
            env_path: String::new(),
            env_status: None,
            load_error: None,
            status: None,
            vsync,
        }
    }
}

/// What the viewer knows this frame that the panels show.
pub struct FrameInfo<'a> {
    pub renderer: Option<&'a Renderer>,
    pub fps: f32,
    pub frame_ms: f32,
    /// A load in flight: its name, progress and seconds so far.
    pub loading: Option<(String, ProgressSnapshot, f32)>,
    pub recent: &'a [PathBuf],
    /// The file's cameras (glTF index, name) and the one looked through.
    pub cameras: Vec<(usize, String)>,
    pub through: Option<usize>,
    pub scene_name: &'a str,
}

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

/// Red text for errors, used by every panel.
pub fn error_text(text: impl Into<String>) -> RichText {
    RichText::new(text).color(Color32::from_rgb(255, 110, 110))
}
