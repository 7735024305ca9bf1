//! The deformation compute pipeline (`shaders/deform.wgsl`): skinning and morph targets into
//! the mesh pool. The part of the pipeline cache that serves `prepare::deform`.

use super::{PipelineCache, buffer_entry, checked_pipeline, compute_pipeline, storage};
use crate::pipelines::shader_library::{ShaderDefs, ShaderError, ShaderLibrary};

pub(super) struct DeformLayouts {
    pub group: wgpu::BindGroupLayout,
    pipeline: wgpu::PipelineLayout,
}

/// In `deform.wgsl`'s binding order: the pool's vertices (read and written), jobs, source
/// data, joint matrix rows, morph weights, parameters.
pub(super) fn deform_layouts(device: &wgpu::Device) -> DeformLayouts {
    let compute = wgpu::ShaderStages::COMPUTE;
    let group = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("deform"),
        entries: &[
            buffer_entry(0, compute, wgpu::BufferBindingType::Storage { read_only: false }),
            storage(1, compute),
            storage(2, compute),
            storage(3, compute),
            storage(4, compute),
            buffer_entry(5, compute, wgpu::BufferBindingType::Uniform),
        ],
    });
    let pipeline = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("deform"),
        bind_group_layouts: &[Some(&group)],
        immediate_size: 0,
    });
    DeformLayouts { group, pipeline }
}

impl PipelineCache {
    pub fn deform_layout(&self) -> &wgpu::BindGroupLayout {
        &self.deform_layouts.group
    }

    /// The deformation pipeline, compiled on first use (scenes without skins or morph targets
    /// never compile it).
    pub fn deform(&mut self, device: &wgpu::Device) -> Result<&wgpu::ComputePipeline, ShaderError> {
        if self.deform.is_none() {
            self.deform = Some(self.create_deform(device, &mut None)?);
        }
        Ok(self.deform.as_ref().expect("just made"))
    }

    pub(super) fn create_deform(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
    ) -> Result<wgpu::ComputePipeline, ShaderError> {
        let module = self.library(candidate).create_module(device, "deform.wgsl", &ShaderDefs::default())?;
        self.compiled += 1;
        checked_pipeline(device, "deform.wgsl", || {
            compute_pipeline(device, &self.deform_layouts.pipeline, &module, "deform", "deform")
        })
    }
}
