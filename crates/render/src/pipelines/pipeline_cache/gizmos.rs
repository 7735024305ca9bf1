//! The gizmo line pipeline (`shaders/gizmo.wgsl`), one per sample count: lines as quads a pixel
//! wide (six vertices a line), drawn in the forward pass after the scene, depth-tested
//! (reverse-Z) without writing depth. The part of
//! the pipeline cache that serves `passes::gizmos`.

use super::{PipelineCache, checked_pipeline};
use crate::pipelines::shader_library::{ShaderDefs, ShaderError, ShaderLibrary};

/// Mirrors `VertexIn` in `gizmo.wgsl`: camera-relative position, the other end's, colour, corner.
pub const GIZMO_VERTEX_BYTES: u64 = 40;

impl PipelineCache {
    /// The gizmo pipeline for `samples`, compiled on first use (a frame without gizmo lines
    /// never compiles it).
    pub fn gizmo(&mut self, device: &wgpu::Device, samples: u32) -> Result<&wgpu::RenderPipeline, ShaderError> {
        if !self.gizmo.contains_key(&samples) {
            let p = self.create_gizmo(device, &mut None, samples)?;
            self.gizmo.insert(samples, p);
        }
        Ok(&self.gizmo[&samples])
    }

    pub fn gizmo_cached(&self, samples: u32) -> Option<&wgpu::RenderPipeline> {
        self.gizmo.get(&samples)
    }

    pub(super) fn create_gizmo(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        samples: u32,
    ) -> Result<wgpu::RenderPipeline, ShaderError> {
        let module = self.library(candidate).create_module(device, "gizmo.wgsl", &ShaderDefs::default())?;
        self.compiled += 1;
        checked_pipeline(device, "gizmo.wgsl", || {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("gizmos"),
                layout: Some(&self.gizmo_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: GIZMO_VERTEX_BYTES,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x3, 3 => Uint32],
                    })],
                },
                primitive: wgpu::PrimitiveState { topology: wgpu::PrimitiveTopology::TriangleList, ..Default::default() },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: crate::targets::DEPTH_FORMAT,
                    depth_write_enabled: Some(false),
                    // Reverse-Z: nearer is greater. Equal keeps lines lying on a surface visible.
                    depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
                    stencil: wgpu::StencilState::default(),
                    bias: wgpu::DepthBiasState::default(),
                }),
                multisample: wgpu::MultisampleState { count: samples, mask: !0, alpha_to_coverage_enabled: false },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: crate::targets::HDR_FORMAT,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        })
    }
}
