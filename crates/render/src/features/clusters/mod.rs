//! The cluster binner: the one owner of the froxel grid's GPU buffers and of the binning passes.
//!
//! Each frame with local lights: `prepare` builds the grid from the view and the light store's
//! bounds, sizes the index buffer by a CPU upper bound of the total list length (cached while
//! neither the view nor the lights change), and writes the grid uniform; `encode` records
//! clear → count → prefix sum → fill → sort short runs (queueing long ones, and writing each
//! cluster's range) → sort long runs (an indirect dispatch), all in one compute pass; lists are
//! counted and filled as one run per (cluster, block of lights), see [`LightBlocks`] and
//! `shaders/cluster_bin.wgsl`. The forward pass then reads `grid`, `ranges` (offset, count per
//! cluster) and `indices` (light slots).
//!
//! A scene without local lights calls neither: the buffers stay as created (a few bytes) and
//! are bound only to satisfy the layout; the shader variant without `LOCAL_LIGHTS` never reads
//! them.

pub mod grid;
mod pipeline;
pub mod reference;

pub use pipeline::{ClusterEntry, ClusterFamily};

use grid::{ClusterConfig, ClusterGrid, GpuClusterGrid, LightBlocks};

use crate::bindings::{GroupBuilder, GroupResources};
use crate::frame_context::FrameContext;
use crate::gpu::buffer::GrowableBuffer;
use crate::gpu::context::GpuContext;
use crate::gpu::readback::{self, ReadbackError};
use crate::pipelines::{PipelineCache, ShaderError};
use crate::resources::light_store::LightStore;
use crate::scene::world::ExtractedView;

/// How fragments find the local lights (every kind but directional and ambient) that reach them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LightWalk {
    /// Through cluster lists: in the fragment shader while the lists are short, by the compute
    /// pass of `ClusteredCompute` once they grow long (see [`AUTO_COMPUTE_ENTER`]).
    #[default]
    Auto,
    /// Through the fragment's cluster list, in the fragment shader.
    Clustered,
    /// Every local light for every fragment (windowed by range): the reference that clustered
    /// rendering must equal.
    AllLights,
    /// Every local light with no range window: the reference for the window's error.
    AllUnbounded,
    /// Through the cluster lists, by a compute pass over the opaque surfaces the forward pass
    /// wrote out (blended surfaces still walk their lists in the fragment shader). The same
    /// image as `Clustered`; much faster where fragment shaders run on few units (see
    /// `shaders/deferred_lights.wgsl`).
    ClusteredCompute,
}

/// `LightWalk::Auto` moves local lights to the compute pass when the cluster lists' CPU bound
/// (`ClusterBinner::index_bound`, a few times the lists' real mean length) exceeds this many
/// entries per cluster. Fragment and compute shading both grow about linearly with the lists and
/// cross a little above this bound on an H100 (`penumbra bench many-lights`; docs/performance.md,
/// "Many lights"); the threshold sits below the crossing, since a frame running long in
/// fragments loses more than one running long in compute.
pub const AUTO_COMPUTE_ENTER: f64 = 11.0;
/// Below this bound per cluster, `LightWalk::Auto` goes back to the fragment shader.
pub const AUTO_COMPUTE_LEAVE: f64 = 5.5;

/// Why binning cannot be exact this frame (the renderer then lights every fragment with every
/// local light instead, and says so).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "cluster lists would need up to {needed} MiB, more than this device's storage-buffer limit of {limit} MiB; \
     shading every fragment with every light this frame (slow but exact); use fewer clusters, fewer local lights \
     or smaller light ranges"
)]
pub struct BinningTooLarge {
    pub needed: u64,
    pub limit: u64,
}

