//! Skinning and morph-target state in the main world.
//!
//! - [`SkinnedMesh`] (authored by importers or scripts) names a mesh's joints (ordinary
//!   entities, animated like any other) and their inverse bind matrices.
//! - [`JointMatrices`] (derived) holds, per joint, the matrix that takes a vertex from the
//!   mesh's bind space to the skinned mesh entity's own space:
//!   `mesh_from_bind = inverse(world_from_mesh) · world_from_joint · joint_from_bind`. Rendering
//!   then places the skinned vertices with the mesh entity's `GlobalTransform` like any other
//!   draw, which lands them at `world_from_joint · joint_from_bind · v` as glTF requires (the
//!   mesh node's own transform cancels out). [`update_joint_matrices`] derives them in
//!   `PostUpdate` after transform propagation, in f64 so that a character far from the origin
//!   keeps its joints' precision (the two world matrices' translations cancel there).
//! - [`MorphWeights`] (authored, animated) weights the mesh's morph targets.
//!
//! The render crate's extraction reads `JointMatrices` and `MorphWeights`; the GPU applies them.

use std::sync::Arc;

use bevy_ecs::prelude::*;
use glam::{DAffine3, DMat4, Mat4};

use crate::components::transform::GlobalTransform;

/// A mesh deformed by a skeleton. On the entity that has the `Mesh3d`.
#[derive(Component, Debug, Clone, PartialEq)]
#[require(JointMatrices)]
pub struct SkinnedMesh {
    /// Per joint, bind space to the joint's space (glTF's inverseBindMatrices).
    pub inverse_bindposes: Arc<[Mat4]>,
    /// The joint entities, in the order the mesh's JOINTS_0 indices refer to.
    pub joints: Vec<Entity>,
}

/// Per joint, the mesh's bind space to the skinned entity's space (see the module doc).
/// Derived; do not write it.
#[derive(Component, Debug, Clone, PartialEq, Default)]
pub struct JointMatrices(pub Vec<Mat4>);

/// Weights of the mesh's morph targets, one per target (extra entries are ignored, missing
/// ones count as 0). On the entity that has the `Mesh3d`.
#[derive(Component, Debug, Clone, PartialEq, Default)]
pub struct MorphWeights(pub Vec<f32>);

/// Recomputes the joint matrices of skinned meshes whose placement, skin or any joint moved
/// since the last run; writes (and marks changed) only those whose matrices differ. A still
/// crowd costs a change-tick check per joint. A joint that no longer exists (despawned) holds
/// the bind pose.
pub fn update_joint_matrices(
    mut skinned: Query<(Ref<SkinnedMesh>, Ref<GlobalTransform>, &mut JointMatrices)>,
    joints: Query<Ref<GlobalTransform>>,
) {
    let mut scratch = Vec::new();
    for (skin, world_from_mesh, mut matrices) in &mut skinned {
        let moved = skin.is_changed()
            || world_from_mesh.is_changed()
            || matrices.0.len() != skin.joints.len()
            || skin.joints.iter().any(|&j| joints.get(j).map_or(true, |g| g.is_changed()));
        if !moved {
            continue;
        }
        let mesh_from_world = DAffine3::from_mat4(Mat4::from(world_from_mesh.0).as_dmat4()).inverse();
        scratch.clear();
        for (i, &joint) in skin.joints.iter().enumerate() {
            let joint_from_bind = skin.inverse_bindposes.get(i).copied().unwrap_or(Mat4::IDENTITY);
            let m = match joints.get(joint) {
                Ok(world_from_joint) => {
                    let world_from_joint = DAffine3::from_mat4(Mat4::from(world_from_joint.0).as_dmat4());
                    let mesh_from_joint = mesh_from_world * world_from_joint;
                    (DMat4::from(mesh_from_joint) * joint_from_bind.as_dmat4()).as_mat4()
                }
                Err(_) => Mat4::IDENTITY,
            };
            // A degenerate mesh transform (scale 0) has no inverse; the draw is invisible then
            // anyway, and NaN must not reach the GPU.
            scratch.push(if m.is_finite() { m } else { Mat4::IDENTITY });
        }
        if matrices.0 != scratch {
            matrices.0.clone_from(&scratch);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Affine3A, Vec3};

    #[test]
    fn joint_matrices_cancel_the_mesh_placement_even_far_from_the_origin() {
        let mut world = World::new();
        let far = Vec3::new(3.0e6, 0.0, -2.0e6);
        let joint = world.spawn(GlobalTransform(Affine3A::from_translation(far + Vec3::new(0.0, 1.5, 0.0)))).id();
        let skin = SkinnedMesh {
            inverse_bindposes: Arc::from([Mat4::from_translation(Vec3::new(0.0, -1.0, 0.0))]),
            joints: vec![joint],
        };
        let mesh = world.spawn((skin, GlobalTransform(Affine3A::from_translation(far)))).id();
        world.run_system_cached(update_joint_matrices).unwrap();
        let m = world.get::<JointMatrices>(mesh).unwrap().0[0];
        // Joint 1.5 m above the mesh, bound 1 m up: bind-space points move up by 0.5 m, exactly.
        assert_eq!(m, Mat4::from_translation(Vec3::new(0.0, 0.5, 0.0)));
    }
}
