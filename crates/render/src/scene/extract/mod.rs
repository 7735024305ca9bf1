//! Extraction: the only code that reads the main world. It runs in the `Extract` stage after
//! `PostUpdate` and writes [`RenderScene`]; it makes no GPU calls.
//!
//! - view: the active camera with the highest `order` (re-extracted every frame: one entity);
//! - draws: the entities the main world's `DrawChanges` feed lists (placement or visibility
//!   written by propagation, mesh or material inserted; see `penumbra_engine::components::
//!   draw_changes`), read again, on all cores when there are many; an unchanged entity costs
//!   nothing, not even a change-tick check. `changed_draws` lists each entity once, in no
//!   particular order; losing its mesh, placement (GlobalTransform) or visibility
//!   (InheritedVisibility) component removes it, as for lights;
//! - deforms: joint matrices and morph weights of skinned and morphed meshes, change-detected
//!   like draws (`changed_deforms` / `removed_deforms`); non-finite weights count as 0;
//! - lights: one generic system per light kind ([`lights`]), change-detected
//!   (`changed_lights` / `removed_lights`); lights with NaN or infinite values are refused with
//!   a warning; with no light entity at all, the default key light and ambient term fill
//!   `default_lights` (see [`default_lighting`]);
//! - environment: the `Environment` resource, copied when it changed (an image is an `Arc`);
//!   with one, the default lights keep their key light but drop their ambient term (the
//!   environment lights the scene from every side instead);
//! - gizmos: the `Gizmos` resource's lines, copied when it changed (non-finite lines dropped);
//! - assets: versions compared against the last snapshot; only changed assets are re-shared.

use bevy_ecs::prelude::*;
use glam::Affine3A;
use penumbra_engine::assets::Assets;
use penumbra_engine::components::{
    Camera, DrawChanges, GlobalTransform, InheritedVisibility, JointMatrices, Mesh3d, MeshMaterial3d, MorphWeights,
};
use penumbra_engine::environment::Environment;
use penumbra_engine::gizmos::Gizmos;
use penumbra_engine::ies::IesProfile;
use penumbra_engine::image::Image;
use penumbra_engine::material::StandardMaterial;
use penumbra_engine::mesh::Mesh;

use crate::scene::entity_table::Replaced;
use crate::scene::world::{DrawItem, ExtractedDeform, ExtractedView, LightKind, RenderScene, Snapshot};

pub mod lights;

/// Systems in the order they run.
pub fn systems() -> impl IntoScheduleConfigs<bevy_ecs::system::ScheduleSystem, ()> {
    (
        begin_frame,
        extract_view,
        extract_draws,
        extract_deforms,
        lights::systems(),
        extract_environment,
        extract_gizmos,
        extract_assets,
    )
        .chain()
}

fn begin_frame(time: Option<Res<penumbra_engine::Time>>, mut scene: ResMut<RenderScene>) {
    scene.frame += 1;
    scene.delta_seconds = time.map_or(0.0, |t| t.delta_secs());
    scene.changed_draws.clear();
    scene.removed_draws.clear();
    scene.changed_deforms.clear();
    scene.removed_deforms.clear();
}

/// NaN weights would smear NaN over every vertex: a weight that is not finite counts 0.
fn finite_weights(weights: &[f32]) -> Vec<f32> {
    weights.iter().map(|w| if w.is_finite() { *w } else { 0.0 }).collect()
}