pub struct ClusterBinner {
    grid_buffer: wgpu::Buffer,
    /// Per (cluster, block of lights) run: its light count, then (after the prefix sum) its
    /// write cursor.
    runs: GrowableBuffer,
    /// Per-cluster (offset, count) into `indices`.
    ranges: GrowableBuffer,
    indices: GrowableBuffer,
    /// How many runs are too long for `sort_short`, the scan's block totals, then those runs.
    long_lists: GrowableBuffer,
    /// The indirect dispatch of `sort_long`, written by `sort_short` (binding 6).
    long_dispatch: wgpu::Buffer,
    /// Binds in `long_dispatch`'s place for the dispatch it drives: a buffer bound for writing
    /// cannot also hold a dispatch's arguments.
    dispatch_stand_in: wgpu::Buffer,
    /// The binning's buffers; and the same with the stand-in for `long_dispatch`, for `sort_long`.
    bind_group: Option<(wgpu::BindGroup, wgpu::BindGroup)>,
    grid: Option<ClusterGrid>,
    light_count: u32,
    /// (grid, light generation) the cached bound was computed for.
    bound_key: Option<(ClusterGrid, u64)>,
    bound: u64,
    /// CPU time of the last computation of the bound (it is cached while view and lights hold).
    pub last_bound_ms: f64,
}

