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
//! No CPU work per draw per frame, and nothing read back. Within a batch, visible instances are
//! drawn in the order the GPU appended them, which varies: only coplanar, overlapping instances
//! of one batch could tell (depth ties). Shadow passes keep drawing the full list: a caster
//! outside the view still casts into it.
//!
//! Needs indirect draws with a first instance (`Features::INDIRECT_FIRST_INSTANCE`); without it
//! (GL, some mobile GPUs) the renderer draws the full list directly, as with culling off.

use bytemuck::{Pod, Zeroable};

use crate::passes::forward::Batch;
use crate::pipelines::pipeline_cache::PipelineCache;
use crate::pipelines::shader_library::ShaderError;
use crate::prepare::buffer::GrowableBuffer;
use crate::prepare::mesh_pool::MeshPool;
use crate::readback::{self, ReadbackError};
use crate::timing::GpuTimer;

/// Words of indirect arguments per batch (`DrawIndexedIndirectArgs`).
pub const ARGS_WORDS: u64 = 5;
const WORKGROUP: u32 = 64;

/// Mirrors `struct CullBatch` in `shaders/cull.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GpuCullBatch {
    center: [f32; 3],
    first: u32,
    half_extent: [f32; 3],
    _pad: u32,
}

/// The buffers the cull pass reads that other owners hold.
pub struct CullInputs<'a> {
    pub view: &'a wgpu::Buffer,
    pub instances: &'a wgpu::Buffer,
    pub draw_slots: &'a wgpu::Buffer,
    /// Entries of the draw list after the culled ones (blended draws), copied as they are.
    pub blended: std::ops::Range<u32>,
}

pub struct GpuCulling {
    item_batch: GrowableBuffer,
    batches: GrowableBuffer,
    args_template: GrowableBuffer,
    args: GrowableBuffer,
    visible_slots: GrowableBuffer,
    params: wgpu::Buffer,
    item_count: u32,
    batch_count: u32,
}

