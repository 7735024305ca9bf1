//! The mesh pool: every mesh's vertices and indices live in one vertex megabuffer and one index
//! megabuffer, so switching meshes between draws costs no buffer rebinding.
//!
//! - Layout: the pool alone decides it. Importers hand over parallel arrays (`Mesh`); `upload`
//!   interleaves them into [`GpuVertex`] (64 bytes) and writes them into ranges handed out by a
//!   first-fit range allocator (`range-alloc`), one for vertices, one for indices.
//! - Growth: when a range does not fit, the buffer is replaced by one of twice the size (or the
//!   size needed) and the old contents copied on the GPU; allocations keep their offsets.
//! - Handles: entries are dense [`MeshId`]s with a free list; a mesh asset maps to an entry.
//! - Dedup: entries are keyed by a blake3 hash of their content, so identical meshes (a model
//!   spawned twice, the same primitive in many files) share one entry and one upload.
//! - Eviction: an entry no asset refers to, or one not drawn for `evict_after_frames`, is freed;
//!   an asset whose entry was evicted is uploaded again the next time it is drawn.
//! - Derived entries: a deformed (skinned or morphed) draw gets its own vertex range, written by
//!   the deformation pass (`features::deform`), sharing its source's index range (the draw's base
//!   vertex points at the copy). Their owner frees them; eviction and dedup leave them alone.
//!   The vertex buffer is therefore also a storage buffer.
//! - Lines: a `LineList` mesh is held as quads (`resources::line_quads`), its first vertex (and
//!   its deformed copies' first vertex) at a multiple of four, which the forward vertex shader
//!   reads each corner's opposite endpoint by.

use std::collections::HashMap;
use std::ops::Range;

use bytemuck::{Pod, Zeroable};
use penumbra_engine::Handle;
use penumbra_engine::bounds::Aabb;
use penumbra_engine::mesh::{Mesh, SelfOverlap, Topology};
use range_alloc::RangeAllocator;

use crate::bindings::{GroupBuilder, GroupResources};
use crate::resources::line_quads;
use crate::scene::world::Snapshot;

/// One interleaved vertex. Absent attributes are zero (colour: white).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuVertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub tangent: [f32; 4],
    pub uv0: [f32; 2],
    pub uv1: [f32; 2],
    /// Linear RGBA, unorm16: vertex colours are in [0, 1] by the glTF spec, and 16 bits keep
    /// smooth gradients free of banding.
    pub color: [u16; 4],
}

impl GpuVertex {
    pub const ATTRIBUTES: [wgpu::VertexAttribute; 6] = wgpu::vertex_attr_array![
        0 => Float32x3, 1 => Float32x3, 2 => Float32x4, 3 => Float32x2, 4 => Float32x2, 5 => Unorm16x4
    ];

    pub fn layout() -> wgpu::VertexBufferLayout<'static> {
        wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<GpuVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &Self::ATTRIBUTES,
        }
    }
}

/// Dense id of a pool entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MeshId(pub u32);

#[derive(Debug, Clone)]
pub struct PoolEntry {
    /// In vertices.
    pub vertices: Range<u32>,
    /// In indices; `None` for non-indexed meshes.
    pub indices: Option<Range<u32>>,
    pub topology: Topology,
    pub aabb: Aabb,
    /// Whether its front faces can overlap on screen (a frame drawing only this entry, once,
    /// may then leave out depth; see `Renderer::render`).
    pub self_overlap: SelfOverlap,
    /// Some vertex has a colour other than opaque white: its draws multiply by vertex colour.
    /// Without, the forward shader has no colour to interpolate, which on GPUs that rasterise
    /// small triangles slowly is a sizeable share of a million-cube frame (docs/performance.md,
    /// "Many cubes, hardware raster").
    pub vertex_colors: bool,
    hash: blake3::Hash,
    /// A deformed draw's vertex copy: its index range belongs to the source entry.
    derived: bool,
    /// Number of mesh assets that map to this entry.
    asset_refs: u32,
    last_used_frame: u64,
}

impl PoolEntry {
    /// A deformed draw's vertex copy (see the module doc).
    pub fn is_derived(&self) -> bool {
        self.derived
    }

    /// Vertices the draw consumes.
    pub fn element_count(&self) -> u32 {
        self.indices.as_ref().map_or(self.vertices.len(), |r| r.len()) as u32
    }
}

