//! The main world's components. Authored components (`Transform`, `Visibility`) are written by
//! users and importers; derived ones (`GlobalTransform`, `InheritedVisibility`) are written only
//! by the `PostUpdate` systems in this module's children.

pub mod camera;
pub mod change_summary;
pub mod draw_changes;
pub mod light;
pub mod mesh;
pub mod skin;
pub mod transform;
pub mod visibility;

pub use bevy_ecs::hierarchy::{ChildOf, Children};
pub use bevy_ecs::name::Name;
pub use camera::{Camera, Exposure, Projection};
pub use draw_changes::DrawChanges;
pub use light::{
    AmbientLight, DirectionalLight, DiskLight, IesLight, PointLight, RectLight, SphereLight, SpotLight, TubeLight,
};
pub use mesh::{Mesh3d, MeshMaterial3d};
pub use skin::{JointMatrices, MorphWeights, SkinnedMesh};
pub use transform::{GlobalTransform, Transform};
pub use visibility::{InheritedVisibility, Visibility};
