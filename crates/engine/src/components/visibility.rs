//! `Visibility` (authored) and `InheritedVisibility` (derived down the hierarchy in `PostUpdate`).

use bevy_ecs::prelude::*;

#[derive(Component, Debug, Clone, Copy, PartialEq, Eq, Default)]
#[require(InheritedVisibility)]
pub enum Visibility {
    /// Visible if the parent is (roots: visible).
    #[default]
    Inherited,
    Visible,
    Hidden,
}

/// Whether the entity is shown after applying every ancestor's `Visibility`.
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq)]
pub struct InheritedVisibility(pub bool);

impl Default for InheritedVisibility {
    fn default() -> Self {
        Self(true)
    }
}

pub fn propagate_visibility(
    roots: Query<(Entity, Option<&Children>), (With<Visibility>, Without<ChildOf>)>,
    nodes: Query<(Option<Ref<Visibility>>, Option<&Children>)>,
    changed: Query<(), Or<(Changed<Visibility>, Changed<ChildOf>)>>,
    mut inherited: Query<&mut InheritedVisibility>,
) {
    // Cheap early-out: nothing authored changed, nothing derived can change.
    if changed.is_empty() {
        return;
    }
    for (root, _) in &roots {
        walk(root, true, &nodes, &mut inherited, 0);
    }
}

fn walk(
    entity: Entity,
    parent_visible: bool,
    nodes: &Query<(Option<Ref<Visibility>>, Option<&Children>)>,
    inherited: &mut Query<&mut InheritedVisibility>,
    depth: u32,
) {
    if depth > 4096 {
        return;
    }
    let Ok((vis, children)) = nodes.get(entity) else {
        return;
    };
    let visible = match vis.as_deref() {
        Some(Visibility::Visible) => true,
        Some(Visibility::Hidden) => false,
        Some(Visibility::Inherited) | None => parent_visible,
    };
    if let Ok(mut iv) = inherited.get_mut(entity) {
        iv.set_if_neq(InheritedVisibility(visible));
    }
    if let Some(children) = children {
        for &child in children {
            walk(child, visible, nodes, inherited, depth + 1);
        }
    }
}
