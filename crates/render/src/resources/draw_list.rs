//! The draw list: what the renderer knows of every drawable entity (its instance slot, mesh and
//! material), the visible opaque and masked draws sorted into instanced [`Batch`]es, the blended
//! draws (sorted back to front each frame), and the draw-slot buffer the shaders index.
//!
//! Data flow per frame, driven by extraction's change lists: [`DrawList::apply_changes`] packs
//! moved draws straight into their instance slots (on all cores for long lists) and records new
//! or re-keyed ones; [`DrawList::prepare_materials`] and [`DrawList::prepare_meshes`] make
//! what the draws use resident; [`DrawList::rebuild_if_dirty`] sorts the draws into batches when
//! a draw, a material's pipeline bits or the frame's [`FrameVariant`] changed; then
//! [`DrawList::upload_slots`] writes the slots of the opaque batches (when rebuilt) and of the
//! blended draws (every frame). The caster generation moves whenever what casts shadows may
//! have changed, so the shadow orchestrator re-renders only then.

use std::collections::{HashMap, HashSet};

use bevy_ecs::entity::Entity;
use glam::Vec3;
use penumbra_engine::Handle;
use penumbra_engine::bounds::Aabb;
use penumbra_engine::mesh::Mesh;

use crate::gpu::buffer::GrowableBuffer;
use crate::gpu::context::Capabilities;
use crate::gpu::formats::{DEPTH_FORMAT, FormatKey, HDR_FORMAT};
use crate::pipelines::PipelineCache;
use crate::resources::draws::{AlphaTest, Batch, DebugView, LocalLights, PipelineKey};
use crate::resources::instances::{GpuInstance, InstanceBuffer};
use crate::resources::light_store::LightShapes;
use crate::resources::materials::{AlphaKey, MaterialFeatures, MaterialKey, MaterialTable, SRGB_SLOTS, TextureSet};
use crate::resources::mesh_pool::{MeshId, MeshPool};
use crate::resources::textures::{TextureCache, TextureRequest};
use crate::scene::entity_table::{EntityTable, Replaced};
use crate::scene::world::RenderScene;

/// World bounds of what casts shadows (opaque and masked triangles) and of everything drawn.
#[derive(Debug, Clone, Copy)]
pub struct SceneBounds {
    pub casters: Aabb,
    pub receivers: Aabb,
}

/// What the renderer last knew about a drawable entity.
#[derive(Debug, Clone, Copy, PartialEq)]
struct DrawState {
    slot: u32,
    mesh: Handle<Mesh>,
    material: MaterialKey,
    mirrored: bool,
    visible: bool,
}

/// A changed draw that only moved (the common case, animation): its slot and new record, to be
/// written with no other change. Anything else (new, re-keyed, gone) is `None` and goes the slow
/// way.
fn pack_move(
    draws: &EntityTable<DrawState>,
    materials: &MaterialTable,
    scene: &RenderScene,
    entity: Entity,
) -> Option<(u32, GpuInstance)> {
    let (item, d) = (scene.draws.get(entity)?, draws.get(entity)?);
    let mirrored = item.world_from_local.matrix3.determinant() < 0.0;
    if (d.mesh, d.material, d.mirrored, d.visible) != (item.mesh, item.material, mirrored, item.visible) {
        return None;
    }
    let material_slot = materials.get(&item.material).map_or(0, |m| m.slot);
    Some((d.slot, GpuInstance::new(&item.world_from_local, material_slot)))
}

/// Change lists at least this long are packed on all cores.
const PARALLEL_PACK_MIN: usize = 20_000;

/// Change lists up to this long are bounded for the shadow maps ([`CasterChanges`]); longer
/// ones count as changes anywhere (bounding a whole animated crowd would cost more than the maps
/// it could keep).
const BOUNDED_CHANGES_MAX: usize = 256;
// The parallel packing path bounds nothing: its lists must count as changes anywhere.
const _: () = assert!(BOUNDED_CHANGES_MAX < PARALLEL_PACK_MIN);

/// Where casters changed since the shadow orchestrator last looked: a world box holding every
/// changed caster where it was and where it is, or anywhere (draws added, removed or re-keyed,
/// poses, materials, long change lists).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CasterChanges {
    Nothing,
    Within(Aabb),
    Anywhere,
}

