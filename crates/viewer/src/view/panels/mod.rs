//! The overlay's panels. Each takes the main world (or the renderer's numbers) and edits copies
//! of what it shows, writing back only what changed, so an untouched panel never marks a
//! component changed (which would re-upload it every frame).

mod animation;
mod environment;
mod inspector;
mod settings;
mod stats;
mod tree;

use bevy_ecs::world::World;
use egui::emath::GuiRounding;
use egui::{Color32, RichText};

pub use environment::load_environment;

use super::ui_state::{Action, FrameInfo, UiState, error_text};

/// File, View and Camera menus along the top.
pub fn menu_bar(ui: &mut egui::Ui, state: &mut UiState, info: &FrameInfo<'_>, actions: &mut Vec<Action>) {
    egui::Panel::top("menu").show(ui, |ui| {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Open…  (Ctrl+O)").clicked() {
                    state.browse(info.recent.first().and_then(|p| p.parent()).map(Into::into));
                }
                if ui.button("Open location…  (Ctrl+L)").clicked() {
                    state.open_dialog = true;
                }
                ui.menu_button("Recent", |ui| {
                    if info.recent.is_empty() {
                        ui.label("(none yet)");
                    }
                    for path in info.recent {
                        if ui.button(path.display().to_string()).clicked() {
                            actions.push(Action::Open(path.clone()));
                        }
                    }
                });
                if ui.button("Screenshot  (F12)").clicked() {
                    actions.push(Action::Screenshot);
                }
                ui.separator();
                if ui.button("Quit  (Esc)").clicked() {
                    actions.push(Action::Quit);
                }
            });
            ui.menu_button("View", |ui| {
                ui.checkbox(&mut state.show_stats, "Stats  (F1)");
                ui.checkbox(&mut state.world_axes, "World axes  (F2)");
                ui.checkbox(&mut state.local_axes, "Local axes  (F3)");
                ui.checkbox(&mut state.show_tree, "Scene tree");
                ui.checkbox(&mut state.show_inspector, "Inspector");
                ui.checkbox(&mut state.show_settings, "Render settings");
                ui.checkbox(&mut state.show_environment, "Environment");
            });
            ui.menu_button("Camera", |ui| {
                if ui.selectable_label(info.through.is_none(), "Orbit camera").clicked() {
                    actions.push(Action::LookThrough(None));
                }
                if info.cameras.is_empty() {
                    ui.label("(the file has no cameras)");
                }
                for (index, name) in &info.cameras {
                    if ui.selectable_label(info.through == Some(*index), format!("{index}: {name}")).clicked() {
                        actions.push(Action::LookThrough(Some(*index)));
                    }
                }
                ui.separator();
                if ui.button("Frame the scene  (F)").clicked() {
                    actions.push(Action::FrameScene);
                }
            });
            if !info.variants.names.is_empty() {
                ui.menu_button("Variants", |ui| {
                    let active = info.variants.active.as_deref();
                    if ui.selectable_label(active.is_none(), "Each part's own material").clicked() {
                        actions.push(Action::Variant(None));
                    }
                    for name in &info.variants.names {
                        if ui.selectable_label(active == Some(name.as_str()), name).clicked() {
                            actions.push(Action::Variant(Some(name.clone())));
                        }
                    }
                });
            }
            if ui.button("Screenshot").on_hover_text("Save the scene without the UI as a PNG (F12)").clicked() {
                actions.push(Action::Screenshot);
            }
            ui.label(RichText::new(info.scene_name).weak());
        });
    });
}

/// Widest a side panel may be, as a fraction of the window: two open side panels leave the
/// scene at least 40 % of it.
const SIDE_FRACTION: f32 = 0.3;
/// A side panel's width when it opens, and the narrowest it can be dragged to (points).
const SIDE_WIDTH: f32 = 240.0;
const SIDE_MIN: f32 = 120.0;

/// The panels that show and edit the scene, docked: the scene tree and the inspector on the
/// left, stats, render settings and the environment on the right, the animation controls at
/// the bottom. Docked panels never overlap each other or leave the window; the scene is drawn
/// in what remains ([`viewport`]).
pub fn scene_panels(
    ui: &mut egui::Ui,
    state: &mut UiState,
    world: &mut World,
    info: &FrameInfo<'_>,
    actions: &mut Vec<Action>,
) {
    let width = ui.ctx().content_rect().width();
    let max = (width * SIDE_FRACTION).max(SIDE_MIN);
    let side = |panel: egui::Panel| {
        panel.resizable(true).default_size(SIDE_WIDTH.min(max)).size_range(SIDE_MIN.min(max)..=max)
    };
    if animation::has_clips(world) {
        egui::Panel::bottom("animation").show(ui, |ui| animation::panel(ui, world));
    }
    if state.show_tree || state.show_inspector {
        side(egui::Panel::left("scene")).show(ui, |ui| {
            egui::ScrollArea::both().auto_shrink([false, false]).show(ui, |ui| {
                if state.show_tree {
                    tree::panel(ui, world, &mut state.selected, actions);
                }
                if state.show_inspector {
                    inspector::panel(ui, world, state.selected);
                }
            });
        });
    }
    let renderer = info.renderer;
    let right = state.show_environment || (renderer.is_some() && (state.show_stats || state.show_settings));
    if right {
        side(egui::Panel::right("tools")).show(ui, |ui| {
            egui::ScrollArea::both().auto_shrink([false, false]).show(ui, |ui| {
                if let Some(renderer) = renderer {
                    if state.show_stats {
                        stats::panel(ui, renderer, info);
                    }
                    if state.show_settings {
                        settings::panel(ui, world, renderer, &mut state.vsync, actions);
                    }
                }
                if state.show_environment {
                    environment::panel(ui, world, &mut state.env_path, &mut state.env_status);
                }
            });
        });
    }
}

