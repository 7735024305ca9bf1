//! Light extraction: one generic system per light kind ([`extract_kind`]), each reading only
//! its own component's changes and removals, so a new kind of light is its component, its
//! [`LightComponent`] impl here, its line in [`systems`], its packing in the light store and its
//! shader code.
//!
//! Per kind and frame, in this order: a light whose entity lost its placement
//! (`GlobalTransform`, for placed kinds) or visibility is removed; a light whose component,
//! placement or visibility changed is extracted again (hidden: removed; a NaN or infinite value:
//! removed with a warning, so none reaches the light store or the cluster bins); a removed
//! component drops its light unless it was inserted again this frame. [`default_lights`] then
//! fills `RenderScene::default_lights` when no light entity exists at all.

use std::collections::HashSet;

use bevy_ecs::prelude::*;
use bevy_ecs::query::QueryFilter;
use glam::Vec3;
use penumbra_engine::components::{
    AmbientLight, DirectionalLight, DiskLight, GlobalTransform, IesLight, InheritedVisibility, PointLight, RectLight,
    SphereLight, SpotLight, TubeLight,
};

use crate::scene::world::{ExtractedLight, LightKey, LightKind, RenderScene};

/// Placement or visibility changed.
type Moved = Or<(Changed<GlobalTransform>, Changed<InheritedVisibility>)>;

/// A light component the renderer extracts.
pub trait LightComponent: Component {
    /// Whether the entity's `GlobalTransform` places the light (every kind but ambient): without
    /// one it lights nothing.
    const PLACED: bool = true;
    /// The changes that extract the light again: its own component's, and its placement's or
    /// visibility's.
    type Changed: QueryFilter;
    /// This kind's key for a light on `entity`.
    fn key(entity: Entity) -> LightKey;
    /// The light as the renderer sees it, placed by `transform` (`None` only for unplaced kinds).
    fn extract(&self, transform: Option<&GlobalTransform>) -> ExtractedLight;
}

/// The light systems, in the order they run.
pub fn systems() -> impl IntoScheduleConfigs<bevy_ecs::system::ScheduleSystem, ()> {
    (
        begin_lights,
        (
            extract_kind::<DirectionalLight>,
            extract_kind::<PointLight>,
            extract_kind::<SpotLight>,
            extract_kind::<AmbientLight>,
            extract_kind::<SphereLight>,
            extract_kind::<TubeLight>,
            extract_kind::<RectLight>,
            extract_kind::<DiskLight>,
            extract_kind::<IesLight>,
        )
            .chain(),
        default_lights,
    )
        .chain()
}

fn begin_lights(mut scene: ResMut<RenderScene>) {
    scene.changed_lights.clear();
    scene.removed_lights.clear();
    scene.any_light_entity = false;
}

/// Extracts what changed of one kind of light (see the module doc).
#[allow(clippy::type_complexity)]
pub fn extract_kind<L: LightComponent>(
    changed: Query<(Entity, &L, Option<&GlobalTransform>, &InheritedVisibility), L::Changed>,
    present: Query<(), With<L>>,
    mut removed: RemovedComponents<L>,
    mut unplaced: RemovedComponents<GlobalTransform>,
    mut unseen: RemovedComponents<InheritedVisibility>,
    mut warned: Local<HashSet<LightKey>>,
    mut scene: ResMut<RenderScene>,
) {
    let scene = &mut *scene;
    scene.any_light_entity |= !present.is_empty();
    // First, since a component removed and added back this frame is re-extracted below.
    let lost_placement = unplaced.read().filter(|_| L::PLACED);
    for e in lost_placement.chain(unseen.read()).collect::<Vec<_>>() {
        remove(scene, L::key(e));
    }
    for (e, light, transform, visibility) in &changed {
        let key = L::key(e);
        if L::PLACED && transform.is_none() {
            remove(scene, key);
            continue;
        }
        let extracted = visibility.0.then(|| light.extract(transform));
        match extracted {
            Some(l) if is_finite(&l) => {
                scene.lights.insert(key, l);
                scene.changed_lights.push(key);
            }
            other => {
                if other.is_some() && warned.insert(key) {
                    tracing::warn!(
                        "{key:?} has a NaN or infinite colour, intensity, position, direction, range, size or cone angle; it lights nothing until fixed"
                    );
                }
                remove(scene, key);
            }
        }
    }
    // A component removed and inserted again within the frame shows up in both lists; the
    // changed query already re-extracted it, so only keys no longer present are dropped.
    for e in removed.read().filter(|e| !changed.contains(*e)).collect::<Vec<_>>() {
        remove(scene, L::key(e));
    }
}

fn remove(scene: &mut RenderScene, key: LightKey) {
    if scene.lights.remove(&key).is_some() {
        scene.removed_lights.push(key);
    }
}

/// With no light entity at all, the default key light (it follows the camera; two values,
/// rebuilt every frame) and ambient term.
fn default_lights(mut scene: ResMut<RenderScene>) {
    let scene = &mut *scene;
    scene.default_lights.clear();
    if scene.any_light_entity {
        return;
    }
    let view_rotation =
        scene.view.map_or(glam::Quat::IDENTITY, |v| v.world_from_view.to_scale_rotation_translation().1);
    scene.default_lights.push(unplaced(
        LightKind::Directional { angular_radius: 0.0 },
        Vec3::splat(super::default_lighting::KEY_ILLUMINANCE),
        (view_rotation * super::default_lighting::KEY_DIRECTION_VIEW).normalize(),
        // A viewer's headlight: it turns with the camera, so its shadows would slide over the
        // model as the user orbits; like the Khronos viewer's, it casts none.
        false,
    ));
    scene.default_lights.push(unplaced(
        LightKind::Ambient,
        Vec3::splat(super::default_lighting::AMBIENT_RADIANCE),
        Vec3::NEG_Z,
        false,
    ));
}