impl CasterChanges {
    fn add(&mut self, changed: &Aabb) {
        *self = match *self {
            // A non-finite box bounds nothing reliably.
            _ if !(changed.min.is_finite() && changed.max.is_finite()) => CasterChanges::Anywhere,
            CasterChanges::Nothing => CasterChanges::Within(*changed),
            CasterChanges::Within(b) => CasterChanges::Within(b.union(changed)),
            CasterChanges::Anywhere => CasterChanges::Anywhere,
        };
    }
}

/// What every draw's pipeline key shares in a frame: how local lights are found and which kinds
/// exist, whether shadows and the environment are compiled in, and the settings every variant
/// reads. A change re-keys every batch.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FrameVariant {
    pub local_lights: LocalLights,
    pub light_shapes: LightShapes,
    /// More global lights than the uniform array holds.
    pub global_lights_in_storage: bool,
    /// Opaque surfaces get their local lights from the deferred-lights compute pass.
    pub deferred_lights: bool,
    pub shadows: bool,
    pub local_shadows: bool,
    pub ibl: bool,
    pub debug: DebugView,
    pub msaa: u32,
}

/// The owners the draw list reads and writes while it prepares a frame.
pub struct DrawContext<'a> {
    pub device: &'a wgpu::Device,
    pub queue: &'a wgpu::Queue,
    pub caps: &'a Capabilities,
    pub pipelines: &'a mut PipelineCache,
    pub instances: &'a mut InstanceBuffer,
    pub materials: &'a mut MaterialTable,
    pub textures: &'a mut TextureCache,
    pub mesh_pool: &'a mut MeshPool,
    /// The pool entry of an entity's deformed vertex copy, if it has one (skins and morph
    /// targets), and whether any draw is deformed at all.
    pub deformed: &'a dyn Fn(Entity, Handle<Mesh>) -> Option<MeshId>,
    pub any_deformed: bool,
    pub frame: u64,
}

pub struct DrawList {
    draws: EntityTable<DrawState>,
    mesh_users: HashMap<Handle<Mesh>, u32>,
    material_users: HashMap<MaterialKey, u32>,
    mesh_ids: HashMap<Handle<Mesh>, MeshId>,
    /// Material pipeline bits last seen, to notice a material switching alpha mode.
    material_bits: HashMap<MaterialKey, (AlphaKey, bool, bool, TextureSet, MaterialFeatures)>,
    opaque_batches: Vec<Batch>,
    /// Batch index of each deformed draw's vertex copy (each is a batch of its own).
    deformed_batches: HashMap<MeshId, usize>,
    opaque_slots: Vec<u32>,
    /// `opaque_slots` changed since it was last uploaded.
    opaque_slots_dirty: bool,
    blend_entities: Vec<Entity>,
    batches_dirty: bool,
    /// Moved by every rebuild: owners that keep per-batch data (culling, the visibility
    /// buffer) compare it with the generation they last saw.
    batch_generation: u64,
    /// Incremented whenever a caster may have changed (draws, batches, materials): local
    /// shadow maps re-render only then or when their light changes.
    caster_generation: u64,
    /// Where casters changed since the shadow orchestrator last took them.
    caster_changes: CasterChanges,
    /// `scene_bounds()` as of a caster generation: every draw change moves the generation.
    bounds_cache: Option<(u64, SceneBounds)>,
    warned_missing: HashSet<Handle<Mesh>>,
    variant: FrameVariant,
    /// The slots of the opaque batches' instances, then of the blended draws.
    slots: GrowableBuffer,
}

impl DrawList {
    pub fn new(device: &wgpu::Device, variant: FrameVariant) -> Self {
        Self {
            draws: EntityTable::default(),
            mesh_users: HashMap::new(),
            material_users: HashMap::new(),
            mesh_ids: HashMap::new(),
            material_bits: HashMap::new(),
            opaque_batches: Vec::new(),
            deformed_batches: HashMap::new(),
            opaque_slots: Vec::new(),
            opaque_slots_dirty: true,
            blend_entities: Vec::new(),
            batches_dirty: true,
            batch_generation: 0,
            caster_generation: 0,
            caster_changes: CasterChanges::Nothing,
            bounds_cache: None,
            warned_missing: HashSet::new(),
            variant,
            slots: GrowableBuffer::new(
                device,
                "draw slots",
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                4096 * 4,
            ),
        }
    }