/// Byte sizes of the pool, for stats and benchmarks.
#[derive(Debug, Clone, Copy, Default)]
pub struct PoolStats {
    pub vertex_capacity_bytes: u64,
    pub index_capacity_bytes: u64,
    pub entries: usize,
    pub bytes_uploaded: u64,
}

pub struct MeshPool {
    vertex_buffer: wgpu::Buffer,
    index_buffer: wgpu::Buffer,
    vertex_alloc: RangeAllocator<u32>,
    index_alloc: RangeAllocator<u32>,
    entries: Vec<Option<PoolEntry>>,
    free_ids: Vec<u32>,
    by_hash: HashMap<blake3::Hash, MeshId>,
    by_asset: HashMap<Handle<Mesh>, (u64, MeshId)>,
    pub evict_after_frames: u64,
    stats: PoolStats,
    /// Incremented whenever the vertex buffer is replaced (bind groups holding it are stale).
    vertex_generation: u64,
    /// Vertices the forward shader can read as storage (the device's largest storage binding):
    /// line quads find their opposite endpoints there.
    readable_vertices: u32,
    /// A line entry lay beyond `readable_vertices` (warned once).
    warned_unreadable_lines: bool,
}

const VERTEX_SIZE: u64 = std::mem::size_of::<GpuVertex>() as u64;
/// Vertex-buffer usage: drawn from, and written by the deformation pass.
const VERTEX_USAGE: wgpu::BufferUsages = wgpu::BufferUsages::VERTEX.union(wgpu::BufferUsages::STORAGE);
const INDEX_SIZE: u64 = 4;
/// Index-buffer usage: drawn from, and read by triangle culling (`shaders/cull.wgsl`).
const INDEX_USAGE: wgpu::BufferUsages = wgpu::BufferUsages::INDEX.union(wgpu::BufferUsages::STORAGE);

