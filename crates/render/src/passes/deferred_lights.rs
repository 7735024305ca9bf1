//! Deferred local lights: the compute pass that shades local lights for opaque surfaces (see
//! `shaders/deferred_lights.wgsl` for why, and how samples are handled).
//!
//! Data flow: the forward pass's opaque batches write colour from global lights and emission,
//! plus each sample's surface (`targets.deferred`); this pass reads those, the depth and the
//! cluster lists, and writes local light per pixel; the forward pass's second half
//! (`forward::encode_after_deferred`) adds it into every sample and draws blended batches, which
//! shade their own local lights.

use bytemuck::{Pod, Zeroable};
use glam::Mat4;

use crate::pipelines::pipeline_cache::{DeferredKey, PipelineCache};
use crate::pipelines::shader_library::ShaderError;
use crate::targets::FrameTargets;
use crate::timing::GpuTimer;

/// Mirrors `DeferredParams` in `deferred_lights.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuDeferredParams {
    pub rel_from_clip: [[f32; 4]; 4],
    pub viewport: [f32; 2],
    pub _pad: [f32; 2],
}

impl GpuDeferredParams {
    pub fn new(clip_from_rel: Mat4, size: (u32, u32)) -> Self {
        Self {
            rel_from_clip: clip_from_rel.inverse().to_cols_array_2d(),
            viewport: [size.0 as f32, size.1 as f32],
            _pad: [0.0; 2],
        }
    }
}

pub fn params_buffer(device: &wgpu::Device) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("deferred lights params"),
        size: std::mem::size_of::<GpuDeferredParams>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Encodes the pass; nothing without deferred targets.
pub fn encode(
    encoder: &mut wgpu::CommandEncoder,
    device: &wgpu::Device,
    pipelines: &mut PipelineCache,
    targets: &FrameTargets,
    view_bind_group: &wgpu::BindGroup,
    key: DeferredKey,
    timer: Option<&mut GpuTimer>,
) -> Result<(), ShaderError> {
    let Some(deferred) = targets.deferred.as_ref() else { return Ok(()) };
    let pipeline = pipelines.deferred(device, key)?;
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some("deferred lights"),
        timestamp_writes: timer.and_then(|t| t.compute_pass("deferred lights")),
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, view_bind_group, &[]);
    pass.set_bind_group(1, &deferred.compute_bind_group, &[]);
    pass.dispatch_workgroups(targets.size.0.div_ceil(8), targets.size.1.div_ceil(8), 1);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gpu_deferred_params_mirror_the_shaders_parameters() {
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuDeferredParams,
            "deferred_lights.wgsl",
            ["LOCAL_LIGHTS", "CLUSTERED_LIGHTS"],
            "DeferredParams",
            [rel_from_clip, viewport]
        );
    }
}
