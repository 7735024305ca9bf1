//! The environment's pipelines: the compute steps that make and prefilter its maps
//! (`env_source.wgsl`, `env_filter.wgsl`, `brdf_lut.wgsl`) and the background pass
//! (`background.wgsl`). The part of the pipeline cache that serves `environment/`.

use std::collections::HashSet;

use super::{PipelineCache, buffer_entry, checked_pipeline, compute_pipeline, rebuild, stale};
use crate::pipelines::shader_library::{ShaderDefs, ShaderError, ShaderLibrary};

/// The format of every environment map (source cube, specular cube, split-sum table).
pub const ENVIRONMENT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// The equirectangular image as uploaded (f32: sources brighter than f16 allows keep their
/// energy until the cube is written, scaled).
pub const EQUIRECT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// One compute step of making the environment's maps, in the order they run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum EnvStep {
    /// Level 0 of the source cube from the sky, the studio gradient or the image.
    Source,
    /// A source mip from the one above.
    Downsample,
    /// One roughness level of the specular cube.
    Specular,
    /// Diffuse irradiance as spherical harmonics.
    IrradianceSh,
    /// The split-sum table (once).
    BrdfLut,
}

/// Where the background is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BackgroundMode {
    /// Inside the forward pass of `samples` samples, after the opaque draws, where the depth is
    /// still the far plane: with deferred local lights, whose colour alpha carries roughness
    /// (the pass also writes the surface target, which the background leaves alone).
    InPass { samples: u32 },
    /// Over the resolved frame, weighted by what the surfaces left uncovered (1 − alpha): one
    /// sample a pixel instead of one a sample.
    Composite,
}

impl EnvStep {
    pub const ALL: [EnvStep; 5] =
        [EnvStep::Source, EnvStep::Downsample, EnvStep::Specular, EnvStep::IrradianceSh, EnvStep::BrdfLut];

    fn file(self) -> &'static str {
        match self {
            EnvStep::Source => "env_source.wgsl",
            EnvStep::BrdfLut => "brdf_lut.wgsl",
            _ => "env_filter.wgsl",
        }
    }

    fn entry(self) -> &'static str {
        match self {
            EnvStep::Source => "make_source",
            EnvStep::Downsample => "downsample",
            EnvStep::Specular => "prefilter_specular",
            EnvStep::IrradianceSh => "project_sh",
            EnvStep::BrdfLut => "integrate_brdf",
        }
    }

    fn index(self) -> usize {
        self as usize
    }
}

pub(super) struct EnvLayouts {
    /// Bind group layouts by `EnvStep`.
    pub steps: [wgpu::BindGroupLayout; 5],
    step_pipelines: [wgpu::PipelineLayout; 5],
    /// The background pass reads only the view group.
    background: wgpu::PipelineLayout,
}

fn storage_texture(binding: u32, dimension: wgpu::TextureViewDimension) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format: ENVIRONMENT_FORMAT,
            view_dimension: dimension,
        },
        count: None,
    }
}

fn sampled(binding: u32, dimension: wgpu::TextureViewDimension, filterable: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension: dimension,
            multisampled: false,
        },
        count: None,
    }
}

pub(super) fn env_layouts(device: &wgpu::Device, view_layout: &wgpu::BindGroupLayout) -> EnvLayouts {
    use wgpu::TextureViewDimension::{Cube, D2, D2Array};
    let compute = wgpu::ShaderStages::COMPUTE;
    let uniform = |b| buffer_entry(b, compute, wgpu::BufferBindingType::Uniform);
    let layout = |label, entries: &[wgpu::BindGroupLayoutEntry]| {
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries })
    };
    let steps = [
        layout("environment source", &[uniform(0), storage_texture(1, D2Array), sampled(2, D2, false)]),
        layout("environment downsample", &[sampled(0, D2Array, false), storage_texture(1, D2Array)]),
        layout(
            "environment specular",
            &[
                uniform(0),
                sampled(1, Cube, true),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: compute,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
                storage_texture(3, D2Array),
            ],
        ),
        layout(
            "environment irradiance",
            &[
                uniform(0),
                sampled(1, D2Array, false),
                buffer_entry(2, compute, wgpu::BufferBindingType::Storage { read_only: false }),
            ],
        ),
        layout("split-sum table", &[storage_texture(0, D2)]),
    ];
    let pipeline_layout = |label, groups: &[Option<&wgpu::BindGroupLayout>]| {
        device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: groups,
            immediate_size: 0,
        })
    };
    EnvLayouts {
        step_pipelines: std::array::from_fn(|i| pipeline_layout("environment step", &[Some(&steps[i])])),
        steps,
        background: pipeline_layout("background", &[Some(view_layout)]),
    }
}

impl PipelineCache {
    pub fn env_layout(&self, step: EnvStep) -> &wgpu::BindGroupLayout {
        &self.env_layouts.steps[step.index()]
    }

    /// Compiles these steps' pipelines (first use only); the first error stops it.
    pub fn compile_env_steps(&mut self, device: &wgpu::Device, steps: &[EnvStep]) -> Result<(), ShaderError> {
        for &step in steps {
            if !self.env.contains_key(&step) {
                let p = self.create_env_step(device, &mut None, step)?;
                self.env.insert(step, p);
            }
        }
        Ok(())
    }