/// What the docked panels leave: the scene's image (`info.viewport`, rendered at this rect's
/// size in pixels the frame before it is shown), and the rect, recorded in `state`.
pub fn viewport(ui: &mut egui::Ui, state: &mut UiState, info: &FrameInfo<'_>) {
    egui::CentralPanel::no_frame().show(ui, |ui| {
        let ppp = ui.ctx().pixels_per_point();
        let rect = ui.max_rect().round_to_pixels(ppp);
        state.viewport = Some(rect);
        if let Some(texture) = info.viewport {
            let uv = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
            ui.painter().image(texture, rect, uv, Color32::WHITE);
        }
    });
}

/// The open dialog, load progress and errors, the shader error and the status line.
pub fn messages(ui: &mut egui::Ui, state: &mut UiState, info: &FrameInfo<'_>, actions: &mut Vec<Action>) {
    if let Some(dialog) = state.file_dialog.as_mut() {
        dialog.show(ui.ctx());
        if dialog.selected() {
            if let Some(path) = dialog.path() {
                actions.push(Action::Open(path.to_path_buf()));
            }
            state.file_dialog = None;
        } else if !dialog.visible() {
            state.file_dialog = None;
        }
    }
    if state.open_dialog {
        let mut open = true;
        egui::Window::new("Open a scene").collapsible(false).open(&mut open).show(ui.ctx(), |ui| {
            ui.label(".gltf, .glb or .obj (or drop a file on the window)");
            let field = ui.add(egui::TextEdit::singleline(&mut state.open_path).desired_width(360.0));
            // The field has the keyboard as soon as the dialog opens: type, then Enter.
            if !field.has_focus() && !field.lost_focus() {
                field.request_focus();
            }
            let enter = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            if (ui.button("Open").clicked() || enter) && !state.open_path.trim().is_empty() {
                actions.push(Action::Open(state.open_path.trim().into()));
                state.open_dialog = false;
            }
        });
        state.open_dialog &= open;
    }
    if let Some((name, progress, seconds, preparing)) = &info.loading {
        egui::Window::new("Loading")
            .collapsible(false)
            .title_bar(false)
            .anchor(egui::Align2::CENTER_BOTTOM, [0.0, -24.0])
            .show(ui.ctx(), |ui| {
                if *preparing {
                    ui.label(format!(
                        "Loading {name} ({seconds:.1} s): preparing the first frame (GPU resources, shaders)"
                    ));
                    ui.add(egui::ProgressBar::new(1.0).animate(true));
                    return;
                }
                ui.label(format!("Loading {name} ({seconds:.1} s): {}", progress.stage.describe()));
                let counted =
                    if progress.total > 0 { format!(" {}/{}", progress.done, progress.total) } else { String::new() };
                ui.add(egui::ProgressBar::new(progress.fraction()).show_percentage().text(counted));
            });
    }
    if let Some(error) = state.load_error.clone() {
        egui::Window::new("Could not open the file")
            .collapsible(false)
            .anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0])
            .show(ui.ctx(), |ui| {
                ui.label(error_text(error));
                ui.label("The current scene is unchanged.");
                if ui.button("OK").clicked() {
                    state.load_error = None;
                }
            });
    }
    if let Some(e) = info.renderer.and_then(|r| r.shader_error()) {
        egui::Window::new("Shader error").collapsible(false).anchor(egui::Align2::LEFT_BOTTOM, [8.0, -8.0]).show(
            ui.ctx(),
            |ui| {
                egui::Frame::new().fill(Color32::from_rgba_unmultiplied(110, 0, 0, 230)).inner_margin(10).show(
                    ui,
                    |ui| {
                        ui.label(
                            RichText::new("Still drawing with the last good shaders").color(Color32::WHITE).strong(),
                        );
                        ui.label(RichText::new(e.to_string()).monospace().color(Color32::WHITE));
                    },
                );
            },
        );
    }
    if let Some(e) = info.renderer.and_then(|r| r.frame_error()) {
        egui::Window::new("The frame could not be drawn")
            .collapsible(false)
            .anchor(egui::Align2::CENTER_BOTTOM, [0.0, -8.0])
            .show(ui.ctx(), |ui| {
                ui.label(RichText::new(e.to_string()).color(Color32::LIGHT_RED));
                ui.label("A smaller window or Render settings > MSAA 1 may fit.");
            });
    }
    if let Some((status, _)) = state.status.as_ref().filter(|(_, t)| t.elapsed() < super::ui_state::STATUS_SHOWN) {
        egui::Area::new(egui::Id::unique("penumbra status line"))
            .anchor(egui::Align2::RIGHT_BOTTOM, [-8.0, -8.0])
            .show(ui.ctx(), |ui| {
                ui.label(
                    RichText::new(status)
                        .color(Color32::from_gray(220))
                        .background_color(Color32::from_black_alpha(160)),
                );
            });
    }
}