fn create_buffer(device: &wgpu::Device, label: &str, bytes: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes,
        usage: usage | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

impl MeshPool {
    /// Initial capacities: 64 Ki vertices (4 MiB) and 256 Ki indices (1 MiB), enough for most
    /// single models without growing.
    pub fn new(device: &wgpu::Device) -> Self {
        let (v, i) = (64 * 1024u32, 256 * 1024u32);
        Self {
            vertex_buffer: create_buffer(device, "mesh pool vertices", v as u64 * VERTEX_SIZE, VERTEX_USAGE),
            index_buffer: create_buffer(device, "mesh pool indices", i as u64 * INDEX_SIZE, INDEX_USAGE),
            vertex_alloc: RangeAllocator::new(0..v),
            index_alloc: RangeAllocator::new(0..i),
            entries: Vec::new(),
            free_ids: Vec::new(),
            by_hash: HashMap::new(),
            by_asset: HashMap::new(),
            // Five seconds at 60 Hz: long enough that toggling an object's visibility does not
            // re-upload it, short enough that a streamed-out model's memory comes back.
            evict_after_frames: 300,
            stats: PoolStats::default(),
            vertex_generation: 0,
            readable_vertices: (device.limits().max_storage_buffer_binding_size / VERTEX_SIZE).min(u32::MAX as u64)
                as u32,
            warned_unreadable_lines: false,
        }
    }

    /// The part of the vertex buffer the forward shader binds for reading (see
    /// `readable_vertices`).
    pub fn readable_vertex_bytes(&self) -> u64 {
        self.vertex_buffer.size().min(self.readable_vertices as u64 * VERTEX_SIZE)
    }

    pub fn vertex_buffer(&self) -> &wgpu::Buffer {
        &self.vertex_buffer
    }

    /// The pool's share of the view group: its vertices, where a line quad's corner finds its
    /// opposite endpoint (`line_quads`) and a triangle-culled draw pulls its vertices.
    pub fn declare_view(b: &mut GroupBuilder) {
        let vc = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::COMPUTE;
        b.buffer("pool_vertices", vc, wgpu::BufferBindingType::Storage { read_only: true });
    }

    pub fn view_resources<'a>(&'a self, r: &mut GroupResources<'a>) {
        // At most the largest storage binding the device allows.
        let binding = wgpu::BufferBinding {
            buffer: self.vertex_buffer(),
            offset: 0,
            size: std::num::NonZeroU64::new(self.readable_vertex_bytes()),
        };
        r.add("pool_vertices", wgpu::BindingResource::Buffer(binding));
    }
    pub fn index_buffer(&self) -> &wgpu::Buffer {
        &self.index_buffer
    }
    /// Moves whenever `vertex_buffer()` is a new buffer.
    pub fn vertex_generation(&self) -> u64 {
        self.vertex_generation
    }
    pub fn entry(&self, id: MeshId) -> Option<&PoolEntry> {
        self.entries.get(id.0 as usize).and_then(Option::as_ref)
    }
    pub fn stats(&self) -> PoolStats {
        PoolStats {
            vertex_capacity_bytes: self.vertex_buffer.size(),
            index_capacity_bytes: self.index_buffer.size(),
            entries: self.entries.iter().filter(|e| e.is_some()).count(),
            ..self.stats
        }
    }

    /// The entry for `handle` at `version`, uploading (or finding an identical entry) if needed.
    pub fn get_or_upload(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        handle: Handle<Mesh>,
        snapshot: &Snapshot<Mesh>,
        frame: u64,
    ) -> MeshId {
        let (version, mesh) = (snapshot.version, snapshot.data.as_ref());
        if let Some(&(v, id)) = self.by_asset.get(&handle) {
            if v == version && self.entry(id).is_some() {
                self.touch(id, frame);
                return id;
            }
            self.release_asset(handle);
        }
        let hash = content_hash(mesh);
        let id = match self.by_hash.get(&hash) {
            Some(&id) => id,
            None => self.upload(device, queue, mesh, hash, frame),
        };
        if let Some(e) = self.entries[id.0 as usize].as_mut() {
            e.asset_refs += 1;
        }
        self.by_asset.insert(handle, (version, id));
        self.touch(id, frame);
        id
    }

    fn touch(&mut self, id: MeshId, frame: u64) {
        if let Some(e) = self.entries[id.0 as usize].as_mut() {
            e.last_used_frame = frame;
        }
    }

    /// The mesh asset is gone (or changed): its entry loses a reference.
    pub fn release_asset(&mut self, handle: Handle<Mesh>) {
        if let Some((_, id)) = self.by_asset.remove(&handle)
            && let Some(e) = self.entries[id.0 as usize].as_mut()
        {
            e.asset_refs = e.asset_refs.saturating_sub(1);
        }
    }

    /// Releases every asset for which `live` is false.
    pub fn retain_assets(&mut self, live: impl Fn(Handle<Mesh>) -> bool) {
        let dead: Vec<Handle<Mesh>> = self.by_asset.keys().copied().filter(|h| !live(*h)).collect();
        for h in dead {
            self.release_asset(h);
        }
    }

    /// Frees entries no asset refers to and entries not drawn for `evict_after_frames`.
    pub fn evict(&mut self, frame: u64) -> usize {
        let mut freed = 0;
        for i in 0..self.entries.len() {
            let stale = match &self.entries[i] {
                Some(e) if e.derived => false,
                Some(e) => e.asset_refs == 0 || frame.saturating_sub(e.last_used_frame) > self.evict_after_frames,
                None => false,
            };
            if stale {
                let e = self.entries[i].take().expect("checked");
                // An empty mesh holds one element of each (ranges cannot be empty).
                self.vertex_alloc.free_range(at_least_one(e.vertices));
                if let Some(r) = e.indices {
                    self.index_alloc.free_range(at_least_one(r));
                }
                self.by_hash.remove(&e.hash);
                self.by_asset.retain(|_, (_, id)| id.0 as usize != i);
                self.free_ids.push(i as u32);
                freed += 1;
            }
        }
        freed
    }

    /// A vertex range the size of `source`'s for a deformed draw, drawn with `source`'s indices.
    /// Its contents are undefined until the deformation pass writes them.
    pub fn allocate_derived(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, source: MeshId) -> Option<MeshId> {
        let src = self.entry(source)?.clone();
        let count = src.vertices.len() as u32;
        let range = self.allocate_vertices(device, queue, count.max(1), alignment(src.topology));
        // A pose can bend any shape.
        let entry = PoolEntry {
            vertices: range.start..range.start + count,
            derived: true,
            asset_refs: 0,
            self_overlap: SelfOverlap::Possible,
            ..src
        };
        Some(self.insert_entry(entry))
    }

    /// Frees a derived entry (other entries are freed by eviction).
    pub fn free_derived(&mut self, id: MeshId) {
        if let Some(e) = self.entries.get_mut(id.0 as usize)
            && e.as_ref().is_some_and(|e| e.derived)
        {
            let e = e.take().expect("checked");
            self.vertex_alloc.free_range(at_least_one(e.vertices));
            self.free_ids.push(id.0);
        }
    }

    /// A derived entry's bounds, which follow its pose.
    pub fn set_derived_aabb(&mut self, id: MeshId, aabb: Aabb) {
        if let Some(Some(e)) = self.entries.get_mut(id.0 as usize)
            && e.derived
        {
            e.aabb = aabb;
        }
    }

    fn insert_entry(&mut self, entry: PoolEntry) -> MeshId {
        match self.free_ids.pop() {
            Some(i) => {
                self.entries[i as usize] = Some(entry);
                MeshId(i)
            }
            None => {
                self.entries.push(Some(entry));
                MeshId(self.entries.len() as u32 - 1)
            }
        }
    }

    fn upload(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        mesh: &Mesh,
        hash: blake3::Hash,
        frame: u64,
    ) -> MeshId {
        let quads = line_quads::expand(mesh);
        let mesh = quads.as_ref().unwrap_or(mesh);
        let vertices = interleave(mesh);
        let vcount = vertices.len() as u32;
        let vrange = self.allocate_vertices(device, queue, vcount.max(1), alignment(mesh.topology));
        queue.write_buffer(&self.vertex_buffer, vrange.start as u64 * VERTEX_SIZE, bytemuck::cast_slice(&vertices));
        self.stats.bytes_uploaded += vertices.len() as u64 * VERTEX_SIZE;
        let irange = mesh.indices.as_ref().map(|indices| {
            let r = self.allocate(device, queue, false, (indices.len() as u32).max(1));
            queue.write_buffer(&self.index_buffer, r.start as u64 * INDEX_SIZE, bytemuck::cast_slice(indices));
            self.stats.bytes_uploaded += indices.len() as u64 * INDEX_SIZE;
            r.start..r.start + indices.len() as u32
        });
        let entry = PoolEntry {
            vertices: vrange.start..vrange.start + vcount,
            indices: irange,
            topology: mesh.topology,
            aabb: mesh.aabb(),
            self_overlap: mesh.self_overlap(),
            vertex_colors: vertices.iter().any(|v| v.color != [u16::MAX; 4]),
            hash,
            derived: false,
            asset_refs: 0,
            last_used_frame: frame,
        };
        let id = self.insert_entry(entry);
        self.by_hash.insert(hash, id);
        id
    }

    /// A range of `len` vertices starting at a multiple of `align`: over-allocates by
    /// `align - 1` and returns the unused head and tail to the allocator.
    fn allocate_vertices(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, len: u32, align: u32) -> Range<u32> {
        let r = self.allocate(device, queue, true, len + align - 1);
        let (start, unused) = align_within(r, len, align);
        for unused in unused.into_iter().filter(|u| !u.is_empty()) {
            self.vertex_alloc.free_range(unused);
        }
        if align == line_quads::VERTEX_ALIGNMENT
            && start + len > self.readable_vertices
            && !self.warned_unreadable_lines
        {
            self.warned_unreadable_lines = true;
            tracing::warn!(
                "a line mesh lies beyond the first {} vertices of the mesh pool, the most this adapter binds for \
                 reading in a shader: its segments cannot find their other ends and are not drawn",
                self.readable_vertices
            );
        }
        start..start + len
    }

    /// A range of `len` elements, growing the buffer when it does not fit.
    fn allocate(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, vertex: bool, len: u32) -> Range<u32> {
        let (alloc, buffer, elem, label, usage) = if vertex {
            (&mut self.vertex_alloc, &mut self.vertex_buffer, VERTEX_SIZE, "mesh pool vertices", VERTEX_USAGE)
        } else {
            (&mut self.index_alloc, &mut self.index_buffer, INDEX_SIZE, "mesh pool indices", INDEX_USAGE)
        };
        if let Ok(r) = alloc.allocate_range(len) {
            return r;
        }
        let old_end = alloc.initial_range().end;
        let new_end = old_end.saturating_mul(2).max(old_end.saturating_add(len));
        let new_buffer = create_buffer(device, label, new_end as u64 * elem, usage);
        // The copy is submitted on its own, now: `queue.write_buffer` data is applied at the start
        // of the next submission, so writes already made to the old buffer land before this copy
        // and writes made to the new one after growing land after it. Encoded into the frame's
        // encoder instead, the copy would run after the new writes and overwrite them.
        let mut copy = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
        copy.copy_buffer_to_buffer(buffer, 0, &new_buffer, 0, old_end as u64 * elem);
        queue.submit([copy.finish()]);
        *buffer = new_buffer;
        alloc.grow_to(new_end);
        if vertex {
            self.vertex_generation += 1;
        }
        tracing::debug!("{label}: grew to {new_end} elements");
        alloc.allocate_range(len).expect("grown to fit")
    }
}

