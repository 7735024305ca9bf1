//! Auto-framing: world bounds of what is drawn, and a camera placement that shows all of it.

use bevy_ecs::prelude::*;
use glam::Vec3;

use crate::assets::Assets;
use crate::bounds::Aabb;
use crate::components::{
    Camera, Children, GlobalTransform, InheritedVisibility, JointMatrices, Mesh3d, MorphWeights, Projection, Transform,
};
use crate::mesh::Mesh;

/// World-space bounds of every visible mesh (after `PostUpdate` has propagated transforms),
/// skinned and morphed meshes in their current pose.
pub fn world_bounds(world: &mut World) -> Aabb {
    let mut q = world.query::<(
        &Mesh3d,
        &GlobalTransform,
        Option<&InheritedVisibility>,
        Option<&JointMatrices>,
        Option<&MorphWeights>,
    )>();
    let meshes = world.resource::<Assets<Mesh>>();
    let mut bounds = Aabb::EMPTY;
    for (mesh, transform, vis, joints, weights) in q.iter(world) {
        if vis.is_some_and(|v| !v.0) {
            continue;
        }
        let Ok(m) = meshes.get(mesh.0) else { continue };
        bounds = bounds.union(&posed_bounds(m, joints, weights).transformed(&transform.0));
    }
    bounds
}

/// World-space bounds of `root`'s visible meshes and its descendants', or `None` if it has none.
pub fn entity_bounds(world: &World, root: Entity) -> Option<Aabb> {
    let mut bounds = Aabb::EMPTY;
    let mut stack = vec![root];
    while let Some(e) = stack.pop() {
        if let Some(b) = mesh_bounds(world, e) {
            bounds = bounds.union(&b);
        }
        if let Some(children) = world.get::<Children>(e) {
            stack.extend(children.iter());
        }
    }
    (!bounds.is_empty()).then_some(bounds)
}

/// World bounds of one entity's mesh, in its current pose; `None` if hidden or without a mesh.
fn mesh_bounds(world: &World, e: Entity) -> Option<Aabb> {
    let entity = world.get_entity(e).ok()?;
    let mesh = entity.get::<Mesh3d>()?;
    let transform = entity.get::<GlobalTransform>()?;
    if entity.get::<InheritedVisibility>().is_some_and(|v| !v.0) {
        return None;
    }
    let m = world.get_resource::<Assets<Mesh>>()?.get(mesh.0).ok()?;
    let local = posed_bounds(m, entity.get::<JointMatrices>(), entity.get::<MorphWeights>());
    Some(local.transformed(&transform.0))
}

/// Local bounds of a mesh in its current skinned and morphed pose.
fn posed_bounds(m: &Mesh, joints: Option<&JointMatrices>, weights: Option<&MorphWeights>) -> Aabb {
    match posed_positions(m, joints, weights) {
        std::borrow::Cow::Borrowed(_) => m.aabb(),
        std::borrow::Cow::Owned(p) => Aabb::from_points(&p),
    }
}

/// A mesh's positions in its current skinned and morphed pose (borrowed when it has none).
pub fn posed_positions<'a>(
    m: &'a Mesh,
    joints: Option<&JointMatrices>,
    weights: Option<&MorphWeights>,
) -> std::borrow::Cow<'a, [Vec3]> {
    let posed = (joints.is_some() && m.is_skinned()) || (weights.is_some() && !m.morph_targets.is_empty());
    if posed {
        let joints = joints.map_or(&[][..], |j| &j.0);
        let weights = weights.map_or(&[][..], |w| &w.0);
        std::borrow::Cow::Owned(m.deformed_positions(joints, weights))
    } else {
        std::borrow::Cow::Borrowed(&m.positions)
    }
}

/// A camera looking down −Z at the centre of `bounds` (the view glTF sample screenshots use).
pub fn framing_camera(bounds: &Aabb, yfov: f32, aspect: f32) -> (Camera, Transform) {
    framing_camera_from(bounds, Vec3::Z, yfov, aspect)
}

