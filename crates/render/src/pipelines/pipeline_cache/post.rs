//! Post-processing pipelines: the tonemap pass's variants, bloom's down- and upsampling
//! (`bloom.wgsl`), automatic exposure's histogram and average (`exposure.wgsl`) and FXAA
//! (`fxaa.wgsl`). The part of the pipeline cache that serves `passes::post` and
//! `passes::tonemap`.

use std::collections::HashSet;

use super::{
    PipelineCache, Tonemapper, buffer_entry, checked_pipeline, compute_pipeline, fullscreen_pipeline, rebuild, stale,
};
use crate::pipelines::shader_library::{ShaderDefs, ShaderError, ShaderLibrary};
use crate::targets::HDR_FORMAT;

/// Everything that selects a tonemap pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TonemapKey {
    pub tonemapper: Tonemapper,
    pub format: wgpu::TextureFormat,
    /// Mix in the bloom chain's level 0.
    pub bloom: bool,
    /// Apply automatic exposure's correction.
    pub auto_exposure: bool,
}

/// A bloom pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BloomStep {
    /// Level 0 from the frame (Karis-weighted).
    DownFirst,
    Down,
    /// Adds a level, tent-filtered, onto the level above.
    Up,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExposureStep {
    Histogram,
    Average,
}

pub(super) struct PostLayouts {
    pub exposure: wgpu::BindGroupLayout,
    exposure_pipeline: wgpu::PipelineLayout,
}

pub(super) fn post_layouts(device: &wgpu::Device) -> PostLayouts {
    let compute = wgpu::ShaderStages::COMPUTE;
    let read_write = wgpu::BufferBindingType::Storage { read_only: false };
    let exposure = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("automatic exposure"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: compute,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            },
            buffer_entry(1, compute, read_write),
            buffer_entry(2, compute, read_write),
        ],
    });
    let exposure_pipeline = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("automatic exposure"),
        bind_group_layouts: &[Some(&exposure)],
        immediate_size: 0,
    });
    PostLayouts { exposure, exposure_pipeline }
}

/// Post-processing pipelines rebuilt by a reload.
#[derive(Default)]
pub(super) struct PostReload {
    bloom: Vec<(BloomStep, wgpu::RenderPipeline)>,
    exposure: Vec<(ExposureStep, wgpu::ComputePipeline)>,
    fxaa: Vec<(wgpu::TextureFormat, wgpu::RenderPipeline)>,
}

impl PipelineCache {
    pub fn exposure_layout(&self) -> &wgpu::BindGroupLayout {
        &self.post_layouts.exposure
    }

    /// Compiles what this frame's post-processing needs (first use only).
    pub fn compile_post(
        &mut self,
        device: &wgpu::Device,
        bloom: bool,
        auto_exposure: bool,
        fxaa_format: Option<wgpu::TextureFormat>,
    ) -> Result<(), ShaderError> {
        if bloom {
            for step in [BloomStep::DownFirst, BloomStep::Down, BloomStep::Up] {
                if !self.bloom.contains_key(&step) {
                    let p = self.create_bloom(device, &mut None, step)?;
                    self.bloom.insert(step, p);
                }
            }
        }
        if auto_exposure {
            for step in [ExposureStep::Histogram, ExposureStep::Average] {
                if !self.exposure.contains_key(&step) {
                    let p = self.create_exposure(device, &mut None, step)?;
                    self.exposure.insert(step, p);
                }
            }
        }
        if let Some(format) = fxaa_format
            && !self.fxaa.contains_key(&format)
        {
            let p = self.create_fxaa(device, &mut None, format)?;
            self.fxaa.insert(format, p);
        }
        Ok(())
    }

    pub fn bloom_cached(&self, step: BloomStep) -> Option<&wgpu::RenderPipeline> {
        self.bloom.get(&step)
    }

    pub fn exposure_cached(&self, step: ExposureStep) -> Option<&wgpu::ComputePipeline> {
        self.exposure.get(&step)
    }

    pub fn fxaa_cached(&self, format: wgpu::TextureFormat) -> Option<&wgpu::RenderPipeline> {
        self.fxaa.get(&format)
    }

    fn create_bloom(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        step: BloomStep,
    ) -> Result<wgpu::RenderPipeline, ShaderError> {
        let defs = ShaderDefs::default().with("FIRST", step == BloomStep::DownFirst);
        let module = self.library(candidate).create_module(device, "bloom.wgsl", &defs)?;
        self.compiled += 1;
        let add = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let up = step == BloomStep::Up;
        checked_pipeline(device, "bloom.wgsl", || {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("bloom"),
                layout: Some(&self.filtered_source_pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(if up { "upsample" } else { "downsample" }),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: HDR_FORMAT,
                        blend: up.then_some(wgpu::BlendState { color: add, alpha: add }),
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        })
    }

    fn create_exposure(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        step: ExposureStep,
    ) -> Result<wgpu::ComputePipeline, ShaderError> {
        let module = self.library(candidate).create_module(device, "exposure.wgsl", &ShaderDefs::default())?;
        self.compiled += 1;
        let entry = match step {
            ExposureStep::Histogram => "build_histogram",
            ExposureStep::Average => "average",
        };
        checked_pipeline(device, "exposure.wgsl", || {
            compute_pipeline(device, &self.post_layouts.exposure_pipeline, &module, entry, entry)
        })
    }

    fn create_fxaa(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        format: wgpu::TextureFormat,
    ) -> Result<wgpu::RenderPipeline, ShaderError> {
        let defs = ShaderDefs::default().with("DECODE_SRGB", format.is_srgb());
        let module = self.library(candidate).create_module(device, "fxaa.wgsl", &defs)?;
        self.compiled += 1;
        checked_pipeline(device, "fxaa.wgsl", || {
            fullscreen_pipeline(device, &self.filtered_source_pipeline_layout, &module, format, "fxaa")
        })
    }

    pub(super) fn reload_post(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        hit: &HashSet<&str>,
    ) -> Result<PostReload, ShaderError> {
        let (bloom_hit, exposure_hit, fxaa_hit) =
            (hit.contains("bloom.wgsl"), hit.contains("exposure.wgsl"), hit.contains("fxaa.wgsl"));
        Ok(PostReload {
            bloom: rebuild(stale(bloom_hit, &self.bloom), |k| self.create_bloom(device, candidate, k))?,
            exposure: rebuild(stale(exposure_hit, &self.exposure), |k| self.create_exposure(device, candidate, k))?,
            fxaa: rebuild(stale(fxaa_hit, &self.fxaa), |k| self.create_fxaa(device, candidate, k))?,
        })
    }

    pub(super) fn post_pipeline_count(&self) -> usize {
        self.bloom.len() + self.exposure.len() + self.fxaa.len()
    }

    /// Swaps in what `reload` rebuilt; returns how many pipelines, by family.
    pub(super) fn apply_post_reload(&mut self, reload: PostReload) -> [(&'static str, usize); 3] {
        let counts = [("bloom", reload.bloom.len()), ("exposure", reload.exposure.len()), ("fxaa", reload.fxaa.len())];
        self.bloom.extend(reload.bloom);
        self.exposure.extend(reload.exposure);
        self.fxaa.extend(reload.fxaa);
        counts
    }
}
