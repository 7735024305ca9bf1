//! The instance buffer: one 64-byte record per drawable entity (world transform, material slot),
//! retained across frames. Each entity owns a slot for its lifetime (the renderer keeps the slot
//! in its per-entity state); only entities extraction reports as changed are re-packed, and only
//! the span of slots that changed is uploaded.

use std::marker::PhantomData;
use std::sync::atomic::{AtomicU32, Ordering};

use bytemuck::{Pod, Zeroable};
use glam::Affine3A;

use crate::gpu::buffer::GrowableBuffer;

/// Mirrors `struct Instance` in `shaders/forward.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuInstance {
    /// Rows of the 3×4 affine `world_from_local`, translation in the last column.
    pub rows: [[f32; 4]; 3],
    pub material: u32,
    pub flags: u32,
    pub _pad: [u32; 2],
}

impl GpuInstance {
    pub fn new(world_from_local: &Affine3A, material: u32) -> Self {
        let m = world_from_local.matrix3;
        let t = world_from_local.translation;
        Self {
            rows: [
                [m.x_axis.x, m.y_axis.x, m.z_axis.x, t.x],
                [m.x_axis.y, m.y_axis.y, m.z_axis.y, t.y],
                [m.x_axis.z, m.y_axis.z, m.z_axis.z, t.z],
            ],
            material,
            flags: 0,
            _pad: [0; 2],
        }
    }

    /// The placement this record holds.
    pub fn world_from_local(&self) -> Affine3A {
        let r = &self.rows;
        Affine3A::from_cols_array(&[
            r[0][0], r[1][0], r[2][0], r[0][1], r[1][1], r[2][1], r[0][2], r[1][2], r[2][2], r[0][3], r[1][3], r[2][3],
        ])
    }
}

pub struct InstanceBuffer {
    cpu: Vec<GpuInstance>,
    buffer: GrowableBuffer,
    free: Vec<u32>,
    dirty: Option<(u32, u32)>,
    /// Bytes written by the last `upload` (0 when nothing changed).
    pub last_upload_bytes: u64,
}

impl InstanceBuffer {
    pub fn new(device: &wgpu::Device) -> Self {
        Self {
            cpu: Vec::new(),
            buffer: GrowableBuffer::new(device, "instances", wgpu::BufferUsages::STORAGE, 1024 * 64),
            free: Vec::new(),
            dirty: None,
            last_upload_bytes: 0,
        }
    }

    pub fn buffer(&self) -> &wgpu::Buffer {
        self.buffer.buffer()
    }

    fn mark(&mut self, slot: u32) {
        self.dirty = Some(self.dirty.map_or((slot, slot), |(a, b)| (a.min(slot), b.max(slot))));
    }

    /// A slot for a new drawable (a freed one first, so the buffer stays dense), holding
    /// `instance`.
    pub fn allocate(&mut self, instance: GpuInstance) -> u32 {
        let slot = self.free.pop().unwrap_or_else(|| {
            self.cpu.push(GpuInstance::zeroed());
            self.cpu.len() as u32 - 1
        });
        self.write(slot, instance);
        slot
    }

    /// The record a slot holds.
    pub fn get(&self, slot: u32) -> GpuInstance {
        self.cpu[slot as usize]
    }

    /// Rewrites a slot's record; uploaded with the next `upload`.
    pub fn write(&mut self, slot: u32, instance: GpuInstance) {
        self.cpu[slot as usize] = instance;
        self.mark(slot);
    }

    /// Writes records into existing slots from several threads at once (each slot from one);
    /// the buffer stays borrowed, so no slot can be allocated or freed meanwhile.
    pub fn disjoint_writer(&mut self) -> SlotWriter<'_> {
        SlotWriter {
            records: self.cpu.as_mut_ptr(),
            len: self.cpu.len(),
            lowest: AtomicU32::new(u32::MAX),
            highest: AtomicU32::new(0),
            dirty: &mut self.dirty,
            _records: PhantomData,
        }
    }

    pub fn free(&mut self, slot: u32) {
        self.free.push(slot);
    }

    /// Uploads the changed span; returns true when the buffer was replaced (bind groups stale).
    pub fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) -> bool {
        self.last_upload_bytes = 0;
        let size = std::mem::size_of::<GpuInstance>() as u64;
        let grew = self.buffer.reserve(device, self.cpu.len() as u64 * size);
        let span = if grew { (!self.cpu.is_empty()).then(|| (0, self.cpu.len() as u32 - 1)) } else { self.dirty };
        if let Some((a, b)) = span {
            let bytes: &[u8] = bytemuck::cast_slice(&self.cpu[a as usize..=b as usize]);
            write_parallel(queue, self.buffer.buffer(), a as u64 * size, bytes);
            self.last_upload_bytes = bytes.len() as u64;
        }
        self.dirty = None;
        grew
    }
}

/// Uploads of at least this many bytes are copied into wgpu's staging memory on all cores.
const PARALLEL_COPY_MIN: usize = 4 << 20;

