//! The MSAA resolve as a pass of Penumbra's own, on adapters where the render pass's resolve
//! costs more (`Capabilities::shader_msaa_resolve`; `shaders/resolve.wgsl`). The forward pass
//! then stores its multisampled colour ([`ColorAttachment::shader_resolve`]) and this pass,
//! encoded right after it, writes each pixel's mean into the target the render pass would have
//! resolved into. Its bind group is made per frame: it runs only on CPU rasterisers, where one
//! bind group is nothing beside the frame.

use crate::gpu::timing::GpuTimer;
use crate::pipelines::parts;
use crate::pipelines::{Compiler, PipelineCache, PipelineFamily, ShaderDefs, ShaderError};
use crate::targets::ColorAttachment;

/// Registers the resolve pass's pipeline family.
pub fn register(device: &wgpu::Device, pipelines: &mut PipelineCache) {
    pipelines.register(ResolveFamily::new(device));
}

/// The resolve pipelines, by the format written, and the layout of the multisampled colour they
/// read.
pub struct ResolveFamily {
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
}

impl ResolveFamily {
    pub fn new(device: &wgpu::Device) -> Self {
        let layout = parts::bind_group_layout(
            device,
            "resolve",
            &[wgpu::BindGroupLayoutEntry {
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: true,
                },
                ..parts::texture(0, false)
            }],
        );
        let pipeline_layout = parts::pipeline_layout(device, "resolve", &[&layout]);
        Self { layout, pipeline_layout }
    }
}

impl PipelineFamily for ResolveFamily {
    type Key = wgpu::TextureFormat;
    type Pipeline = wgpu::RenderPipeline;
    const NAME: &'static str = "resolve";

    fn shader(&self, _: &wgpu::TextureFormat) -> (&'static str, ShaderDefs) {
        ("resolve.wgsl", ShaderDefs::default())
    }

    fn create(
        &self,
        device: &Compiler,
        module: &wgpu::ShaderModule,
        format: &wgpu::TextureFormat,
    ) -> wgpu::RenderPipeline {
        parts::fullscreen_pipeline(device, &self.pipeline_layout, module, *format, "resolve")
    }
}

/// Before the pass that draws into `attachment`: compiles the resolve pipeline, or, if its
/// shader does not build, has the render pass resolve instead (so a broken `resolve.wgsl`
/// costs no frame), returning the error.
pub fn prepare<'a>(
    device: &wgpu::Device,
    pipelines: &mut PipelineCache,
    attachment: ColorAttachment<'a>,
) -> (ColorAttachment<'a>, Option<ShaderError>) {
    if attachment.shader_resolve.is_none() {
        return (attachment, None);
    }
    match pipelines.get::<ResolveFamily>(device, format(&attachment)) {
        Ok(_) => (attachment, None),
        Err(e) => {
            let ColorAttachment { draw, shader_resolve, .. } = attachment;
            (ColorAttachment { draw, pass_resolve: shader_resolve, shader_resolve: None }, Some(e))
        }
    }
}

/// The format written: the multisampled target's, which is made in the format of the view it
/// resolves into (`FrameTargets`).
fn format(attachment: &ColorAttachment) -> wgpu::TextureFormat {
    attachment.draw.texture().format()
}

/// Resolves `attachment.draw` into `attachment.shader_resolve`, if the frame resolves by shader
/// (after [`prepare`]).
pub fn encode(
    encoder: &mut wgpu::CommandEncoder,
    device: &wgpu::Device,
    pipelines: &PipelineCache,
    attachment: &ColorAttachment,
    timer: Option<&mut GpuTimer>,
) {
    let Some(target) = attachment.shader_resolve else { return };
    let Some(pipeline) = pipelines.cached::<ResolveFamily>(&format(attachment)) else { return };
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("resolve"),
        layout: &pipelines.family::<ResolveFamily>().layout,
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(attachment.draw) }],
    });
    parts::draw_fullscreen(encoder, "resolve", target, pipeline, &bind_group, timer.and_then(|t| t.pass("resolve")));
}
