//! The mesh deformer: the one owner of skinning and morph-target data on the GPU and of the
//! compute pass that applies them (`shaders/deform.wgsl`).
//!
//! How a pose reaches the screen:
//! 1. Source data, once per mesh content (keyed by the asset's shared `Arc<Mesh>`, so the
//!    instances of a scene, whose mesh assets share one `Arc`, share one copy): per vertex four
//!    joints and four weights, and per morph target per vertex the position, normal and tangent
//!    displacements, packed into one storage buffer of words (range-allocated; a CPU mirror re-uploads it if it grows).
//!    Beside it, on the CPU, what bounds need: per joint the bind-space box of the vertices it
//!    moves, the box of unskinned vertices, and per target its largest displacement per axis.
//! 2. Per deformed draw (an entity whose `Mesh3d` has skin or morph data and that carries
//!    `JointMatrices` or `MorphWeights`): a derived mesh-pool entry, its own vertex copy drawn
//!    with the source's indices. Batching, culling, shadow casters and the forward pass treat
//!    it as an ordinary mesh, so the pose is computed once however many passes draw it.
//! 3. Per frame, only for draws whose pose changed (or that are new): a job (source and copy
//!    ranges, data offsets), the joint matrices (three rows each, identity beyond the pose's
//!    joints) and the weights, packed contiguously for this frame's jobs and uploaded; then one
//!    dispatch (one workgroup row per job). A still character costs nothing after its first
//!    frame.
//! 4. Bounds: the copy's box is recomputed on the CPU from the pose, conservatively (skinning
//!    blends joint transforms with weights summing to 1, so a vertex stays within the convex
//!    hull of its joints' images of it, each inside that joint's transformed box, grown by the
//!    weighted morph displacements), and handed to the pool; culling and shadow fitting use it.
//!
//! Limits: the whole vertex pool is bound as one storage buffer, so deformation needs the pool
//! within `max_storage_buffer_binding_size` (128 MiB on lavapipe: two million vertices); past
//! it draws keep their bind pose and an error is logged once. A mesh with more than
//! 65 535 × 64 vertices is not deformed either (the dispatch's row limit).

use std::collections::{HashMap, HashSet};
use std::ops::Range;

use bevy_ecs::entity::Entity;
use bytemuck::{Pod, Zeroable};
use glam::{Affine3A, Mat4, Vec3};
use penumbra_engine::Handle;
use penumbra_engine::bounds::Aabb;
use penumbra_engine::mesh::Mesh;
use range_alloc::RangeAllocator;

use crate::frame_context::FrameContext;
use crate::gpu::buffer::GrowableBuffer;
use crate::pipelines::{PipelineCache, ShaderError};
use crate::resources::line_quads;
use crate::resources::mesh_pool::{MeshId, MeshPool};

mod pipeline;
use crate::scene::world::{ExtractedDeform, RenderScene};
pub use pipeline::DeformFamily;

const WORKGROUP: u32 = 64;
const NO_SKIN: u32 = u32::MAX;
/// Words per vertex per morph target (`deform.wgsl`'s MORPH_WORDS).
const MORPH_WORDS: usize = 9;
/// Words per skinned vertex (`deform.wgsl`'s SKIN_WORDS).
const SKIN_WORDS: usize = 6;
/// Workgroup rows one dispatch dimension holds (WebGPU's guaranteed minimum).
const MAX_ROWS: u32 = 65_535;

/// Mirrors `struct Job` in `shaders/deform.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GpuJob {
    source_vertex: u32,
    output_vertex: u32,
    vertex_count: u32,
    skin_offset: u32,
    joint_row: u32,
    morph_offset: u32,
    target_count: u32,
    weight_offset: u32,
}

/// Which mesh content a source was packed from: the address of the asset's shared data, kept
/// alive by the source itself (so the address cannot be reused while the key exists).
type SourceKey = usize;

/// A mesh's deformation data.
struct Source {
    /// Holds the content the key points at.
    _mesh: std::sync::Arc<Mesh>,
    /// Words in `data`.
    range: Range<u32>,
    vertex_count: u32,
    skin_offset: Option<u32>,
    morph_offset: u32,
    target_count: u32,
    /// Matrices a job uploads: the largest joint index with weight (+ 1), at least 1.
    joint_count: u32,
    /// Per joint, the bind-space box of the vertices it moves (weight > 0).
    joint_boxes: Vec<Aabb>,
    /// Vertices no joint moves (all weights 0), or all vertices without a skin.
    rest_box: Aabb,
    /// Per target, its largest displacement along each axis.
    morph_extents: Vec<Vec3>,
    /// Deformed draws using it.
    users: u32,
}