/// A camera on the ray from the centre of `bounds` along `direction`, looking back at the
/// centre, as close as it can be while every corner of the box stays inside the frame.
pub fn framing_camera_from(bounds: &Aabb, direction: Vec3, yfov: f32, aspect: f32) -> (Camera, Transform) {
    let largest = if bounds.is_empty() { 0.0 } else { bounds.half_extents().max_element() };
    // Flat or point-like bounds get a minimum thickness relative to their size (a fixed floor
    // would dominate a micrometre-scale scene); an empty scene or a single point a unit box.
    let (center, half) = if largest > 0.0 && largest.is_finite() {
        (bounds.center(), bounds.half_extents().max(Vec3::splat(largest * 1e-3)))
    } else {
        (if bounds.is_empty() { Vec3::ZERO } else { bounds.center() }, Vec3::ONE)
    };
    let back = direction.normalize_or(Vec3::Z);
    let up = if back.cross(Vec3::Y).length_squared() < 1e-6 { Vec3::NEG_Z } else { Vec3::Y };
    let looking = Transform::from_translation(back).looking_at(Vec3::ZERO, up);
    let (tan_y, tan_x) = ((0.5 * yfov).tan(), (0.5 * yfov).tan() * aspect);
    // Each corner, in view axes with z towards the camera, needs the camera at least
    // z + |x|/tan_x (and z + |y|/tan_y) from the centre. 5 % margin on the lateral terms so
    // silhouettes do not touch the border.
    let inverse = looking.rotation.inverse();
    let mut distance: f32 = 0.0;
    for i in 0..8 {
        let corner = Vec3::new(
            if i & 1 == 0 { -half.x } else { half.x },
            if i & 2 == 0 { -half.y } else { half.y },
            if i & 4 == 0 { -half.z } else { half.z },
        );
        let v = inverse * corner;
        distance = distance.max(v.z + (v.x.abs() / tan_x).max(v.y.abs() / tan_y) * 1.05);
    }
    let radius = half.length();
    distance = distance.max(radius * 1e-3);
    // Reverse-Z with an infinite far plane leaves plenty of precision; the near plane only has
    // to stay in front of the bounds and must scale with them (tiny and huge scenes alike).
    let znear = ((distance - radius) * 0.5).max(radius * 1e-3);
    let transform = Transform::from_translation(center + back * distance).with_rotation(looking.rotation);
    let camera =
        Camera { projection: Projection::Perspective { yfov, znear, aspect_ratio: None }, ..Default::default() };
    (camera, transform)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn framing_scales_with_the_scene() {
        for scale in [1e-4f32, 1.0, 1e5] {
            let b = Aabb { min: Vec3::splat(-scale), max: Vec3::splat(scale) };
            let (cam, t) = framing_camera(&b, 0.8, 1.5);
            let d = t.translation.z;
            assert!(d > scale * 2.0 && d < scale * 10.0, "distance {d} for scale {scale}");
            assert!(cam.projection.znear() < d - scale * 3f32.sqrt() && cam.projection.znear() > 0.0);
            assert!(t.rotation.angle_between(glam::Quat::IDENTITY) < 1e-6, "front view looks down -Z");
        }
    }

    #[test]
    fn every_corner_is_inside_the_frustum_from_any_direction() {
        let b = Aabb { min: Vec3::new(-3.0, -1.0, -0.5), max: Vec3::new(2.0, 4.0, 1.0) };
        for dir in [Vec3::Z, Vec3::X, Vec3::Y, Vec3::new(1.0, 0.7, -0.4), Vec3::NEG_Y] {
            let (cam, t) = framing_camera_from(&b, dir, 0.8, 1.3);
            let clip_from_world = cam.projection.clip_from_view(1.3) * t.to_affine().inverse();
            for i in 0..8 {
                let c = Vec3::new(
                    if i & 1 == 0 { b.min.x } else { b.max.x },
                    if i & 2 == 0 { b.min.y } else { b.max.y },
                    if i & 4 == 0 { b.min.z } else { b.max.z },
                );
                let p = clip_from_world * c.extend(1.0);
                let ndc = p.truncate() / p.w;
                assert!(
                    p.w > 0.0 && ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0 && ndc.z <= 1.0,
                    "{dir}: corner {c} at {ndc}"
                );
            }
        }
    }
}
