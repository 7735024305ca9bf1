//! Picking: which drawn triangle a ray hits first, on the CPU from the meshes in `Assets<Mesh>`.
//!
//! Each visible mesh entity's box is tested first (the ray taken into its local space, so a
//! scaled or sheared transform needs no world-space copy of the vertices), then its triangles
//! (Möller–Trumbore). Skinned and morphed meshes are tested in their current pose. Hits are
//! compared by world distance. Used by the viewer's click-to-select and double-click-to-focus;
//! scripts can call it too.

use bevy_ecs::prelude::*;
use glam::{Affine3A, Vec3};

use crate::assets::Assets;
use crate::bounds::Aabb;
use crate::components::{GlobalTransform, InheritedVisibility, JointMatrices, Mesh3d, MorphWeights};
use crate::mesh::{Mesh, Topology};

/// A half-line in world space. `direction` need not be normalised.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub direction: Vec3,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    pub entity: Entity,
    /// World-space point hit.
    pub point: Vec3,
    /// World distance from the ray's origin.
    pub distance: f32,
}

/// The nearest triangle of a visible mesh the ray hits, if any. Non-finite rays hit nothing.
pub fn raycast(world: &mut World, ray: Ray) -> Option<RayHit> {
    let dir = ray.direction.try_normalize()?;
    if !ray.origin.is_finite() {
        return None;
    }
    let mut q = world.query::<(
        Entity,
        &Mesh3d,
        &GlobalTransform,
        Option<&InheritedVisibility>,
        Option<&JointMatrices>,
        Option<&MorphWeights>,
    )>();
    let meshes = world.resource::<Assets<Mesh>>();
    let mut best: Option<RayHit> = None;
    for (entity, mesh, transform, vis, joints, weights) in q.iter(world) {
        if vis.is_some_and(|v| !v.0) {
            continue;
        }
        let Ok(m) = meshes.get(mesh.0) else { continue };
        if m.topology != Topology::TriangleList {
            continue;
        }
        let positions = crate::framing::posed_positions(m, joints, weights);
        let Some(t) = hit_mesh(&positions, m.indices.as_deref(), &transform.0, ray.origin, dir) else { continue };
        let point = ray.origin + dir * t;
        if best.is_none_or(|b| t < b.distance) {
            best = Some(RayHit { entity, point, distance: t });
        }
    }
    best
}

/// World distance along `dir` (normalised) to the nearest triangle, or `None`.
fn hit_mesh(positions: &[Vec3], indices: Option<&[u32]>, world: &Affine3A, origin: Vec3, dir: Vec3) -> Option<f32> {
    if world.matrix3.determinant().abs() < f32::MIN_POSITIVE || !world.is_finite() {
        return None;
    }
    let local_from_world = world.inverse();
    let o = local_from_world.transform_point3(origin);
    // Not normalised: a local parameter t is then the same t in world units.
    let d = local_from_world.transform_vector3(dir);
    let bounds = Aabb::from_points(positions);
    slab(&bounds, o, d)?;
    let tri = |i: usize| -> Option<[Vec3; 3]> {
        let idx = |k: usize| indices.map_or(Some(k), |ix| ix.get(k).map(|&v| v as usize));
        Some([*positions.get(idx(3 * i)?)?, *positions.get(idx(3 * i + 1)?)?, *positions.get(idx(3 * i + 2)?)?])
    };
    let count = indices.map_or(positions.len(), <[u32]>::len) / 3;
    (0..count).filter_map(|i| tri(i).and_then(|[a, b, c]| triangle(o, d, a, b, c))).min_by(f32::total_cmp)
}

/// Entry parameter of the ray into the box, if it meets it ahead of the origin.
fn slab(b: &Aabb, o: Vec3, d: Vec3) -> Option<f32> {
    if b.is_empty() {
        return None;
    }
    let inv = d.recip();
    let (t0, t1) = ((b.min - o) * inv, (b.max - o) * inv);
    let near = t0.min(t1).max_element().max(0.0);
    let far = t0.max(t1).min_element();
    (near <= far).then_some(near)
}

/// Möller–Trumbore, both faces; the ray parameter of the hit, if ahead of the origin.
fn triangle(o: Vec3, d: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Option<f32> {
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    // Relative to the triangle's and ray's size, so tiny and huge scenes pick alike.
    if det.abs() <= 1e-12 * e1.length() * e2.length() * d.length() || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > 0.0 && t.is_finite()).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::components::Transform;
    use crate::{App, CorePlugin};

    fn scene(transforms: &[Transform]) -> (App, Vec<Entity>) {
        let mut app = App::new();
        app.add_plugins(CorePlugin);
        app.world.init_resource::<Assets<Mesh>>();
        let cube = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
        let ids = transforms.iter().map(|t| app.world.spawn((Mesh3d(cube), *t)).id()).collect();
        app.update();
        (app, ids)
    }

    #[test]
    fn nearest_of_two_cubes_is_hit_at_its_face() {
        let (mut app, ids) = scene(&[Transform::from_xyz(0.0, 0.0, -5.0), Transform::from_xyz(0.0, 0.0, -10.0)]);
        let hit = raycast(&mut app.world, Ray { origin: Vec3::ZERO, direction: Vec3::NEG_Z }).expect("hit");
        assert_eq!(hit.entity, ids[0]);
        assert!((hit.distance - 4.5).abs() < 1e-4, "{hit:?}");
        assert!((hit.point - Vec3::new(0.0, 0.0, -4.5)).length() < 1e-4);
    }

    #[test]
    fn scaled_far_and_tiny_objects_hit_at_world_distance() {
        for (scale, far) in [(1e-4f32, 0.0f32), (1e4, 0.0), (1.0, 1e6)] {
            let t = Transform::from_xyz(far, 0.0, -10.0 * scale).with_scale(Vec3::splat(scale));
            let (mut app, ids) = scene(&[t]);
            let origin = Vec3::new(far, 0.0, 0.0);
            let hit = raycast(&mut app.world, Ray { origin, direction: Vec3::NEG_Z * 3.0 }).expect("hit");
            assert_eq!(hit.entity, ids[0]);
            let expected = 9.5 * scale;
            assert!((hit.distance - expected).abs() <= expected * 1e-4, "scale {scale}: {hit:?}");
        }
    }

    #[test]
    fn misses_hidden_degenerate_and_non_finite() {
        let (mut app, ids) = scene(&[Transform::from_xyz(0.0, 0.0, -5.0)]);
        assert!(raycast(&mut app.world, Ray { origin: Vec3::ZERO, direction: Vec3::X }).is_none());
        assert!(raycast(&mut app.world, Ray { origin: Vec3::NAN, direction: Vec3::NEG_Z }).is_none());
        assert!(raycast(&mut app.world, Ray { origin: Vec3::ZERO, direction: Vec3::ZERO }).is_none());
        app.world.entity_mut(ids[0]).insert(crate::components::Visibility::Hidden);
        app.update();
        assert!(raycast(&mut app.world, Ray { origin: Vec3::ZERO, direction: Vec3::NEG_Z }).is_none());
        let (mut app, _) = scene(&[Transform::from_xyz(0.0, 0.0, -5.0).with_scale(Vec3::ZERO)]);
        assert!(raycast(&mut app.world, Ray { origin: Vec3::ZERO, direction: Vec3::NEG_Z }).is_none());
    }
}
