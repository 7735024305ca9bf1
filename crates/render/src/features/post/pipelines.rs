//! Post-processing's pipeline families: bloom's down- and upsampling (`bloom.wgsl`) and
//! automatic exposure's histogram and average (`exposure.wgsl`), with their layouts.

use crate::gpu::formats::HDR_FORMAT;
use crate::pipelines::parts::{self, storage_rw};
use crate::pipelines::{PipelineFamily, ShaderDefs};

/// A bloom pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BloomStep {
    /// Level 0 from the frame (Karis-weighted).
    DownFirst,
    Down,
    /// Adds a level, tent-filtered, onto the level above.
    Up,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExposureStep {
    Histogram,
    Average,
}

pub struct BloomFamily {
    /// The filtered source each pass reads.
    pub source: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
}

impl BloomFamily {
    pub fn new(device: &wgpu::Device, source: &wgpu::BindGroupLayout) -> Self {
        Self { source: source.clone(), pipeline_layout: parts::pipeline_layout(device, "bloom", &[source]) }
    }
}

impl PipelineFamily for BloomFamily {
    type Key = BloomStep;
    type Pipeline = wgpu::RenderPipeline;
    const NAME: &'static str = "bloom";

    fn shader(&self, step: &BloomStep) -> (&'static str, ShaderDefs) {
        ("bloom.wgsl", ShaderDefs::default().with("FIRST", *step == BloomStep::DownFirst))
    }

    fn create(&self, device: &wgpu::Device, module: &wgpu::ShaderModule, step: &BloomStep) -> wgpu::RenderPipeline {
        let up = *step == BloomStep::Up;
        let blend = up.then_some(wgpu::BlendState { color: parts::ADD, alpha: parts::ADD });
        let targets = [Some(wgpu::ColorTargetState { format: HDR_FORMAT, blend, write_mask: wgpu::ColorWrites::ALL })];
        let fragment = if up { "upsample" } else { "downsample" };
        let f = parts::Fullscreen { label: "bloom", fragment, targets: &targets, depth_stencil: None, samples: 1 };
        parts::fullscreen(device, &self.pipeline_layout, module, f)
    }
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

    fn create(&self, device: &wgpu::Device, module: &wgpu::ShaderModule, step: &ExposureStep) -> wgpu::ComputePipeline {
        let entry = match step {
            ExposureStep::Histogram => "build_histogram",
            ExposureStep::Average => "average",
        };
        parts::compute_pipeline(device, &self.pipeline_layout, module, entry, entry)
    }
}
