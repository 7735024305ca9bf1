//! Tonemap pass: one full-screen triangle from the resolved HDR target (with bloom and
//! automatic exposure when on, see `post.rs`, which owns its inputs) into the output.

use crate::pipelines::pipeline_cache::{PipelineCache, TonemapKey};
use crate::pipelines::shader_library::ShaderError;
use crate::timing::GpuTimer;

/// Where the tonemapped frame goes.
pub struct Output<'a> {
    pub view: &'a wgpu::TextureView,
    pub format: wgpu::TextureFormat,
}

pub fn encode(
    encoder: &mut wgpu::CommandEncoder,
    device: &wgpu::Device,
    pipelines: &mut PipelineCache,
    inputs: &wgpu::BindGroup,
    key: TonemapKey,
    output: Output,
    timer: Option<&mut GpuTimer>,
) -> Result<(), ShaderError> {
    let pipeline = pipelines.tonemap(device, key)?;
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("tonemap"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: output.view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: timer.and_then(|t| t.pass("tonemap")),
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, inputs, &[]);
    pass.draw(0..3, 0..1);
    Ok(())
}
