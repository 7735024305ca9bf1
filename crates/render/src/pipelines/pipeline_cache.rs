//! The pipeline cache: owns the bind group layouts and every render pipeline, each compiled once
//! per [`PipelineKey`] and kept for the renderer's lifetime.
//!
//! Feature switches that would otherwise be shader branches (alpha mode, unlit) are WGSL
//! `override` constants fixed at pipeline creation, so each pipeline's shader contains only the
//! path it runs. Every draw is an instanced draw (a batch of one is an instance count of one), so
//! instancing is not a key dimension.

use std::collections::HashMap;

use penumbra_engine::mesh::Topology;

use super::shader_library::ShaderLibrary;
use crate::prepare::materials::AlphaKey;
use crate::prepare::mesh_pool::GpuVertex;

/// Everything that selects a forward pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PipelineKey {
    pub unlit: bool,
    pub alpha: AlphaKey,
    pub topology: TopologyKey,
    /// Double-sided materials draw both faces.
    pub cull_back_faces: bool,
    /// Mirrored instances (negative determinant) wind clockwise.
    pub front_face_cw: bool,
    pub sample_count: u32,
    pub color_format: FormatKey,
    pub depth_format: FormatKey,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum TopologyKey {
    Triangles,
    Lines,
    Points,
}

impl From<Topology> for TopologyKey {
    fn from(t: Topology) -> Self {
        match t {
            Topology::TriangleList => TopologyKey::Triangles,
            Topology::LineList => TopologyKey::Lines,
            Topology::PointList => TopologyKey::Points,
        }
    }
}

/// A texture format usable as a map key with a total order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FormatKey(pub wgpu::TextureFormat);

