//! The frustum-culling compute pipeline (`shaders/cull.wgsl`): the part of the pipeline cache
//! that serves `passes::culling`.

use super::{PipelineCache, buffer_entry, checked_pipeline, storage};
use crate::pipelines::shader_library::{ShaderDefs, ShaderError, ShaderLibrary};

/// The cull pass's bind group layout, in `cull.wgsl`'s binding order: view, instances, draw
/// list, entry → batch, batches, indirect args (written), visible list (written), params.
pub(super) fn cull_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let compute = wgpu::ShaderStages::COMPUTE;
    let read_write = wgpu::BufferBindingType::Storage { read_only: false };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("cull"),
        entries: &[
            buffer_entry(0, compute, wgpu::BufferBindingType::Uniform),
            storage(1, compute),
            storage(2, compute),
            storage(3, compute),
            storage(4, compute),
            buffer_entry(5, compute, read_write),
            buffer_entry(6, compute, read_write),
            buffer_entry(7, compute, wgpu::BufferBindingType::Uniform),
        ],
    })
}

impl PipelineCache {
    /// The cull pipeline, compiled on first use.
    pub fn cull(&mut self, device: &wgpu::Device) -> Result<&wgpu::ComputePipeline, ShaderError> {
        if self.cull.is_none() {
            self.cull = Some(self.create_cull(device, &mut None)?);
        }
        Ok(self.cull.as_ref().expect("just created"))
    }

    pub(super) fn create_cull(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
    ) -> Result<wgpu::ComputePipeline, ShaderError> {
        let module = self.library(candidate).create_module(device, "cull.wgsl", &ShaderDefs::default())?;
        self.compiled += 1;
        checked_pipeline(device, "cull.wgsl", || {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("cull"),
                layout: Some(&self.cull_pipeline_layout),
                module: &module,
                entry_point: Some("cull_instances"),
                compilation_options: Default::default(),
                cache: None,
            })
        })
    }
}
