//! The environment's pipeline families: the compute steps that make and prefilter its maps
//! (`env_source.wgsl`, `env_filter.wgsl`, `brdf_lut.wgsl`) and the background pass
//! (`background.wgsl`), with their layouts.

use crate::gpu::formats::{DEPTH_FORMAT, ENVIRONMENT_FORMAT, HDR_FORMAT, SURFACE_SHAPE_FORMAT};
use crate::pipelines::parts::{self, buffer_entry};
use crate::pipelines::{Compiler, PipelineFamily, ShaderDefs};

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
    /// `surface`: the pass also writes the deferred lights' surface target (transmissive
    /// frames draw the background in the pass without one, so that their copy holds it).
    InPass { samples: u32, surface: bool },
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

    fn defs(self) -> ShaderDefs {
        ShaderDefs::default()
            .with("DOWNSAMPLE", self == EnvStep::Downsample)
            .with("SPECULAR", self == EnvStep::Specular)
            .with("IRRADIANCE_SH", self == EnvStep::IrradianceSh)
    }
}

struct EnvLayouts {
    steps: [wgpu::BindGroupLayout; 5],
    step_pipelines: [wgpu::PipelineLayout; 5],
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

fn env_layouts(device: &wgpu::Device, view_layout: &wgpu::BindGroupLayout) -> EnvLayouts {
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

/// The compute steps' pipelines, one per step, with their bind group layouts.
pub struct EnvStepFamily {
    steps: [wgpu::BindGroupLayout; 5],
    pipelines: [wgpu::PipelineLayout; 5],
}

/// The background pipelines, by where the background is drawn; they read only the view group.
pub struct BackgroundFamily {
    pipeline_layout: wgpu::PipelineLayout,
}

/// Both environment families (made together: they share the layouts' construction).
pub fn families(device: &wgpu::Device, view: &wgpu::BindGroupLayout) -> (EnvStepFamily, BackgroundFamily) {
    let EnvLayouts { steps, step_pipelines, background } = env_layouts(device, view);
    (EnvStepFamily { steps, pipelines: step_pipelines }, BackgroundFamily { pipeline_layout: background })
}

impl EnvStepFamily {
    /// The bind group layout of `step`.
    pub fn layout(&self, step: EnvStep) -> &wgpu::BindGroupLayout {
        &self.steps[step.index()]
    }
}

impl PipelineFamily for EnvStepFamily {
    type Key = EnvStep;
    type Pipeline = wgpu::ComputePipeline;
    const NAME: &'static str = "environment";

    fn shader(&self, step: &EnvStep) -> (&'static str, ShaderDefs) {
        (step.file(), step.defs())
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, step: &EnvStep) -> wgpu::ComputePipeline {
        parts::compute_pipeline(device, &self.pipelines[step.index()], module, step.entry(), step.entry())
    }
}

impl PipelineFamily for BackgroundFamily {
    type Key = BackgroundMode;
    type Pipeline = wgpu::RenderPipeline;
    const NAME: &'static str = "background";

    fn shader(&self, _: &BackgroundMode) -> (&'static str, ShaderDefs) {
        ("background.wgsl", ShaderDefs::default())
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, mode: &BackgroundMode) -> wgpu::RenderPipeline {
        let color =
            |blend| Some(wgpu::ColorTargetState { format: HDR_FORMAT, blend, write_mask: wgpu::ColorWrites::COLOR });
        let (samples, depth_stencil, targets) = match *mode {
            // Only where the depth is still the cleared far plane: no surface there. Alpha keeps
            // what the clear wrote (deferred lights read it as "no surface").
            BackgroundMode::InPass { samples, surface } => (
                samples,
                Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(false),
                    depth_compare: Some(wgpu::CompareFunction::Equal),
                    stencil: wgpu::StencilState::default(),
                    bias: wgpu::DepthBiasState::default(),
                }),
                [
                    color(None),
                    Some(wgpu::ColorTargetState {
                        format: SURFACE_SHAPE_FORMAT,
                        blend: None,
                        write_mask: wgpu::ColorWrites::empty(),
                    }),
                ][..if surface { 2 } else { 1 }]
                    .to_vec(),
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
                    alpha: parts::KEEP,
                }))],
            ),
        };
        let f =
            parts::Fullscreen { label: "background", fragment: "fs_main", targets: &targets, depth_stencil, samples };
        parts::fullscreen(device, &self.pipeline_layout, module, f)
    }
}
