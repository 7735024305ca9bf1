//! GPU frustum culling: the one owner of the culled draw list and the indirect draw arguments.
//!
//! When batches are rebuilt, [`GpuCulling::prepare_batches`] uploads, for the opaque and masked
//! draw list (`draw_slots[0..n]`, batch by batch), which batch each entry belongs to, each
//! batch's mesh bounds and region, and a template of each batch's indirect arguments with an
//! instance count of 0 (all O(draws), and only then). Each frame, [`GpuCulling::encode`]
//! resets the arguments from the template, copies the blended part of the draw list (not
//! culled: few, sorted on the CPU) and runs `shaders/cull.wgsl`, which appends every entry
//! whose box is in view to its batch's region of `visible_slots` and counts it. The forward
//! pass binds `visible_slots` in place of the draw list and draws each opaque batch indirectly;
//! consecutive indexed batches sharing pipeline and material go out as one
//! `multi_draw_indexed_indirect`.
//!
//! Occlusion culling (two-phase, with a hierarchical depth buffer) splits this: the early
//! cull keeps only what was visible last frame, the forward pass draws that, and
//! [`GpuCulling::encode_late`] reduces its depth into a pyramid (`shaders/hzb.wgsl`), then
//! tests everything in the frustum against the pyramid, remembers the answer for the next
//! frame and sends what is visible but was not drawn to a second, late set of indirect draws
//! (its own arguments, and a region of `visible_slots` after the blended entries). See
//! `shaders/cull.wgsl` for why nothing visible can be lost.
//!
//! No CPU work per draw per frame. The one thing read back is the late cull's count of hidden
//! entries, a few frames late and without waiting, for `OcclusionCulling::Auto`
//! (`occlusion_feedback.rs`). Within a batch, visible instances are
//! drawn in the order the GPU appended them, which varies: only coplanar, overlapping instances
//! of one batch could tell (depth ties). Shadow maps are culled by their own clip volumes (a
//! caster outside the view still casts into it), from the per-batch data uploaded here
//! (`features/shadows/caster_cull.rs`).
//!
//! Needs indirect draws with a first instance (`Features::INDIRECT_FIRST_INSTANCE`); without it
//! (GL, some mobile GPUs) the renderer draws the full list directly, as with culling off.
//!
//! Triangle culling (`TriangleCulling`): batches of meshes with at most [`MAX_TRIANGLES`]
//! triangles and 256 vertices are marked when batches are rebuilt, each with a region of
//! `triangle_indices` as large as all its instances' triangles. The cull pass (every phase)
//! then tests each instance it draws triangle by triangle and writes those that can cover a
//! sample to the region (see `shaders/cull.wgsl`); the batch's arguments become one indexed
//! draw of its region (index count counted by the pass, one instance whose index is the mesh's
//! first vertex), which the forward pass draws with the pulled-vertex pipeline. After the
//! hidden-count word each argument buffer holds one word per batch: the instances a
//! triangle-culled batch drew.

use std::sync::Arc;

use std::collections::HashMap;

use bytemuck::{Pod, Zeroable};

use crate::frame_context::FrameContext;
use crate::pipelines::{PipelineCache, ShaderError};
use crate::resources::draws::{Batch, TopologyKey};
use occlusion_feedback::{Advisor, Feedback};

mod counts;
mod hzb;
pub mod occlusion_feedback;
mod pipelines;
mod settings;
use crate::gpu::buffer::GrowableBuffer;
use crate::gpu::readback::{self, ReadbackError};
use crate::gpu::timing::GpuTimer;
use crate::resources::mesh_pool::MeshPool;
use hzb::Hzb;
pub use occlusion_feedback::OcclusionMeasure;
pub use pipelines::{CullFamily, CullPhase, HzbFamily, HzbStep, families};
pub use settings::{OCCLUSION_AUTO_MIN, OcclusionCulling, TriangleCulling};

