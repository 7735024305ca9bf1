//! The animation panel, for scenes with clips: the clip, play/pause, loop, speed and the play
//! head. Edits a copy of the first `AnimationPlayer`; the real one takes the copy's playback
//! state only when something changed.

use bevy_ecs::entity::Entity;
use bevy_ecs::world::World;
use penumbra_engine::animation::{AnimationPlayer, Repeat};

/// What the panel can change in a player.
fn playback(p: &AnimationPlayer) -> (Option<usize>, f32, f32, bool, Repeat) {
    (p.active(), p.time(), p.speed(), p.is_paused(), p.repeat())
}

/// Whether the scene has a player with clips (the panel shows only then).
pub fn has_clips(world: &mut World) -> bool {
    let mut q = world.query::<&AnimationPlayer>();
    q.iter(world).any(|p| !p.clips().is_empty())
}

pub fn panel(ui: &mut egui::Ui, world: &mut World) {
    let found = {
        let mut q = world.query::<(Entity, &AnimationPlayer)>();
        q.iter(world).next().map(|(e, p)| (e, p.clone()))
    };
    let Some((root, mut player)) = found else { return };
    let before = playback(&player);
    edit(ui, &mut player);
    if playback(&player) != before
        && let Some(mut p) = world.get_mut::<AnimationPlayer>(root)
    {
        p.copy_playback(&player);
    }
}

fn edit(ui: &mut egui::Ui, player: &mut AnimationPlayer) {
    let n = player.clips().len();
    let title = format!("Animation ({n} clip{})", if n == 1 { "" } else { "s" });
    egui::CollapsingHeader::new(title).default_open(true).show(ui, |ui| {
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