/// A deformed draw.
struct Instance {
    mesh: Handle<Mesh>,
    /// The content it was deformed from: a new version of the asset is new content (a new key).
    source: SourceKey,
    source_entry: MeshId,
    output: MeshId,
}

/// Which deformed draws `prepare` looks at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Visit {
    /// Those the change lists name.
    Changes,
    /// Every one (a mesh asset changed under a draw), redeforming those whose pose changed.
    Scan,
    /// Every one, redeforming all (the change lists cannot be trusted: a frame was missed).
    Resync,
}

/// What `prepare` did this frame, for the renderer.
#[derive(Debug, Default)]
pub struct DeformFrame {
    /// Jobs the pass will run (0: the pass is left out).
    pub jobs: usize,
    /// A deformed draw appeared, went, or got a new copy: batches must be rebuilt.
    pub outputs_changed: bool,
    /// Copies whose bounds changed (their batches' cull bounds follow).
    pub moved: Vec<MeshId>,
}

pub struct MeshDeformer {
    sources: HashMap<SourceKey, Source>,
    data: Vec<u32>,
    data_alloc: RangeAllocator<u32>,
    data_buffer: GrowableBuffer,
    /// Words of `data` to upload before the next dispatch (everything after growth).
    data_dirty: Option<Range<u32>>,
    instances: HashMap<Entity, Instance>,
    jobs: Vec<GpuJob>,
    joint_rows: Vec<[f32; 4]>,
    weights: Vec<f32>,
    job_buffer: GrowableBuffer,
    joint_buffer: GrowableBuffer,
    weight_buffer: GrowableBuffer,
    params: wgpu::Buffer,
    /// The bind group, and the pool's vertex generation it was made for.
    bind_group: Option<(u64, wgpu::BindGroup)>,
    /// The widest job this frame, in workgroups.
    max_groups: u32,
    warned_too_large: bool,
}

impl MeshDeformer {
    /// Registers the deformation pipeline family.
    pub fn new(device: &wgpu::Device, pipelines: &mut PipelineCache) -> Self {
        pipelines.register(DeformFamily::new(device));
        let storage = wgpu::BufferUsages::STORAGE;
        Self {
            sources: HashMap::new(),
            data: Vec::new(),
            data_alloc: RangeAllocator::new(0..0),
            data_buffer: GrowableBuffer::new(device, "deform data", storage, 256),
            data_dirty: None,
            instances: HashMap::new(),
            jobs: Vec::new(),
            joint_rows: Vec::new(),
            weights: Vec::new(),
            job_buffer: GrowableBuffer::new(device, "deform jobs", storage, 256),
            joint_buffer: GrowableBuffer::new(device, "joint matrices", storage, 256),
            weight_buffer: GrowableBuffer::new(device, "morph weights", storage, 256),
            params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("deform params"),
                size: 16,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            bind_group: None,
            max_groups: 0,
            warned_too_large: false,
        }
    }

    /// The vertex copy drawn for `entity`, if it is deformed and still draws `mesh`.
    pub fn output(&self, entity: Entity, mesh: Handle<Mesh>) -> Option<MeshId> {
        self.instances.get(&entity).filter(|i| i.mesh == mesh).map(|i| i.output)
    }

    /// Deformed draws.
    pub fn instance_count(&self) -> usize {
        self.instances.len()
    }

    /// GPU bytes held (source data, this frame's jobs, joints and weights).
    pub fn gpu_bytes(&self) -> u64 {
        self.data_buffer.capacity()
            + self.job_buffer.capacity()
            + self.joint_buffer.capacity()
            + self.weight_buffer.capacity()
    }