impl PartialOrd for FormatKey {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for FormatKey {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        format!("{:?}", self.0).cmp(&format!("{:?}", other.0))
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Tonemapper {
    /// Khronos PBR Neutral: hue-preserving, base colours reproduce as authored. The default.
    Neutral,
    /// ACES filmic (Hill's RRT+ODT fit).
    Aces,
    /// Clamp only.
    None,
}

impl Tonemapper {
    fn constant(self) -> f64 {
        match self {
            Tonemapper::Neutral => 0.0,
            Tonemapper::Aces => 1.0,
            Tonemapper::None => 2.0,
        }
    }
}

pub struct PipelineCache {
    shaders: ShaderLibrary,
    pub view_layout: wgpu::BindGroupLayout,
    pub material_layout: wgpu::BindGroupLayout,
    pub tonemap_layout: wgpu::BindGroupLayout,
    pub mipmap_layout: wgpu::BindGroupLayout,
    forward_layout: wgpu::PipelineLayout,
    tonemap_pipeline_layout: wgpu::PipelineLayout,
    mipmap_pipeline_layout: wgpu::PipelineLayout,
    forward: HashMap<PipelineKey, wgpu::RenderPipeline>,
    tonemap: HashMap<(Tonemapper, wgpu::TextureFormat), wgpu::RenderPipeline>,
    mipmap: HashMap<wgpu::TextureFormat, wgpu::RenderPipeline>,
}

fn storage(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

impl PipelineCache {
    pub fn new(device: &wgpu::Device, shaders: ShaderLibrary) -> Self {
        let vf = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
        let view_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("view"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: vf,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                storage(1, wgpu::ShaderStages::VERTEX),
                storage(2, wgpu::ShaderStages::VERTEX),
                storage(3, wgpu::ShaderStages::FRAGMENT),
                storage(4, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        let mut material_entries = Vec::new();
        for i in 0..5u32 {
            material_entries.push(wgpu::BindGroupLayoutEntry {
                binding: 2 * i,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            });
            material_entries.push(wgpu::BindGroupLayoutEntry {
                binding: 2 * i + 1,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            });
        }
        let material_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("material"),
            entries: &material_entries,
        });
        let tonemap_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("tonemap"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            }],
        });
        let mipmap_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("mipmap"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let mipmap_pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("mipmap"),
            bind_group_layouts: &[Some(&mipmap_layout)],
            immediate_size: 0,
        });
        let forward_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("forward"),
            bind_group_layouts: &[Some(&view_layout), Some(&material_layout)],
            immediate_size: 0,
        });
        let tonemap_pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("tonemap"),
            bind_group_layouts: &[Some(&tonemap_layout)],
            immediate_size: 0,
        });
        Self {
            shaders,
            view_layout,
            material_layout,
            tonemap_layout,
            mipmap_layout,
            forward_layout,
            tonemap_pipeline_layout,
            mipmap_pipeline_layout,
            forward: HashMap::new(),
            tonemap: HashMap::new(),
            mipmap: HashMap::new(),
        }
    }

    pub fn forward_pipeline_count(&self) -> usize {
        self.forward.len()
    }

    pub fn forward(&mut self, device: &wgpu::Device, key: PipelineKey) -> &wgpu::RenderPipeline {
        if !self.forward.contains_key(&key) {
            let p = self.create_forward(device, key);
            self.forward.insert(key, p);
        }
        &self.forward[&key]
    }

    /// A pipeline already created by [`PipelineCache::forward`].
    pub fn forward_cached(&self, key: &PipelineKey) -> Option<&wgpu::RenderPipeline> {
        self.forward.get(key)
    }

    fn create_forward(&self, device: &wgpu::Device, key: PipelineKey) -> wgpu::RenderPipeline {
        let module = self.shaders.get("forward.wgsl");
        let alpha = match key.alpha {
            AlphaKey::Opaque => 0.0,
            AlphaKey::Mask => 1.0,
            AlphaKey::Blend => 2.0,
        };
        let constants = [("ALPHA_MODE", alpha), ("UNLIT", if key.unlit { 1.0 } else { 0.0 })];
        let blend = (key.alpha == AlphaKey::Blend).then_some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING);
        let label = format!("forward {key:?}");
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(&label),
            layout: Some(&self.forward_layout),
            vertex: wgpu::VertexState {
                module,
                entry_point: Some("vs_main"),
                compilation_options: wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() },
                buffers: &[Some(GpuVertex::layout())],
            },
            primitive: wgpu::PrimitiveState {
                topology: match key.topology {
                    TopologyKey::Triangles => wgpu::PrimitiveTopology::TriangleList,
                    TopologyKey::Lines => wgpu::PrimitiveTopology::LineList,
                    TopologyKey::Points => wgpu::PrimitiveTopology::PointList,
                },
                strip_index_format: None,
                front_face: if key.front_face_cw { wgpu::FrontFace::Cw } else { wgpu::FrontFace::Ccw },
                cull_mode: key.cull_back_faces.then_some(wgpu::Face::Back),
                unclipped_depth: false,
                polygon_mode: wgpu::PolygonMode::Fill,
                conservative: false,
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: key.depth_format.0,
                // Blended surfaces are sorted back to front and must not hide what lies behind
                // them in later draws.
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
                compilation_options: wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() },
                targets: &[Some(wgpu::ColorTargetState {
                    format: key.color_format.0,
                    blend,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    }

    pub fn tonemap(
        &mut self,
        device: &wgpu::Device,
        tonemapper: Tonemapper,
        format: wgpu::TextureFormat,
    ) -> &wgpu::RenderPipeline {
        let key = (tonemapper, format);
        if !self.tonemap.contains_key(&key) {
            let module = self.shaders.get("tonemap.wgsl");
            let encode = if format.is_srgb() { 0.0 } else { 1.0 };
            let constants = [("TONEMAPPER", tonemapper.constant()), ("ENCODE_SRGB", encode)];
            let p = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("tonemap"),
                layout: Some(&self.tonemap_pipeline_layout),
                vertex: wgpu::VertexState {
                    module,
                    entry_point: Some("vs_main"),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: &constants,
                        ..Default::default()
                    },
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module,
                    entry_point: Some("fs_main"),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: &constants,
                        ..Default::default()
                    },
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            });
            self.tonemap.insert(key, p);
        }
        &self.tonemap[&key]
    }

    /// The pipeline that writes one mip level of a texture of `format` from the level above.
    pub fn mipmap(&mut self, device: &wgpu::Device, format: wgpu::TextureFormat) -> &wgpu::RenderPipeline {
        if !self.mipmap.contains_key(&format) {
            let module = self.shaders.get("mipmap.wgsl");
            let p = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("mipmap"),
                layout: Some(&self.mipmap_pipeline_layout),
                vertex: wgpu::VertexState {
                    module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            });
            self.mipmap.insert(format, p);
        }
        &self.mipmap[&format]
    }
}