    /// The frame's shared key parts; a change re-keys every batch at the next rebuild.
    pub fn set_variant(&mut self, variant: FrameVariant) {
        if variant != self.variant {
            self.variant = variant;
            self.batches_dirty = true;
        }
    }

    pub fn variant(&self) -> &FrameVariant {
        &self.variant
    }

    /// Marks every batch for a rebuild (settings every key reads changed).
    pub fn invalidate(&mut self) {
        self.batches_dirty = true;
    }

    /// Something a caster draws changed outside the draw list (a pose, a material's cutoff).
    pub fn casters_changed(&mut self) {
        self.caster_generation += 1;
        self.caster_changes = CasterChanges::Anywhere;
    }

    /// Where casters changed since the last call: shadow maps whose volume holds none of it keep
    /// what they hold.
    pub fn take_caster_changes(&mut self) -> CasterChanges {
        std::mem::replace(&mut self.caster_changes, CasterChanges::Nothing)
    }

    pub fn caster_generation(&self) -> u64 {
        self.caster_generation
    }

    pub fn batch_generation(&self) -> u64 {
        self.batch_generation
    }

    pub fn opaque_batches(&self) -> &[Batch] {
        &self.opaque_batches
    }

    pub fn opaque_slots(&self) -> &[u32] {
        &self.opaque_slots
    }

    /// The batch of a deformed draw's vertex copy.
    pub fn deformed_batch(&self, id: MeshId) -> Option<usize> {
        self.deformed_batches.get(&id).copied()
    }

    /// Blended draws there are (each frame sorts the visible ones).
    pub fn blend_count(&self) -> usize {
        self.blend_entities.len()
    }

    /// The buffer of draw slots the shaders index.
    pub fn slots(&self) -> &GrowableBuffer {
        &self.slots
    }

    /// The pool entry of each mesh asset a draw uses, for the deformer.
    pub fn draw_mesh(&self, entity: Entity) -> Option<(Handle<Mesh>, MeshId)> {
        self.draws.get(entity).and_then(|d| Some((d.mesh, *self.mesh_ids.get(&d.mesh)?)))
    }

    /// Sorts the draws into batches if anything they depend on changed; returns whether it did.
    pub fn rebuild_if_dirty(&mut self, cx: &DrawContext) -> bool {
        if !self.batches_dirty {
            return false;
        }
        self.rebuild_batches(cx);
        true
    }

    /// Writes the draw slots: the opaque batches' when they changed or the buffer grew, the
    /// blended draws' (`blended`, sorted this frame) every frame. Returns whether the buffer was
    /// replaced.
    pub fn upload_slots(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, blended: &[(Batch, u32)]) -> bool {
        let opaque_len = self.opaque_slots.len();
        let total = opaque_len + blended.len();
        let grew = self.slots.reserve(device, (total.max(1) * 4) as u64);
        if (self.opaque_slots_dirty || grew) && opaque_len > 0 {
            queue.write_buffer(self.slots.buffer(), 0, bytemuck::cast_slice(&self.opaque_slots));
        }
        self.opaque_slots_dirty = false;
        if !blended.is_empty() {
            let blend_slots: Vec<u32> = blended.iter().map(|(_, slot)| *slot).collect();
            queue.write_buffer(self.slots.buffer(), opaque_len as u64 * 4, bytemuck::cast_slice(&blend_slots));
        }
        grew
    }

    /// World bounds of the visible draws, and of those among them that cast shadows (opaque and
    /// masked triangles): a pass over every draw, made again only when the caster generation
    /// moved.
    pub fn scene_bounds(&mut self, cx: &DrawContext, scene: &RenderScene) -> SceneBounds {
        if let Some((generation, bounds)) = self.bounds_cache
            && generation == self.caster_generation
        {
            return bounds;
        }
        let mut bounds = SceneBounds { casters: Aabb::EMPTY, receivers: Aabb::EMPTY };
        for (entity, d) in self.draws.iter().filter(|(_, d)| d.visible) {
            let Some(entry) = self.draw_mesh_id(cx, entity, d).and_then(|id| cx.mesh_pool.entry(id)) else { continue };
            let Some(item) = scene.draws.get(entity) else { continue };
            let world = entry.aabb.transformed(&item.world_from_local);
            if world.is_empty() || !world.min.is_finite() || !world.max.is_finite() {
                continue;
            }
            bounds.receivers = bounds.receivers.union(&world);
            let casts = entry.topology == penumbra_engine::mesh::Topology::TriangleList
                && cx.materials.get(&d.material).is_some_and(|m| m.alpha != AlphaKey::Blend);
            if casts {
                bounds.casters = bounds.casters.union(&world);
            }
        }
        self.bounds_cache = Some((self.caster_generation, bounds));
        bounds
    }

