//! The scene tree: the entity hierarchy (roots, then `Children` in order) with names. Clicking
//! selects (the inspector shows it; the viewport draws its bounding box), double-clicking
//! focuses the camera on it.

use bevy_ecs::entity::Entity;
use bevy_ecs::query::{With, Without};
use bevy_ecs::world::World;
use penumbra_engine::components::{
    Camera, ChildOf, Children, DirectionalLight, Mesh3d, Name, PointLight, SpotLight, Transform,
};

use crate::view::ui_state::Action;

/// Roots listed before "and N more": a scene of a million cubes must not build a million rows.
const MAX_ROOTS: usize = 500;

pub fn panel(ui: &mut egui::Ui, world: &mut World, selected: &mut Option<Entity>, actions: &mut Vec<Action>) {
    let roots: Vec<Entity> = {
        // Placed things only: resources are entities too in bevy_ecs 0.20.
        let mut q = world.query_filtered::<Entity, (With<Transform>, Without<ChildOf>)>();
        let mut v: Vec<Entity> = q.iter(world).collect();
        v.sort();
        v
    };
    egui::CollapsingHeader::new("Scene tree").default_open(true).show(ui, |ui| {
        for &root in roots.iter().take(MAX_ROOTS) {
            node(ui, world, root, selected, actions);
        }
        if roots.len() > MAX_ROOTS {
            ui.label(format!("… and {} more", roots.len() - MAX_ROOTS));
        }
    });
}

/// What kind of thing an entity is, for its row.
fn label(world: &World, e: Entity) -> String {
    let name = world.get::<Name>(e).map_or_else(|| format!("entity {}", e.index()), |n| n.as_str().to_owned());
    let kind = if world.get::<Mesh3d>(e).is_some() {
        "  (mesh)"
    } else if world.get::<Camera>(e).is_some() {
        "  (camera)"
    } else if world.get::<DirectionalLight>(e).is_some()
        || world.get::<PointLight>(e).is_some()
        || world.get::<SpotLight>(e).is_some()
    {
        "  (light)"
    } else {
        ""
    };
    format!("{name}{kind}")
}

fn node(ui: &mut egui::Ui, world: &World, e: Entity, selected: &mut Option<Entity>, actions: &mut Vec<Action>) {
    let text = label(world, e);
    let is_selected = *selected == Some(e);
    let children: Vec<Entity> = world.get::<Children>(e).map(|c| c.iter().copied().collect()).unwrap_or_default();
    let response = if children.is_empty() {
        ui.selectable_label(is_selected, text)
    } else {
        let id = ui.make_persistent_id(e);
        let (_, header, _) = egui::collapsing_header::CollapsingState::load_with_default_open(ui.ctx(), id, false)
            .show_header(ui, |ui| ui.selectable_label(is_selected, text))
            .body(|ui| {
                for &c in &children {
                    node(ui, world, c, selected, actions);
                }
            });
        header.inner
    };
    if response.clicked() {
        *selected = Some(e);
    }
    if response.double_clicked() {
        actions.push(Action::Focus(e));
    }
}