/// Where `len` elements aligned to `align` start within `r` (which holds `len + align - 1`),
/// and the parts of `r` before and after them.
fn align_within(r: Range<u32>, len: u32, align: u32) -> (u32, [Range<u32>; 2]) {
    let start = r.start.next_multiple_of(align);
    (start, [r.start..start, start + len..r.end])
}

/// The range an entry's allocation covers: its own, or one element for an empty one.
fn at_least_one(r: Range<u32>) -> Range<u32> {
    r.start..r.end.max(r.start + 1)
}

/// Where an entry of this topology may start in the vertex buffer.
fn alignment(topology: Topology) -> u32 {
    if topology == Topology::LineList { line_quads::VERTEX_ALIGNMENT } else { 1 }
}

fn content_hash(mesh: &Mesh) -> blake3::Hash {
    let mut h = blake3::Hasher::new();
    h.update(&[mesh.topology as u8]);
    let mut field = |bytes: &[u8]| {
        h.update(&(bytes.len() as u64).to_le_bytes());
        h.update(bytes);
    };
    field(bytemuck::cast_slice(&mesh.positions));
    field(bytemuck::cast_slice(&mesh.normals));
    field(bytemuck::cast_slice(&mesh.tangents));
    field(bytemuck::cast_slice(&mesh.uv0));
    field(bytemuck::cast_slice(&mesh.uv1));
    field(bytemuck::cast_slice(&mesh.colors));
    match &mesh.indices {
        Some(i) => field(bytemuck::cast_slice(i)),
        None => field(b"non-indexed"),
    }
    h.finalize()
}

