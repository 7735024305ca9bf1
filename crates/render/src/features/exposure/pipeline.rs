//! Automatic exposure's pipeline family: the luminance histogram and its average
//! (`exposure.wgsl`).

use crate::pipelines::parts::{self, storage_rw};
use crate::pipelines::{Compiler, PipelineFamily, ShaderDefs};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExposureStep {
    Histogram,
    Average,
}

/// Automatic exposure's compute pipelines: the frame's HDR colour, the histogram (written) and
/// the post parameters (written).
pub struct ExposureFamily {
    pub layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
}

impl ExposureFamily {
    pub fn new(device: &wgpu::Device) -> Self {
        let compute = wgpu::ShaderStages::COMPUTE;
        let layout = parts::bind_group_layout(
            device,
            "automatic exposure",
            &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: compute,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                storage_rw(1, compute),
                storage_rw(2, compute),
            ],
        );
        let pipeline_layout = parts::pipeline_layout(device, "automatic exposure", &[&layout]);
        Self { layout, pipeline_layout }
    }
}

impl PipelineFamily for ExposureFamily {
    type Key = ExposureStep;
    type Pipeline = wgpu::ComputePipeline;
    const NAME: &'static str = "exposure";

    fn shader(&self, _: &ExposureStep) -> (&'static str, ShaderDefs) {
        ("exposure.wgsl", ShaderDefs::default())
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, step: &ExposureStep) -> wgpu::ComputePipeline {
        let entry = match step {
            ExposureStep::Histogram => "build_histogram",
            ExposureStep::Average => "average",
        };
        parts::compute_pipeline(device, &self.pipeline_layout, module, entry, entry)
    }
}
