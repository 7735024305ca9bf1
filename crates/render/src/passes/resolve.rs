//! The MSAA resolve as a pass of Penumbra's own, on adapters where the render pass's resolve
//! costs more (`Capabilities::shader_msaa_resolve`; `shaders/resolve.wgsl`). The forward pass
//! then stores its multisampled colour ([`ColorAttachment::shader_resolve`]) and this pass,
//! encoded right after it, writes each pixel's mean into the target the render pass would have
//! resolved into. Its bind group is made per frame: it runs only on CPU rasterisers, where one
//! bind group is nothing beside the frame.

use crate::pipelines::pipeline_cache::PipelineCache;
use crate::pipelines::shader_library::ShaderError;
use crate::targets::ColorAttachment;

/// Resolves `attachment.draw` into `attachment.shader_resolve`, if the frame resolves by shader.
pub fn encode(
    encoder: &mut wgpu::CommandEncoder,
    device: &wgpu::Device,
    pipelines: &mut PipelineCache,
    attachment: &ColorAttachment,
) -> Option<ShaderError> {
    let target = attachment.shader_resolve?;
    let pipeline = match pipelines.resolve(device, target.texture().format()) {
        Ok(p) => p.clone(),
        Err(e) => return Some(e),
    };
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("resolve"),
        layout: &pipelines.resolve_layout,
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(attachment.draw) }],
    });
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("resolve"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: target,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT), store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(&pipeline);
    pass.set_bind_group(0, &bind_group, &[]);
    pass.draw(0..3, 0..1);
    None
}
