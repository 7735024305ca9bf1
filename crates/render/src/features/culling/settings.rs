//! Culling's settings: when occlusion culling and triangle culling run.

/// When occlusion culling runs (it needs GPU culling).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OcclusionCulling {
    Off,
    On,
    /// On where it pays: with at least [`OCCLUSION_AUTO_MIN`] opaque instances, on a GPU, while
    /// it hides at least 1 % of them (measured on the GPU and read back a few frames late; off,
    /// it is tried again for two frames in every 60: `features::culling::occlusion_feedback`). The
    /// depth pyramid, the late cull and the split render pass cost a GPU little; on a CPU
    /// rasteriser (lavapipe) they cost more than hidden objects save there (docs/performance.md,
    /// "Many objects").
    #[default]
    Auto,
}

/// When triangle culling runs (it needs GPU culling).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TriangleCulling {
    Off,
    On,
    /// On a GPU; off on a CPU rasteriser, where the cull pass's work is the rasteriser's own
    /// (its cores do both) and instanced draws skip what covers nothing as cheaply.
    #[default]
    Auto,
}

/// Opaque instances from which `OcclusionCulling::Auto` culls occluded objects.
pub const OCCLUSION_AUTO_MIN: usize = 10_000;
