//! Extraction: the only code that reads the main world. It runs in the `Extract` stage after
//! `PostUpdate` and writes [`RenderScene`]; it makes no GPU calls.
//!
//! - view: the active camera with the highest `order` (re-extracted every frame: one entity);
//! - draws: change-detected; an unchanged entity costs nothing;
//! - lights: re-extracted only when a light changed, appeared or vanished; with none at all, the
//!   default key light and ambient term are added (see [`default_lighting`]);
//! - assets: versions compared against the last snapshot; only changed assets are re-shared.

use bevy_ecs::prelude::*;
use glam::{Affine3A, Vec3};
use penumbra_engine::assets::Assets;
use penumbra_engine::components::{
    AmbientLight, Camera, DirectionalLight, GlobalTransform, InheritedVisibility, Mesh3d, MeshMaterial3d, PointLight,
    SpotLight,
};
use penumbra_engine::image::Image;
use penumbra_engine::material::StandardMaterial;
use penumbra_engine::mesh::Mesh;

use crate::world::{DrawItem, ExtractedLight, ExtractedView, LightKind, RenderScene, Snapshot};

/// Systems in the order they run.
pub fn systems() -> impl IntoScheduleConfigs<bevy_ecs::system::ScheduleSystem, ()> {
    (begin_frame, extract_view, extract_draws, extract_lights, extract_assets).chain()
}

fn begin_frame(mut scene: ResMut<RenderScene>) {
    scene.frame += 1;
    scene.changed_draws.clear();
    scene.removed_draws.clear();
}

fn extract_view(cameras: Query<(&Camera, &GlobalTransform, &InheritedVisibility)>, mut scene: ResMut<RenderScene>) {
    let view = cameras.iter().filter(|(c, _, v)| c.is_active && v.0).max_by_key(|(c, ..)| c.order).map(
        |(camera, transform, _)| {
            // Only rotation and translation define the view; a scaled camera would skew it.
            let (_, rotation, translation) = transform.0.to_scale_rotation_translation();
            ExtractedView {
                world_from_view: Affine3A::from_rotation_translation(rotation, translation),
                projection: camera.projection,
                exposure: camera.exposure.scale(),
            }
        },
    );
    if scene.view != view {
        scene.view = view;
    }
}

fn extract_draws(
    changed: Query<
        (Entity, &GlobalTransform, &Mesh3d, Option<&MeshMaterial3d>, &InheritedVisibility),
        Or<(Changed<GlobalTransform>, Changed<Mesh3d>, Changed<MeshMaterial3d>, Changed<InheritedVisibility>)>,
    >,
    all: Query<(&GlobalTransform, &Mesh3d, Option<&MeshMaterial3d>, &InheritedVisibility)>,
    mut removed_meshes: RemovedComponents<Mesh3d>,
    mut removed_materials: RemovedComponents<MeshMaterial3d>,
    mut scene: ResMut<RenderScene>,
) {
    let scene = &mut *scene;
    for (entity, transform, mesh, material, visibility) in &changed {
        let item = DrawItem {
            world_from_local: transform.0,
            mesh: mesh.0,
            material: material.map(|m| m.0),
            visible: visibility.0,
        };
        scene.draws.insert(entity, item);
        scene.changed_draws.push(entity);
    }
    for entity in removed_meshes.read() {
        // Removed and inserted again within the frame: still drawable, already re-extracted.
        if all.contains(entity) {
            continue;
        }
        if scene.draws.remove(&entity).is_some() {
            scene.removed_draws.push(entity);
        }
    }
    // Losing only the material falls back to the default one.
    for entity in removed_materials.read() {
        if let Ok((transform, mesh, material, visibility)) = all.get(entity) {
            scene.draws.insert(
                entity,
                DrawItem {
                    world_from_local: transform.0,
                    mesh: mesh.0,
                    material: material.map(|m| m.0),
                    visible: visibility.0,
                },
            );
            scene.changed_draws.push(entity);
        }
    }
}

/// The lights a scene without lights is shown with. The key light comes from above the
/// viewer's left shoulder so that whatever side the camera looks at is lit; the ambient term
/// keeps shadowed sides readable. The README documents both values.
pub mod default_lighting {
    use glam::Vec3;
    /// Lux. A white Lambertian surface facing it reflects 3/π ≈ 0.95 cd/m².
    pub const KEY_ILLUMINANCE: f32 = 3.0;
    /// Direction the key light travels, in view space (x right, y up, looking down −z).
    pub const KEY_DIRECTION_VIEW: Vec3 = Vec3::new(0.4, -0.6, -0.7);
    /// cd/m²: a quarter of the key's brightness on a facing white surface, so that sides the
    /// key does not reach keep their texture.
    pub const AMBIENT_RADIANCE: f32 = 0.25;
}