fn placed(kind: LightKind, color: Vec3, t: &GlobalTransform, range: Option<f32>, shadows: bool) -> ExtractedLight {
    ExtractedLight { kind, color, position: t.translation(), direction: t.forward(), right: t.right(), range, shadows }
}

fn unplaced(kind: LightKind, color: Vec3, direction: Vec3, shadows: bool) -> ExtractedLight {
    ExtractedLight { kind, color, position: Vec3::ZERO, direction, right: Vec3::X, range: None, shadows }
}

/// The transform of a placed kind (its system skips entities without one).
fn placement(t: Option<&GlobalTransform>) -> &GlobalTransform {
    t.expect("placed lights are extracted only with a GlobalTransform")
}

impl LightComponent for DirectionalLight {
    type Changed = Or<(Changed<DirectionalLight>, Moved)>;
    fn key(e: Entity) -> LightKey {
        LightKey::Directional(e)
    }
    fn extract(&self, t: Option<&GlobalTransform>) -> ExtractedLight {
        let kind = LightKind::Directional { angular_radius: self.angular_radius };
        unplaced(kind, self.color * self.illuminance, placement(t).forward(), self.shadows)
    }
}

impl LightComponent for PointLight {
    type Changed = Or<(Changed<PointLight>, Moved)>;
    fn key(e: Entity) -> LightKey {
        LightKey::Point(e)
    }
    fn extract(&self, t: Option<&GlobalTransform>) -> ExtractedLight {
        placed(LightKind::Point, self.color * self.intensity, placement(t), self.range, self.shadows)
    }
}

impl LightComponent for SpotLight {
    type Changed = Or<(Changed<SpotLight>, Moved)>;
    fn key(e: Entity) -> LightKey {
        LightKey::Spot(e)
    }
    fn extract(&self, t: Option<&GlobalTransform>) -> ExtractedLight {
        let kind = LightKind::Spot { inner_cone_angle: self.inner_cone_angle, outer_cone_angle: self.outer_cone_angle };
        placed(kind, self.color * self.intensity, placement(t), self.range, self.shadows)
    }
}

impl LightComponent for AmbientLight {
    const PLACED: bool = false;
    type Changed = Or<(Changed<AmbientLight>, Changed<InheritedVisibility>)>;
    fn key(e: Entity) -> LightKey {
        LightKey::Ambient(e)
    }
    fn extract(&self, _: Option<&GlobalTransform>) -> ExtractedLight {
        unplaced(LightKind::Ambient, self.color * self.intensity, Vec3::NEG_Z, false)
    }
}

impl LightComponent for SphereLight {
    type Changed = Or<(Changed<SphereLight>, Moved)>;
    fn key(e: Entity) -> LightKey {
        LightKey::Sphere(e)
    }
    fn extract(&self, t: Option<&GlobalTransform>) -> ExtractedLight {
        placed(
            LightKind::Sphere { radius: self.radius },
            self.color * self.intensity,
            placement(t),
            self.range,
            self.shadows,
        )
    }
}

impl LightComponent for TubeLight {
    type Changed = Or<(Changed<TubeLight>, Moved)>;
    fn key(e: Entity) -> LightKey {
        LightKey::Tube(e)
    }
    fn extract(&self, t: Option<&GlobalTransform>) -> ExtractedLight {
        let kind = LightKind::Tube { length: self.length, radius: self.radius };
        placed(kind, self.color * self.intensity, placement(t), self.range, self.shadows)
    }
}

impl LightComponent for RectLight {
    type Changed = Or<(Changed<RectLight>, Moved)>;
    fn key(e: Entity) -> LightKey {
        LightKey::Rect(e)
    }
    fn extract(&self, t: Option<&GlobalTransform>) -> ExtractedLight {
        let kind = LightKind::Rect { width: self.width, height: self.height };
        placed(kind, self.color * self.luminance, placement(t), self.range, self.shadows)
    }
}

impl LightComponent for DiskLight {
    type Changed = Or<(Changed<DiskLight>, Moved)>;
    fn key(e: Entity) -> LightKey {
        LightKey::Disk(e)
    }
    fn extract(&self, t: Option<&GlobalTransform>) -> ExtractedLight {
        placed(
            LightKind::Disk { radius: self.radius },
            self.color * self.luminance,
            placement(t),
            self.range,
            self.shadows,
        )
    }
}

impl LightComponent for IesLight {
    type Changed = Or<(Changed<IesLight>, Moved)>;
    fn key(e: Entity) -> LightKey {
        LightKey::Ies(e)
    }
    fn extract(&self, t: Option<&GlobalTransform>) -> ExtractedLight {
        placed(
            LightKind::Ies { profile: self.profile },
            self.color * self.scale,
            placement(t),
            self.range,
            self.shadows,
        )
    }
}

fn is_finite(l: &ExtractedLight) -> bool {
    let shape = match l.kind {
        LightKind::Spot { inner_cone_angle: a, outer_cone_angle: b }
        | LightKind::Tube { length: a, radius: b }
        | LightKind::Rect { width: a, height: b } => a.is_finite() && b.is_finite(),
        LightKind::Sphere { radius } | LightKind::Disk { radius } => radius.is_finite(),
        LightKind::Directional { angular_radius } => angular_radius.is_finite(),
        LightKind::Point | LightKind::Ambient | LightKind::Ies { .. } => true,
    };
    l.color.is_finite()
        && l.position.is_finite()
        && l.direction.is_finite()
        && l.right.is_finite()
        && l.range.is_none_or(f32::is_finite)
        && shape
}