impl ClusterBinner {
    /// Registers the binning pipeline family.
    pub fn new(device: &wgpu::Device, pipelines: &mut PipelineCache) -> Self {
        pipelines.register(ClusterFamily::new(device));
        let storage = wgpu::BufferUsages::STORAGE;
        Self {
            grid_buffer: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("cluster grid"),
                size: std::mem::size_of::<GpuClusterGrid>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            runs: GrowableBuffer::new(device, "cluster runs", storage, 256),
            ranges: GrowableBuffer::new(device, "cluster ranges", storage | wgpu::BufferUsages::COPY_SRC, 256),
            indices: GrowableBuffer::new(device, "cluster indices", storage | wgpu::BufferUsages::COPY_SRC, 256),
            long_lists: GrowableBuffer::new(device, "cluster long lists", storage | wgpu::BufferUsages::COPY_SRC, 256),
            long_dispatch: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("cluster long-list dispatch"),
                size: 16,
                usage: wgpu::BufferUsages::INDIRECT | storage,
                mapped_at_creation: false,
            }),
            dispatch_stand_in: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("cluster long-list dispatch stand-in"),
                size: 16,
                usage: storage,
                mapped_at_creation: false,
            }),
            bind_group: None,
            grid: None,
            light_count: 0,
            bound_key: None,
            bound: 0,
            last_bound_ms: 0.0,
        }
    }

    pub fn grid_buffer(&self) -> &wgpu::Buffer {
        &self.grid_buffer
    }

    pub fn ranges(&self) -> &wgpu::Buffer {
        self.ranges.buffer()
    }

    pub fn indices(&self) -> &wgpu::Buffer {
        self.indices.buffer()
    }

    /// The binner's share of the view group: the grid, each cluster's range and the lists.
    pub fn declare_view(b: &mut GroupBuilder) {
        let lit = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
        let storage = wgpu::BufferBindingType::Storage { read_only: true };
        b.buffer("grid", lit, wgpu::BufferBindingType::Uniform).buffer("cluster_ranges", lit, storage).buffer(
            "cluster_lights",
            lit,
            storage,
        );
    }

    pub fn view_resources<'a>(&'a self, r: &mut GroupResources<'a>) {
        r.buffer("grid", self.grid_buffer())
            .buffer("cluster_ranges", self.ranges())
            .buffer("cluster_lights", self.indices());
    }

    pub fn gpu_bytes(&self) -> u64 {
        self.grid_buffer.size()
            + self.runs.capacity()
            + self.ranges.capacity()
            + self.indices.capacity()
            + self.long_lists.capacity()
    }

    /// This frame's grid (after `prepare`).
    pub fn grid(&self) -> Option<&ClusterGrid> {
        self.grid.as_ref()
    }

    /// How this frame's lights are split into blocks (after `prepare`).
    pub fn light_blocks(&self) -> LightBlocks {
        LightBlocks::new(self.light_count, self.grid.map_or(1, |g| g.cluster_count()))
    }

    /// The CPU bound on the total list length that sized the index buffer.
    pub fn index_bound(&self) -> u64 {
        self.bound
    }

    /// Sets up this frame's grid and buffers. Returns whether buffers were replaced (the
    /// forward bind group must be rebuilt), or an error when exact lists cannot fit the device.
    pub fn prepare(
        &mut self,
        ctx: &GpuContext,
        pipelines: &PipelineCache,
        view: &ExtractedView,
        viewport: (u32, u32),
        config: ClusterConfig,
        store: &mut LightStore,
    ) -> Result<bool, BinningTooLarge> {
        let (device, queue) = (&ctx.device, &ctx.queue);
        let grid = ClusterGrid::new(view, viewport, config, store.local_bounds());
        let key = (grid, store.local_generation);
        if self.bound_key != Some(key) {
            let t = std::time::Instant::now();
            self.bound = grid.index_bound(store.local_lights());
            self.bound_key = Some(key);
            self.last_bound_ms = t.elapsed().as_secs_f64() * 1e3;
        }
        let limit = device.limits().max_storage_buffer_binding_size;
        let index_bytes = (self.bound.max(1) * 4).next_multiple_of(256);
        if index_bytes > limit {
            return Err(BinningTooLarge { needed: index_bytes >> 20, limit: limit >> 20 });
        }
        let clusters = grid.cluster_count() as u64;
        let blocks = LightBlocks::new(store.local_count(), grid.cluster_count());
        let runs = blocks.runs(grid.cluster_count());
        let run_bytes = (runs * 4).next_multiple_of(256);
        // (Also within u32 words, as the shaders count runs.)
        if run_bytes > limit.min(u32::MAX as u64) {
            return Err(BinningTooLarge { needed: run_bytes >> 20, limit: limit >> 20 });
        }
        self.light_count = store.local_count();
        let mut grew = self.runs.reserve(device, run_bytes);
        // One more, always empty, for fragments in front of the first slice.
        grew |= self.ranges.reserve(device, (clusters + 1) * 8);
        grew |= self.indices.reserve(device, index_bytes);
        // The queue count, the scan's block totals, then the queue: each
        // queued run holds more than SHORT_LIST lights, so the bound limits their number.
        let long_runs = runs.min(self.bound / (SHORT_LIST + 1) + 1);
        grew |= self.long_lists.reserve(device, 4 + (runs.div_ceil(SCAN_BLOCK) + long_runs) * 4);
        let gpu = grid.to_gpu(store.global_count(), self.light_count, blocks);
        queue.write_buffer(&self.grid_buffer, 0, bytemuck::bytes_of(&gpu));
        self.grid = Some(grid);
        if grew || self.bind_group.is_none() {
            self.bind_group = Some((
                self.create_bind_group(device, pipelines, store, &self.long_dispatch),
                self.create_bind_group(device, pipelines, store, &self.dispatch_stand_in),
            ));
        }
        Ok(grew)
    }

    /// The binning bind group also holds the light buffer: call when the store's buffer grew.
    pub fn light_buffer_replaced(&mut self) {
        self.bind_group = None;
    }

    fn create_bind_group(
        &self,
        device: &wgpu::Device,
        pipelines: &PipelineCache,
        store: &LightStore,
        dispatch: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry { binding, resource: buffer.as_entire_binding() }
        }
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cluster binning"),
            layout: &pipelines.family::<ClusterFamily>().layout,
            entries: &[
                entry(0, &self.grid_buffer),
                entry(1, store.buffer()),
                entry(2, self.runs.buffer()),
                entry(3, self.ranges.buffer()),
                entry(4, self.indices.buffer()),
                entry(5, self.long_lists.buffer()),
                entry(6, dispatch),
            ],
        })
    }

    /// Reads the last binned frame's lists back (blocking; for tests and benchmarks): each
    /// cluster's light slots in list order.
    pub fn read_lists(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Vec<Vec<u32>>, ReadbackError> {
        let Some(grid) = &self.grid else { return Ok(Vec::new()) };
        let clusters = grid.cluster_count() as u64;
        let words = |bytes: Vec<u8>| -> Vec<u32> { bytemuck::pod_collect_to_vec(&bytes) };
        let ranges = words(readback::read_buffer(device, queue, self.ranges.buffer(), clusters * 8)?);
        let total = ranges.chunks_exact(2).map(|r| r[0] as u64 + r[1] as u64).max().unwrap_or(0);
        let indices = words(readback::read_buffer(device, queue, self.indices.buffer(), total * 4)?);
        Ok(ranges
            .chunks_exact(2)
            .map(|r| indices.get(r[0] as usize..(r[0] + r[1]) as usize).map_or_else(Vec::new, <[u32]>::to_vec))
            .collect())
    }

    /// Records the binning passes (after `prepare`).
    pub fn encode(&self, cx: &mut FrameContext) -> Result<(), ShaderError> {
        let (encoder, device, pipelines, timer) =
            (&mut *cx.encoder, cx.device, &mut *cx.pipelines, cx.timer.as_deref_mut());
        let (Some(grid), Some((bind_group, sort_long_bind_group))) = (&self.grid, &self.bind_group) else {
            return Ok(());
        };
        pipelines.prepare::<ClusterFamily>(device, ClusterEntry::ALL)?;
        // At most 2²⁰ clusters × 2¹⁶ blocks (LightBlocks): runs fit a u32 where their counters
        // fit a storage buffer (prepare checked).
        let runs = self.light_blocks().runs(grid.cluster_count()) as u32;
        encoder.clear_buffer(self.runs.buffer(), 0, Some(runs as u64 * 4));
        // BIN_LIGHTS lights to a workgroup of 64 threads (they share the lights' candidate
        // clusters).
        let light_groups = self.light_count.div_ceil(BIN_LIGHTS);
        let slices = bin_slices(light_groups);
        let blocks = runs.div_ceil(SCAN_BLOCK as u32);
        let dispatches = [
            (ClusterEntry::Count, light_groups, slices),
            // Blocks of SCAN_BLOCK runs, a workgroup each, then each block's base added.
            (ClusterEntry::ScanBlocks, blocks, 1),
            (ClusterEntry::ScanApply, blocks, 1),
            (ClusterEntry::Fill, light_groups, slices),
            // One invocation per run, 64 to a workgroup.
            (ClusterEntry::SortShort, runs.div_ceil(64), 1),
        ];
        // One compute pass: the dispatches need the same barriers between them as between
        // passes, and a pass of its own for each would add timestamps and a pass boundary per
        // pass, a large share of the binning at a thousand lights.
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(BINNING_PASS),
            timestamp_writes: timer.and_then(|t| t.compute_pass(BINNING_PASS)),
        });
        pass.set_bind_group(0, bind_group, &[]);
        for (entry, groups, slices) in dispatches {
            pass.set_pipeline(pipelines.cached::<ClusterFamily>(&entry).expect("created above"));
            dispatch_1d(&mut pass, groups, slices, device.limits().max_compute_workgroups_per_dimension);
        }
        // One workgroup per run sort_short queued (it is long), sized on the GPU.
        pass.set_bind_group(0, sort_long_bind_group, &[]);
        pass.set_pipeline(pipelines.cached::<ClusterFamily>(&ClusterEntry::SortLong).expect("created above"));
        pass.dispatch_workgroups_indirect(&self.long_dispatch, 0);
        Ok(())
    }
}