/// Words of indirect arguments per batch (`DrawIndexedIndirectArgs`).
pub const ARGS_WORDS: u64 = 5;
const WORKGROUP: u32 = 64;
/// Triangles a mesh may have for its batches to be triangle-culled (one bit each in the pass).
pub const MAX_TRIANGLES: u32 = 64;
/// Vertices a mesh may have for it: an index names its vertex in 8 bits.
const MAX_VERTICES: u32 = 256;
/// Instance slots a triangle-culled index can name (the other 24 bits).
const MAX_SLOT: u32 = 1 << 24;
/// Indices the culled lists may hold in all (256 MiB); batches past it draw instances.
const TRIANGLE_INDEX_BUDGET: u64 = 64 << 20;
/// `CullBatch::triangles_first` of a batch that draws instances.
const NO_TRIANGLES: u32 = u32::MAX;
const CULL_BACK: u32 = 1;
const FRONT_CW: u32 = 2;

/// Mirrors `struct CullBatch` in `shaders/cull.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GpuCullBatch {
    center: [f32; 3],
    first: u32,
    half_extent: [f32; 3],
    triangles_first: u32,
    index_start: u32,
    triangle_count: u32,
    vertex_start: u32,
    flags: u32,
}

/// `first`: the batch's region in `triangle_indices` when it is triangle-culled.
fn cull_batch(b: &Batch, mesh_pool: &MeshPool, triangles_first: Option<u32>) -> GpuCullBatch {
    let entry = mesh_pool.entry(b.mesh_id);
    let bounds = entry.map(|e| e.aabb).filter(|a| !a.is_empty() && a.min.is_finite() && a.max.is_finite());
    // Without usable bounds a batch is never culled.
    let (center, half_extent) =
        bounds.map_or(([0.0; 3], [f32::MAX / 16.0; 3]), |a| (a.center().to_array(), a.half_extents().to_array()));
    let indices = entry.and_then(|e| e.indices.clone()).unwrap_or(0..0);
    let flags = if b.key.cull_back_faces { CULL_BACK } else { 0 } | if b.key.front_face_cw { FRONT_CW } else { 0 };
    GpuCullBatch {
        center,
        first: b.first,
        half_extent,
        triangles_first: triangles_first.unwrap_or(NO_TRIANGLES),
        index_start: indices.start,
        triangle_count: indices.len() as u32 / 3,
        vertex_start: entry.map_or(0, |e| e.vertices.start),
        flags,
    }
}

/// Whether batch `b` can be triangle-culled: triangles of a small indexed mesh of its own
/// (not a deformed copy, whose vertices the deformation pass rewrites), with every instance
/// slot nameable in an index.
fn triangle_cullable(b: &Batch, mesh_pool: &MeshPool, max_slot: u32) -> bool {
    let Some(entry) = mesh_pool.entry(b.mesh_id) else { return false };
    let Some(indices) = &entry.indices else { return false };
    b.key.topology == TopologyKey::Triangles
        && b.count > 0
        && !entry.is_derived()
        && indices.len() % 3 == 0
        && (1..=MAX_TRIANGLES as usize * 3).contains(&indices.len())
        && entry.vertices.len() <= MAX_VERTICES as usize
        && max_slot < MAX_SLOT
}

/// The frame triangle culling tests against.
#[derive(Debug, Clone, Copy)]
pub struct RasterTarget {
    pub size: (u32, u32),
    pub samples: u32,
    /// The rasteriser's sub-pixel precision (`Capabilities::subpixel_bits`).
    pub subpixel_bits: u32,
}

impl RasterTarget {
    /// How far the rasteriser may move a vertex from where the cull pass computes it, in
    /// pixels on each axis: half a sub-pixel step, plus the rounding by which the pass and the
    /// vertex shader (different compilations of the same arithmetic) and the pass's own
    /// projection may differ (about 1e-4 pixel at 4K, taken 20 times over).
    fn snap(&self) -> f32 {
        0.5 / (1u32 << self.subpixel_bits.min(16)) as f32 + 2e-3
    }
}

/// What the forward pass needs to draw triangle-culled batches.
#[derive(Clone)]
pub struct TriangleDraws {
    /// The culled index lists, batch by batch.
    pub indices: wgpu::Buffer,
    /// Per opaque batch (in batch order): whether it draws from `indices`.
    pub culled: Arc<[bool]>,
}

