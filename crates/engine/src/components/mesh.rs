//! Components that make an entity drawable: which mesh, with which material.

use bevy_ecs::prelude::*;

use super::draw_changes::record_insert;
use super::transform::Transform;
use super::visibility::Visibility;
use crate::assets::Handle;
use crate::material::StandardMaterial;
use crate::mesh::Mesh;

/// Immutable: to draw another mesh, insert a new `Mesh3d` (the insertion is what tells the
/// renderer, see [`super::draw_changes`]).
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq)]
#[component(immutable, on_insert = record_insert)]
#[require(Transform, Visibility)]
pub struct Mesh3d(pub Handle<Mesh>);

/// Without one, the mesh draws with the glTF default material (white, metallic 1, roughness 1).
/// Immutable like [`Mesh3d`]: insert a new one to change it.
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq)]
#[component(immutable, on_insert = record_insert)]
pub struct MeshMaterial3d(pub Handle<StandardMaterial>);