/// Poses of skinned and morphed meshes: copied when their joint matrices or weights changed.
/// A pose without a mesh is kept (the mesh may come back); the renderer pairs them by entity.
fn extract_deforms(
    changed: Query<
        (Entity, Option<&JointMatrices>, Option<&MorphWeights>),
        Or<(Changed<JointMatrices>, Changed<MorphWeights>)>,
    >,
    poses: Query<(Option<&JointMatrices>, Option<&MorphWeights>)>,
    mut removed_joints: RemovedComponents<JointMatrices>,
    mut removed_weights: RemovedComponents<MorphWeights>,
    mut scene: ResMut<RenderScene>,
) {
    let scene = &mut *scene;
    // Listed by the removals below; `changed` may list them again.
    let mut relisted = 0;
    for entity in removed_joints.read().chain(removed_weights.read()).collect::<Vec<_>>() {
        // Losing one of the two leaves the other: re-extract what is left.
        match poses.get(entity) {
            Ok((j, w)) if j.is_some() || w.is_some() => {
                let pose = ExtractedDeform {
                    joints: j.map(|j| j.0.clone()).unwrap_or_default(),
                    morph_weights: w.map(|w| finite_weights(&w.0)).unwrap_or_default(),
                };
                scene.deforms.insert(entity, pose);
                scene.changed_deforms.push(entity);
                relisted += 1;
            }
            _ => {
                if scene.deforms.remove(&entity).is_some() {
                    scene.removed_deforms.push(entity);
                }
            }
        }
    }
    for (entity, joints, weights) in &changed {
        let pose = scene.deforms.entry(entity).or_default();
        if let Some(j) = joints {
            pose.joints.clone_from(&j.0);
        }
        if let Some(w) = weights {
            pose.morph_weights = finite_weights(&w.0);
        }
        if !scene.changed_deforms[..relisted].contains(&entity) {
            scene.changed_deforms.push(entity);
        }
    }
}

fn extract_view(cameras: Query<(&Camera, &GlobalTransform, &InheritedVisibility)>, mut scene: ResMut<RenderScene>) {
    let view = cameras.iter().filter(|(c, _, v)| c.is_active && v.0).max_by_key(|(c, ..)| c.order).map(
        |(camera, transform, _)| {
            // Only rotation and translation define the view; a scaled camera would skew it, and
            // a zero-scaled one has no inverse.
            ExtractedView {
                world_from_view: Affine3A::from_rotation_translation(transform.rotation(), transform.translation()),
                projection: camera.projection,
                exposure: camera.exposure.scale(),
            }
        },
    );
    if scene.view != view {
        scene.view = view;
    }
}

/// Components of a draw removed (or despawned) since the last extraction.
#[derive(bevy_ecs::system::SystemParam)]
struct RemovedDrawParts<'w, 's> {
    meshes: RemovedComponents<'w, 's, Mesh3d>,
    materials: RemovedComponents<'w, 's, MeshMaterial3d>,
    transforms: RemovedComponents<'w, 's, GlobalTransform>,
    visibility: RemovedComponents<'w, 's, InheritedVisibility>,
}