    pub fn apply_changes(&mut self, cx: &mut DrawContext, scene: &RenderScene, in_step: bool) {
        if !in_step {
            // Missed change lists: diff against the full draw set instead.
            let gone: Vec<Entity> = self.draws.keys().filter(|e| !scene.draws.contains(*e)).collect();
            let all: Vec<Entity> = scene.draws.keys().collect();
            self.apply(cx, scene, &gone, &all);
        } else {
            self.apply(cx, scene, &scene.removed_draws, &scene.changed_draws);
        }
    }

    fn apply(&mut self, cx: &mut DrawContext, scene: &RenderScene, removed: &[Entity], changed: &[Entity]) {
        if !removed.is_empty() || !changed.is_empty() {
            self.caster_generation += 1;
        }
        // A few draws that only moved are bounded where they were and where they are (the
        // common case of an animated object in a still scene); anything else may be anywhere.
        let bounded = removed.is_empty() && changed.len() <= BOUNDED_CHANGES_MAX;
        if !bounded {
            self.caster_changes = CasterChanges::Anywhere;
        }
        for entity in removed {
            if let Some(old) = self.draws.remove(*entity) {
                self.forget_draw(cx, &old);
            }
        }
        // Moves first, in any order; then new and re-keyed draws in entity order, so instance
        // slots are allocated the same way whatever order extraction listed them in.
        // Moves write their record straight into their own slot; anything else is listed.
        let mut rekeyed = Vec::new();
        if changed.len() < PARALLEL_PACK_MIN {
            for &entity in changed {
                match pack_move(&self.draws, cx.materials, scene, entity) {
                    Some((slot, instance)) => {
                        // Hidden draws cast nothing, nor do draws without a mesh yet (its arrival
                        // rebuilds the batches, a change anywhere); a record rewritten as it was
                        // changes nothing.
                        let was = cx.instances.get(slot);
                        let draw = self.draws.get(entity).filter(|d| d.visible);
                        if bounded && bytemuck::bytes_of(&was) != bytemuck::bytes_of(&instance) {
                            let local = draw.and_then(|d| self.draw_mesh_id(cx, entity, d));
                            if let Some(aabb) = local.and_then(|id| cx.mesh_pool.entry(id)).map(|e| e.aabb) {
                                let before = aabb.transformed(&was.world_from_local());
                                let after = aabb.transformed(&instance.world_from_local());
                                self.caster_changes.add(&before.union(&after));
                            }
                        }
                        cx.instances.write(slot, instance);
                    }
                    None => rekeyed.push(entity),
                }
            }
        } else {
            // Packing a million moved instances is most of a frame's CPU time on one core.
            let pool = bevy_tasks::ComputeTaskPool::get_or_init(bevy_tasks::TaskPool::default);
            let chunk = changed.len().div_ceil(pool.thread_num().max(1) * 4);
            // The writer borrows the instance records; packing reads the draw and material tables.
            let writer = cx.instances.disjoint_writer();
            let (draws, materials) = (&self.draws, &*cx.materials);
            let parts = pool.scope(|s| {
                for entities in changed.chunks(chunk) {
                    let writer = &writer;
                    s.spawn(async move {
                        let mut rekeyed = Vec::new();
                        let (mut lowest, mut highest) = (u32::MAX, 0);
                        for &entity in entities {
                            match pack_move(draws, materials, scene, entity) {
                                Some((slot, instance)) => {
                                    // SAFETY: `changed` lists each entity once (extraction's
                                    // contract) and every drawn entity owns its own slot.
                                    unsafe { writer.write(slot, instance) };
                                    lowest = lowest.min(slot);
                                    highest = highest.max(slot);
                                }
                                None => rekeyed.push(entity),
                            }
                        }
                        writer.wrote_span(lowest, highest);
                        rekeyed
                    });
                }
            });
            drop(writer);
            rekeyed = parts.into_iter().flatten().collect();
        }
        rekeyed.sort_unstable();
        if !rekeyed.is_empty() {
            self.caster_changes = CasterChanges::Anywhere;
        }
        for entity in rekeyed {
            let Some(item) = scene.draws.get(entity) else {
                continue;
            };
            let mirrored = item.world_from_local.matrix3.determinant() < 0.0;
            // The material slot is assigned by prepare_materials; slot 0 until then is harmless
            // because the instance is re-packed there once the slot is known.
            let material_slot = cx.materials.get(&item.material).map_or(0, |m| m.slot);
            let instance = GpuInstance::new(&item.world_from_local, material_slot);
            let previous = self.draws.get(entity).copied();
            if let Some(old) = &previous
                && (old.mesh != item.mesh || old.material != item.material)
            {
                self.release_users(old);
            }
            if previous.is_none_or(|o| o.mesh != item.mesh || o.material != item.material) {
                *self.mesh_users.entry(item.mesh).or_default() += 1;
                *self.material_users.entry(item.material).or_default() += 1;
            }
            let slot = match previous {
                Some(d) => {
                    cx.instances.write(d.slot, instance);
                    d.slot
                }
                None => cx.instances.allocate(instance),
            };
            let state = DrawState { slot, mesh: item.mesh, material: item.material, mirrored, visible: item.visible };
            self.batches_dirty = true;
            if let Replaced::Other(_, stale) = self.draws.insert(entity, state) {
                // Not reported removed (extraction reports reused indices; this is a backstop).
                self.forget_draw(cx, &stale);
            }
        }
    }

