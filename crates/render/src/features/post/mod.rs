//! Post-processing: the one owner of what happens between the resolved HDR frame and the
//! output, besides the tonemap curve itself (`tonemap.rs`).
//!
//! Data flow, each step only when its setting is on (the frame plan lists each):
//! 1. bloom (`bloom.wgsl`): a half-size mip chain of the HDR frame, down then up; the tonemap
//!    pass mixes its level 0 in by `strength` (energy-preserving: a uniform image is unchanged);
//! 2. automatic exposure (`exposure.wgsl`): a luminance histogram of the HDR frame and its
//!    percentile-trimmed mean, turned into EV100, clamped, adapted over time, and written into
//!    the parameters buffer the tonemap pass reads (no CPU read-back, no frame of delay);
//! 3. the tonemap pass, into the output or, with FXAA (`features/fxaa`), into its 8-bit
//!    intermediate.
//!
//! Textures are sized with the frame and remade only when it changes size or a setting that
//! shapes them changes; bind groups only when a view they hold is replaced.

use bytemuck::{Pod, Zeroable};

use crate::features::tonemap::{TonemapFamily, TonemapKey};
use crate::frame_context::FrameContext;
use crate::gpu::formats::HDR_FORMAT;
use crate::gpu::timing::GpuTimer;
use crate::pipelines::{PipelineCache, ShaderError, parts};
use crate::resources::draws::Tonemapper;
use crate::targets::FrameTargets;

mod pipelines;
pub use pipelines::{BloomFamily, BloomStep, ExposureFamily, ExposureStep};

/// Which post-processing effects run. All off by default: each costs GPU time and changes
/// the image, so a scene asks for it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PostSettings {
    pub bloom: Option<BloomSettings>,
    /// FXAA on the tonemapped image (a cheap alternative to MSAA, or on top of it).
    pub fxaa: bool,
    /// Automatic exposure instead of the camera's EV100 alone.
    pub auto_exposure: Option<AutoExposure>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct BloomSettings {
    /// How much of the frame is replaced by its blur, 0..=1.
    pub strength: f32,
    /// Most levels of the half-size chain (fewer when the frame is small), 1..=12.
    pub levels: u32,
}