/// Draws: the entities the main world's [`DrawChanges`] feed lists (placement or visibility
/// written by propagation, mesh or material inserted), read again; on the feed's first drain,
/// every drawable entity. Nothing scans the change ticks of unchanged entities.
fn extract_draws(
    all: Query<(&GlobalTransform, &Mesh3d, Option<&MeshMaterial3d>, &InheritedVisibility)>,
    every: Query<Entity, (With<GlobalTransform>, With<Mesh3d>, With<InheritedVisibility>)>,
    mut removed: RemovedDrawParts,
    entities: &bevy_ecs::entity::Entities,
    mut feed: ResMut<DrawChanges>,
    mut seen: Local<SeenThisFrame>,
    mut scene: ResMut<RenderScene>,
) {
    let scene = &mut *scene;
    // Losing its placement or visibility makes a mesh undrawable as surely as losing the mesh.
    // Handled first: a component removed and added back this frame is re-extracted below.
    for entity in removed.transforms.read().chain(removed.visibility.read()).collect::<Vec<_>>() {
        if scene.draws.remove(entity).is_some() {
            scene.removed_draws.push(entity);
        }
    }
    let (drained, first) = feed.drain();
    let lists = if first {
        // Entities that existed before the feed did were never recorded.
        vec![every.iter().collect()]
    } else if drained.unique {
        drained.lists
    } else {
        // Hooks and several passes may list an entity more than once; the renderer writes
        // each listed entity's record from one thread, so each is extracted once. Entities
        // despawned since they were listed go first: their index may now be a live entity's,
        // and among live entities an index names one entity.
        seen.next_frame();
        let unique =
            drained.lists.into_iter().flatten().filter(|&e| entities.contains(e) && seen.first_time(e)).collect();
        vec![unique]
    };
    let read = |entity: Entity| {
        let (transform, mesh, material, visibility) = all.get(entity).ok()?;
        let item = DrawItem {
            world_from_local: transform.0,
            mesh: mesh.0,
            material: material.map(|m| m.0),
            visible: visibility.0,
        };
        Some(item)
    };
    let total: usize = lists.iter().map(Vec::len).sum();
    if total < PARALLEL_EXTRACT_MIN {
        for entity in lists.into_iter().flatten() {
            // Not drawable (a camera, a light, an empty that moved) or already despawned.
            let Some(item) = read(entity) else { continue };
            // A despawned entity whose index was reused this frame is gone even if its removal
            // has not been read yet.
            if let Replaced::Other(old, _) = scene.draws.insert(entity, item) {
                scene.removed_draws.push(old);
            }
            scene.changed_draws.push(entity);
        }
    } else {
        // On all cores, each task filing what it reads straight into the table (each entity at
        // its own index) and listing it. The order of `changed_draws` is therefore unspecified:
        // the renderer orders what depends on it.
        scene.draws.reserve_indices(entities.len() as usize);
        let sink = std::sync::Mutex::new(Vec::new());
        {
            let writer = scene.draws.disjoint_writer();
            let pool = bevy_tasks::ComputeTaskPool::get_or_init(bevy_tasks::TaskPool::default);
            let chunk = total.div_ceil(pool.thread_num().max(1) * 4).max(1024);
            pool.scope(|s| {
                for part in lists.iter().flat_map(|l| l.chunks(chunk)) {
                    let (writer, sink, read) = (&writer, &sink, &read);
                    s.spawn(async move {
                        let mut task = TaskLists { lists: ChangeLists::default(), sink };
                        for &entity in part {
                            let Some(item) = read(entity) else { continue };
                            // SAFETY: the lists hold each entity once (made unique above), and
                            // live entities have distinct indices.
                            match unsafe { writer.insert(entity, item) } {
                                Ok(Replaced::Other(old, _)) => task.lists.displaced.push(old),
                                Ok(_) => {}
                                Err(item) => task.lists.beyond.push((entity, item)),
                            }
                            task.lists.changed.push(entity);
                        }
                    });
                }
            });
        }
        for l in sink.into_inner().unwrap_or_else(|e| e.into_inner()) {
            scene.changed_draws.extend(l.changed);
            scene.removed_draws.extend(l.displaced);
            // Not reachable while `Entities::len` bounds entity indices; kept correct anyway.
            for (entity, item) in l.beyond {
                if let Replaced::Other(old, _) = scene.draws.insert(entity, item) {
                    scene.removed_draws.push(old);
                }
            }
        }
    }
    for entity in removed.meshes.read() {
        // Removed and inserted again within the frame: still drawable, already re-extracted.
        if all.contains(entity) {
            continue;
        }
        if scene.draws.remove(entity).is_some() {
            scene.removed_draws.push(entity);
        }
    }
    // Losing only the material falls back to the default one. An entity extracted above was
    // read without its material and must not be listed twice (the renderer writes each listed
    // entity's record from one thread); nor may one whose material was removed twice.
    let removed_materials: Vec<Entity> = removed.materials.read().collect();
    if !removed_materials.is_empty() {
        let mut listed: std::collections::HashSet<Entity> = scene.changed_draws.iter().copied().collect();
        for entity in removed_materials {
            if !listed.insert(entity) {
                continue;
            }
            if let Some(item) = read(entity) {
                if let Replaced::Other(old, _) = scene.draws.insert(entity, item) {
                    scene.removed_draws.push(old);
                }
                scene.changed_draws.push(entity);
            }
        }
    }
}

/// Which entity indices one extraction has listed, to list each live entity once: per index, the
/// frame it was last listed in.
#[derive(Default)]
struct SeenThisFrame {
    frame: u32,
    seen: Vec<u32>,
}

impl SeenThisFrame {
    fn next_frame(&mut self) {
        self.frame = self.frame.wrapping_add(1);
        if self.frame == 0 {
            // Wrapped: stamps from 2^32 frames ago would read as this frame's.
            self.seen.iter_mut().for_each(|s| *s = 0);
            self.frame = 1;
        }
    }