fn interleave(mesh: &Mesh) -> Vec<GpuVertex> {
    let unorm16 = |x: f32| (x.clamp(0.0, 1.0) * 65535.0).round() as u16;
    (0..mesh.positions.len())
        .map(|i| GpuVertex {
            position: mesh.positions[i].into(),
            normal: mesh.normals.get(i).copied().unwrap_or_default().into(),
            tangent: mesh.tangents.get(i).copied().unwrap_or_default().into(),
            uv0: mesh.uv0.get(i).copied().unwrap_or_default().into(),
            uv1: mesh.uv1.get(i).copied().unwrap_or_default().into(),
            color: mesh.colors.get(i).map_or([u16::MAX; 4], |c| c.to_array().map(unorm16)),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_aligned_range_starts_at_a_multiple_and_returns_the_rest() {
        for start in 0..9u32 {
            for len in 1..6u32 {
                let r = start..start + len + 3;
                let (at, [head, tail]) = align_within(r.clone(), len, 4);
                assert_eq!(at % 4, 0);
                assert!(at >= r.start && at + len <= r.end, "{r:?} {len}: {at}");
                assert_eq!((head.start, head.end, tail.start, tail.end), (r.start, at, at + len, r.end));
            }
        }
        assert_eq!(at_least_one(5..5), 5..6);
        assert_eq!(at_least_one(5..9), 5..9);
    }

    #[test]
    fn gpu_vertex_is_64_bytes() {
        assert_eq!(std::mem::size_of::<GpuVertex>(), 64);
    }

    #[test]
    fn identical_content_hashes_equal_and_any_change_differs() {
        let a = Mesh::uv_sphere(1.0, 8, 4);
        let mut b = a.clone();
        assert_eq!(content_hash(&a), content_hash(&b));
        b.uv0[3].x += 1e-6;
        assert_ne!(content_hash(&a), content_hash(&b));
        let mut c = a.clone();
        c.indices = None;
        assert_ne!(content_hash(&a), content_hash(&c));
    }
}