    /// Releases what a draw that is gone held: its instance slot, its mesh and material uses.
    fn forget_draw(&mut self, cx: &mut DrawContext, old: &DrawState) {
        cx.instances.free(old.slot);
        self.release_users(old);
        self.batches_dirty = true;
    }

    fn release_users(&mut self, old: &DrawState) {
        if let Some(n) = self.mesh_users.get_mut(&old.mesh) {
            *n -= 1;
            if *n == 0 {
                self.mesh_users.remove(&old.mesh);
                self.mesh_ids.remove(&old.mesh);
            }
        }
        if let Some(n) = self.material_users.get_mut(&old.material) {
            *n -= 1;
            if *n == 0 {
                self.material_users.remove(&old.material);
            }
        }
    }

    pub fn prepare_materials(&mut self, cx: &mut DrawContext, scene: &RenderScene, encoder: &mut wgpu::CommandEncoder) {
        let users = &self.material_users;
        cx.materials.retain(scene, |k| users.contains_key(k));
        let keys: Vec<MaterialKey> = self.material_users.keys().copied().collect();
        // New or changed images are uploaded together so their mip chains build in parallel.
        let mut requests = Vec::new();
        for m in keys.iter().flatten().filter_map(|h| scene.materials.get(h)) {
            for (slot, tex) in m.data.textures().into_iter().enumerate() {
                let Some(t) = tex else { continue };
                let Some(img) = scene.images.get(&t.image) else { continue };
                let srgb = SRGB_SLOTS[slot];
                let queued = requests.iter().any(|r: &TextureRequest| r.image == t.image && r.srgb == srgb);
                if !queued && cx.textures.is_stale(t.image, srgb, img.version) {
                    requests.push(TextureRequest {
                        image: t.image,
                        srgb,
                        version: img.version,
                        data: img.data.clone(),
                    });
                }
            }
        }
        cx.textures.upload_many(cx.device, cx.queue, encoder, cx.pipelines, &requests);
        let mut new_slots = false;
        for key in keys {
            let before = cx.materials.get(&key).map(|m| m.slot);
            let ok = cx.materials.prepare(cx.device, cx.textures, scene, key);
            if !ok {
                continue;
            }
            let m = cx.materials.get(&key).expect("prepared");
            let bits = (m.alpha, m.unlit, m.double_sided, m.textures, m.features);
            if self.material_bits.insert(key, bits) != Some(bits) {
                self.batches_dirty = true;
            }
            new_slots |= before != Some(m.slot);
        }
        cx.textures.retain(|h| scene.images.contains_key(&h));
        self.material_bits.retain(|k, _| self.material_users.contains_key(k));
        if new_slots {
            // Instances packed before their material had a slot get the real one now.
            for (entity, d) in self.draws.iter() {
                if let (Some(m), Some(item)) = (cx.materials.get(&d.material), scene.draws.get(entity)) {
                    cx.instances.write(d.slot, GpuInstance::new(&item.world_from_local, m.slot));
                }
            }
        }
    }

