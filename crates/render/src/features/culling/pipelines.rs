//! The culling pipeline families: frustum culling (`shaders/cull.wgsl`) in its three phases,
//! and the hierarchical depth buffer's reductions (`shaders/hzb.wgsl`), with their layouts.

use crate::pipelines::parts::{self, buffer_entry, storage};
use crate::pipelines::{Compiler, PipelineFamily, ShaderDefs};

/// Which cull pass: without occlusion culling, or its early or late half; each also with
/// triangle culling for the batches marked for it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CullPhase {
    Frustum,
    Early,
    Late,
    FrustumTriangles,
    EarlyTriangles,
    LateTriangles,
}

/// Which reduction of the hierarchical depth buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum HzbStep {
    /// Level 0 from the frame's depth (single- or multisampled).
    FromDepth { multisampled: bool },
    /// A level from the one below it.
    Reduce,
}

struct CullLayouts {
    /// Bind group layouts by `CullPhase`, in its order.
    cull: [wgpu::BindGroupLayout; 6],
    cull_pipeline: [wgpu::PipelineLayout; 6],
    /// `FromDepth` single-sampled, multisampled, then `Reduce`.
    hzb: [wgpu::BindGroupLayout; 3],
    hzb_pipeline: [wgpu::PipelineLayout; 3],
}

impl CullPhase {
    fn index(self) -> usize {
        self as usize
    }

    /// The phase with triangle culling, or without.
    pub fn with_triangles(self, triangles: bool) -> Self {
        use CullPhase::*;
        match (self, triangles) {
            (Frustum | FrustumTriangles, t) => {
                if t {
                    FrustumTriangles
                } else {
                    Frustum
                }
            }
            (Early | EarlyTriangles, t) => {
                if t {
                    EarlyTriangles
                } else {
                    Early
                }
            }
            (Late | LateTriangles, t) => {
                if t {
                    LateTriangles
                } else {
                    Late
                }
            }
        }
    }

    pub fn occlusion_early(self) -> bool {
        matches!(self, CullPhase::Early | CullPhase::EarlyTriangles)
    }

    pub fn occlusion_late(self) -> bool {
        matches!(self, CullPhase::Late | CullPhase::LateTriangles)
    }

    pub fn triangles(self) -> bool {
        matches!(self, CullPhase::FrustumTriangles | CullPhase::EarlyTriangles | CullPhase::LateTriangles)
    }
}

impl HzbStep {
    fn index(self) -> usize {
        match self {
            HzbStep::FromDepth { multisampled } => multisampled as usize,
            HzbStep::Reduce => 2,
        }
    }
}

/// The layouts, in `cull.wgsl`'s binding order: view, instances, draw list, entry → batch,
/// batches, indirect args (written), visible list (written), params; the early phase adds
/// last frame's visibility, the late phase rewrites it and reads the depth pyramid; triangle
/// culling adds the mesh pool's indices and vertices and the culled index list (written).
fn cull_layouts(device: &wgpu::Device) -> CullLayouts {
    let compute = wgpu::ShaderStages::COMPUTE;
    let read_write = wgpu::BufferBindingType::Storage { read_only: false };
    let mut entries = vec![
        buffer_entry(0, compute, wgpu::BufferBindingType::Uniform),
        storage(1, compute),
        storage(2, compute),
        storage(3, compute),
        storage(4, compute),
        buffer_entry(5, compute, read_write),
        buffer_entry(6, compute, read_write),
        buffer_entry(7, compute, wgpu::BufferBindingType::Uniform),
    ];
    let layout = |label, entries: &[wgpu::BindGroupLayoutEntry]| {
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries })
    };
    let triangle_entries = [storage(10, compute), storage(11, compute), buffer_entry(12, compute, read_write)];
    let with_triangles = |entries: &[wgpu::BindGroupLayoutEntry]| [entries, &triangle_entries[..]].concat();
    let frustum = layout("cull", &entries);
    let frustum_triangles = layout("cull triangles", &with_triangles(&entries));
    entries.push(storage(8, compute));
    let early = layout("cull early", &entries);
    let early_triangles = layout("cull early triangles", &with_triangles(&entries));
    entries.pop();
    entries.push(buffer_entry(8, compute, read_write));
    entries.push(texture_entry(9, wgpu::TextureSampleType::Float { filterable: false }, false));
    let late = layout("cull late", &entries);
    let late_triangles = layout("cull late triangles", &with_triangles(&entries));
    let storage_out = wgpu::BindGroupLayoutEntry {
        binding: 1,
        visibility: compute,
        ty: wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format: wgpu::TextureFormat::R32Float,
            view_dimension: wgpu::TextureViewDimension::D2,
        },
        count: None,
    };
    let hzb = [
        layout("hzb from depth", &[texture_entry(0, wgpu::TextureSampleType::Depth, false), storage_out]),
        layout("hzb from msaa depth", &[texture_entry(0, wgpu::TextureSampleType::Depth, true), storage_out]),
        layout(
            "hzb reduce",
            &[texture_entry(0, wgpu::TextureSampleType::Float { filterable: false }, false), storage_out],
        ),
    ];
    let pipeline_layout = |label, group: &wgpu::BindGroupLayout| {
        device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[Some(group)],
            immediate_size: 0,
        })
    };
    CullLayouts {
        cull_pipeline: [
            pipeline_layout("cull", &frustum),
            pipeline_layout("cull early", &early),
            pipeline_layout("cull late", &late),
            pipeline_layout("cull triangles", &frustum_triangles),
            pipeline_layout("cull early triangles", &early_triangles),
            pipeline_layout("cull late triangles", &late_triangles),
        ],
        cull: [frustum, early, late, frustum_triangles, early_triangles, late_triangles],
        hzb_pipeline: [
            pipeline_layout("hzb", &hzb[0]),
            pipeline_layout("hzb msaa", &hzb[1]),
            pipeline_layout("hzb reduce", &hzb[2]),
        ],
        hzb,
    }
}

