//! Deferred local lights: the compute pass that shades local lights for opaque surfaces (see
//! `shaders/deferred_lights.wgsl` for why, and how samples are handled), and the composite that
//! adds its light into the frame.
//!
//! Data flow: the forward pass's opaque batches write colour from global lights and emission,
//! plus each sample's surface (`targets.deferred`); this pass reads those, the depth and the
//! cluster lists, and writes local light per pixel; the forward pass's second half
//! (`forward::encode_after_deferred`) adds it into every sample through [`DeferredLights::composite`]
//! and draws blended batches, which shade their own local lights.

use bytemuck::{Pod, Zeroable};
use glam::Mat4;

use crate::frame_context::FrameContext;
use crate::gpu::formats::{DEPTH_FORMAT, HDR_FORMAT, LOCAL_LIGHT_FORMAT};
use crate::pipelines::parts::{self, uniform};
use crate::pipelines::{Compiler, PipelineCache, PipelineFamily, ShaderDefs, ShaderError};
use crate::resources::light_store::LightShapes;
use crate::targets::FrameTargets;

/// Mirrors `DeferredParams` in `deferred_lights.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuDeferredParams {
    pub rel_from_clip: [[f32; 4]; 4],
    pub viewport: [f32; 2],
    pub _pad: [f32; 2],
}

impl GpuDeferredParams {
    pub fn new(clip_from_rel: Mat4, size: (u32, u32)) -> Self {
        Self {
            rel_from_clip: clip_from_rel.inverse().to_cols_array_2d(),
            viewport: [size.0 as f32, size.1 as f32],
            _pad: [0.0; 2],
        }
    }
}

fn params_buffer(device: &wgpu::Device) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("deferred lights params"),
        size: std::mem::size_of::<GpuDeferredParams>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Selects a deferred-lights compute pipeline: the frame's sample count and the kinds of lights
/// with a size it must shade.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DeferredKey {
    pub multisampled: bool,
    pub light_shapes: LightShapes,
    /// Some local light reads a shadow map.
    pub local_shadows: bool,
}

/// The owner of the pass's resources: its parameters, and the bind groups over the frame
/// targets it reads and writes (made again when the targets are).
pub struct DeferredLights {
    params: wgpu::Buffer,
    /// For the targets of this id: the compute pass's group 1 and the composite's group 0.
    groups: Option<(u64, wgpu::BindGroup, wgpu::BindGroup)>,
}

impl DeferredLights {
    /// Registers the pass's pipeline families.
    pub fn new(device: &wgpu::Device, pipelines: &mut PipelineCache, view: &wgpu::BindGroupLayout) -> Self {
        pipelines.register(DeferredFamily::new(device, view));
        pipelines.register(CompositeFamily::new(device));
        Self { params: params_buffer(device), groups: None }
    }

    /// This frame's camera, for the pass to find each pixel's position.
    pub fn write_params(&self, queue: &wgpu::Queue, clip_from_rel: Mat4, size: (u32, u32)) {
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&GpuDeferredParams::new(clip_from_rel, size)));
    }

    /// Binds the frame's deferred targets (once per set of targets).
    pub fn prepare(&mut self, device: &wgpu::Device, pipelines: &PipelineCache, targets: &FrameTargets) {
        let (Some(deferred), Some(hdr), Some(depth)) = (&targets.deferred, &targets.hdr, &targets.depth_view) else {
            self.groups = None;
            return;
        };
        if self.groups.as_ref().is_some_and(|(id, _, _)| *id == targets.id) {
            return;
        }
        let view = |binding, view| wgpu::BindGroupEntry { binding, resource: wgpu::BindingResource::TextureView(view) };
        let compute = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("deferred lights"),
            layout: pipelines.family::<DeferredFamily>().inputs(targets.samples > 1),
            entries: &[
                view(0, hdr.msaa_view.as_ref().unwrap_or(&hdr.view)),
                view(1, &deferred.surface_shape_view),
                view(2, depth),
                view(3, &deferred.local_light_view),
                wgpu::BindGroupEntry { binding: 4, resource: self.params.as_entire_binding() },
            ],
        });
        let composite = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("deferred composite"),
            layout: &pipelines.family::<CompositeFamily>().layout,
            entries: &[view(0, &deferred.local_light_view)],
        });
        self.groups = Some((targets.id, compute, composite));
    }

    /// Encodes the pass; nothing without deferred targets.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        cx: &mut FrameContext,
        view_bind_group: &wgpu::BindGroup,
        key: DeferredKey,
    ) -> Result<(), ShaderError> {
        let (encoder, device, pipelines, targets, timer) =
            (&mut *cx.encoder, cx.device, &mut *cx.pipelines, cx.targets, cx.timer.as_deref_mut());
        let Some((_, group, _)) = self.groups.as_ref() else { return Ok(()) };
        let pipeline = pipelines.get::<DeferredFamily>(device, key)?;
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("deferred lights"),
            timestamp_writes: timer.and_then(|t| t.compute_pass("deferred lights")),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, view_bind_group, &[]);
        pass.set_bind_group(1, group, &[]);
        pass.dispatch_workgroups(targets.size.0.div_ceil(8), targets.size.1.div_ceil(8), 1);
        Ok(())
    }

    /// The composite's bind group (group 0 of [`CompositeFamily`]'s pipelines), once the
    /// frame's deferred targets are bound.
    pub fn composite_group(&self) -> Option<&wgpu::BindGroup> {
        self.groups.as_ref().map(|(_, _, group)| group)
    }
}