/// Per-batch data of the opaque and masked draw list (`draw_slots[0..item_count]`), as
/// `shaders/cull_bounds.wgsl` reads it.
#[derive(Clone, Copy)]
pub struct BatchBuffers<'a> {
    /// Which batch each entry belongs to.
    pub item_batch: &'a wgpu::Buffer,
    /// `CullBatch` per batch: mesh bounds and where its region starts.
    pub batches: &'a wgpu::Buffer,
    /// `ARGS_WORDS` per batch, instance count 0.
    pub args_template: &'a wgpu::Buffer,
    pub item_count: u32,
    pub batch_count: u32,
}

/// The buffers the cull pass reads that other owners hold.
pub struct CullInputs<'a> {
    pub view: &'a wgpu::Buffer,
    pub instances: &'a wgpu::Buffer,
    pub draw_slots: &'a wgpu::Buffer,
    /// Entries of the draw list after the culled ones (blended draws), copied as they are.
    pub blended: std::ops::Range<u32>,
    /// The mesh pool's buffers, which triangle culling reads.
    pub pool_indices: &'a wgpu::Buffer,
    pub pool_vertices: &'a wgpu::Buffer,
}

pub struct GpuCulling {
    item_batch: GrowableBuffer,
    batches: GrowableBuffer,
    args_template: GrowableBuffer,
    args: GrowableBuffer,
    late_template: GrowableBuffer,
    late_args: GrowableBuffer,
    /// One word per draw-list entry: whether it passed the late test last frame.
    was_visible: GrowableBuffer,
    visible_slots: GrowableBuffer,
    /// Triangle culling: the arguments' templates (early or only, and late) with the marked
    /// batches' draws of their regions, and the regions.
    triangle_template: GrowableBuffer,
    late_triangle_template: GrowableBuffer,
    triangle_indices: GrowableBuffer,
    /// Which batches the last `prepare_batches` marked (empty: none).
    triangle_batches: Arc<[bool]>,
    params: wgpu::Buffer,
    /// What `params` holds, so that a still frame writes nothing.
    written_params: Option<[u32; 8]>,
    hzb: Option<Hzb>,
    item_count: u32,
    batch_count: u32,
    late_base: u32,
    /// Whether the last frame ran the occlusion phases (which arguments hold its counts).
    occlusion: bool,
    /// The frame `prepare_frame` was last called for, and the last one that ran occlusion culling.
    frame: u64,
    last_occlusion_frame: Option<u64>,
    /// Hidden counts on their way back, and what they decide for `OcclusionCulling::Auto`.
    feedback: Feedback,
    advisor: Advisor,
    /// Bind groups by phase with the resources they were made of: remade only when one of them
    /// was replaced (no `create_*` per frame on the hot path).
    groups: HashMap<CullPhase, (Vec<wgpu::Buffer>, Option<wgpu::TextureView>, wgpu::BindGroup)>,
}

