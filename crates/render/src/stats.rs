//! What the renderer reports about its frames: what the last frame did ([`FrameStats`]) and the
//! GPU memory its pools hold ([`MemoryStats`]), for the viewer's Stats panel and the benchmarks.

use crate::frame::FramePlan;
use crate::gpu::timing::FrameTimings;

/// What the last frame did, for stats panels and benchmarks.
#[derive(Debug, Clone, Default)]
pub struct FrameStats {
    pub frame: u64,
    pub draw_calls: u32,
    pub instances: u32,
    pub primitives: u64,
    /// Lights in the store (global + local).
    pub lights: u32,
    /// Of which local (every kind but directional and ambient), binned into clusters when binning runs.
    pub local_lights: u32,
    /// Upper bound of the cluster lists' total length that sized the index buffer (0 without
    /// binning).
    pub cluster_index_bound: u64,
    pub light_bytes_uploaded: u64,
    pub instance_bytes_uploaded: u64,
    /// CPU time of the whole frame on this thread up to submission: prepare + encode.
    pub cpu_ms: f64,
    /// Of `cpu_ms`, syncing the render world's retained state and uploading what changed.
    pub prepare_ms: f64,
    /// Of `prepare_ms`, handing changed instance records to wgpu (`queue.write_buffer`).
    pub instance_upload_ms: f64,
    /// `queue.submit` alone (outside `cpu_ms`: a driver busy with earlier frames may block it).
    pub submit_ms: f64,
    /// GPU time per pass of the newest frame the GPU has finished (timing enabled only).
    pub gpu: Option<FrameTimings>,
    pub plan: FramePlan,
    /// Forward pipelines in the cache.
    pub pipelines: usize,
    /// Pipelines compiled since start-up.
    pub pipelines_compiled: usize,
    /// Shader library generation: incremented by every successful hot reload.
    pub shader_generation: u64,
    /// Environment prefilter chains run since start-up (one per environment change).
    pub environment_prefilters: u64,
}

impl FrameStats {
    pub fn gpu_total_ms(&self) -> Option<f64> {
        self.gpu.as_ref().map(|t| t.passes.iter().map(|(_, ms)| ms).sum())
    }
}

/// Memory held by the main GPU pools, in bytes.
#[derive(Debug, Clone, Copy, Default)]
pub struct MemoryStats {
    pub mesh_pool: u64,
    pub textures: u64,
    /// What the textures would take as RGBA8 with full mip chains (`textures` less this is what
    /// block-compressed KTX2 textures saved).
    pub textures_rgba8: u64,
    /// Instances and draw lists: the draw list, the view's and the shadow maps' culled lists and
    /// indirect arguments, the visibility buffer's batch tables.
    pub instances: u64,
    pub targets: u64,
    pub lights: u64,
    /// Cluster grid, counts, ranges and index lists.
    pub clusters: u64,
    /// The shadow atlas (0 while no light casts).
    pub shadows: u64,
    /// The environment's cubes and split-sum table (0 without an environment).
    pub environment: u64,
    /// Bloom's chain and FXAA's intermediate (0 with both off).
    pub post: u64,
    /// Skinning and morph-target data (deformed vertex copies count in `mesh_pool`).
    pub deform: u64,
}

impl MemoryStats {
    /// Every pool together.
    pub fn total(&self) -> u64 {
        self.mesh_pool
            + self.textures
            + self.instances
            + self.targets
            + self.lights
            + self.clusters
            + self.shadows
            + self.environment
            + self.post
            + self.deform
    }
}