    pub fn env_step_cached(&self, step: EnvStep) -> Option<&wgpu::ComputePipeline> {
        self.env.get(&step)
    }

    /// The background pipeline of `mode`, compiled on first use.
    pub fn background(
        &mut self,
        device: &wgpu::Device,
        mode: BackgroundMode,
    ) -> Result<&wgpu::RenderPipeline, ShaderError> {
        if !self.background.contains_key(&mode) {
            let p = self.create_background(device, &mut None, mode)?;
            self.background.insert(mode, p);
        }
        Ok(&self.background[&mode])
    }

    pub fn background_cached(&self, mode: BackgroundMode) -> Option<&wgpu::RenderPipeline> {
        self.background.get(&mode)
    }

    pub(super) fn create_env_step(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        step: EnvStep,
    ) -> Result<wgpu::ComputePipeline, ShaderError> {
        let defs = ShaderDefs::default()
            .with("DOWNSAMPLE", step == EnvStep::Downsample)
            .with("SPECULAR", step == EnvStep::Specular)
            .with("IRRADIANCE_SH", step == EnvStep::IrradianceSh);
        let module = self.library(candidate).create_module(device, step.file(), &defs)?;
        self.compiled += 1;
        checked_pipeline(device, step.file(), || {
            compute_pipeline(
                device,
                &self.env_layouts.step_pipelines[step.index()],
                &module,
                step.entry(),
                step.entry(),
            )
        })
    }

    pub(super) fn create_background(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        mode: BackgroundMode,
    ) -> Result<wgpu::RenderPipeline, ShaderError> {
        let module = self.library(candidate).create_module(device, "background.wgsl", &ShaderDefs::default())?;
        self.compiled += 1;
        let color = |blend| {
            Some(wgpu::ColorTargetState {
                format: crate::targets::HDR_FORMAT,
                blend,
                write_mask: wgpu::ColorWrites::COLOR,
            })
        };
        let (samples, depth_stencil, targets) = match mode {
            // Only where the depth is still the cleared far plane: no surface there. Alpha keeps
            // what the clear wrote (deferred lights read it as "no surface").
            BackgroundMode::InPass { samples } => (
                samples,
                Some(wgpu::DepthStencilState {
                    format: crate::targets::DEPTH_FORMAT,
                    depth_write_enabled: Some(false),
                    depth_compare: Some(wgpu::CompareFunction::Equal),
                    stencil: wgpu::StencilState::default(),
                    bias: wgpu::DepthBiasState::default(),
                }),
                vec![
                    color(None),
                    Some(wgpu::ColorTargetState {
                        format: super::SURFACE_SHAPE_FORMAT,
                        blend: None,
                        write_mask: wgpu::ColorWrites::empty(),
                    }),
                ],
            ),
            // Premultiplied "under": the frame holds the surfaces' radiance with their coverage
            // in alpha (cleared to 0), so the background adds where coverage is short.
            BackgroundMode::Composite => (
                1,
                None,
                vec![color(Some(wgpu::BlendState {
                    color: wgpu::BlendComponent {
                        src_factor: wgpu::BlendFactor::OneMinusDstAlpha,
                        dst_factor: wgpu::BlendFactor::One,
                        operation: wgpu::BlendOperation::Add,
                    },
                    alpha: wgpu::BlendComponent {
                        src_factor: wgpu::BlendFactor::Zero,
                        dst_factor: wgpu::BlendFactor::One,
                        operation: wgpu::BlendOperation::Add,
                    },
                }))],
            ),
        };
        checked_pipeline(device, "background.wgsl", || {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("background"),
                layout: Some(&self.env_layouts.background),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil,
                multisample: wgpu::MultisampleState { count: samples, mask: !0, alpha_to_coverage_enabled: false },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &targets,
                }),
                multiview_mask: None,
                cache: None,
            })
        })
    }

    /// Rebuilds the environment pipelines whose entry file is `hit` (reads a changed file).
    pub(super) fn reload_env(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        hit: &HashSet<&str>,
    ) -> Result<EnvReload, ShaderError> {
        let mut out = EnvReload::default();
        for step in self.env.keys().copied().collect::<Vec<_>>() {
            if hit.contains(step.file()) {
                out.steps.push((step, self.create_env_step(device, candidate, step)?));
            }
        }
        out.background = rebuild(stale(hit.contains("background.wgsl"), &self.background), |k| {
            self.create_background(device, candidate, k)
        })?;
        Ok(out)
    }

    pub(super) fn env_pipeline_count(&self) -> usize {
        self.env.len() + self.background.len()
    }

    /// Swaps in what `reload` rebuilt; returns how many pipelines, by family.
    pub(super) fn apply_env_reload(&mut self, reload: EnvReload) -> [(&'static str, usize); 2] {
        let counts = [("environment", reload.steps.len()), ("background", reload.background.len())];
        self.env.extend(reload.steps);
        self.background.extend(reload.background);
        counts
    }
}

/// Environment pipelines rebuilt by a reload, swapped in only if every pipeline compiled.
#[derive(Default)]
pub(super) struct EnvReload {
    steps: Vec<(EnvStep, wgpu::ComputePipeline)>,
    background: Vec<(BackgroundMode, wgpu::RenderPipeline)>,
}

impl EnvReload {
    pub(super) fn rebuilds_steps(&self) -> bool {
        !self.steps.is_empty()
    }
}