    /// Returns whether any mesh asset now maps to another pool entry (or to none).
    pub fn prepare_meshes(&mut self, cx: &mut DrawContext, scene: &RenderScene) -> bool {
        let mut changed = false;
        // Mesh assets that vanished release their pool entries; entries nothing refers to are
        // evicted at the end of the frame.
        cx.mesh_pool.retain_assets(|h| scene.meshes.contains_key(&h));
        self.warned_missing.retain(|h| self.mesh_users.contains_key(h) && !scene.meshes.contains_key(h));
        let handles: Vec<Handle<Mesh>> = self.mesh_users.keys().copied().collect();
        for handle in handles {
            let Some(snapshot) = scene.meshes.get(&handle) else {
                if self.warned_missing.insert(handle) {
                    tracing::warn!("a draw refers to mesh {handle:?}, which no longer exists; not drawn");
                }
                if self.mesh_ids.remove(&handle).is_some() {
                    self.batches_dirty = true;
                    changed = true;
                }
                cx.mesh_pool.release_asset(handle);
                continue;
            };
            let id = cx.mesh_pool.get_or_upload(cx.device, cx.queue, handle, snapshot, cx.frame);
            if self.mesh_ids.insert(handle, id) != Some(id) {
                self.batches_dirty = true;
                changed = true;
            }
        }
        changed
    }

    fn pipeline_key(&self, cx: &DrawContext, d: &DrawState) -> Option<PipelineKey> {
        let m = cx.materials.get(&d.material)?;
        let entry = cx.mesh_pool.entry(*self.mesh_ids.get(&d.mesh)?)?;
        let triangles = entry.topology == penumbra_engine::mesh::Topology::TriangleList;
        Some(PipelineKey {
            unlit: m.unlit,
            alpha: m.alpha,
            textures: m.textures,
            features: m.features,
            // Blended surfaces are not in the surface targets, nor are surfaces with parameters
            // the surface buffer does not hold: they walk their own lists.
            local_lights: if self.variant.deferred_lights
                && m.alpha != AlphaKey::Blend
                && m.features.fits_surface_buffer()
            {
                LocalLights::Deferred
            } else {
                self.variant.local_lights
            },
            light_shapes: self.variant.light_shapes,
            global_lights_in_storage: self.variant.global_lights_in_storage,
            shadows: self.variant.shadows,
            local_shadows: self.variant.local_shadows,
            ibl: self.variant.ibl,
            debug: self.variant.debug,
            topology: entry.topology.into(),
            vertex_colors: entry.vertex_colors,
            // Only triangles have a back (lines are drawn as quads whose winding follows the
            // segment on screen; points face the viewer), so only their keys cull and wind.
            cull_back_faces: !m.double_sided && triangles,
            front_face_cw: d.mirrored && triangles,
            sample_count: self.variant.msaa,
            alpha_test: AlphaTest::choose(
                m.alpha,
                self.variant.msaa,
                m.textures.has(TextureSet::BASE_COLOR) || entry.vertex_colors,
                cx.caps,
            ),
            // Frames with direct output or without depth replace these per frame (see `render`).
            color_format: FormatKey(HDR_FORMAT),
            depth_format: Some(FormatKey(DEPTH_FORMAT)),
            tonemap: None,
            visibility_occlusion: false,
            pulled_vertices: false,
        })
    }

    /// The pool entry `entity` draws: its deformed copy if it has one, else its mesh's entry.
    fn draw_mesh_id(&self, cx: &DrawContext, entity: Entity, d: &DrawState) -> Option<MeshId> {
        (cx.deformed)(entity, d.mesh).or_else(|| self.mesh_ids.get(&d.mesh).copied())
    }

