//! The deformation pipeline family (`shaders/deform.wgsl`): skinning and morph targets into the
//! mesh pool, one compute pipeline, with its bind group layout in `deform.wgsl`'s binding
//! order: the pool's vertices (read and written), jobs, source data, joint matrix rows, morph
//! weights, parameters.

use crate::pipelines::parts::{self, storage, storage_rw, uniform};
use crate::pipelines::{Compiler, PipelineFamily, ShaderDefs};

pub struct DeformFamily {
    pub layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
}

impl DeformFamily {
    pub fn new(device: &wgpu::Device) -> Self {
        let compute = wgpu::ShaderStages::COMPUTE;
        let layout = parts::bind_group_layout(
            device,
            "deform",
            &[
                storage_rw(0, compute),
                storage(1, compute),
                storage(2, compute),
                storage(3, compute),
                storage(4, compute),
                uniform(5, compute),
            ],
        );
        let pipeline_layout = parts::pipeline_layout(device, "deform", &[&layout]);
        Self { layout, pipeline_layout }
    }
}

impl PipelineFamily for DeformFamily {
    type Key = ();
    type Pipeline = wgpu::ComputePipeline;
    const NAME: &'static str = "deform";

    fn shader(&self, _: &()) -> (&'static str, ShaderDefs) {
        ("deform.wgsl", ShaderDefs::default())
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, _: &()) -> wgpu::ComputePipeline {
        parts::compute_pipeline(device, &self.pipeline_layout, module, "deform", "deform")
    }
}