impl Default for BloomSettings {
    fn default() -> Self {
        Self { strength: 0.04, levels: 7 }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct AutoExposure {
    /// The EV100 range the exposure stays in.
    pub min_ev100: f32,
    pub max_ev100: f32,
    /// EV subtracted from the metered value (positive: brighter image).
    pub compensation: f32,
    /// Adaptation rate per second: each second closes 1 − e^(−speed) of the gap.
    pub speed: f32,
}

impl Default for AutoExposure {
    fn default() -> Self {
        Self { min_ev100: -6.0, max_ev100: 18.0, compensation: 0.0, speed: 3.0 }
    }
}

impl PostSettings {
    pub fn validate(&self) -> Result<(), String> {
        if let Some(b) = &self.bloom {
            if !(0.0..=1.0).contains(&b.strength) {
                return Err(format!("bloom strength {} must lie in 0..=1", b.strength));
            }
            if !(1..=12).contains(&b.levels) {
                return Err(format!("bloom levels {} must lie in 1..=12", b.levels));
            }
        }
        if let Some(a) = &self.auto_exposure {
            if !(a.min_ev100.is_finite() && a.max_ev100.is_finite() && a.min_ev100 <= a.max_ev100) {
                return Err(format!("auto exposure range {}..{} must be finite and ordered", a.min_ev100, a.max_ev100));
            }
            if !a.compensation.is_finite() {
                return Err(format!("auto exposure compensation {} must be finite", a.compensation));
            }
            if !(a.speed.is_finite() && a.speed > 0.0) {
                return Err(format!("auto exposure speed {} must be positive", a.speed));
            }
        }
        Ok(())
    }
}

/// Mirrors `PostParams` in `shaders/post_params.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
struct GpuPostParams {
    exposure_scale: f32,
    adapted_ev: f32,
    bloom_strength: f32,
    bloom_norm: f32,
    min_ev: f32,
    max_ev: f32,
    compensation: f32,
    adaptation: f32,
    camera_exposure: f32,
    _pad: [f32; 3],
}

/// Bytes of `GpuPostParams` the GPU owns while automatic exposure runs.
const GPU_OWNED: usize = 8;

struct BloomChain {
    frame: (u32, u32),
    texture: wgpu::Texture,
    views: Vec<wgpu::TextureView>,
    /// Group reading the frame (level 0's source), then each level's (level i + 1's source).
    down_groups: Vec<wgpu::BindGroup>,
    /// The frame view the first group reads.
    source: wgpu::TextureView,
    /// Group reading level i + 1 (drawn onto level i).
    up_groups: Vec<wgpu::BindGroup>,
}

/// What this frame's post-processing does (for the frame plan).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PostFrame {
    pub bloom: bool,
    pub auto_exposure: bool,
}

pub struct PostProcess {
    params: wgpu::Buffer,
    histogram: wgpu::Buffer,
    sampler: wgpu::Sampler,
    bloom_stand_in: wgpu::TextureView,
    bloom: Option<BloomChain>,
    /// Tonemap inputs, and the HDR view and bloom level they hold.
    tonemap_group: Option<(wgpu::BindGroup, wgpu::TextureView, Option<wgpu::TextureView>)>,
    exposure_group: Option<(wgpu::BindGroup, wgpu::TextureView)>,
    /// Automatic exposure has not metered a frame yet: the first jumps to its target.
    exposure_fresh: bool,
    frame: PostFrame,
}

fn bloom_levels(frame: (u32, u32), most: u32) -> u32 {
    // Level 0 is half the frame; stop before a level's shorter side drops under 4 texels.
    let shorter = frame.0.min(frame.1).max(1);
    most.min(shorter.ilog2().saturating_sub(2)).max(1)
}

impl PostProcess {
    /// Registers the post-processing pipeline families.
    pub fn new(device: &wgpu::Device, pipelines: &mut PipelineCache) -> Self {
        let source = parts::filtered_source_layout(device);
        pipelines.register(BloomFamily::new(device, &source));
        pipelines.register(ExposureFamily::new(device));
        let stand_in = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("no bloom"),
            size: wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: HDR_FORMAT,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let buffer = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        Self {
            params: buffer("post parameters", std::mem::size_of::<GpuPostParams>() as u64),
            histogram: buffer("luminance histogram", 256 * 4),
            sampler: device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("post linear clamp"),
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                ..Default::default()
            }),
            bloom_stand_in: stand_in.create_view(&Default::default()),
            bloom: None,
            tonemap_group: None,
            exposure_group: None,
            exposure_fresh: true,
            frame: PostFrame::default(),
        }
    }

    /// The parameters buffer (exposure correction and adapted EV first): for tests and tools.
    pub fn params_buffer(&self) -> &wgpu::Buffer {
        &self.params
    }

    pub fn gpu_bytes(&self) -> u64 {
        // Bloom's chain (FXAA's intermediate belongs to features/fxaa).
        self.bloom.as_ref().map_or(0, |b| {
            (0..b.texture.mip_level_count())
                .map(|l| ((b.texture.width() >> l).max(1) * (b.texture.height() >> l).max(1)) as u64 * 8)
                .sum()
        })
    }

    /// Sizes what the enabled effects need to the frame, writes their parameters, and remakes
    /// bind groups whose views were replaced.
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipelines: &PipelineCache,
        targets: &FrameTargets,
        settings: &PostSettings,
        delta_seconds: f32,
        camera_exposure: f32,
    ) -> PostFrame {
        let frame = targets.size;
        let Some(hdr_view) = targets.hdr_view() else {
            // The frame draws straight into the output (nothing post-processes it): no effect
            // runs and there is no tonemap pass to feed.
            self.bloom = None;
            self.tonemap_group = None;
            self.exposure_group = None;
            self.exposure_fresh = true;
            self.frame = PostFrame::default();
            return self.frame;
        };
        match &settings.bloom {
            Some(b) => {
                let levels = bloom_levels(frame, b.levels);
                if self.bloom.as_ref().is_none_or(|c| c.frame != frame || c.views.len() as u32 != levels) {
                    self.bloom = Some(BloomChain::new(device, pipelines, &self.sampler, frame, hdr_view, levels));
                } else if let Some(chain) = &mut self.bloom {
                    chain.rebind_source(device, pipelines, &self.sampler, hdr_view);
                }
            }
            None => self.bloom = None,
        }
        let bloom_view = self.bloom.as_ref().map(|b| b.views[0].clone());
        let stale = self.tonemap_group.as_ref().is_none_or(|(_, hdr, bloom)| hdr != hdr_view || *bloom != bloom_view);
        if stale {
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("tonemap inputs"),
                layout: &pipelines.family::<TonemapFamily>().layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(hdr_view) },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(
                            bloom_view.as_ref().unwrap_or(&self.bloom_stand_in),
                        ),
                    },
                    wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&self.sampler) },
                    wgpu::BindGroupEntry { binding: 3, resource: self.params.as_entire_binding() },
                ],
            });
            self.tonemap_group = Some((group, hdr_view.clone(), bloom_view));
        }
        if settings.auto_exposure.is_some() {
            if self.exposure_group.as_ref().is_none_or(|(_, hdr)| hdr != hdr_view) {
                let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("automatic exposure"),
                    layout: &pipelines.family::<ExposureFamily>().layout,
                    entries: &[
                        wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(hdr_view) },
                        wgpu::BindGroupEntry { binding: 1, resource: self.histogram.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 2, resource: self.params.as_entire_binding() },
                    ],
                });
                self.exposure_group = Some((group, hdr_view.clone()));
            }
        } else {
            self.exposure_group = None;
            self.exposure_fresh = true;
        }

        let auto = settings.auto_exposure.clone().unwrap_or_default();
        let adaptation = if self.exposure_fresh { 1.0 } else { 1.0 - (-delta_seconds.max(0.0) * auto.speed).exp() };
        let params = GpuPostParams {
            exposure_scale: 1.0,
            adapted_ev: 0.0,
            bloom_strength: settings.bloom.as_ref().map_or(0.0, |b| b.strength),
            bloom_norm: self.bloom.as_ref().map_or(1.0, |b| 1.0 / b.views.len() as f32),
            min_ev: auto.min_ev100,
            max_ev: auto.max_ev100,
            compensation: auto.compensation,
            adaptation,
            camera_exposure,
            _pad: [0.0; 3],
        };
        let bytes = bytemuck::bytes_of(&params);
        // With automatic exposure the GPU owns the correction and its state.
        let from = if settings.auto_exposure.is_some() { GPU_OWNED } else { 0 };
        queue.write_buffer(&self.params, from as u64, &bytes[from..]);
        self.frame = PostFrame { bloom: self.bloom.is_some(), auto_exposure: settings.auto_exposure.is_some() };
        self.frame
    }

    /// Bloom and automatic exposure: after the HDR frame is resolved, before the tonemap pass.
    /// Marks the exposure metered once encoded.
    pub fn encode_before_tonemap(&mut self, cx: &mut FrameContext) -> Result<(), ShaderError> {
        let (encoder, device, pipelines, targets, mut timer) =
            (&mut *cx.encoder, cx.device, &mut *cx.pipelines, cx.targets, cx.timer.as_deref_mut());
        if self.frame.bloom {
            pipelines.prepare::<BloomFamily>(device, [BloomStep::DownFirst, BloomStep::Down, BloomStep::Up])?;
        }
        if self.frame.auto_exposure {
            pipelines.prepare::<ExposureFamily>(device, [ExposureStep::Histogram, ExposureStep::Average])?;
        }
        if let Some(chain) = &self.bloom {
            let clear = wgpu::LoadOp::Clear(wgpu::Color::BLACK);
            for (i, group) in chain.down_groups.iter().enumerate() {
                let step = if i == 0 { BloomStep::DownFirst } else { BloomStep::Down };
                let mut pass = bloom_pass(encoder, &chain.views[i], clear, timer.as_deref_mut());
                pass.set_pipeline(pipelines.cached::<BloomFamily>(&step).expect("compiled above"));
                pass.set_bind_group(0, group, &[]);
                pass.draw(0..3, 0..1);
            }
            for (i, group) in chain.up_groups.iter().enumerate().rev() {
                let mut pass = bloom_pass(encoder, &chain.views[i], wgpu::LoadOp::Load, timer.as_deref_mut());
                pass.set_pipeline(pipelines.cached::<BloomFamily>(&BloomStep::Up).expect("compiled above"));
                pass.set_bind_group(0, group, &[]);
                pass.draw(0..3, 0..1);
            }
        }
        if let Some((group, _)) = &self.exposure_group {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("automatic exposure"),
                timestamp_writes: timer.and_then(|t| t.compute_pass("exposure")),
            });
            pass.set_bind_group(0, group, &[]);
            pass.set_pipeline(pipelines.cached::<ExposureFamily>(&ExposureStep::Histogram).expect("compiled above"));
            let (w, h) = targets.size;
            pass.dispatch_workgroups(w.div_ceil(16), h.div_ceil(16), 1);
            pass.set_pipeline(pipelines.cached::<ExposureFamily>(&ExposureStep::Average).expect("compiled above"));
            pass.dispatch_workgroups(1, 1, 1);
            self.exposure_fresh = false;
        }
        Ok(())
    }

    /// The tonemap pipeline key for this frame, writing a target of `format` (the output, or
    /// FXAA's intermediate).
    pub fn tonemap_key(&self, tonemapper: Tonemapper, format: wgpu::TextureFormat) -> TonemapKey {
        TonemapKey { tonemapper, format, bloom: self.frame.bloom, auto_exposure: self.frame.auto_exposure }
    }

    pub fn tonemap_group(&self) -> &wgpu::BindGroup {
        &self.tonemap_group.as_ref().expect("prepared before encoding").0
    }
}