    /// Syncs deformed draws with the scene and plans this frame's jobs. `draw_mesh` gives a
    /// drawn entity's mesh and its pool entry. See [`Visit`]: normally only the entities the
    /// change lists name, so a still crowd costs nothing.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pool: &mut MeshPool,
        scene: &RenderScene,
        draw_mesh: impl Fn(Entity) -> Option<(Handle<Mesh>, MeshId)>,
        visit: Visit,
    ) -> DeformFrame {
        let (scan, resync) = (visit != Visit::Changes, visit == Visit::Resync);
        let mut frame = DeformFrame::default();
        self.jobs.clear();
        self.joint_rows.clear();
        self.weights.clear();
        self.max_groups = 0;
        if self.pool_too_large(pool, &mut frame) {
            return frame;
        }
        let changed: HashSet<Entity> = scene.changed_deforms.iter().copied().collect();
        // What can have changed: poses that changed or went, draws that changed (a new mesh or
        // material) or went; everything on a scan or a resync.
        let mut entities: Vec<Entity> = if scan {
            self.instances.keys().chain(scene.deforms.keys()).copied().collect()
        } else {
            let draws = scene.changed_draws.iter().chain(&scene.removed_draws);
            let relevant = draws.filter(|e| scene.deforms.contains_key(e) || self.instances.contains_key(e));
            let poses = scene.changed_deforms.iter().chain(&scene.removed_deforms);
            poses.chain(relevant).copied().collect()
        };
        // Entity order, so jobs (and anything allocated for them) come out the same every run.
        entities.sort_unstable();
        entities.dedup();
        for entity in entities {
            let draw = draw_mesh(entity);
            let pose = scene.deforms.get(&entity);
            let snapshot = draw.and_then(|(mesh, _)| scene.meshes.get(&mesh));
            let key = snapshot.map(|s| std::sync::Arc::as_ptr(&s.data) as SourceKey);
            // No longer deformed as it was (pose gone, draw gone, another mesh or its content).
            let stale = self.instances.get(&entity).is_some_and(|i| match (pose, draw, key) {
                (Some(_), Some((mesh, entry)), Some(key)) => {
                    mesh != i.mesh || entry != i.source_entry || key != i.source
                }
                _ => true,
            });
            if stale {
                self.drop_instance(entity, pool);
                frame.outputs_changed = true;
            }
            let (Some(pose), Some((mesh, entry)), Some(snapshot), Some(key)) = (pose, draw, snapshot, key) else {
                continue;
            };
            let is_new = !self.instances.contains_key(&entity);
            if is_new {
                if !self.ensure_source(key, &snapshot.data) {
                    continue;
                }
                let Some(output) = pool.allocate_derived(device, queue, entry) else {
                    self.release_unused_source(key);
                    continue;
                };
                if let Some(s) = self.sources.get_mut(&key) {
                    s.users += 1;
                }
                let instance = Instance { mesh, source: key, source_entry: entry, output };
                self.instances.insert(entity, instance);
                frame.outputs_changed = true;
            } else if !resync && !changed.contains(&entity) {
                continue;
            }
            let (Some(instance), Some(entry_range)) =
                (self.instances.get(&entity), pool.entry(entry).map(|e| e.vertices.clone()))
            else {
                continue;
            };
            let output = instance.output;
            let Some(output_start) = pool.entry(output).map(|e| e.vertices.start) else { continue };
            let Some(source) = self.sources.get(&instance.source) else { continue };
            let job = push_job(&mut self.joint_rows, &mut self.weights, source, pose, entry_range.start, output_start);
            self.jobs.push(job);
            self.max_groups = self.max_groups.max(source.vertex_count.div_ceil(WORKGROUP));
            pool.set_derived_aabb(output, pose_bounds(source, pose));
            frame.moved.push(output);
        }
        // Allocating copies may have grown the pool past what one binding can hold.
        if self.pool_too_large(pool, &mut frame) {
            return frame;
        }
        frame.jobs = self.jobs.len();
        self.upload(device, queue, pool);
        frame
    }

    /// Past the adapter's storage binding limit the pool cannot be bound for writing: every
    /// deformed draw returns to its bind pose (with one logged error) and no job runs.
    fn pool_too_large(&mut self, pool: &mut MeshPool, frame: &mut DeformFrame) -> bool {
        // The pool decides how much of its vertex buffer a shader can bind.
        let limit = pool.readable_vertex_bytes();
        if pool.vertex_buffer().size() <= limit {
            return false;
        }
        if !self.warned_too_large {
            tracing::error!(
                "the mesh pool ({} MiB) exceeds this adapter's storage binding limit ({} MiB): skinned and \
                 morphed meshes are drawn in their bind pose",
                pool.vertex_buffer().size() >> 20,
                limit >> 20
            );
            self.warned_too_large = true;
        }
        frame.outputs_changed |= !self.instances.is_empty();
        let all: Vec<Entity> = self.instances.keys().copied().collect();
        for e in all {
            self.drop_instance(e, pool);
        }
        self.jobs.clear();
        self.joint_rows.clear();
        self.weights.clear();
        frame.moved.clear();
        true
    }

    fn drop_instance(&mut self, entity: Entity, pool: &mut MeshPool) {
        let Some(instance) = self.instances.remove(&entity) else { return };
        pool.free_derived(instance.output);
        if let Some(s) = self.sources.get_mut(&instance.source) {
            s.users = s.users.saturating_sub(1);
        }
        self.release_unused_source(instance.source);
    }

    /// Frees a source no deformed draw uses any more.
    fn release_unused_source(&mut self, key: SourceKey) {
        if self.sources.get(&key).is_some_and(|s| s.users == 0)
            && let Some(s) = self.sources.remove(&key)
        {
            self.data_alloc.free_range(s.range);
        }
    }

    /// Packs `mesh`'s deformation data unless it is there already. False when the mesh has
    /// nothing to deform (or is too large to).
    fn ensure_source(&mut self, key: SourceKey, mesh: &std::sync::Arc<Mesh>) -> bool {
        if self.sources.contains_key(&key) {
            return true;
        }
        let key_mesh = mesh;
        if (!mesh.is_skinned() && mesh.morph_targets.is_empty()) || mesh.vertex_count() == 0 {
            return false;
        }
        // Importers validate their meshes; a mesh built or edited in code might not be, and
        // packing indexes its attributes by vertex.
        if let Err(e) = mesh.validate() {
            tracing::error!("a skinned or morphed mesh is invalid ({e}); drawn in its bind pose");
            return false;
        }
        // Deformed as the pool holds it (line segments as quads), vertex for vertex.
        let quads = line_quads::expand(mesh);
        let mesh = quads.as_ref().unwrap_or(mesh);
        let n = mesh.vertex_count();
        if n.div_ceil(WORKGROUP as usize) > MAX_ROWS as usize {
            tracing::warn!("a mesh of {n} vertices is too large to deform on the GPU; drawn in its bind pose");
            return false;
        }
        let words = source_words(mesh);
        let range = self.allocate_words(words.max(1));
        let words = &mut self.data[range.start as usize..range.end as usize];
        // A reused range holds an older source's words; nothing stale may reach the shader.
        words.fill(0);
        let source = pack_source(mesh, key_mesh, range.clone(), words);
        self.mark_dirty(range);
        self.sources.insert(key, source);
        true
    }

    fn allocate_words(&mut self, words: u32) -> Range<u32> {
        if let Ok(r) = self.data_alloc.allocate_range(words) {
            return r;
        }
        let old = self.data_alloc.initial_range().end;
        let new = old.saturating_mul(2).max(old + words).max(4096);
        self.data_alloc.grow_to(new);
        self.data.resize(new as usize, 0);
        self.data_dirty = Some(0..new);
        self.data_alloc.allocate_range(words).expect("grown to fit")
    }

    fn mark_dirty(&mut self, r: Range<u32>) {
        self.data_dirty = Some(match self.data_dirty.take() {
            Some(d) => d.start.min(r.start)..d.end.max(r.end),
            None => r,
        });
    }

    fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, pool: &MeshPool) {
        let mut rebind = false;
        if let Some(r) = self.data_dirty.take() {
            if self.data_buffer.reserve(device, self.data.len() as u64 * 4) {
                rebind = true;
                // The bind group holds the old buffer, whether or not jobs run this frame.
                self.bind_group = None;
                queue.write_buffer(self.data_buffer.buffer(), 0, bytemuck::cast_slice(&self.data));
            } else if !r.is_empty() {
                let words = &self.data[r.start as usize..r.end as usize];
                queue.write_buffer(self.data_buffer.buffer(), r.start as u64 * 4, bytemuck::cast_slice(words));
            }
        }
        if self.jobs.is_empty() {
            return;
        }
        rebind |= self.job_buffer.reserve(device, std::mem::size_of_val(self.jobs.as_slice()) as u64);
        rebind |= self.joint_buffer.reserve(device, (self.joint_rows.len().max(1) * 16) as u64);
        rebind |= self.weight_buffer.reserve(device, (self.weights.len().max(1) * 4) as u64);
        queue.write_buffer(self.job_buffer.buffer(), 0, bytemuck::cast_slice(&self.jobs));
        if !self.joint_rows.is_empty() {
            queue.write_buffer(self.joint_buffer.buffer(), 0, bytemuck::cast_slice(&self.joint_rows));
        }
        if !self.weights.is_empty() {
            queue.write_buffer(self.weight_buffer.buffer(), 0, bytemuck::cast_slice(&self.weights));
        }
        queue.write_buffer(&self.params, 0, bytemuck::cast_slice(&[self.jobs.len() as u32, 0, 0, 0]));
        if rebind || self.bind_group.as_ref().is_none_or(|(g, _)| *g != pool.vertex_generation()) {
            self.bind_group = None;
        }
    }

    /// Runs this frame's jobs. Call after `prepare` when its frame had jobs.
    pub fn encode(&mut self, cx: &mut FrameContext, pool: &MeshPool) -> Result<(), ShaderError> {
        let (encoder, device, pipelines, timer) =
            (&mut *cx.encoder, cx.device, &mut *cx.pipelines, cx.timer.as_deref_mut());
        if self.jobs.is_empty() {
            return Ok(());
        }
        pipelines.get::<DeformFamily>(device, ())?;
        if self.bind_group.is_none() {
            fn buf(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
                wgpu::BindGroupEntry { binding, resource: buffer.as_entire_binding() }
            }
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("deform"),
                layout: &pipelines.family::<DeformFamily>().layout,
                entries: &[
                    buf(0, pool.vertex_buffer()),
                    buf(1, self.job_buffer.buffer()),
                    buf(2, self.data_buffer.buffer()),
                    buf(3, self.joint_buffer.buffer()),
                    buf(4, self.weight_buffer.buffer()),
                    buf(5, &self.params),
                ],
            });
            self.bind_group = Some((pool.vertex_generation(), group));
        }
        let pipeline = pipelines.get::<DeformFamily>(device, ())?;
        let (_, group) = self.bind_group.as_ref().expect("made above");
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("deform"),
            timestamp_writes: timer.and_then(|t| t.compute_pass("deform")),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, &[]);
        let jobs = self.jobs.len() as u32;
        pass.dispatch_workgroups(self.max_groups, jobs.min(MAX_ROWS), jobs.div_ceil(MAX_ROWS));
        Ok(())
    }
}

