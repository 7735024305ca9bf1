//! Bloom: a half-size mip chain of the HDR frame, down then up (`bloom.wgsl`); the tonemap pass
//! mixes its level 0 in by `strength` (energy-preserving: a uniform image is unchanged).
//!
//! A post-processing stage (`features::post`): it prepares before the tonemap stage, leaving
//! its level 0 and its fields of the parameters buffer for it. The chain is sized with the
//! frame and made again only when the frame's size or the level count changes; the group that
//! reads the frame only when the frame's HDR target is replaced.

use crate::features::post::{Decision, PostPrepare, PostShared, PostStage, Target};
use crate::frame_context::FrameContext;
use crate::gpu::formats::HDR_FORMAT;
use crate::gpu::timing::GpuTimer;
use crate::pass::Pass;
use crate::pipelines::{PipelineCache, ShaderError, parts};

mod pipeline;
pub use pipeline::{BloomFamily, BloomStep};

pub const PASS: Pass = Pass::new("Bloom", "HDR colour -> half-size mip chain");

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

impl BloomSettings {
    pub fn validate(&self) -> Result<(), String> {
        if !(0.0..=1.0).contains(&self.strength) {
            return Err(format!("bloom strength {} must lie in 0..=1", self.strength));
        }
        if !(1..=12).contains(&self.levels) {
            return Err(format!("bloom levels {} must lie in 1..=12", self.levels));
        }
        Ok(())
    }
}

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

pub struct Bloom {
    chain: Option<BloomChain>,
}

fn bloom_levels(frame: (u32, u32), most: u32) -> u32 {
    // Level 0 is half the frame; stop before a level's shorter side drops under 4 texels.
    let shorter = frame.0.min(frame.1).max(1);
    most.min(shorter.ilog2().saturating_sub(2)).max(1)
}

impl Bloom {
    /// Registers bloom's pipeline family.
    pub fn new(device: &wgpu::Device, pipelines: &mut PipelineCache) -> Self {
        pipelines.register(BloomFamily::new(device, &parts::filtered_source_layout(device)));
        Self { chain: None }
    }
}

impl PostStage for Bloom {
    /// `None`: off.
    type Settings = Option<BloomSettings>;
    const PASS: Pass = PASS;

    fn wants_hdr(settings: &Option<BloomSettings>) -> bool {
        settings.is_some()
    }

    fn prepare(&mut self, cx: &PostPrepare, settings: &Option<BloomSettings>, shared: &mut PostShared) -> Decision {
        let (Some(b), Some(hdr)) = (settings, cx.hdr) else {
            self.chain = None;
            return Decision::LeftOut("bloom is off");
        };
        let frame = cx.size;
        let levels = bloom_levels(frame, b.levels);
        let sampler = &shared.sampler;
        match &mut self.chain {
            Some(chain) if chain.frame == frame && chain.views.len() as u32 == levels => {
                chain.rebind_source(cx.device, cx.pipelines, sampler, hdr);
            }
            _ => self.chain = Some(BloomChain::new(cx.device, cx.pipelines, sampler, frame, hdr, levels)),
        }
        let chain = self.chain.as_ref().expect("made above");
        shared.bloom = Some(chain.views[0].clone());
        shared.params.bloom_strength = b.strength;
        shared.params.bloom_norm = 1.0 / chain.views.len() as f32;
        Decision::Runs("bloom is on")
    }

    fn encode(&mut self, cx: &mut FrameContext, _: &PostShared, _: &Target) -> Result<(), ShaderError> {
        let Some(chain) = &self.chain else { return Ok(()) };
        let (encoder, device, pipelines, mut timer) =
            (&mut *cx.encoder, cx.device, &mut *cx.pipelines, cx.timer.as_deref_mut());
        pipelines.prepare::<BloomFamily>(device, [BloomStep::DownFirst, BloomStep::Down, BloomStep::Up])?;
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
        Ok(())
    }

    fn gpu_bytes(&self) -> u64 {
        self.chain.as_ref().map_or(0, |b| {
            (0..b.texture.mip_level_count())
                .map(|l| ((b.texture.width() >> l).max(1) * (b.texture.height() >> l).max(1)) as u64 * 8)
                .sum()
        })
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
    fn bloom_levels_stop_before_tiny_levels() {
        assert_eq!(bloom_levels((1920, 1080), 7), 7);
        assert_eq!(bloom_levels((64, 64), 7), 4);
        assert_eq!(bloom_levels((4, 4), 7), 1);
    }

    #[test]
    fn settings_are_range_checked() {
        assert!(BloomSettings::default().validate().is_ok());
        let bad = BloomSettings { strength: 2.0, levels: 7 };
        assert!(bad.validate().unwrap_err().contains("strength"));
        assert!(BloomSettings { levels: 0, ..Default::default() }.validate().unwrap_err().contains("levels"));
    }
}
