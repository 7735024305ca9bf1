//! What the viewer draws as gizmo lines: the world axes (F2) at the origin, each object's local
//! axes (F3), and the selected object's bounding box. Refilled before each update from the
//! previous frame's placements (so during an animation the lines trail the pose by one frame),
//! and written to the `Gizmos` resource only when they changed, so a still view re-extracts
//! nothing.

use bevy_ecs::entity::Entity;
use bevy_ecs::query::With;
use bevy_ecs::world::World;
use glam::Vec3;
use penumbra_engine::components::{GlobalTransform, Mesh3d, Transform};
use penumbra_engine::framing::{entity_bounds, world_bounds};
use penumbra_engine::gizmos::{AXIS_COLORS, Gizmos};

/// Objects beyond this many get no local axes (a million-cube scene would draw a thicket).
const MAX_LOCAL_AXES: usize = 10_000;
const SELECTION_COLOR: Vec3 = Vec3::new(1.0, 0.8, 0.1);

pub struct GizmoRequest {
    pub world_axes: bool,
    pub local_axes: bool,
    pub selected: Option<Entity>,
    /// The viewer's own camera, which gets no axes.
    pub camera: Entity,
}

pub fn update(world: &mut World, request: &GizmoRequest) {
    let mut g = Gizmos::default();
    if request.world_axes || request.local_axes {
        let bounds = world_bounds(world);
        let size = if bounds.is_empty() { 1.0 } else { bounds.half_extents().max_element().max(1e-6) };
        if request.world_axes {
            for (axis, color) in [Vec3::X, Vec3::Y, Vec3::Z].into_iter().zip(AXIS_COLORS) {
                g.line(Vec3::ZERO, axis * size * 1.5, color);
            }
        }
        if request.local_axes {
            let mut q = world.query_filtered::<(Entity, &GlobalTransform, Option<&Mesh3d>), With<Transform>>();
            let placed: Vec<(Entity, GlobalTransform, bool)> = q
                .iter(world)
                .filter(|(e, ..)| *e != request.camera)
                .take(MAX_LOCAL_AXES)
                .map(|(e, t, m)| (e, *t, m.is_some()))
                .collect();
            for (e, t, has_mesh) in placed {
                // Orientation, not scale: each axis is as long as the object (or a twentieth of
                // the scene for lights, cameras and empty nodes).
                let length = match has_mesh.then(|| entity_bounds(world, e)).flatten() {
                    Some(b) => b.half_extents().max_element() * 1.25,
                    None => size * 0.05,
                };
                let origin = t.translation();
                for (axis, color) in [Vec3::X, Vec3::Y, Vec3::Z].into_iter().zip(AXIS_COLORS) {
                    let direction = (t.0.matrix3 * axis).normalize_or_zero();
                    g.line(origin, origin + direction * length, color);
                }
            }
        }
    }
    if let Some(b) = request.selected.and_then(|e| entity_bounds(world, e)) {
        g.aabb(&b, SELECTION_COLOR);
    }
    let unchanged = world.get_resource::<Gizmos>().is_some_and(|current| *current == g);
    if !unchanged {
        world.insert_resource(g);
    }
}
