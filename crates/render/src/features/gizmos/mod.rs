//! Gizmo lines: the extracted `Gizmos` (world-space segments) uploaded as camera-relative quad
//! vertices (six a line, each with both ends: `shaders/line_quads.wgsl` widens them to a pixel,
//! as scene lines) each frame they exist (the camera moves, and camera-relative positions keep lines
//! far from the origin as precise as the meshes they annotate), then drawn by the forward pass
//! after the scene's draws, in the same render pass so they are depth-tested against it and
//! multisampled with it. With no lines nothing is uploaded, compiled or drawn.

use glam::Vec3;
use penumbra_engine::gizmos::GizmoLine;

use crate::gpu::buffer::GrowableBuffer;
use crate::gpu::formats::{DEPTH_FORMAT, HDR_FORMAT};
use crate::pipelines::{Compiler, PipelineCache, PipelineFamily, ShaderDefs, parts};

/// Mirrors `VertexIn` in `gizmo.wgsl`: camera-relative position, the other end's, colour, corner.
pub const GIZMO_VERTEX_BYTES: u64 = 40;

/// The gizmo line pipelines (`shaders/gizmo.wgsl`), one per sample count: lines as quads a
/// pixel wide (six vertices a line), depth-tested (reverse-Z) without writing depth.
pub struct GizmoFamily {
    pipeline_layout: wgpu::PipelineLayout,
    /// With the visibility buffer's occlusion group as group 1 (a hybrid frame's gizmos).
    occluded_layout: wgpu::PipelineLayout,
}

impl GizmoFamily {
    /// `occlusion`: the first of `features::visibility::occlusion_layouts`.
    pub fn new(device: &wgpu::Device, view: &wgpu::BindGroupLayout, occlusion: &wgpu::BindGroupLayout) -> Self {
        Self {
            pipeline_layout: parts::pipeline_layout(device, "gizmos", &[view]),
            occluded_layout: device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("gizmos over the visibility buffer"),
                bind_group_layouts: &[Some(view), Some(occlusion)],
                immediate_size: 0,
            }),
        }
    }
}

/// One gizmo pipeline: the frame's sample count, and whether the lines are drawn over the
/// visibility buffer in a hybrid frame (each sample tested against its depth).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct GizmoKey {
    pub samples: u32,
    pub occluded: bool,
}

impl PipelineFamily for GizmoFamily {
    type Key = GizmoKey;
    type Pipeline = wgpu::RenderPipeline;
    const NAME: &'static str = "gizmo";
    const PER_VARIANT: bool = true;

    fn shader(&self, key: &GizmoKey) -> (&'static str, ShaderDefs) {
        ("gizmo.wgsl", ShaderDefs::default().with("VISIBILITY_OCCLUSION", key.occluded))
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, key: &GizmoKey) -> wgpu::RenderPipeline {
        let samples = &key.samples;
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("gizmos"),
            layout: Some(if key.occluded { &self.occluded_layout } else { &self.pipeline_layout }),
            vertex: wgpu::VertexState {
                module,
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
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(false),
                // Reverse-Z: nearer is greater. Equal keeps lines lying on a surface visible.
                depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState::default(),
            }),
            multisample: wgpu::MultisampleState { count: *samples, mask: !0, alpha_to_coverage_enabled: false },
            fragment: Some(wgpu::FragmentState {
                module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: HDR_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: device.cache(),
        })
    }
}

/// Mirrors `VertexIn` in `shaders/gizmo.wgsl` (`GIZMO_VERTEX_BYTES`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct GizmoVertex {
    rel_position: [f32; 3],
    other_rel_position: [f32; 3],
    color: [f32; 3],
    corner: u32,
}

/// The frame's gizmo vertices, for the forward pass.
#[derive(Clone, Copy)]
pub struct GizmoDraw<'a> {
    pub vertices: &'a wgpu::Buffer,
    pub count: u32,
}

pub struct GizmoLines {
    buffer: Option<GrowableBuffer>,
    count: u32,
    scratch: Vec<GizmoVertex>,
}

impl GizmoLines {
    /// Registers the gizmo pipeline family.
    pub fn new(
        device: &wgpu::Device,
        pipelines: &mut PipelineCache,
        view: &wgpu::BindGroupLayout,
        occlusion: &wgpu::BindGroupLayout,
    ) -> Self {
        pipelines.register(GizmoFamily::new(device, view, occlusion));
        Self { buffer: None, count: 0, scratch: Vec::new() }
    }

    /// Uploads `lines` relative to `camera`; returns the vertex count (0: nothing to draw).
    pub fn prepare(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, lines: &[GizmoLine], camera: Vec3) -> u32 {
        self.count = 0;
        if lines.is_empty() {
            return 0;
        }
        self.scratch.clear();
        for l in lines {
            let ends = [(l.start - camera).to_array(), (l.end - camera).to_array()];
            // Two triangles over the corners (side in bit 0, end in bit 1).
            for corner in [0u32, 1, 2, 2, 1, 3] {
                let end = (corner >> 1) as usize;
                self.scratch.push(GizmoVertex {
                    rel_position: ends[end],
                    other_rel_position: ends[1 - end],
                    color: l.color.to_array(),
                    corner,
                });
            }
        }
        let bytes = self.scratch.len() as u64 * GIZMO_VERTEX_BYTES;
        let buffer = self
            .buffer
            .get_or_insert_with(|| GrowableBuffer::new(device, "gizmo lines", wgpu::BufferUsages::VERTEX, bytes));
        buffer.reserve(device, bytes);
        queue.write_buffer(buffer.buffer(), 0, bytemuck::cast_slice(&self.scratch));
        self.count = self.scratch.len() as u32;
        self.count
    }

    /// What the forward pass draws this frame, if anything.
    pub fn draw(&self) -> Option<GizmoDraw<'_>> {
        let buffer = self.buffer.as_ref().filter(|_| self.count > 0)?;
        Some(GizmoDraw { vertices: buffer.buffer(), count: self.count })
    }

    /// Bytes held on the GPU.
    pub fn memory(&self) -> u64 {
        self.buffer.as_ref().map_or(0, GrowableBuffer::capacity)
    }
}
