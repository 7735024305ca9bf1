//! Passes: each encodes GPU work from what prepare made. Nothing here reads the ECS.
pub mod clusters;
pub mod culling;
pub mod deferred_lights;
pub mod forward;
pub mod gizmos;
pub mod occlusion_feedback;
pub mod post;
pub mod resolve;
pub mod shadows;
pub mod tonemap;
pub mod visibility;

/// One full-screen triangle drawn by `pipeline` with `bind_group` into all of `target` (its
/// previous contents cleared), with the pass's timestamps if given: the shape of the
/// mip-generation, resolve and FXAA passes.
pub fn draw_fullscreen(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    target: &wgpu::TextureView,
    pipeline: &wgpu::RenderPipeline,
    bind_group: &wgpu::BindGroup,
    timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
) {
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: target,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT), store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: None,
        timestamp_writes,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind_group, &[]);
    pass.draw(0..3, 0..1);
}