/// The binning pass's timer label: counting, scan, fill, sorts of short runs (one invocation
/// each) and of long runs (a workgroup each, an indirect dispatch the short sorts size).
pub const BINNING_PASS: &str = "cluster binning";

/// Lights a workgroup of the count and fill walks takes (`BIN_LIGHTS` in cluster_bin.wgsl). 16
/// rather than 8 counts faster at many lights on the many-lights scene; 32 gains little more
/// there and leaves too few workgroups at a thousand lights.
const BIN_LIGHTS: u32 = 16;

/// Runs a workgroup of the scan takes (`SCAN_THREADS` × `SCAN_ITEMS` in cluster_bin.wgsl).
const SCAN_BLOCK: u64 = 256 * 4;

/// The longest run `sort_short` sorts itself (`SHORT_LIST` in cluster_bin.wgsl).
const SHORT_LIST: u64 = 16;

/// Dispatches at least `groups` workgroups of 64, spilling into y past the per-dimension limit
/// (the shaders flatten the id and skip the surplus).
fn dispatch_1d(pass: &mut wgpu::ComputePass, groups: u32, slices: u32, limit: u32) {
    let x = groups.clamp(1, limit.max(1));
    pass.dispatch_workgroups(x, groups.div_ceil(x).max(1), slices.max(1));
}