fn texture_entry(binding: u32, sample_type: wgpu::TextureSampleType, multisampled: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture { sample_type, view_dimension: wgpu::TextureViewDimension::D2, multisampled },
        count: None,
    }
}

/// The cull pass's pipelines, one per phase.
pub struct CullFamily {
    layouts: [wgpu::BindGroupLayout; 6],
    pipelines: [wgpu::PipelineLayout; 6],
}

/// The depth pyramid's pipelines, one per reduction.
pub struct HzbFamily {
    layouts: [wgpu::BindGroupLayout; 3],
    pipelines: [wgpu::PipelineLayout; 3],
}

/// Both culling families, made together (they share their layouts' construction).
pub fn families(device: &wgpu::Device) -> (CullFamily, HzbFamily) {
    let CullLayouts { cull, cull_pipeline, hzb, hzb_pipeline } = cull_layouts(device);
    (CullFamily { layouts: cull, pipelines: cull_pipeline }, HzbFamily { layouts: hzb, pipelines: hzb_pipeline })
}

impl CullFamily {
    pub fn layout(&self, phase: CullPhase) -> &wgpu::BindGroupLayout {
        &self.layouts[phase.index()]
    }
}

impl HzbFamily {
    pub fn layout(&self, step: HzbStep) -> &wgpu::BindGroupLayout {
        &self.layouts[step.index()]
    }
}

impl PipelineFamily for CullFamily {
    type Key = CullPhase;
    type Pipeline = wgpu::ComputePipeline;
    const NAME: &'static str = "cull";
    const PER_VARIANT: bool = true;

    fn shader(&self, phase: &CullPhase) -> (&'static str, ShaderDefs) {
        let defs = ShaderDefs::default()
            .with("OCCLUSION_EARLY", phase.occlusion_early())
            .with("OCCLUSION_LATE", phase.occlusion_late())
            .with("TRIANGLE_CULLING", phase.triangles());
        ("cull.wgsl", defs)
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, phase: &CullPhase) -> wgpu::ComputePipeline {
        parts::compute_pipeline(device, &self.pipelines[phase.index()], module, "cull_instances", "cull")
    }
}

impl PipelineFamily for HzbFamily {
    type Key = HzbStep;
    type Pipeline = wgpu::ComputePipeline;
    const NAME: &'static str = "depth pyramid";

    fn shader(&self, step: &HzbStep) -> (&'static str, ShaderDefs) {
        let defs = ShaderDefs::default()
            .with("FROM_DEPTH", *step != HzbStep::Reduce)
            .with("MULTISAMPLED", *step == HzbStep::FromDepth { multisampled: true });
        ("hzb.wgsl", defs)
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, step: &HzbStep) -> wgpu::ComputePipeline {
        parts::compute_pipeline(device, &self.pipelines[step.index()], module, "reduce", "hzb")
    }
}