    fn first_time(&mut self, entity: Entity) -> bool {
        let i = entity.index_u32() as usize;
        if i >= self.seen.len() {
            self.seen.resize((i + 1).next_power_of_two(), 0);
        }
        std::mem::replace(&mut self.seen[i], self.frame) != self.frame
    }
}

/// Frames that change at least this many entities read them on all cores; below it, starting
/// the tasks costs more than the reading.
const PARALLEL_EXTRACT_MIN: usize = 20_000;

/// What one parallel extraction task changed.
#[derive(Default)]
struct ChangeLists {
    changed: Vec<Entity>,
    /// Despawned entities whose index a changed entity now holds.
    displaced: Vec<Entity>,
    beyond: Vec<(Entity, DrawItem)>,
}

/// A task's lists, handed to the shared list when the task ends.
struct TaskLists<'a> {
    lists: ChangeLists,
    sink: &'a std::sync::Mutex<Vec<ChangeLists>>,
}

impl Drop for TaskLists<'_> {
    fn drop(&mut self) {
        let lists = std::mem::take(&mut self.lists);
        if !lists.changed.is_empty() {
            self.sink.lock().unwrap_or_else(|e| e.into_inner()).push(lists);
        }
    }
}

/// The lights a scene without lights is shown with. The key light comes from above the
/// viewer's left shoulder so that whatever side the camera looks at is lit; the ambient term
/// keeps shadowed sides readable. docs/lights.md ("Types and units") documents both values.
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

fn extract_gizmos(gizmos: Option<Res<Gizmos>>, mut scene: ResMut<RenderScene>) {
    match gizmos {
        Some(g) if g.is_changed() => {
            scene.gizmos.clear();
            let finite = |l: &&penumbra_engine::gizmos::GizmoLine| {
                l.start.is_finite() && l.end.is_finite() && l.color.is_finite()
            };
            scene.gizmos.extend(g.lines().iter().filter(finite));
        }
        Some(_) => {}
        None => scene.gizmos.clear(),
    }
}

fn extract_environment(environment: Option<Res<Environment>>, mut scene: ResMut<RenderScene>) {
    match environment {
        Some(env) if env.is_changed() || scene.environment.is_none() => scene.environment = Some(env.clone()),
        Some(_) => {}
        None => {
            if scene.environment.is_some() {
                scene.environment = None;
            }
        }
    }
    // An environment the renderer will refuse (bad numbers set from code) lights nothing: the
    // default ambient term stays then.
    if scene.environment.as_ref().is_some_and(|e| e.validate().is_ok()) {
        scene.default_lights.retain(|l| l.kind != LightKind::Ambient);
    }
}

/// Returns whether a snapshot was replaced (a new version) or removed; new assets alone do not
/// count (nothing drawn can refer to them without a draw change).
fn sync_assets<T: Send + Sync + 'static>(
    assets: &Assets<T>,
    snapshots: &mut std::collections::HashMap<penumbra_engine::Handle<T>, Snapshot<T>>,
) -> bool {
    let before = snapshots.len();
    snapshots.retain(|h, _| assets.contains(*h));
    let mut changed = snapshots.len() != before;
    for (handle, _) in assets.iter() {
        let version = assets.version(handle).expect("live handle from iter");
        let known = snapshots.get(&handle).map(|s| s.version);
        if known != Some(version) {
            changed |= known.is_some();
            let data = assets.get_arc(handle).expect("live handle from iter").clone();
            snapshots.insert(handle, Snapshot { version, data });
        }
    }
    changed
}

fn extract_assets(
    meshes: Res<Assets<Mesh>>,
    materials: Res<Assets<StandardMaterial>>,
    images: Res<Assets<Image>>,
    ies_profiles: Res<Assets<IesProfile>>,
    mut scene: ResMut<RenderScene>,
) {
    let scene = &mut *scene;
    scene.meshes_changed = sync_assets(&meshes, &mut scene.meshes);
    sync_assets(&materials, &mut scene.materials);
    sync_assets(&images, &mut scene.images);
    sync_assets(&ies_profiles, &mut scene.ies_profiles);
}

#[cfg(test)]
mod tests;