/// `queue.write_buffer`, with the copy into staging memory split across the compute threads
/// when it is large: on one core, copying a million moved instances' records was a large share
/// of such a frame's prepare time (docs/performance.md, "Many cubes, hardware raster").
fn write_parallel(queue: &wgpu::Queue, buffer: &wgpu::Buffer, offset: u64, bytes: &[u8]) {
    let size = wgpu::BufferSize::new(bytes.len() as u64);
    let pool = bevy_tasks::ComputeTaskPool::get_or_init(bevy_tasks::TaskPool::default);
    let threads = pool.thread_num();
    let view = size
        .filter(|_| bytes.len() >= PARALLEL_COPY_MIN && threads > 1)
        .and_then(|size| queue.write_buffer_with(buffer, offset, size));
    let Some(mut view) = view else {
        queue.write_buffer(buffer, offset, bytes);
        return;
    };
    let chunk = bytes.len().div_ceil(threads);
    let mut rest = view.slice(..);
    pool.scope(|s| {
        for src in bytes.chunks(chunk) {
            let (dst, tail) = rest.split_at(src.len());
            rest = tail;
            let dst = StagingPart(dst);
            s.spawn(async move {
                let mut dst = dst;
                dst.0.copy_from_slice(src);
            });
        }
    });
    // Dropping the view queues the copy from staging memory into `buffer`.
    drop(view);
}

/// A disjoint part of a staging view, handed to one copying task.
struct StagingPart<'a>(wgpu::WriteOnly<'a, [u8]>);

// SAFETY: a `WriteOnly<[u8]>` is a unique, write-only borrow of bytes, as sendable as `&mut [u8]`;
// wgpu implements `Send` only for sized contents (its impl's implicit `T: Sized` bound).
unsafe impl Send for StagingPart<'_> {}

/// Parallel writes into an [`InstanceBuffer`]'s records (see [`SlotWriter::write`]); the span
/// each task reports with [`SlotWriter::wrote_span`] is marked for upload when the writer is
/// dropped.
pub struct SlotWriter<'a> {
    records: *mut GpuInstance,
    len: usize,
    lowest: AtomicU32,
    highest: AtomicU32,
    dirty: &'a mut Option<(u32, u32)>,
    _records: PhantomData<&'a mut [GpuInstance]>,
}

// SAFETY: each call writes one record, and `write`'s contract keeps calls for the same slot from
// overlapping; the records stay borrowed (and in place) for the writer's lifetime.
unsafe impl Sync for SlotWriter<'_> {}
unsafe impl Send for SlotWriter<'_> {}

impl SlotWriter<'_> {
    /// Writes one slot's record; slots beyond the buffer are ignored.
    ///
    /// # Safety
    /// No other call for the same slot may run at the same time.
    pub unsafe fn write(&self, slot: u32, instance: GpuInstance) {
        if (slot as usize) < self.len {
            // SAFETY: in bounds, the vector cannot move while borrowed, and this slot is
            // written by this call alone (the contract).
            unsafe { self.records.add(slot as usize).write(instance) };
        }
    }

    /// Records that slots `lowest..=highest` were written (once per task: shared atomics
    /// updated per write would serialise the writers).
    pub fn wrote_span(&self, lowest: u32, highest: u32) {
        self.lowest.fetch_min(lowest, Ordering::Relaxed);
        self.highest.fetch_max(highest, Ordering::Relaxed);
    }
}

impl Drop for SlotWriter<'_> {
    fn drop(&mut self) {
        let (lowest, highest) = (*self.lowest.get_mut(), *self.highest.get_mut());
        if lowest <= highest {
            *self.dirty = Some(self.dirty.map_or((lowest, highest), |(a, b)| (a.min(lowest), b.max(highest))));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Quat, Vec3};

    #[test]
    fn rows_reproduce_the_affine_transform() {
        let a = Affine3A::from_scale_rotation_translation(
            Vec3::new(1.0, 2.0, 3.0),
            Quat::from_rotation_z(0.3),
            Vec3::new(4.0, 5.0, 6.0),
        );
        let g = GpuInstance::new(&a, 0);
        let p = Vec3::new(0.5, -1.0, 2.0);
        let by_rows = Vec3::new(
            Vec3::from_slice(&g.rows[0][..3]).dot(p) + g.rows[0][3],
            Vec3::from_slice(&g.rows[1][..3]).dot(p) + g.rows[1][3],
            Vec3::from_slice(&g.rows[2][..3]).dot(p) + g.rows[2][3],
        );
        assert!((by_rows - a.transform_point3(p)).length() < 1e-5);
        assert_eq!(std::mem::size_of::<GpuInstance>(), 64);
    }

    #[test]
    fn gpu_instance_mirrors_the_shaders_instance() {
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuInstance,
            "forward.wgsl",
            [],
            "Instance",
            [rows => "row_x", material, flags]
        );
    }

    #[test]
    fn a_large_upload_copied_on_several_threads_lands_byte_for_byte() {
        let ctx = crate::GpuContext::new_headless(&crate::AdapterRequest::default()).expect(crate::INSTALL_HINT);
        let len = PARALLEL_COPY_MIN + 1_000_004;
        let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("test"),
            size: len as u64 + 16,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let bytes: Vec<u8> = (0..len).map(|i| (i * 7 + i / 251) as u8).collect();
        write_parallel(&ctx.queue, &buffer, 8, &bytes);
        let back = crate::gpu::readback::read_buffer(&ctx.device, &ctx.queue, &buffer, len as u64 + 16).unwrap();
        assert_eq!(&back[..8], [0; 8]);
        assert!(back[8..8 + len] == bytes[..], "the copy is exact");
        assert_eq!(&back[8 + len..], [0; 8]);
    }
}
