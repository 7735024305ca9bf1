//! The viewer's egui overlay, drawn over the tonemapped frame (never into the scene): the
//! current shader error, in red, until a reload fixes it; the environment panel (source, a
//! .hdr/.exr file to load, intensity, rotation, background); and, for animated scenes, the
//! animation panel (the clips, play/pause, loop, speed, the time). The other panels of the full
//! viewer (issue #6) will grow here.
//!
//! The overlay edits copies of the scene's `Environment` and of its `AnimationPlayer`; the viewer
//! writes them back to the main world when they changed, so the renderer and the animation
//! system see ordinary changes.

use std::path::Path;
use std::sync::Arc;

use egui::{Color32, RichText};
use penumbra_engine::animation::{AnimationPlayer, Repeat};
use penumbra_engine::environment::{Background, Environment, EnvironmentImage, EnvironmentSource, Sky};
use penumbra_render::ShaderError;
use winit::event::WindowEvent;
use winit::window::Window;

pub struct Overlay {
    ctx: egui::Context,
    state: egui_winit::State,
    renderer: egui_wgpu::Renderer,
    /// The environment panel's file field.
    env_path: String,
    /// The last load's outcome: what was loaded, or why not.
    env_status: Option<Result<String, String>>,
}

/// Loads `path` as the environment's image; on failure the environment stays as it was and
/// the error (naming the file) is returned.
pub fn load_environment(env: &mut Option<Environment>, path: &Path) -> Result<String, String> {
    let image = EnvironmentImage::load(path).map_err(|e| e.to_string())?;
    let loaded = format!("{} ({}×{})", path.display(), image.width, image.height);
    let current = env.get_or_insert_with(Environment::default);
    current.source = EnvironmentSource::Image(Arc::new(image));
    Ok(loaded)
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
        Self { ctx, state, renderer, env_path: String::new(), env_status: None }
    }

    /// Feeds a window event to egui; true when egui used it (the camera should ignore it).
    pub fn on_window_event(&mut self, window: &Window, event: &WindowEvent) -> bool {
        self.state.on_window_event(window, event).consumed
    }

    /// Shows the outcome of loading an environment from outside the panel (a dropped file).
    pub fn set_env_status(&mut self, status: Result<String, String>) {
        self.env_status = Some(status);
    }

    /// Draws the overlay into `target` (already holding the frame) and submits it. `env` is
    /// the scene's environment and `player` its animation player, edited in place by the panels.
    #[allow(clippy::too_many_arguments)]
    pub fn draw(
        &mut self,
        window: &Window,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        target: &wgpu::TextureView,
        size: (u32, u32),
        shader_error: Option<&ShaderError>,
        env: &mut Option<Environment>,
        mut player: Option<&mut AnimationPlayer>,
    ) {
        let raw = self.state.take_egui_input(window);
        let (env_path, env_status) = (&mut self.env_path, &mut self.env_status);
        let mut full = self.ctx.run_ui(raw, |ui| {
            environment_panel(ui, env, env_path, env_status);
            if let Some(player) = player.as_deref_mut() {
                animation_panel(ui, player);
            }
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

fn environment_panel(
    ui: &mut egui::Ui,
    env: &mut Option<Environment>,
    path: &mut String,
    status: &mut Option<Result<String, String>>,
) {
    egui::Window::new("Environment").default_open(false).anchor(egui::Align2::RIGHT_TOP, [-8.0, 8.0]).show(
        ui.ctx(),
        |ui| {
            let kind = match env.as_ref().map(|e| &e.source) {
                None => "none",
                Some(EnvironmentSource::Auto) => "auto",
                Some(EnvironmentSource::Sky(_)) => "sky",
                Some(EnvironmentSource::Studio) => "studio",
                Some(EnvironmentSource::Image(_)) => "image",
            };
            ui.horizontal(|ui| {
                for (name, source) in [
                    ("none", None),
                    ("auto", Some(EnvironmentSource::Auto)),
                    ("sky", Some(EnvironmentSource::Sky(Sky::default()))),
                    ("studio", Some(EnvironmentSource::Studio)),
                ] {
                    if ui.selectable_label(kind == name, name).clicked() && kind != name {
                        match source {
                            None => *env = None,
                            Some(s) => env.get_or_insert_with(Environment::default).source = s,
                        }
                    }
                }
                if kind == "image" {
                    let _ = ui.selectable_label(true, "image");
                }
            });
            ui.horizontal(|ui| {
                ui.add(egui::TextEdit::singleline(path).hint_text(".hdr or .exr file (or drop one on the window)"));
                if ui.button("Load").clicked() {
                    *status = Some(load_environment(env, Path::new(path.trim())));
                }
            });
            match status {
                Some(Ok(m)) => {
                    ui.label(format!("loaded {m}"));
                }
                Some(Err(e)) => {
                    ui.label(RichText::new(e.as_str()).color(Color32::from_rgb(255, 90, 90)));
                }
                None => {}
            }
            let Some(e) = env.as_mut() else { return };
            ui.add(egui::Slider::new(&mut e.intensity, 0.0..=16.0).logarithmic(true).text("intensity"));
            let mut degrees = e.rotation.to_degrees();
            if ui.add(egui::Slider::new(&mut degrees, -180.0..=180.0).text("rotation °")).changed() {
                e.rotation = degrees.to_radians();
            }
            let mut blur = match e.background {
                Background::Blurred(r) => Some(r),
                _ => None,
            };
            ui.horizontal(|ui| {
                ui.label("background");
                if ui.selectable_label(e.background == Background::Environment, "environment").clicked() {
                    e.background = Background::Environment;
                    blur = None;
                }
                if ui.selectable_label(blur.is_some(), "blurred").clicked() && blur.is_none() {
                    blur = Some(0.5);
                }
                if ui.selectable_label(matches!(e.background, Background::Color(_)), "colour").clicked() {
                    e.background = Background::Color([0.02, 0.02, 0.025]);
                    blur = None;
                }
            });
            if let Some(mut r) = blur {
                ui.add(egui::Slider::new(&mut r, 0.0..=1.0).text("blur (roughness)"));
                e.background = Background::Blurred(r);
            }
        },
    );
}

/// The scene's clips (by name), play/pause, loop, speed and the play head.
fn animation_panel(ui: &mut egui::Ui, player: &mut AnimationPlayer) {
    let n = player.clips().len();
    let title = format!("Animation ({n} clip{})", if n == 1 { "" } else { "s" });
    egui::Window::new(title).default_open(true).anchor(egui::Align2::LEFT_BOTTOM, [8.0, -8.0]).show(ui.ctx(), |ui| {
        let active = player.active();
        let names: Vec<String> = player.clips().iter().map(|c| c.name.clone()).collect();
        let mut chosen = None;
        egui::ComboBox::from_label("clip").selected_text(active.map_or("(stopped)", |i| names[i].as_str())).show_ui(
            ui,
            |ui| {
                for (i, name) in names.iter().enumerate() {
                    if ui.selectable_label(active == Some(i), name).clicked() {
                        chosen = Some(i);
                    }
                }
            },
        );
        if let Some(i) = chosen.filter(|&i| Some(i) != active) {
            // Indices come from the list itself: always valid.
            let _ = player.play(i);
        }
        ui.horizontal(|ui| {
            if ui.button(if player.is_paused() { "play" } else { "pause" }).clicked() {
                if player.is_paused() { player.resume() } else { player.pause() }
            }
            let mut looping = player.repeat() == Repeat::Loop;
            if ui.checkbox(&mut looping, "loop").changed() {
                player.set_repeat(if looping { Repeat::Loop } else { Repeat::Once });
            }
        });
        let mut speed = player.speed();
        if ui.add(egui::Slider::new(&mut speed, -2.0..=2.0).text("speed")).changed() {
            let _ = player.set_speed(speed);
        }
        let duration = player.active_clip().map_or(0.0, |c| c.duration());
        let mut time = player.time();
        if ui.add(egui::Slider::new(&mut time, 0.0..=duration.max(1e-3)).text("time (s)")).changed() {
            let _ = player.seek(time);
        }
    });
}