/// The compute pass's pipelines, with the layouts of its inputs, single-sampled and
/// multisampled.
pub struct DeferredFamily {
    inputs: [wgpu::BindGroupLayout; 2],
    pipelines: [wgpu::PipelineLayout; 2],
}

impl DeferredFamily {
    fn new(device: &wgpu::Device, view: &wgpu::BindGroupLayout) -> Self {
        let compute = wgpu::ShaderStages::COMPUTE;
        let inputs = [false, true].map(|multisampled| {
            let surface = |binding, sample_type| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: compute,
                ty: wgpu::BindingType::Texture {
                    sample_type,
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled,
                },
                count: None,
            };
            parts::bind_group_layout(
                device,
                if multisampled { "deferred lights (msaa)" } else { "deferred lights" },
                &[
                    surface(0, wgpu::TextureSampleType::Float { filterable: false }),
                    surface(1, wgpu::TextureSampleType::Uint),
                    surface(2, wgpu::TextureSampleType::Depth),
                    parts::storage_texture(3, LOCAL_LIGHT_FORMAT, wgpu::TextureViewDimension::D2),
                    uniform(4, compute),
                ],
            )
        });
        let pipelines = [0, 1].map(|i| parts::pipeline_layout(device, "deferred lights", &[view, &inputs[i]]));
        Self { inputs, pipelines }
    }

    fn inputs(&self, multisampled: bool) -> &wgpu::BindGroupLayout {
        &self.inputs[multisampled as usize]
    }
}

impl PipelineFamily for DeferredFamily {
    type Key = DeferredKey;
    type Pipeline = wgpu::ComputePipeline;
    const NAME: &'static str = "deferred lights";
    const PER_VARIANT: bool = true;

    fn shader(&self, key: &DeferredKey) -> (&'static str, ShaderDefs) {
        let defs = ShaderDefs::default()
            .with("MULTISAMPLED", key.multisampled)
            .with("LOCAL_LIGHTS", true)
            .with("CLUSTERED_LIGHTS", true)
            .with("SPHERE_TUBE_LIGHTS", key.light_shapes.sphere_tube)
            .with("LTC_LIGHTS", key.light_shapes.ltc)
            .with("IES_LIGHTS", key.light_shapes.ies)
            .with("LOCAL_SHADOWS", key.local_shadows);
        ("deferred_lights.wgsl", defs)
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, key: &DeferredKey) -> wgpu::ComputePipeline {
        let layout = &self.pipelines[key.multisampled as usize];
        parts::compute_pipeline(device, layout, module, "shade_local_lights", "deferred lights")
    }
}

/// The composite's pipelines, by the frame's sample count: they add the local light into every
/// sample (radiance only; alpha stays), neither testing nor writing the depth the pass keeps
/// for the blended draws after it.
pub struct CompositeFamily {
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
}

impl CompositeFamily {
    fn new(device: &wgpu::Device) -> Self {
        let layout = parts::bind_group_layout(device, "deferred composite", &[parts::texture(0, false)]);
        let pipeline_layout = parts::pipeline_layout(device, "deferred composite", &[&layout]);
        Self { layout, pipeline_layout }
    }
}

impl PipelineFamily for CompositeFamily {
    type Key = u32;
    type Pipeline = wgpu::RenderPipeline;
    const NAME: &'static str = "deferred composite";

    fn shader(&self, _: &u32) -> (&'static str, ShaderDefs) {
        ("deferred_composite.wgsl", ShaderDefs::default())
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, samples: &u32) -> wgpu::RenderPipeline {
        // Adds radiance; leaves alpha as it is.
        let blend = Some(wgpu::BlendState { color: parts::ADD, alpha: parts::KEEP });
        let targets = [Some(wgpu::ColorTargetState { format: HDR_FORMAT, blend, write_mask: wgpu::ColorWrites::ALL })];
        // The pass keeps the opaque depth for the blended draws after it; the composite neither
        // tests nor writes it.
        let depth_stencil = Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(false),
            depth_compare: Some(wgpu::CompareFunction::Always),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        });
        let f = parts::Fullscreen {
            label: "deferred composite",
            fragment: "fs_main",
            targets: &targets,
            depth_stencil,
            samples: *samples,
        };
        parts::fullscreen(device, &self.pipeline_layout, module, f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gpu_deferred_params_mirror_the_shaders_parameters() {
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuDeferredParams,
            "deferred_lights.wgsl",
            ["LOCAL_LIGHTS", "CLUSTERED_LIGHTS"],
            "DeferredParams",
            [rel_from_clip, viewport]
        );
    }
}
