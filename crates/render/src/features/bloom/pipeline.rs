//! Bloom's pipeline family: down- and upsampling (`bloom.wgsl`) into the HDR mip chain.

use crate::gpu::formats::HDR_FORMAT;
use crate::pipelines::parts;
use crate::pipelines::{Compiler, PipelineFamily, ShaderDefs};

/// A bloom pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BloomStep {
    /// Level 0 from the frame (Karis-weighted).
    DownFirst,
    Down,
    /// Adds a level, tent-filtered, onto the level above.
    Up,
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

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, step: &BloomStep) -> wgpu::RenderPipeline {
        let up = *step == BloomStep::Up;
        let blend = up.then_some(wgpu::BlendState { color: parts::ADD, alpha: parts::ADD });
        let targets = [Some(wgpu::ColorTargetState { format: HDR_FORMAT, blend, write_mask: wgpu::ColorWrites::ALL })];
        let fragment = if up { "upsample" } else { "downsample" };
        let f = parts::Fullscreen { label: "bloom", fragment, targets: &targets, depth_stencil: None, samples: 1 };
        parts::fullscreen(device, &self.pipeline_layout, module, f)
    }
}
