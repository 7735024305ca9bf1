//! The shadow casters' pipeline family (depth only, `shaders/shadow_caster.wgsl`) and its
//! bind group layout: the caster view (dynamic offset, one per atlas layer), instances, draw
//! slots and materials.

use crate::gpu::formats::SHADOW_ATLAS_FORMAT;
use crate::pipelines::parts::{self, dynamic_uniform, storage};
use crate::pipelines::{Compiler, PipelineFamily, ShaderDefs};
use crate::resources::mesh_pool::GpuVertex;

/// Everything that selects a caster pipeline. Casters draw both faces (a single-sided wall must
/// still block light coming from behind it), so face culling and winding are not key dimensions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CasterKey {
    /// Discards where the base colour's alpha is below the material's cutoff.
    pub alpha_mask: bool,
    pub base_color_texture: bool,
    /// `ShadowSettings::slope_bias` (raster state), as bits.
    pub slope_bias_bits: u32,
}

pub struct CasterFamily {
    /// The caster group: the caster view, instances, draw slots and materials.
    pub layout: wgpu::BindGroupLayout,
    /// Opaque casters (caster group only) and masked ones (with the material group).
    pipeline_layouts: [wgpu::PipelineLayout; 2],
}

impl CasterFamily {
    pub fn new(device: &wgpu::Device, material: &wgpu::BindGroupLayout) -> Self {
        let vertex = wgpu::ShaderStages::VERTEX;
        let layout = parts::bind_group_layout(
            device,
            "shadow casters",
            &[
                dynamic_uniform(0, vertex, None),
                storage(1, vertex),
                storage(2, vertex),
                storage(3, wgpu::ShaderStages::FRAGMENT),
            ],
        );
        let pipeline_layouts = [
            parts::pipeline_layout(device, "shadow casters", &[&layout]),
            parts::pipeline_layout(device, "masked shadow casters", &[&layout, material]),
        ];
        Self { layout, pipeline_layouts }
    }
}

impl PipelineFamily for CasterFamily {
    type Key = CasterKey;
    type Pipeline = wgpu::RenderPipeline;
    const NAME: &'static str = "shadow caster";
    const PER_VARIANT: bool = true;

    fn shader(&self, key: &CasterKey) -> (&'static str, ShaderDefs) {
        let defs =
            ShaderDefs::default().with("ALPHA_MASK", key.alpha_mask).with("BASE_COLOR_TEXTURE", key.base_color_texture);
        ("shadow_caster.wgsl", defs)
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, key: &CasterKey) -> wgpu::RenderPipeline {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("shadow caster"),
            layout: Some(&self.pipeline_layouts[key.alpha_mask as usize]),
            vertex: wgpu::VertexState {
                module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(GpuVertex::layout())],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: SHADOW_ATLAS_FORMAT,
                depth_write_enabled: Some(true),
                // Reverse-Z: nearer the light is greater.
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: wgpu::StencilState::default(),
                // Pushed away from the light (toward 0) by a multiple of the caster's depth
                // slope: steep surfaces, whose depth changes most across a texel, get the
                // most. No constant term: its size would depend on the depth format.
                bias: wgpu::DepthBiasState {
                    constant: 0,
                    slope_scale: -f32::from_bits(key.slope_bias_bits),
                    clamp: 0.0,
                },
            }),
            multisample: wgpu::MultisampleState::default(),
            fragment: key.alpha_mask.then(|| wgpu::FragmentState {
                module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[],
            }),
            multiview_mask: None,
            cache: device.cache(),
        })
    }
}