/// Workgroups the count and fill walks give each group of BIN_LIGHTS lights (z of their
/// dispatch): enough for about [`BIN_WORKGROUPS`] in all. A few large lights (three area lights
/// reaching across the view: up to 8192 clusters each) otherwise leave one workgroup of 64
/// threads walking all their cells while the rest of the GPU idles; a thousand lights and more
/// fill the GPU with one workgroup per group, as before.
fn bin_slices(light_groups: u32) -> u32 {
    (BIN_WORKGROUPS / light_groups.max(1)).clamp(1, MAX_BIN_SLICES)
}

/// The count and fill walks' target workgroup count: four per multiprocessor of a large GPU
/// (132 on an H100 SXM).
const BIN_WORKGROUPS: u32 = 512;
/// At most this many slices per light group: 64 × 64 threads cover a light touching 4096 cells
/// in one step each.
const MAX_BIN_SLICES: u32 = 64;

#[cfg(test)]
mod tests {
    use super::{BIN_LIGHTS, LightBlocks, SCAN_BLOCK, SHORT_LIST, bin_slices, grid};

    #[test]
    fn few_light_groups_are_split_into_slices_and_many_are_not() {
        assert_eq!(bin_slices(1), 64, "three area lights: 64 workgroups walk their cells");
        assert_eq!(bin_slices(63), 8, "a thousand lights");
        assert_eq!(bin_slices(625), 1, "ten thousand: one workgroup per group, as before");
        assert_eq!(bin_slices(0), 64);
    }
    use crate::pipelines::shader_library::EMBEDDED;

    /// The long-run buffer is sized for one block total per SCAN_BLOCK runs and a queue bounded
    /// through SHORT_LIST, the walks are dispatched for BIN_LIGHTS lights a workgroup, blocks are
    /// capped at the mask's bits, and the CPU twin builds the same candidate boxes: the shader's
    /// constants must be the same.
    #[test]
    fn the_scan_block_and_short_list_are_the_shaders() {
        let (_, source) = EMBEDDED.iter().find(|(file, _)| *file == "cluster_bin.wgsl").expect("embedded");
        assert!(source.contains(&format!("const SCAN_THREADS: u32 = {}u;", SCAN_BLOCK / 4)));
        assert!(source.contains("const SCAN_ITEMS: u32 = 4u;"));
        assert!(source.contains(&format!("const SHORT_LIST: u32 = {SHORT_LIST}u;")));
        assert!(source.contains(&format!("const BIN_LIGHTS: u32 = {BIN_LIGHTS}u;")));
        // The long-run sort's mask holds a bit per light of the largest block.
        assert!(source.contains(&format!("const MASK_WORDS: u32 = {}u;", LightBlocks::MAX_LIGHTS / 32)));
        // The CPU twin's candidate boxes are the GPU walk's.
        for (name, value) in [
            ("CANDIDATE_MARGIN", grid::CANDIDATE_MARGIN),
            ("LOOKUP_SLACK", grid::LOOKUP_SLACK),
            ("NEAR_SIDE_GUARD", grid::NEAR_SIDE_GUARD),
        ] {
            assert!(source.contains(&format!("const {name}: f32 = {value:?};")), "{name}");
        }
        for entry in ["scan_blocks", "scan_apply"] {
            assert!(source.contains(&format!("@workgroup_size({})\nfn {entry}(", SCAN_BLOCK / 4)), "{entry}");
        }
    }
}