/// A light's own data, placement or visibility changed.
type LightChanged = Or<(
    Changed<DirectionalLight>,
    Changed<PointLight>,
    Changed<SpotLight>,
    Changed<AmbientLight>,
    Changed<GlobalTransform>,
    Changed<InheritedVisibility>,
)>;
type IsLight = Or<(With<DirectionalLight>, With<PointLight>, With<SpotLight>, With<AmbientLight>)>;

/// Lights of every type removed (or despawned) since the last extraction.
#[derive(bevy_ecs::system::SystemParam)]
struct RemovedLights<'w, 's> {
    directional: RemovedComponents<'w, 's, DirectionalLight>,
    point: RemovedComponents<'w, 's, PointLight>,
    spot: RemovedComponents<'w, 's, SpotLight>,
    ambient: RemovedComponents<'w, 's, AmbientLight>,
}

impl RemovedLights<'_, '_> {
    fn count(&mut self) -> usize {
        self.directional.read().count()
            + self.point.read().count()
            + self.spot.read().count()
            + self.ambient.read().count()
    }
}

fn extract_lights(
    directional: Query<(&DirectionalLight, &GlobalTransform, &InheritedVisibility)>,
    point: Query<(&PointLight, &GlobalTransform, &InheritedVisibility)>,
    spot: Query<(&SpotLight, &GlobalTransform, &InheritedVisibility)>,
    ambient: Query<(&AmbientLight, &InheritedVisibility)>,
    changed: Query<(), (LightChanged, IsLight)>,
    mut removed: RemovedLights,
    mut scene: ResMut<RenderScene>,
) {
    let removed = removed.count();
    // The default key light follows the camera, so it must be refreshed whenever the view moves.
    if removed == 0 && changed.is_empty() && !scene.default_lighting && !scene.lights.is_empty() {
        return;
    }
    let mut lights = Vec::new();
    for (l, t, v) in &directional {
        if v.0 {
            lights.push(ExtractedLight {
                kind: LightKind::Directional,
                color: l.color * l.illuminance,
                position: Vec3::ZERO,
                direction: t.forward(),
                range: None,
            });
        }
    }
    for (l, t, v) in &point {
        if v.0 {
            lights.push(ExtractedLight {
                kind: LightKind::Point,
                color: l.color * l.intensity,
                position: t.translation(),
                direction: Vec3::NEG_Z,
                range: l.range,
            });
        }
    }
    for (l, t, v) in &spot {
        if v.0 {
            lights.push(ExtractedLight {
                kind: LightKind::Spot { inner_cone_angle: l.inner_cone_angle, outer_cone_angle: l.outer_cone_angle },
                color: l.color * l.intensity,
                position: t.translation(),
                direction: t.forward(),
                range: l.range,
            });
        }
    }
    for (l, v) in &ambient {
        if v.0 {
            lights.push(ExtractedLight {
                kind: LightKind::Ambient,
                color: l.color * l.intensity,
                position: Vec3::ZERO,
                direction: Vec3::NEG_Z,
                range: None,
            });
        }
    }
    let authored = directional.iter().len() + point.iter().len() + spot.iter().len() + ambient.iter().len();
    scene.default_lighting = authored == 0;
    if scene.default_lighting {
        let view_rotation =
            scene.view.map_or(glam::Quat::IDENTITY, |v| v.world_from_view.to_scale_rotation_translation().1);
        lights.push(ExtractedLight {
            kind: LightKind::Directional,
            color: Vec3::splat(default_lighting::KEY_ILLUMINANCE),
            position: Vec3::ZERO,
            direction: (view_rotation * default_lighting::KEY_DIRECTION_VIEW).normalize(),
            range: None,
        });
        lights.push(ExtractedLight {
            kind: LightKind::Ambient,
            color: Vec3::splat(default_lighting::AMBIENT_RADIANCE),
            position: Vec3::ZERO,
            direction: Vec3::NEG_Z,
            range: None,
        });
    }
    scene.lights = lights;
}

fn sync_assets<T: Send + Sync + 'static>(
    assets: &Assets<T>,
    snapshots: &mut std::collections::HashMap<penumbra_engine::Handle<T>, Snapshot<T>>,
) {
    snapshots.retain(|h, _| assets.contains(*h));
    for (handle, _) in assets.iter() {
        let version = assets.version(handle).expect("live handle from iter");
        if snapshots.get(&handle).is_none_or(|s| s.version != version) {
            let data = assets.get_arc(handle).expect("live handle from iter").clone();
            snapshots.insert(handle, Snapshot { version, data });
        }
    }
}

fn extract_assets(
    meshes: Res<Assets<Mesh>>,
    materials: Res<Assets<StandardMaterial>>,
    images: Res<Assets<Image>>,
    mut scene: ResMut<RenderScene>,
) {
    let scene = &mut *scene;
    sync_assets(&meshes, &mut scene.meshes);
    sync_assets(&materials, &mut scene.materials);
    sync_assets(&images, &mut scene.images);
}
