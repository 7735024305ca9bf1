//! `Visibility` (authored) and `InheritedVisibility` (derived down the hierarchy in `PostUpdate`).

use bevy_ecs::prelude::*;

use super::change_summary::any_changed;
use super::draw_changes::{DrawChanges, record_insert};

/// Authored visibility. Each table of them keeps a summary tick (see `Transform`).
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq, Default)]
#[component(summary_tick)]
#[require(InheritedVisibility)]
pub enum Visibility {
    /// Visible if the parent is (roots: visible).
    #[default]
    Inherited,
    Visible,
    Hidden,
}

/// Whether the entity is shown after applying every ancestor's `Visibility`. Derived by
/// propagation: write `Visibility`, not this (see `GlobalTransform` for why).
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq)]
#[component(on_insert = record_insert)]
pub struct InheritedVisibility(pub bool);

impl Default for InheritedVisibility {
    fn default() -> Self {
        Self(true)
    }
}

/// Entities with neither parent nor children whose `Visibility` changed: most of a large scene.
type ChangedStandalone<'w, 's> = Query<
    'w,
    's,
    (Entity, &'static Visibility, &'static mut InheritedVisibility),
    (Changed<Visibility>, Without<ChildOf>, Without<Children>),
>;

/// Every standalone entity's `Visibility`, for its tables' summary ticks.
type StandaloneProbe<'w, 's> = Query<'w, 's, Ref<'static, Visibility>, (Without<ChildOf>, Without<Children>)>;

/// Whether a root (or an entity without a parent) is shown.
fn shown_alone(visibility: &Visibility) -> bool {
    *visibility != Visibility::Hidden
}

/// Derives `InheritedVisibility`, and records each entity whose `InheritedVisibility` changes in
/// the [`DrawChanges`] feed (when the renderer keeps one).
pub fn propagate_visibility(
    mut inherited: ParamSet<(ChangedStandalone, Query<&mut InheritedVisibility>, StandaloneProbe)>,
    // A root without Visibility (a bare grouping entity) still passes its children's on.
    roots: Query<Entity, (With<Children>, Without<ChildOf>)>,
    nodes: Query<(Option<Ref<Visibility>>, Option<&Children>)>,
    hierarchy_changed: Query<(), (Or<(Changed<Visibility>, Changed<ChildOf>)>, Or<(With<ChildOf>, With<Children>)>)>,
    parentless: Query<&Visibility, Without<ChildOf>>,
    mut unparented: RemovedComponents<ChildOf>,
    mut feed: Option<ResMut<DrawChanges>>,
) {
    // Standalone entities are their own answer: only the changed ones are visited, on all
    // cores; and when no table of them saw a write since the last frame, none is.
    if any_changed(&inherited.p2()) {
        let pass = feed.as_mut().map(|f| f.begin_pass());
        inherited.p0().par_iter_mut().for_each_init(
            || pass.map(|p| p.task_recorder()),
            |recorder, (entity, visibility, mut derived)| {
                if derived.set_if_neq(InheritedVisibility(shown_alone(visibility)))
                    && let Some(r) = recorder
                {
                    r.record(entity);
                }
            },
        );
    }
    let mut record = |entity: Entity| {
        if let Some(f) = feed.as_mut() {
            f.record(entity);
        }
    };
    let unparented: Vec<Entity> = unparented.read().collect();
    let mut inherited = inherited.p1();
    // An entity that lost its parent no longer inherits its parent's hiding.
    for &entity in &unparented {
        if let (Ok(visibility), Ok(mut derived)) = (parentless.get(entity), inherited.get_mut(entity))
            && derived.set_if_neq(InheritedVisibility(shown_alone(visibility)))
        {
            record(entity);
        }
    }
    // Hierarchies: nothing authored changed in any of them, nothing derived can change.
    if hierarchy_changed.is_empty() && unparented.is_empty() {
        return;
    }
    for root in &roots {
        walk(root, true, &nodes, &mut inherited, &mut record, 0);
    }
}

fn walk(
    entity: Entity,
    parent_visible: bool,
    nodes: &Query<(Option<Ref<Visibility>>, Option<&Children>)>,
    inherited: &mut Query<&mut InheritedVisibility>,
    record: &mut impl FnMut(Entity),
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
    if let Ok(mut iv) = inherited.get_mut(entity)
        && iv.set_if_neq(InheritedVisibility(visible))
    {
        record(entity);
    }
    if let Some(children) = children {
        for &child in children {
            walk(child, visible, nodes, inherited, record, depth + 1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{App, CorePlugin};

    fn shown(app: &App, e: Entity) -> bool {
        app.world.get::<InheritedVisibility>(e).unwrap().0
    }

    #[test]
    fn hiding_reaches_children_and_standalone_entities() {
        let mut app = App::new();
        app.add_plugins(CorePlugin);
        let alone = app.world.spawn(Visibility::Hidden).id();
        let parent = app.world.spawn(Visibility::Hidden).id();
        let child = app.world.spawn((Visibility::Inherited, ChildOf(parent))).id();
        let shown_child = app.world.spawn((Visibility::Visible, ChildOf(parent))).id();
        app.update();
        assert!(!shown(&app, alone) && !shown(&app, parent) && !shown(&app, child));
        assert!(shown(&app, shown_child), "Visible overrides a hidden parent");
        *app.world.get_mut::<Visibility>(alone).unwrap() = Visibility::Inherited;
        *app.world.get_mut::<Visibility>(parent).unwrap() = Visibility::Visible;
        app.update();
        assert!(shown(&app, alone) && shown(&app, parent) && shown(&app, child));
    }

    #[test]
    fn children_of_a_root_without_visibility_are_resolved() {
        let mut app = App::new();
        app.add_plugins(CorePlugin);
        let group = app.world.spawn_empty().id();
        let hidden = app.world.spawn((Visibility::Hidden, ChildOf(group))).id();
        let grandchild = app.world.spawn((Visibility::Inherited, ChildOf(hidden))).id();
        app.update();
        assert!(!shown(&app, hidden) && !shown(&app, grandchild));
    }

    #[test]
    fn a_child_leaving_a_hidden_parent_shows() {
        let mut app = App::new();
        app.add_plugins(CorePlugin);
        let parent = app.world.spawn(Visibility::Hidden).id();
        let child = app.world.spawn((Visibility::Inherited, ChildOf(parent))).id();
        app.update();
        assert!(!shown(&app, child));
        app.world.entity_mut(child).remove::<ChildOf>();
        app.update();
        assert!(shown(&app, child), "no parent hides it any more");
    }
}
