//! The mip generation pipeline family (`shaders/mipmap.wgsl`): one level of a texture from the
//! level above, as 2×2 means, through views of a format; the texture cache renders its chains
//! with it.

use crate::pipelines::parts::{self, texture, uniform};
use crate::pipelines::{Compiler, PipelineFamily, ShaderDefs};

/// A level's source, loaded texel by texel, and the sRGB decoding table.
pub struct MipmapFamily {
    pub layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
}

impl MipmapFamily {
    pub fn new(device: &wgpu::Device) -> Self {
        let layout =
            parts::bind_group_layout(device, "mipmap", &[texture(0, false), uniform(1, wgpu::ShaderStages::FRAGMENT)]);
        let pipeline_layout = parts::pipeline_layout(device, "mipmap", &[&layout]);
        Self { layout, pipeline_layout }
    }
}

impl PipelineFamily for MipmapFamily {
    /// The format of the views drawn through, and whether the shader converts sRGB itself (the
    /// views are unorm views of an sRGB texture).
    type Key = (wgpu::TextureFormat, bool);
    type Pipeline = wgpu::RenderPipeline;
    const NAME: &'static str = "mipmap";

    fn shader(&self, &(_, shader_srgb): &Self::Key) -> (&'static str, ShaderDefs) {
        ("mipmap.wgsl", ShaderDefs::default().with("SRGB", shader_srgb))
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, &(format, _): &Self::Key) -> wgpu::RenderPipeline {
        parts::fullscreen_pipeline(device, &self.pipeline_layout, module, format, "mipmap")
    }
}
