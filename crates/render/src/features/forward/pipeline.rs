//! The forward pass's pipeline family: one render pipeline per [`PipelineKey`] (a batch's
//! shader variant of `forward.wgsl` and its raster state), with the view and material groups.

use crate::gpu::formats::SURFACE_SHAPE_FORMAT;
use crate::pipelines::{Compiler, PipelineFamily, ShaderDefs};
use crate::resources::draws::{LocalLights, PipelineKey, TopologyKey};
use crate::resources::materials::extension::PipelineLayouts;
use crate::resources::materials::{AlphaKey, MaterialTable};
use crate::resources::mesh_pool::GpuVertex;

/// The forward pass's pipelines (`forward.wgsl`), one per [`PipelineKey`]: the shader variant
/// and raster state of a batch.
pub struct ForwardFamily {
    /// The view and material groups, and the extension group of the key's material extensions.
    layouts: PipelineLayouts,
    /// The same with the visibility buffer's occlusion group as group 2, for the draws of a
    /// hybrid frame (`PipelineKey::visibility_occlusion`); transmissive ones read the copy in
    /// that group too.
    occluded: PipelineLayouts,
}

impl ForwardFamily {
    pub fn new(
        view: &wgpu::BindGroupLayout,
        materials: &MaterialTable,
        transmission: &wgpu::BindGroupLayout,
        occlusion: &[wgpu::BindGroupLayout; 2],
    ) -> Self {
        let layouts = PipelineLayouts::new(
            "forward",
            &[Some(view), Some(materials.layout())],
            materials.extension_layouts().clone(),
        )
        .with_transmission(transmission);
        let occluded = PipelineLayouts::new(
            "forward over the visibility buffer",
            &[Some(view), Some(materials.layout()), Some(&occlusion[0])],
            materials.extension_layouts().clone(),
        )
        .with_transmission(&occlusion[1]);
        Self { layouts, occluded }
    }
}

impl PipelineFamily for ForwardFamily {
    type Key = PipelineKey;
    type Pipeline = wgpu::RenderPipeline;
    const NAME: &'static str = "forward";
    const PER_VARIANT: bool = true;

    fn shader(&self, key: &PipelineKey) -> (&'static str, ShaderDefs) {
        ("forward.wgsl", key.shader_defs())
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, key: &PipelineKey) -> wgpu::RenderPipeline {
        let layouts = if key.visibility_occlusion { &self.occluded } else { &self.layouts };
        forward_pipeline(device, &layouts.get(device, key.features), module, *key)
    }
}

/// The forward pipeline of `key` from its composed `module`.
fn forward_pipeline(
    device: &Compiler,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    key: PipelineKey,
) -> wgpu::RenderPipeline {
    let blend = (key.alpha == AlphaKey::Blend).then_some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING);
    let label = format!("forward {key:?}");
    let color = Some(wgpu::ColorTargetState { format: key.color_format.0, blend, write_mask: wgpu::ColorWrites::ALL });
    let surface = |format| Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL });
    let targets = if key.local_lights == LocalLights::Deferred {
        vec![color, surface(SURFACE_SHAPE_FORMAT)]
    } else {
        vec![color]
    };
    let vertex_buffers = [Some(GpuVertex::layout())];
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(&label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: if key.pulled_vertices { &[] } else { &vertex_buffers },
        },
        primitive: wgpu::PrimitiveState {
            // Lines are drawn as quads (resources/line_quads.rs); keys of lines and points
            // never cull (see `DrawList::pipeline_key`).
            topology: match key.topology {
                TopologyKey::Triangles | TopologyKey::Lines => wgpu::PrimitiveTopology::TriangleList,
                TopologyKey::Points => wgpu::PrimitiveTopology::PointList,
            },
            strip_index_format: None,
            front_face: if key.front_face_cw { wgpu::FrontFace::Cw } else { wgpu::FrontFace::Ccw },
            cull_mode: key.cull_back_faces.then_some(wgpu::Face::Back),
            unclipped_depth: false,
            polygon_mode: wgpu::PolygonMode::Fill,
            conservative: false,
        },
        depth_stencil: key.depth_format.map(|depth| wgpu::DepthStencilState {
            format: depth.0,
            // Blended surfaces are sorted back to front and must not hide what lies
            // behind them in later draws.
            depth_write_enabled: Some(key.alpha != AlphaKey::Blend),
            // Reverse-Z: nearer is greater.
            depth_compare: Some(wgpu::CompareFunction::Greater),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        }),
        multisample: wgpu::MultisampleState { count: key.sample_count, mask: !0, alpha_to_coverage_enabled: false },
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &targets,
        }),
        multiview_mask: None,
        cache: device.cache(),
    })
}
