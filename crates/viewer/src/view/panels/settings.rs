//! The render settings panel: tonemapper, exposure (the active camera's EV100), the quality
//! preset, the shadow filter, MSAA, FXAA,
//! bloom, automatic exposure, debug views and vsync. Renderer settings change through
//! [`Action::Settings`] (validated by the renderer); exposure is the camera component's.

use bevy_ecs::world::World;
use penumbra_engine::components::Camera;
use penumbra_render::DebugView;
use penumbra_render::features::shadows::ShadowFilter;
use penumbra_render::{AutoExposure, BloomSettings};
use penumbra_render::{QualityPreset, Renderer, Tonemapper};

use crate::view::ui_state::Action;

pub fn panel(ui: &mut egui::Ui, world: &mut World, renderer: &Renderer, vsync: &mut bool, actions: &mut Vec<Action>) {
    let before = renderer.settings().clone();
    let mut s = before.clone();
    egui::CollapsingHeader::new("Render settings").default_open(true).show(ui, |ui| {
        ui.horizontal(|ui| {
            ui.label("tonemapper");
            for (t, name) in [(Tonemapper::Neutral, "neutral"), (Tonemapper::Aces, "ACES"), (Tonemapper::None, "clamp")]
            {
                ui.selectable_value(&mut s.tonemapper, t, name);
            }
        });
        exposure(ui, world);
        ui.horizontal(|ui| {
            ui.label("quality");
            let current = QualityPreset::matching(&s);
            for p in QualityPreset::ALL {
                if ui.selectable_label(current == Some(p), p.name()).clicked() {
                    p.apply(&mut s);
                }
            }
            if current.is_none() {
                ui.weak("(custom)");
            }
        });
        ui.horizontal(|ui| {
            ui.label("shadows");
            ui.selectable_value(&mut s.shadows.filter, ShadowFilter::Pcf, "PCF");
            ui.selectable_value(&mut s.shadows.filter, ShadowFilter::Pcss, "PCSS");
        });
        ui.horizontal(|ui| {
            ui.label("MSAA");
            ui.selectable_value(&mut s.msaa, 1, "off");
            ui.selectable_value(&mut s.msaa, 4, "4×");
            ui.checkbox(&mut s.post.fxaa, "FXAA");
        });
        let mut bloom = s.post.bloom.is_some();
        ui.horizontal(|ui| {
            ui.checkbox(&mut bloom, "bloom");
            match (&mut s.post.bloom, bloom) {
                (Some(b), true) => {
                    ui.add(egui::Slider::new(&mut b.strength, 0.0..=1.0).text("strength"));
                }
                (None, true) => s.post.bloom = Some(BloomSettings::default()),
                (_, false) => s.post.bloom = None,
            }
        });
        let mut auto = s.post.auto_exposure.is_some();
        ui.checkbox(&mut auto, "automatic exposure");
        if auto != s.post.auto_exposure.is_some() {
            s.post.auto_exposure = auto.then(AutoExposure::default);
        }
        ui.horizontal(|ui| {
            ui.label("debug view");
            for (v, name) in [
                (DebugView::None, "off"),
                (DebugView::ClusterHeat, "light clusters"),
                (DebugView::Cascades, "cascades"),
                (DebugView::Normals, "normals"),
                (DebugView::Uvs, "UVs"),
            ] {
                ui.selectable_value(&mut s.debug_view, v, name);
            }
        });
        if ui.checkbox(vsync, "vsync").changed() {
            actions.push(Action::Vsync(*vsync));
        }
    });
    if s != before {
        actions.push(Action::Settings(s));
    }
}

/// The active camera's exposure, EV100 (higher is darker).
fn exposure(ui: &mut egui::Ui, world: &mut World) {
    let mut q = world.query::<&mut Camera>();
    let Some(mut camera) = q.iter_mut(world).find(|c| c.is_active) else { return };
    let mut ev = camera.exposure.ev100;
    if ui.add(egui::Slider::new(&mut ev, -6.0..=18.0).text("exposure (EV100)")).changed() {
        camera.exposure.ev100 = ev;
    }
}