    /// Sorts visible opaque and masked draws into instanced batches; collects blended draws.
    fn rebuild_batches(&mut self, cx: &DrawContext) {
        self.batches_dirty = false;
        let casters_before = self.caster_signature();
        let mut items: Vec<(PipelineKey, MaterialKey, MeshId, Handle<Mesh>, u32)> = Vec::new();
        self.blend_entities.clear();
        for (entity, d) in self.draws.iter() {
            if !d.visible {
                continue;
            }
            let (Some(key), Some(mesh_id)) = (self.pipeline_key(cx, d), self.draw_mesh_id(cx, entity, d)) else {
                continue;
            };
            // Transmissive surfaces are drawn after the opaque colour is copied, back to front
            // with blended ones (`features::transmission`).
            if key.alpha == AlphaKey::Blend || key.features.has(MaterialFeatures::TRANSMISSION) {
                self.blend_entities.push(entity);
            } else {
                items.push((key, d.material, mesh_id, d.mesh, d.slot));
            }
        }
        // Opaque before masked (AlphaKey order), then by pipeline, material and pool entry (mesh
        // assets with identical content share an entry, so they batch together); the slot makes
        // the order total, so the frame is deterministic whatever the hash-map order.
        items.sort_unstable_by_key(|&(key, material, mesh_id, _, slot)| (key.alpha, key, material, mesh_id, slot));
        self.blend_entities.sort_unstable();
        self.opaque_batches.clear();
        self.deformed_batches.clear();
        self.opaque_slots.clear();
        self.opaque_slots_dirty = true;
        self.batch_generation += 1;
        for (key, material, mesh_id, mesh, slot) in items {
            let i = self.opaque_slots.len() as u32;
            self.opaque_slots.push(slot);
            match self.opaque_batches.last_mut() {
                Some(b) if b.key == key && b.material == material && b.mesh_id == mesh_id => b.count += 1,
                _ => self.opaque_batches.push(Batch { key, material, mesh, mesh_id, first: i, count: 1 }),
            }
        }
        if cx.any_deformed {
            for (i, b) in self.opaque_batches.iter().enumerate() {
                if cx.mesh_pool.entry(b.mesh_id).is_some_and(|e| e.is_derived()) {
                    self.deformed_batches.insert(b.mesh_id, i);
                }
            }
        }
        // New pipeline keys alone (shadows switched on, a debug view) change no caster.
        if self.caster_signature() != casters_before {
            self.caster_generation += 1;
            self.caster_changes = CasterChanges::Anywhere;
        }
    }

    /// What the shadow passes draw: each opaque or masked batch's mesh, material, alpha mode
    /// and instances.
    fn caster_signature(&self) -> (Vec<(MeshId, MaterialKey, AlphaKey, u32, u32)>, Vec<u32>) {
        let batches =
            self.opaque_batches.iter().map(|b| (b.mesh_id, b.material, b.key.alpha, b.first, b.count)).collect();
        (batches, self.opaque_slots.clone())
    }

    /// The world-space boxes of the blended draws (for the part of the screen they can cover).
    pub fn blended_bounds(&self, cx: &DrawContext, scene: &RenderScene) -> Vec<Aabb> {
        self.blend_entities
            .iter()
            .filter_map(|entity| {
                let d = self.draws.get(*entity)?;
                let entry = cx.mesh_pool.entry(self.draw_mesh_id(cx, *entity, d)?)?;
                Some(entry.aabb.transformed(&scene.draws.get(*entity)?.world_from_local))
            })
            .collect()
    }

    /// Blended draws, farthest first (by the centre of their world bounds along the view axis).
    pub fn sort_blended(&self, cx: &DrawContext, scene: &RenderScene) -> Vec<(Batch, u32)> {
        let Some(view) = scene.view else {
            return Vec::new();
        };
        let eye = Vec3::from(view.world_from_view.translation);
        let forward = (view.world_from_view.matrix3 * glam::Vec3A::NEG_Z).normalize_or_zero();
        let mut out: Vec<(f32, Entity, Batch, u32)> = Vec::new();
        for entity in &self.blend_entities {
            let Some(d) = self.draws.get(*entity) else { continue };
            let (Some(key), Some(mesh_id)) = (self.pipeline_key(cx, d), self.draw_mesh_id(cx, *entity, d)) else {
                continue;
            };
            let (Some(entry), Some(item)) = (cx.mesh_pool.entry(mesh_id), scene.draws.get(*entity)) else {
                continue;
            };
            let center = entry.aabb.transformed(&item.world_from_local).center();
            let depth = (center - eye).dot(forward.into());
            let batch = Batch { key, material: d.material, mesh: d.mesh, mesh_id, first: 0, count: 1 };
            out.push((depth, *entity, batch, d.slot));
        }
        // Farthest first; ties broken by entity so the order is deterministic.
        out.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        out.into_iter().map(|(_, _, b, s)| (b, s)).collect()
    }
}