/// Appends a job's joint rows and weights to this frame's packing and returns the job.
fn push_job(
    joint_rows: &mut Vec<[f32; 4]>,
    weights: &mut Vec<f32>,
    source: &Source,
    pose: &ExtractedDeform,
    source_vertex: u32,
    output_vertex: u32,
) -> GpuJob {
    let joint_row = joint_rows.len() as u32;
    if source.skin_offset.is_some() {
        // Joints the pose lacks (a script's skin shorter than the mesh needs) hold the bind
        // pose rather than reading past this draw's matrices.
        for j in 0..source.joint_count as usize {
            let m = pose.joints.get(j).copied().unwrap_or(Mat4::IDENTITY);
            let rows = m.transpose();
            joint_rows.extend([rows.x_axis.to_array(), rows.y_axis.to_array(), rows.z_axis.to_array()]);
        }
    }
    let weight_offset = weights.len() as u32;
    for t in 0..source.target_count as usize {
        weights.push(pose.morph_weights.get(t).copied().unwrap_or(0.0));
    }
    GpuJob {
        source_vertex,
        output_vertex,
        vertex_count: source.vertex_count,
        skin_offset: source.skin_offset.unwrap_or(NO_SKIN),
        joint_row,
        morph_offset: source.morph_offset,
        target_count: source.target_count,
        weight_offset,
    }
}