impl GpuCulling {
    /// Registers the culling and depth-pyramid pipeline families.
    pub fn new(device: &wgpu::Device, pipelines: &mut PipelineCache) -> Self {
        let (cull, hzb) = pipelines::families(device);
        pipelines.register(cull);
        pipelines.register(hzb);
        use wgpu::BufferUsages as U;
        Self {
            item_batch: GrowableBuffer::new(device, "cull item batches", U::STORAGE, 256),
            batches: GrowableBuffer::new(device, "cull batches", U::STORAGE, 256),
            args_template: GrowableBuffer::new(device, "indirect args template", U::COPY_SRC, 256),
            args: GrowableBuffer::new(device, "indirect args", U::STORAGE | U::INDIRECT | U::COPY_SRC, 256),
            late_template: GrowableBuffer::new(device, "late indirect args template", U::COPY_SRC, 256),
            late_args: GrowableBuffer::new(device, "late indirect args", U::STORAGE | U::INDIRECT | U::COPY_SRC, 256),
            was_visible: GrowableBuffer::new(device, "visible last frame", U::STORAGE, 256),
            visible_slots: GrowableBuffer::new(device, "visible draw slots", U::STORAGE | U::COPY_SRC, 4096 * 4),
            triangle_template: GrowableBuffer::new(device, "triangle-culled args template", U::COPY_SRC, 256),
            late_triangle_template: GrowableBuffer::new(device, "late triangle-culled args template", U::COPY_SRC, 256),
            triangle_indices: GrowableBuffer::new(device, "triangle-culled indices", U::STORAGE | U::INDEX, 256),
            triangle_batches: Arc::from([]),
            params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("cull params"),
                size: 32,
                usage: U::UNIFORM | U::COPY_DST,
                mapped_at_creation: false,
            }),
            written_params: None,
            hzb: None,
            item_count: 0,
            batch_count: 0,
            late_base: 0,
            occlusion: false,
            frame: 0,
            last_occlusion_frame: None,
            feedback: Feedback::new(device),
            advisor: Advisor::default(),
            groups: HashMap::new(),
        }
    }

    /// What the last `prepare_batches` uploaded about the batches, for other culls of the same
    /// draw list (the shadow maps', `features/shadows/caster_cull.rs`).
    pub fn batch_buffers(&self) -> BatchBuffers<'_> {
        BatchBuffers {
            item_batch: self.item_batch.buffer(),
            batches: self.batches.buffer(),
            args_template: self.args_template.buffer(),
            item_count: self.item_count,
            batch_count: self.batch_count,
        }
    }

    /// The indirect arguments, `ARGS_WORDS` words per opaque batch in batch order.
    pub fn args(&self) -> &wgpu::Buffer {
        self.args.buffer()
    }

    /// The late draws' indirect arguments (occlusion culling), laid out like `args`.
    pub fn late_args(&self) -> &wgpu::Buffer {
        self.late_args.buffer()
    }

    /// The draw list as the forward pass reads it: each opaque batch's visible instances at the
    /// start of its region, then the blended entries.
    pub fn visible_slots(&self) -> &wgpu::Buffer {
        self.visible_slots.buffer()
    }

    pub fn gpu_bytes(&self) -> u64 {
        self.item_batch.capacity()
            + self.batches.capacity()
            + self.args_template.capacity()
            + self.args.capacity()
            + self.visible_slots.capacity()
            + self.late_template.capacity()
            + self.late_args.capacity()
            + self.was_visible.capacity()
            + self.triangle_template.capacity()
            + self.late_triangle_template.capacity()
            + self.triangle_indices.capacity()
    }

    /// Whether frames cull triangles: some batch is marked.
    fn triangles_active(&self) -> bool {
        !self.triangle_batches.is_empty()
    }

    /// The triangle-culled draws of this frame, if it culls triangles.
    pub fn triangle_draws(&self) -> Option<TriangleDraws> {
        self.triangles_active().then(|| TriangleDraws {
            indices: self.triangle_indices.buffer().clone(),
            culled: self.triangle_batches.clone(),
        })
    }

    /// After the batches were rebuilt: what the cull pass needs to know about them.
    /// `late_base`: where the late draws' region starts in the visible list (after the opaque
    /// and the most blended entries there can be). Every entry counts as visible last frame.
    /// `triangles`: mark the batches that can be triangle-culled, given the largest instance
    /// slot of the draw list (`None`: mark none).
    pub fn prepare_batches(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        batches: &[Batch],
        mesh_pool: &MeshPool,
        late_base: u32,
        triangles: Option<u32>,
    ) {
        let mut item_batch = Vec::new();
        let mut gpu_batches = Vec::with_capacity(batches.len());
        let mut template = Vec::with_capacity(batches.len() * ARGS_WORDS as usize);
        let mut triangle_template = Vec::new();
        let mut marked = Vec::with_capacity(batches.len());
        let mut triangle_indices = 0u64;
        for (i, b) in batches.iter().enumerate() {
            item_batch.extend(std::iter::repeat_n(i as u32, b.count as usize));
            let entry = mesh_pool.entry(b.mesh_id);
            let region = entry.and_then(|e| e.indices.as_ref()).map(|r| r.len() as u64 * b.count as u64).filter(|&n| {
                triangles.is_some_and(|max_slot| triangle_cullable(b, mesh_pool, max_slot))
                    && triangle_indices + n <= TRIANGLE_INDEX_BUDGET
            });
            let first = region.map(|n| {
                let first = triangle_indices as u32;
                triangle_indices += n;
                first
            });
            gpu_batches.push(cull_batch(b, mesh_pool, first));
            marked.push(first.is_some());
            let words: [u32; ARGS_WORDS as usize] = match entry {
                Some(e) => match &e.indices {
                    Some(r) => [r.len() as u32, 0, r.start, e.vertices.start, b.first],
                    None => [e.vertices.len() as u32, 0, e.vertices.start, b.first, 0],
                },
                None => [0; ARGS_WORDS as usize],
            };
            template.extend(words);
            // The region as one draw: its index count is what the pass keeps, its one instance
            // is the mesh's first vertex (forward.wgsl, PULLED_VERTICES).
            let triangle_words = match (first, entry) {
                (Some(first), Some(e)) => [0, 1, first, 0, e.vertices.start],
                _ => words,
            };
            triangle_template.extend(triangle_words);
        }
        self.item_count = item_batch.len() as u32;
        self.batch_count = batches.len() as u32;
        self.item_batch.reserve(device, item_batch.len() as u64 * 4);
        self.batches.reserve(device, std::mem::size_of_val(gpu_batches.as_slice()) as u64);
        self.args_template.reserve(device, template.len() as u64 * 4);
        // The hidden-count word, then one visible-instance count per batch (triangle culling).
        triangle_template.extend(std::iter::repeat_n(0, 1 + batches.len()));
        self.args.reserve(device, triangle_template.len() as u64 * 4);
        // The late draws' first instance is in their own region.
        let mut late = template.clone();
        for (words, b) in late.chunks_exact_mut(ARGS_WORDS as usize).zip(batches) {
            let indexed = mesh_pool.entry(b.mesh_id).is_some_and(|e| e.indices.is_some());
            words[if indexed { 4 } else { 3 }] += late_base;
        }
        // Triangle-culled batches draw their region again (rewritten by the late cull).
        let mut late_triangles = late.clone();
        for ((words, triangle_words), &m) in late_triangles
            .chunks_exact_mut(ARGS_WORDS as usize)
            .zip(triangle_template.chunks_exact(ARGS_WORDS as usize))
            .zip(&marked)
        {
            if m {
                words.copy_from_slice(triangle_words);
            }
        }
        late_triangles.extend(std::iter::repeat_n(0, 1 + batches.len()));
        self.late_base = late_base;
        // The word after the late arguments counts what the late cull hid (`hidden_word`).
        late.push(0);
        self.late_template.reserve(device, late.len() as u64 * 4);
        self.late_args.reserve(device, late_triangles.len() as u64 * 4);
        self.triangle_batches = if triangle_indices > 0 { Arc::from(marked) } else { Arc::from([]) };
        if triangle_indices > 0 {
            self.triangle_template.reserve(device, triangle_template.len() as u64 * 4);
            self.late_triangle_template.reserve(device, late_triangles.len() as u64 * 4);
            self.triangle_indices.reserve(device, triangle_indices * 4);
            queue.write_buffer(self.triangle_template.buffer(), 0, bytemuck::cast_slice(&triangle_template));
            queue.write_buffer(self.late_triangle_template.buffer(), 0, bytemuck::cast_slice(&late_triangles));
        }
        self.was_visible.reserve(device, item_batch.len() as u64 * 4);
        let all_visible = vec![1u32; item_batch.len()];
        for (buffer, bytes) in [
            (&self.item_batch, bytemuck::cast_slice::<u32, u8>(&item_batch)),
            (&self.batches, bytemuck::cast_slice(&gpu_batches)),
            (&self.args_template, bytemuck::cast_slice(&template)),
            (&self.late_template, bytemuck::cast_slice(&late)),
            (&self.was_visible, bytemuck::cast_slice(&all_visible)),
        ] {
            if !bytes.is_empty() {
                queue.write_buffer(buffer.buffer(), 0, bytes);
            }
        }
    }

    /// Rewrites one batch's bounds (a deformed draw's copy moved) without a rebuild.
    pub fn update_batch_bounds(&self, queue: &wgpu::Queue, index: usize, batch: &Batch, mesh_pool: &MeshPool) {
        if index >= self.batch_count as usize {
            return;
        }
        // Deformed copies, the only batches updated here, are never triangle-culled.
        let gpu = cull_batch(batch, mesh_pool, None);
        let offset = (index * std::mem::size_of::<GpuCullBatch>()) as u64;
        queue.write_buffer(self.batches.buffer(), offset, bytemuck::bytes_of(&gpu));
    }

    /// Every frame: the parameters, the depth pyramid for a frame of `frame_size` when
    /// `occlusion` runs, and room for the whole visible list (`draw_list_len` entries, plus the
    /// late region). `target`: the frame's size and samples per pixel, which triangle culling
    /// tests against (it runs whenever batches are marked).
    /// Returns whether `visible_slots` was replaced.
    pub fn prepare_frame(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        draw_list_len: usize,
        occlusion: Option<(u32, u32)>,
        target: RasterTarget,
        frame: u64,
    ) -> bool {
        self.occlusion = occlusion.is_some();
        self.frame = frame;
        let levels = match occlusion {
            Some(size) => {
                if self.hzb.as_ref().is_none_or(|h| h.frame_size != size) {
                    self.hzb = Some(Hzb::new(device, size));
                }
                self.hzb.as_ref().map_or(1, Hzb::levels)
            }
            None => {
                self.hzb = None;
                1
            }
        };
        let hidden_word = self.batch_count * ARGS_WORDS as u32;
        let params = [
            self.item_count,
            self.late_base,
            levels,
            hidden_word,
            (target.size.0 as f32).to_bits(),
            (target.size.1 as f32).to_bits(),
            target.samples,
            target.snap().to_bits(),
        ];
        if self.written_params != Some(params) {
            queue.write_buffer(&self.params, 0, bytemuck::cast_slice(&params));
            self.written_params = Some(params);
        }
        let late_end = if self.occlusion { self.late_base as usize + self.item_count as usize } else { 0 };
        self.visible_slots.reserve(device, draw_list_len.max(late_end).max(1) as u64 * 4)
    }

    /// Compiles the pipelines a frame needs (the frustum cull, or occlusion culling's phases and
    /// depth-pyramid reductions for `samples` per pixel), so that a failure can be known before
    /// the frame commits to indirect draws.
    pub fn compile(
        device: &wgpu::Device,
        pipelines: &mut PipelineCache,
        occlusion: bool,
        triangles: bool,
        samples: u32,
    ) -> Result<(), ShaderError> {
        // With and without triangles when they are wanted: whether any batch is marked is
        // known only once the batches are prepared.
        let phases: &[CullPhase] = if occlusion { &[CullPhase::Early, CullPhase::Late] } else { &[CullPhase::Frustum] };
        for &phase in phases {
            pipelines.get::<CullFamily>(device, phase)?;
            if triangles {
                pipelines.get::<CullFamily>(device, phase.with_triangles(true))?;
            }
        }
        if !occlusion {
            return Ok(());
        }
        pipelines.get::<HzbFamily>(device, HzbStep::FromDepth { multisampled: samples > 1 })?;
        pipelines.get::<HzbFamily>(device, HzbStep::Reduce).map(|_| ())
    }

    /// Resets the arguments, copies the blended entries and culls: the whole frustum cull, or
    /// the early half of occlusion culling when the frame was prepared with it. The pipelines
    /// are the ones [`GpuCulling::compile`] made before the frame chose indirect draws.
    pub fn encode(&mut self, cx: &mut FrameContext, inputs: &CullInputs) {
        let (encoder, device, pipelines, timer) =
            (&mut *cx.encoder, cx.device, &*cx.pipelines, cx.timer.as_deref_mut());
        let phase = if self.occlusion { CullPhase::Early } else { CullPhase::Frustum };
        let phase = phase.with_triangles(self.triangles_active());
        let args_bytes = self.batch_count as u64 * ARGS_WORDS * 4;
        if self.triangles_active() {
            // With the hidden-count word and the visible-instance counts after the arguments.
            let bytes = args_bytes + 4 * (1 + self.batch_count as u64);
            encoder.copy_buffer_to_buffer(self.triangle_template.buffer(), 0, self.args.buffer(), 0, bytes);
        } else if args_bytes > 0 {
            encoder.copy_buffer_to_buffer(self.args_template.buffer(), 0, self.args.buffer(), 0, args_bytes);
        }
        if !inputs.blended.is_empty() {
            let offset = inputs.blended.start as u64 * 4;
            let size = inputs.blended.len() as u64 * 4;
            encoder.copy_buffer_to_buffer(inputs.draw_slots, offset, self.visible_slots.buffer(), offset, size);
        }
        self.dispatch(encoder, device, pipelines, inputs, phase, timer);
    }

    /// Occlusion culling, after the early draws: the depth pyramid from `depth` (the frame's
    /// depth target, `samples` per pixel), then the late cull.
    pub fn encode_late(&mut self, cx: &mut FrameContext, inputs: &CullInputs, depth: (&wgpu::TextureView, u32)) {
        let (encoder, device, pipelines, mut timer) =
            (&mut *cx.encoder, cx.device, &*cx.pipelines, cx.timer.as_deref_mut());
        let first = HzbStep::FromDepth { multisampled: depth.1 > 1 };
        let Some(hzb) = &mut self.hzb else { return };
        if hzb.level_groups.as_ref().is_none_or(|(d, _)| d != depth.0) {
            let groups = (0..hzb.level_views.len())
                .map(|level| {
                    let (step, input) =
                        if level == 0 { (first, depth.0) } else { (HzbStep::Reduce, &hzb.level_views[level - 1]) };
                    device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("depth pyramid level"),
                        layout: pipelines.family::<HzbFamily>().layout(step),
                        entries: &[
                            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(input) },
                            wgpu::BindGroupEntry {
                                binding: 1,
                                resource: wgpu::BindingResource::TextureView(&hzb.level_views[level]),
                            },
                        ],
                    })
                })
                .collect();
            hzb.level_groups = Some((depth.0.clone(), groups));
        }
        let hzb = self.hzb.as_ref().expect("made above");
        let groups = &hzb.level_groups.as_ref().expect("made above").1;
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("depth pyramid"),
                timestamp_writes: timer.as_deref_mut().and_then(|t| t.compute_pass("depth pyramid")),
            });
            for (level, (out, bind_group)) in hzb.level_views.iter().zip(groups).enumerate() {
                let step = if level == 0 { first } else { HzbStep::Reduce };
                let Some(pipeline) = pipelines.cached::<HzbFamily>(&step) else { continue };
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, bind_group, &[]);
                let size = out.texture().size();
                let (w, h) = ((size.width >> level).max(1), (size.height >> level).max(1));
                pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
            }
        }
        let args_bytes = self.batch_count as u64 * ARGS_WORDS * 4;
        if self.triangles_active() {
            // With the hidden count and the visible-instance counts after them.
            let bytes = args_bytes + 4 * (1 + self.batch_count as u64);
            encoder.copy_buffer_to_buffer(self.late_triangle_template.buffer(), 0, self.late_args.buffer(), 0, bytes);
        } else if args_bytes > 0 {
            // With the hidden count after them.
            encoder.copy_buffer_to_buffer(self.late_template.buffer(), 0, self.late_args.buffer(), 0, args_bytes + 4);
        }
        let phase = CullPhase::Late.with_triangles(self.triangles_active());
        self.dispatch(encoder, device, pipelines, inputs, phase, timer);
        // Measured only after a frame that also culled by occlusion: its visible set is what the
        // early pass drew, so the pyramid holds what a steady state would.
        if args_bytes > 0 && self.last_occlusion_frame == Some(self.frame.wrapping_sub(1)) {
            self.feedback.record(encoder, self.late_args.buffer(), args_bytes, self.frame, self.item_count);
        }
        self.last_occlusion_frame = Some(self.frame);
    }

    /// For `OcclusionCulling::Auto`, once per frame that could cull by occlusion: whether it
    /// should (see `occlusion_feedback.rs`).
    pub fn occlusion_wanted(&mut self) -> bool {
        self.advisor.wants()
    }

    /// Reads the hidden counts that came back, without waiting, and lets the newest decide.
    pub fn collect_feedback(&mut self, device: &wgpu::Device) {
        if let Some(m) = self.feedback.collect(device) {
            self.advisor.report(m);
        }
    }

    /// After the frame's submission: starts reading back what the frame measured.
    pub fn after_submit(&mut self) {
        self.feedback.after_submit();
    }

    /// The newest measured frame's hidden count (entries in view that occlusion culling left
    /// out) and opaque entries.
    pub fn occlusion_measure(&self) -> Option<OcclusionMeasure> {
        self.feedback.latest()
    }

    fn dispatch(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        device: &wgpu::Device,
        pipelines: &PipelineCache,
        inputs: &CullInputs,
        phase: CullPhase,
        timer: Option<&mut GpuTimer>,
    ) {
        let Some(pipeline) = pipelines.cached::<CullFamily>(&phase) else { return };
        if self.item_count == 0 {
            return;
        }
        let late = phase.occlusion_late();
        let args = if late { self.late_args.buffer() } else { self.args.buffer() };
        let mut buffers = vec![
            inputs.view.clone(),
            inputs.instances.clone(),
            inputs.draw_slots.clone(),
            self.item_batch.buffer().clone(),
            self.batches.buffer().clone(),
            args.clone(),
            self.visible_slots.buffer().clone(),
            self.params.clone(),
        ];
        if phase.occlusion_early() || late {
            buffers.push(self.was_visible.buffer().clone());
        }
        // Bindings 10 to 12 (8 and 9 are occlusion culling's).
        let first_triangle_buffer = buffers.len();
        if phase.triangles() {
            buffers.extend([
                inputs.pool_indices.clone(),
                inputs.pool_vertices.clone(),
                self.triangle_indices.buffer().clone(),
            ]);
        }
        let hzb_view = if late { self.hzb.as_ref().map(|h| h.full_view.clone()) } else { None };
        let stale = self.groups.get(&phase).is_none_or(|(b, v, _)| *b != buffers || *v != hzb_view);
        if stale {
            // Other owners' buffers (instances, draw list, view) and ours grow by replacement.
            let mut entries: Vec<wgpu::BindGroupEntry> = buffers
                .iter()
                .enumerate()
                .map(|(i, b)| {
                    let binding =
                        if i >= first_triangle_buffer { (10 + i - first_triangle_buffer) as u32 } else { i as u32 };
                    wgpu::BindGroupEntry { binding, resource: b.as_entire_binding() }
                })
                .collect();
            if let Some(view) = &hzb_view {
                entries.push(wgpu::BindGroupEntry { binding: 9, resource: wgpu::BindingResource::TextureView(view) });
            }
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("cull"),
                layout: pipelines.family::<CullFamily>().layout(phase),
                entries: &entries,
            });
            self.groups.insert(phase, (buffers, hzb_view, group));
        }
        let bind_group = &self.groups[&phase].2;
        let label = if late { "cull late" } else { "cull" };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: timer.and_then(|t| t.compute_pass(label)),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        let (x, y) =
            dispatch_grid(self.item_count.div_ceil(WORKGROUP), device.limits().max_compute_workgroups_per_dimension);
        pass.dispatch_workgroups(x, y, 1);
    }
}

/// A 2D grid of at least `groups` workgroups within the per-dimension limit.
pub fn dispatch_grid(groups: u32, limit: u32) -> (u32, u32) {
    if groups <= limit {
        (groups.max(1), 1)
    } else {
        let y = groups.div_ceil(limit);
        (groups.div_ceil(y), y)
    }
}

#[cfg(test)]
mod tests;
