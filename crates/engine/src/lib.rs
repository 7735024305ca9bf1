//! Penumbra's main world: the [`App`] and its schedules, [`Time`], the scene components,
//! [`Assets`] for meshes, materials and images, built-in primitives, and scene import.
//!
//! Data flows one way: users and importers write authored components (`Transform`, `Visibility`,
//! lights, cameras, `Mesh3d`); `PostUpdate` derives world-space state (`GlobalTransform`,
//! `InheritedVisibility`); the render crate's extraction then reads it. Nothing here knows the GPU.

pub mod animation;
pub mod app;
pub mod assets;
pub mod bounds;
pub mod color;
pub mod components;
pub mod compressed_image;
pub mod environment;
pub mod framing;
pub mod gizmos;
pub mod ies;
pub mod image;
pub mod import;
pub mod material;
pub mod mesh;
pub mod mip_chain;
pub mod output;
pub mod parallel;
pub mod picking;
pub mod primitives;
pub mod scenes;
pub mod time;
pub mod variants;

use bevy_ecs::schedule::IntoScheduleConfigs;

pub use app::{App, Plugin, PostUpdate, Startup, Update};
pub use assets::{AssetEdit, Assets, Handle, StaleHandle};
pub use time::{Time, TimeMode};

/// Registers the asset stores and the `PostUpdate` systems that derive world-space state.
pub struct CorePlugin;

impl Plugin for CorePlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<Assets<mesh::Mesh>>()
            .init_resource::<Assets<material::StandardMaterial>>()
            .init_resource::<Assets<image::Image>>()
            .init_resource::<Assets<ies::IesProfile>>()
            .add_systems(
                PostUpdate,
                (
                    variants::apply_material_variants,
                    animation::animate,
                    components::transform::propagate_transforms,
                    components::visibility::propagate_visibility,
                    components::skin::update_joint_matrices,
                )
                    .chain(),
            );
    }
}

pub mod prelude {
    pub use crate::CorePlugin;
    pub use crate::animation::{AnimationClip, AnimationPlayer, Repeat};
    pub use crate::app::{App, Plugin, PostUpdate, Startup, Update};
    pub use crate::assets::{Assets, Handle};
    pub use crate::bounds::Aabb;
    pub use crate::components::*;
    pub use crate::environment::{Background, Environment, EnvironmentImage, EnvironmentSource, Sky};
    pub use crate::gizmos::Gizmos;
    pub use crate::ies::IesProfile;
    pub use crate::image::Image;
    pub use crate::import::{
        ImportError, ImportOptions, SceneFile, clone_scene, load_scene, spawn_instance, unload_scene,
    };
    pub use crate::material::{AlphaMode, StandardMaterial, TextureRef};
    pub use crate::mesh::{Mesh, MorphTarget, Topology};
    pub use crate::time::{Time, TimeMode};
    pub use crate::variants::{SceneVariants, VariantMaterials, select_variant};
    pub use bevy_ecs::prelude::*;
    pub use glam::{Affine3A, Mat3, Mat4, Quat, Vec2, Vec3, Vec4};
}
