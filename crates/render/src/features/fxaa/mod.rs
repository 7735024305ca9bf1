//! FXAA: the tonemap stage writes the displayed frame into this stage's 8-bit intermediate
//! (display-encoded values, so the filter works on what is seen), and this pass filters it into
//! the output (`shaders/fxaa.wgsl`).
//!
//! A post-processing stage (`features::post`): it runs when FXAA is on and the frame has an
//! HDR target (a frame drawn straight into the output has no tonemap pass to write the
//! intermediate). The intermediate is its input: sized with the frame, made again only when
//! the frame's size changes.

use crate::features::post::{Decision, PostPrepare, PostShared, PostStage, Target};
use crate::frame_context::FrameContext;
use crate::gpu::formats::LDR_FORMAT;
use crate::pass::Pass;
use crate::pipelines::{Compiler, PipelineCache, PipelineFamily, ShaderDefs, ShaderError, parts};

pub const PASS: Pass = Pass::new("Fxaa", "tonemapped intermediate -> output");

/// What the pass reads: the intermediate and its bind group.
struct Intermediate {
    size: (u32, u32),
    view: wgpu::TextureView,
    group: wgpu::BindGroup,
}

pub struct Fxaa {
    intermediate: Option<Intermediate>,
}

impl Fxaa {
    /// Registers FXAA's pipeline family.
    pub fn new(device: &wgpu::Device, pipelines: &mut PipelineCache) -> Self {
        pipelines.register(FxaaFamily::new(device, &parts::filtered_source_layout(device)));
        Self { intermediate: None }
    }
}

impl PostStage for Fxaa {
    /// On or off.
    type Settings = bool;
    const PASS: Pass = PASS;

    fn wants_hdr(on: &bool) -> bool {
        *on
    }

    fn prepare(&mut self, cx: &PostPrepare, on: &bool, shared: &mut PostShared) -> Decision {
        if !*on || cx.hdr.is_none() {
            self.intermediate = None;
            return Decision::LeftOut("FXAA is off");
        }
        let size = cx.size;
        if self.intermediate.as_ref().is_none_or(|i| i.size != size) {
            let texture = cx.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("fxaa input"),
                size: wgpu::Extent3d { width: size.0.max(1), height: size.1.max(1), depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: LDR_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            });
            let view = texture.create_view(&Default::default());
            let group = cx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("fxaa input"),
                layout: &cx.pipelines.family::<FxaaFamily>().source,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&shared.sampler) },
                ],
            });
            self.intermediate = Some(Intermediate { size, view, group });
        }
        Decision::Runs("FXAA is on")
    }

    fn input(&self) -> Option<Target> {
        self.intermediate.as_ref().map(|i| Target { view: i.view.clone(), format: LDR_FORMAT })
    }

    fn encode(&mut self, cx: &mut FrameContext, _: &PostShared, output: &Target) -> Result<(), ShaderError> {
        let Some(intermediate) = &self.intermediate else { return Ok(()) };
        let pipeline = cx.pipelines.get::<FxaaFamily>(cx.device, output.format)?;
        let timestamps = cx.timer.as_deref_mut().and_then(|t| t.pass("fxaa"));
        parts::draw_fullscreen(cx.encoder, "fxaa", &output.view, pipeline, &intermediate.group, timestamps);
        Ok(())
    }

    fn gpu_bytes(&self) -> u64 {
        self.intermediate.as_ref().map_or(0, |i| i.size.0 as u64 * i.size.1 as u64 * 4)
    }
}

/// FXAA's pipelines, by output format.
pub struct FxaaFamily {
    /// The intermediate and its sampler.
    source: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
}

impl FxaaFamily {
    fn new(device: &wgpu::Device, source: &wgpu::BindGroupLayout) -> Self {
        Self { source: source.clone(), pipeline_layout: parts::pipeline_layout(device, "fxaa", &[source]) }
    }
}

impl PipelineFamily for FxaaFamily {
    type Key = wgpu::TextureFormat;
    type Pipeline = wgpu::RenderPipeline;
    const NAME: &'static str = "fxaa";

    fn shader(&self, format: &wgpu::TextureFormat) -> (&'static str, ShaderDefs) {
        ("fxaa.wgsl", ShaderDefs::default().with("DECODE_SRGB", format.is_srgb()))
    }

    fn create(
        &self,
        device: &Compiler,
        module: &wgpu::ShaderModule,
        format: &wgpu::TextureFormat,
    ) -> wgpu::RenderPipeline {
        parts::fullscreen_pipeline(device, &self.pipeline_layout, module, *format, "fxaa")
    }
}
