//! Components that make an entity drawable: which mesh, with which material.

use bevy_ecs::prelude::*;

use super::transform::Transform;
use super::visibility::Visibility;
use crate::assets::Handle;
use crate::material::StandardMaterial;
use crate::mesh::Mesh;

#[derive(Component, Debug, Clone, Copy, PartialEq, Eq)]
#[require(Transform, Visibility)]
pub struct Mesh3d(pub Handle<Mesh>);

/// Without one, the mesh draws with the glTF default material (white, metallic 1, roughness 1).
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq)]
pub struct MeshMaterial3d(pub Handle<StandardMaterial>);