fn source_words(mesh: &Mesh) -> u32 {
    let n = mesh.vertex_count();
    let skin = if mesh.is_skinned() { n * SKIN_WORDS } else { 0 };
    (skin + mesh.morph_targets.len() * n * MORPH_WORDS) as u32
}

/// Packs `mesh`'s joints, weights and morph displacements into `words` (which start at word
/// `range.start` of the data buffer) and measures what bounds need. `key_mesh` is the snapshot
/// the source is keyed by (its address), kept alive with it; `mesh` is what is drawn of it.
fn pack_source(mesh: &Mesh, key_mesh: &std::sync::Arc<Mesh>, range: Range<u32>, words: &mut [u32]) -> Source {
    let n = mesh.vertex_count();
    let mut at = 0;
    let skin_offset = mesh.is_skinned().then_some(range.start);
    let mut joint_boxes: Vec<Aabb> = Vec::new();
    let mut rest_box = Aabb::EMPTY;
    if mesh.is_skinned() {
        for (v, (joints, weights)) in mesh.joints.iter().zip(&mesh.weights).enumerate() {
            let w = &mut words[at..at + SKIN_WORDS];
            // An influence of weight 0 reads joint 0: exporters pad unused slots with any index
            // (255, 65535), which would otherwise count as joints to upload every frame.
            let j = |i: usize| if weights[i] > 0.0 { joints[i] as u32 } else { 0 };
            w[0] = j(0) | j(1) << 16;
            w[1] = j(2) | j(3) << 16;
            for i in 0..4 {
                w[2 + i] = weights[i].to_bits();
            }
            at += SKIN_WORDS;
            let p = mesh.positions[v];
            let point = Aabb { min: p, max: p };
            let mut moved = false;
            for (j, w) in joints.iter().zip(weights.to_array()) {
                if w > 0.0 {
                    let j = *j as usize;
                    if joint_boxes.len() <= j {
                        joint_boxes.resize(j + 1, Aabb::EMPTY);
                    }
                    joint_boxes[j] = joint_boxes[j].union(&point);
                    moved = true;
                }
            }
            if !moved {
                rest_box = rest_box.union(&point);
            }
        }
    } else {
        rest_box = mesh.aabb();
    }
    let morph_offset = range.start + at as u32;
    let mut morph_extents = Vec::with_capacity(mesh.morph_targets.len());
    for t in &mesh.morph_targets {
        let mut extent = Vec3::ZERO;
        for v in 0..n {
            let get = |a: &Vec<Vec3>| a.get(v).copied().unwrap_or(Vec3::ZERO);
            let (dp, dn, dt) = (get(&t.positions), get(&t.normals), get(&t.tangents));
            extent = extent.max(dp.abs());
            let w = &mut words[at..at + MORPH_WORDS];
            for (i, x) in dp.to_array().into_iter().chain(dn.to_array()).chain(dt.to_array()).enumerate() {
                w[i] = x.to_bits();
            }
            at += MORPH_WORDS;
        }
        morph_extents.push(extent);
    }
    Source {
        _mesh: key_mesh.clone(),
        range,
        vertex_count: n as u32,
        skin_offset,
        morph_offset,
        target_count: mesh.morph_targets.len() as u32,
        // Every index the shader reads (weighted ones; unweighted slots read joint 0) has its
        // matrix.
        joint_count: (joint_boxes.len() as u32).max(1),
        joint_boxes,
        rest_box,
        morph_extents,
        users: 0,
    }
}

/// The deformed copy's bounds under `pose` (see the module doc, step 4).
fn pose_bounds(source: &Source, pose: &ExtractedDeform) -> Aabb {
    let mut grow = Vec3::ZERO;
    for (t, extent) in source.morph_extents.iter().enumerate() {
        grow += pose.morph_weights.get(t).copied().unwrap_or(0.0).abs() * *extent;
    }
    let grown = |b: &Aabb| if b.is_empty() { *b } else { Aabb { min: b.min - grow, max: b.max + grow } };
    let mut bounds = grown(&source.rest_box);
    for (j, b) in source.joint_boxes.iter().enumerate() {
        if b.is_empty() {
            continue;
        }
        let m = pose.joints.get(j).copied().unwrap_or(Mat4::IDENTITY);
        bounds = bounds.union(&grown(b).transformed(&Affine3A::from_mat4(m)));
    }
    bounds
}

#[cfg(test)]
mod tests;
