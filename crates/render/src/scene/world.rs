//! `RenderScene`: everything the renderer needs from the main world, as plain data. Extraction
//! writes it (and is the only code that reads the ECS); prepare and the passes read it.
//!
//! Draw items are retained across frames, keyed by entity: extraction touches only entities
//! whose transform, mesh, material or visibility changed, and lists what it touched in
//! `changed_draws` / `removed_draws` so that prepare uploads exactly that. Assets are shared
//! `Arc` snapshots stamped with the version they had when extracted.

use std::collections::HashMap;
use std::sync::Arc;

use bevy_ecs::entity::Entity;
use bevy_ecs::resource::Resource;
use glam::{Affine3A, Vec3};
use penumbra_engine::Handle;
use penumbra_engine::components::Projection;
use penumbra_engine::environment::Environment;
use penumbra_engine::ies::IesProfile;
use penumbra_engine::image::Image;
use penumbra_engine::material::StandardMaterial;
use penumbra_engine::mesh::Mesh;

use crate::scene::entity_table::EntityTable;

/// The camera the frame is rendered from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExtractedView {
    /// Camera placement; scale is ignored.
    pub world_from_view: Affine3A,
    pub projection: Projection,
    /// Linear multiplier applied to radiance before tonemapping.
    pub exposure: f32,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrawItem {
    pub world_from_local: Affine3A,
    pub mesh: Handle<Mesh>,
    /// `None` draws with the glTF default material.
    pub material: Option<Handle<StandardMaterial>>,
    pub visible: bool,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LightKind {
    Directional {
        /// Radians; the size of the light's disk for soft shadows.
        angular_radius: f32,
    },
    Point,
    Spot {
        inner_cone_angle: f32,
        outer_cone_angle: f32,
    },
    Ambient,
    Sphere {
        radius: f32,
    },
    /// Along `ExtractedLight::right`.
    Tube {
        length: f32,
        radius: f32,
    },
    /// `width` along `right`, facing `direction`.
    Rect {
        width: f32,
        height: f32,
    },
    Disk {
        radius: f32,
    },
    /// A point light shaped by a photometric profile; its nadir is `direction`, its C = 0°
    /// plane passes through `right`.
    Ies {
        profile: Handle<IesProfile>,
    },
}

/// Which light a store entry is: an entity's light component, or one of the default lights.
/// An entity carrying two light components (a point and a spot light) is two lights.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum LightKey {
    Directional(Entity),
    Point(Entity),
    Spot(Entity),
    Ambient(Entity),
    Sphere(Entity),
    Tube(Entity),
    Rect(Entity),
    Disk(Entity),
    Ies(Entity),
    /// `RenderScene::default_lights[i]`.
    Default(u8),
}

/// One light in world space with its intensity folded into `color` (cd, lux or cd/m²; for rect
/// and disk lights the emitting face's luminance; for IES lights a factor on the profile's
/// candela).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExtractedLight {
    pub kind: LightKind,
    pub color: Vec3,
    pub position: Vec3,
    /// Direction the light travels (unit): the light's local −Z.
    pub direction: Vec3,
    /// The light's local +X (unit): a tube's axis, a rectangle's width.
    pub right: Vec3,
    /// glTF's `range`; `None` lets the light store derive one from the intensity.
    pub range: Option<f32>,
    /// Whether the light casts shadows (the shadow orchestrator decides which get maps).
    pub shadows: bool,
}

/// The pose of a deformed draw: what the deformation pass needs beyond the mesh.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ExtractedDeform {
    /// Per joint, mesh bind space to the entity's space (`JointMatrices`); empty without a skin.
    pub joints: Vec<glam::Mat4>,
    /// Morph-target weights (`MorphWeights`); empty without morph targets.
    pub morph_weights: Vec<f32>,
}

/// An asset as of the version extraction saw.
#[derive(Debug, Clone)]
pub struct Snapshot<T> {
    pub version: u64,
    pub data: Arc<T>,
}

#[derive(Resource, Default)]
pub struct RenderScene {
    /// Incremented by every extraction. A renderer that did not see the previous one (attached
    /// late, or skipped a frame) cannot trust the change lists and resynchronises from `draws`.
    pub frame: u64,
    pub view: Option<ExtractedView>,
    pub draws: EntityTable<DrawItem>,
    /// Entities inserted or changed in `draws` this frame.
    pub changed_draws: Vec<Entity>,
    /// Entities removed from `draws` this frame.
    pub removed_draws: Vec<Entity>,
    /// Poses of skinned and morphed draws, retained like `draws` (keyed by the drawing entity).
    pub deforms: HashMap<Entity, ExtractedDeform>,
    /// Entities whose pose was inserted or changed this frame.
    pub changed_deforms: Vec<Entity>,
    /// Entities that lost their skin and morph weights (or were despawned) this frame.
    pub removed_deforms: Vec<Entity>,
    /// Every visible light with finite parameters, retained across frames like `draws`.
    pub lights: HashMap<LightKey, ExtractedLight>,
    /// Lights inserted or changed this frame.
    pub changed_lights: Vec<LightKey>,
    /// Lights removed (despawned, hidden, or given up for bad values) this frame.
    pub removed_lights: Vec<LightKey>,
    /// The default key and ambient lights, when the scene has no light entities at all.
    pub default_lights: Vec<ExtractedLight>,
    /// Some light entity exists this frame (hidden or refused ones too): without any, the
    /// default lights fill `default_lights`.
    pub any_light_entity: bool,
    pub meshes: HashMap<Handle<Mesh>, Snapshot<Mesh>>,
    /// A mesh snapshot was replaced (new version) or removed this frame.
    pub meshes_changed: bool,
    pub materials: HashMap<Handle<StandardMaterial>, Snapshot<StandardMaterial>>,
    pub images: HashMap<Handle<Image>, Snapshot<Image>>,
    pub ies_profiles: HashMap<Handle<IesProfile>, Snapshot<IesProfile>>,
    /// The main world's `Environment` resource, if it has one (an image is shared, not copied).
    pub environment: Option<Environment>,
    /// Debug lines of the main world's `Gizmos` resource (finite ones only).
    pub gizmos: Vec<penumbra_engine::gizmos::GizmoLine>,
    /// Seconds since the previous frame by the main world's `Time` (fixed in headless runs):
    /// what time-based effects (automatic exposure's adaptation) advance by.
    pub delta_seconds: f32,
}