impl GpuCulling {
    pub fn new(device: &wgpu::Device) -> Self {
        use wgpu::BufferUsages as U;
        Self {
            item_batch: GrowableBuffer::new(device, "cull item batches", U::STORAGE, 256),
            batches: GrowableBuffer::new(device, "cull batches", U::STORAGE, 256),
            args_template: GrowableBuffer::new(device, "indirect args template", U::COPY_SRC, 256),
            args: GrowableBuffer::new(device, "indirect args", U::STORAGE | U::INDIRECT | U::COPY_SRC, 256),
            visible_slots: GrowableBuffer::new(device, "visible draw slots", U::STORAGE | U::COPY_SRC, 4096 * 4),
            params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("cull params"),
                size: 16,
                usage: U::UNIFORM | U::COPY_DST,
                mapped_at_creation: false,
            }),
            item_count: 0,
            batch_count: 0,
        }
    }

    /// The indirect arguments, `ARGS_WORDS` words per opaque batch in batch order.
    pub fn args(&self) -> &wgpu::Buffer {
        self.args.buffer()
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
    }

    /// After the batches were rebuilt: what the cull pass needs to know about them. Returns
    /// whether a buffer the forward pass binds was replaced.
    pub fn prepare_batches(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        batches: &[Batch],
        mesh_pool: &MeshPool,
    ) -> bool {
        let mut item_batch = Vec::new();
        let mut gpu_batches = Vec::with_capacity(batches.len());
        let mut template = Vec::with_capacity(batches.len() * ARGS_WORDS as usize);
        for (i, b) in batches.iter().enumerate() {
            item_batch.extend(std::iter::repeat_n(i as u32, b.count as usize));
            let entry = mesh_pool.entry(b.mesh_id);
            let bounds = entry.map(|e| e.aabb).filter(|a| !a.is_empty() && a.min.is_finite() && a.max.is_finite());
            // Without usable bounds a batch is never culled.
            let (center, half_extent) = bounds
                .map_or(([0.0; 3], [f32::MAX / 16.0; 3]), |a| (a.center().to_array(), a.half_extents().to_array()));
            gpu_batches.push(GpuCullBatch { center, first: b.first, half_extent, _pad: 0 });
            let words: [u32; ARGS_WORDS as usize] = match entry {
                Some(e) => match &e.indices {
                    Some(r) => [r.len() as u32, 0, r.start, e.vertices.start, b.first],
                    None => [e.vertices.len() as u32, 0, e.vertices.start, b.first, 0],
                },
                None => [0; ARGS_WORDS as usize],
            };
            template.extend(words);
        }
        self.item_count = item_batch.len() as u32;
        self.batch_count = batches.len() as u32;
        self.item_batch.reserve(device, item_batch.len() as u64 * 4);
        self.batches.reserve(device, std::mem::size_of_val(gpu_batches.as_slice()) as u64);
        self.args_template.reserve(device, template.len() as u64 * 4);
        let grew = self.args.reserve(device, template.len() as u64 * 4);
        for (buffer, bytes) in [
            (&self.item_batch, bytemuck::cast_slice::<u32, u8>(&item_batch)),
            (&self.batches, bytemuck::cast_slice(&gpu_batches)),
            (&self.args_template, bytemuck::cast_slice(&template)),
        ] {
            if !bytes.is_empty() {
                queue.write_buffer(buffer.buffer(), 0, bytes);
            }
        }
        queue.write_buffer(&self.params, 0, bytemuck::cast_slice(&[self.item_count, 0, 0, 0]));
        grew
    }

    /// Makes room for the whole draw list (opaque and blended entries); returns whether
    /// `visible_slots` was replaced.
    pub fn reserve(&mut self, device: &wgpu::Device, draw_list_len: usize) -> bool {
        self.visible_slots.reserve(device, draw_list_len.max(1) as u64 * 4)
    }

    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        device: &wgpu::Device,
        pipelines: &mut PipelineCache,
        inputs: &CullInputs,
        timer: Option<&mut GpuTimer>,
    ) -> Result<(), ShaderError> {
        let pipeline = pipelines.cull(device)?.clone();
        let args_bytes = self.batch_count as u64 * ARGS_WORDS * 4;
        if args_bytes > 0 {
            encoder.copy_buffer_to_buffer(self.args_template.buffer(), 0, self.args.buffer(), 0, args_bytes);
        }
        if !inputs.blended.is_empty() {
            let offset = inputs.blended.start as u64 * 4;
            let size = inputs.blended.len() as u64 * 4;
            encoder.copy_buffer_to_buffer(inputs.draw_slots, offset, self.visible_slots.buffer(), offset, size);
        }
        if self.item_count == 0 {
            return Ok(());
        }
        fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry { binding, resource: buffer.as_entire_binding() }
        }
        // Made per frame (microseconds): the inputs belong to other owners and may be replaced.
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cull"),
            layout: &pipelines.cull_layout,
            entries: &[
                entry(0, inputs.view),
                entry(1, inputs.instances),
                entry(2, inputs.draw_slots),
                entry(3, self.item_batch.buffer()),
                entry(4, self.batches.buffer()),
                entry(5, self.args.buffer()),
                entry(6, self.visible_slots.buffer()),
                entry(7, &self.params),
            ],
        });
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("cull"),
            timestamp_writes: timer.and_then(|t| t.compute_pass("cull")),
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        let (x, y) =
            dispatch_grid(self.item_count.div_ceil(WORKGROUP), device.limits().max_compute_workgroups_per_dimension);
        pass.dispatch_workgroups(x, y, 1);
        Ok(())
    }

    /// Instances each opaque batch drew in the last culled frame (reads back; tests and tools).
    pub fn read_visible_counts(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Vec<u32>, ReadbackError> {
        if self.batch_count == 0 {
            return Ok(Vec::new());
        }
        let bytes = readback::read_buffer(device, queue, self.args.buffer(), self.batch_count as u64 * ARGS_WORDS * 4)?;
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
        Ok(words.chunks_exact(ARGS_WORDS as usize).map(|w| w[1]).collect())
    }
}

/// A 2D grid of at least `groups` workgroups within the per-dimension limit.
fn dispatch_grid(groups: u32, limit: u32) -> (u32, u32) {
    if groups <= limit {
        (groups.max(1), 1)
    } else {
        let y = groups.div_ceil(limit);
        (groups.div_ceil(y), y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_dispatch_grid_covers_every_group_within_the_limit() {
        for (groups, limit) in [(1, 65535), (65535, 65535), (65536, 65535), (1 << 24, 65535), (9, 3), (7, 3)] {
            let (x, y) = dispatch_grid(groups, limit);
            assert!(x <= limit && y <= limit, "{groups}: {x}x{y}");
            assert!(x * y >= groups, "{groups}: {x}x{y}");
        }
    }
}
