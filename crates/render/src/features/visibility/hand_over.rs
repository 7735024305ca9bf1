//! A hybrid frame's hand-over from the visibility buffer to the forward pass: the owner of the
//! full-screen pass (`shaders/visibility_hand_over.wgsl`) that writes each sample's depth from
//! the visibility buffer into the frame's depth target and, multisampled, the shaded colour into
//! each sample of the multisampled HDR target. The forward pass then draws what only it
//! rasterises (blended draws, gizmo lines) over them, loading both, and resolves as it would
//! after its own opaque draws; so only those draws pay for the fixed-function pipeline.

use crate::gpu::formats::{DEPTH_FORMAT, HDR_FORMAT};
use crate::pipelines::parts::{self, Fullscreen, storage, uniform};
use crate::pipelines::{Compiler, PipelineFamily, ShaderDefs};

/// The hand-over's pipelines, one per sample count.
pub struct HandOverFamily {
    pub layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
}

impl HandOverFamily {
    pub fn new(device: &wgpu::Device) -> Self {
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let layout = parts::bind_group_layout(
            device,
            "visibility hand-over",
            &[storage(0, fragment), uniform(1, fragment), parts::texture(2, false)],
        );
        let pipeline_layout = parts::pipeline_layout(device, "visibility hand-over", &[&layout]);
        Self { layout, pipeline_layout }
    }
}

impl PipelineFamily for HandOverFamily {
    /// The frame's sample count.
    type Key = u32;
    type Pipeline = wgpu::RenderPipeline;
    const NAME: &'static str = "visibility hand-over";

    fn shader(&self, samples: &u32) -> (&'static str, ShaderDefs) {
        ("visibility_hand_over.wgsl", ShaderDefs::default().with("MULTISAMPLED", *samples > 1))
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, samples: &u32) -> wgpu::RenderPipeline {
        let colour =
            [Some(wgpu::ColorTargetState { format: HDR_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL })];
        let depth = wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Always),
            stencil: Default::default(),
            bias: Default::default(),
        };
        let targets: &[Option<wgpu::ColorTargetState>] = if *samples > 1 { &colour } else { &[] };
        let f = Fullscreen {
            label: "visibility hand-over",
            fragment: "fs_main",
            targets,
            depth_stencil: Some(depth),
            samples: *samples,
        };
        parts::fullscreen(device, &self.pipeline_layout, module, f)
    }
}
