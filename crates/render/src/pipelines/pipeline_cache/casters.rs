//! Shadow-caster pipelines (depth only, `shaders/shadow_caster.wgsl`): the part of the pipeline
//! cache that serves the shadow orchestrator.

use super::{PipelineCache, PipelineTiming, checked_pipeline, storage};
use crate::passes::shadows::orchestrator::ATLAS_FORMAT;
use crate::pipelines::shader_library::{ShaderDefs, ShaderError, ShaderLibrary};
use crate::prepare::mesh_pool::GpuVertex;

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

/// The caster bind group layout: the caster view (dynamic offset, one per atlas layer),
/// instances, draw slots and materials.
pub(super) fn caster_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let vertex = wgpu::ShaderStages::VERTEX;
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("shadow casters"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: vertex,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: None,
                },
                count: None,
            },
            storage(1, vertex),
            storage(2, vertex),
            storage(3, wgpu::ShaderStages::FRAGMENT),
        ],
    })
}

impl PipelineCache {
    /// The caster pipeline for `key`, compiling it on first use.
    pub fn caster(&mut self, device: &wgpu::Device, key: CasterKey) -> Result<&wgpu::RenderPipeline, ShaderError> {
        if !self.caster.contains_key(&key) {
            let p = self.create_caster(device, &mut None, key)?;
            self.caster.insert(key, p);
        }
        Ok(&self.caster[&key])
    }

    pub fn caster_cached(&self, key: &CasterKey) -> Option<&wgpu::RenderPipeline> {
        self.caster.get(key)
    }

    pub(super) fn create_caster(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        key: CasterKey,
    ) -> Result<wgpu::RenderPipeline, ShaderError> {
        let module = self.library(candidate).create_module(device, "shadow_caster.wgsl", &caster_defs(key))?;
        self.compiled += 1;
        let _timing = PipelineTiming(std::time::Instant::now());
        let layout = &self.caster_pipeline_layouts[key.alpha_mask as usize];
        checked_pipeline(device, "shadow_caster.wgsl", || {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("shadow caster"),
                layout: Some(layout),
                vertex: wgpu::VertexState {
                    module: &module,
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
                    format: ATLAS_FORMAT,
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
                    module: &module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[],
                }),
                multiview_mask: None,
                cache: None,
            })
        })
    }
}

/// The switches of the shadow caster pipeline `key`.
pub(super) fn caster_defs(key: CasterKey) -> ShaderDefs {
    ShaderDefs::default().with("ALPHA_MASK", key.alpha_mask).with("BASE_COLOR_TEXTURE", key.base_color_texture)
}