fn bloom_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    view: &wgpu::TextureView,
    load: wgpu::LoadOp<wgpu::Color>,
    timer: Option<&mut GpuTimer>,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("bloom"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: timer.and_then(|t| t.pass("bloom")),
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

fn sampled_group(
    device: &wgpu::Device,
    pipelines: &PipelineCache,
    sampler: &wgpu::Sampler,
    view: &wgpu::TextureView,
    label: &str,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout: &pipelines.family::<BloomFamily>().source,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(view) },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(sampler) },
        ],
    })
}

impl BloomChain {
    fn new(
        device: &wgpu::Device,
        pipelines: &PipelineCache,
        sampler: &wgpu::Sampler,
        frame: (u32, u32),
        hdr_view: &wgpu::TextureView,
        levels: u32,
    ) -> Self {
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("bloom"),
            size: wgpu::Extent3d {
                width: (frame.0 / 2).max(1),
                height: (frame.1 / 2).max(1),
                depth_or_array_layers: 1,
            },
            mip_level_count: levels,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: HDR_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let views: Vec<wgpu::TextureView> = (0..levels)
            .map(|l| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    base_mip_level: l,
                    mip_level_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        let mut down_groups = vec![sampled_group(device, pipelines, sampler, hdr_view, "bloom from frame")];
        for v in &views[..views.len() - 1] {
            down_groups.push(sampled_group(device, pipelines, sampler, v, "bloom down"));
        }
        let up_groups = views[1..].iter().map(|v| sampled_group(device, pipelines, sampler, v, "bloom up")).collect();
        Self { frame, texture, views, down_groups, up_groups, source: hdr_view.clone() }
    }

    /// The first group reads the frame: remade when the frame's HDR target was replaced at the
    /// same size (a sample-count change).
    fn rebind_source(
        &mut self,
        device: &wgpu::Device,
        pipelines: &PipelineCache,
        sampler: &wgpu::Sampler,
        hdr_view: &wgpu::TextureView,
    ) {
        if self.source != *hdr_view {
            self.down_groups[0] = sampled_group(device, pipelines, sampler, hdr_view, "bloom from frame");
            self.source = hdr_view.clone();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gpu_post_params_mirror_the_shaders_parameters() {
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuPostParams,
            "exposure.wgsl",
            [],
            "PostParams",
            [
                exposure_scale,
                adapted_ev,
                bloom_strength,
                bloom_norm,
                min_ev,
                max_ev,
                compensation,
                adaptation,
                camera_exposure
            ]
        );
    }

    #[test]
    fn bloom_levels_stop_before_tiny_levels() {
        assert_eq!(bloom_levels((1920, 1080), 7), 7);
        assert_eq!(bloom_levels((64, 64), 7), 4);
        assert_eq!(bloom_levels((4, 4), 7), 1);
    }

    #[test]
    fn settings_are_range_checked() {
        assert!(PostSettings::default().validate().is_ok());
        let bad = PostSettings { bloom: Some(BloomSettings { strength: 2.0, levels: 7 }), ..Default::default() };
        assert!(bad.validate().unwrap_err().contains("strength"));
        let bad = PostSettings {
            auto_exposure: Some(AutoExposure { min_ev100: 5.0, max_ev100: 1.0, ..Default::default() }),
            ..Default::default()
        };
        assert!(bad.validate().unwrap_err().contains("range"));
    }
}
