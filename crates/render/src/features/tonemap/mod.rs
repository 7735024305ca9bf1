//! Tonemap: one full-screen triangle from the resolved HDR frame (with bloom's level 0 and
//! automatic exposure's correction when they run) into the output, or into the input of the
//! stage after it (FXAA's intermediate).
//!
//! A post-processing stage (`features::post`), after the stages that feed it: it binds the HDR
//! frame, bloom's level 0 (a 1×1 stand-in without bloom), the chain's sampler and its
//! parameters buffer, and remakes that group only when a view in it is replaced.
//!
//! When nothing reads the HDR colour the pass does not run: the forward shader applies the same
//! display transform (`shaders/display.wgsl`) and draws into the output, and the clear colour,
//! which no shader touches, goes through [`display_color`], this module's CPU copy of it.

use crate::features::post::{Decision, PostPrepare, PostShared, PostStage, Target};
use crate::frame_context::FrameContext;
use crate::gpu::formats::HDR_FORMAT;
use crate::pass::Pass;
use crate::pipelines::parts::{self, sampler, storage, texture};
use crate::pipelines::{Compiler, PipelineCache, PipelineFamily, ShaderDefs, ShaderError};
use crate::resources::draws::Tonemapper;

pub const PASS: Pass = Pass::new("Tonemap", "HDR colour [, bloom chain] [, exposure] -> output (sRGB)");

/// The tonemap stage: its inputs' bind group and the bloom stand-in.
pub struct Tonemap {
    bloom_stand_in: wgpu::TextureView,
    /// The group, and the HDR and bloom views it holds.
    group: Option<(wgpu::BindGroup, wgpu::TextureView, Option<wgpu::TextureView>)>,
    /// The curve this frame was prepared with.
    tonemapper: Tonemapper,
}

impl Tonemap {
    /// Registers the tonemap pipeline family.
    pub fn new(device: &wgpu::Device, pipelines: &mut PipelineCache) -> Self {
        pipelines.register(TonemapFamily::new(device));
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
        Self { bloom_stand_in: stand_in.create_view(&Default::default()), group: None, tonemapper: Tonemapper::Neutral }
    }
}

impl PostStage for Tonemap {
    type Settings = Tonemapper;
    const PASS: Pass = PASS;

    fn wants_hdr(_: &Tonemapper) -> bool {
        false
    }

    fn prepare(&mut self, cx: &PostPrepare, tonemapper: &Tonemapper, shared: &mut PostShared) -> Decision {
        self.tonemapper = *tonemapper;
        let Some(hdr) = cx.hdr else {
            self.group = None;
            return Decision::LeftOut(
                "nothing reads the HDR colour (MSAA 1, or MSAA resolving display colours; no \
                 post-processing, environment background, blended draws, gizmos, deferred \
                 lights or HDR readback): the opaque pass tonemaps and draws into the output",
            );
        };
        let bloom = shared.bloom.clone();
        if self.group.as_ref().is_none_or(|(_, h, b)| h != hdr || *b != bloom) {
            let group = cx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("tonemap inputs"),
                layout: &cx.pipelines.family::<TonemapFamily>().layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(hdr) },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(bloom.as_ref().unwrap_or(&self.bloom_stand_in)),
                    },
                    wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&shared.sampler) },
                    wgpu::BindGroupEntry { binding: 3, resource: shared.buffer().as_entire_binding() },
                ],
            });
            self.group = Some((group, hdr.clone(), bloom));
        }
        Decision::Runs("the HDR colour is tonemapped into the output")
    }

    fn encode(&mut self, cx: &mut FrameContext, shared: &PostShared, output: &Target) -> Result<(), ShaderError> {
        let Some((group, _, _)) = &self.group else { return Ok(()) };
        let key = TonemapKey {
            tonemapper: self.tonemapper,
            format: output.format,
            bloom: shared.bloom.is_some(),
            auto_exposure: shared.auto_exposure,
        };
        encode(cx, group, key, output)
    }
}

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

/// The tonemap pipelines, with the layout of their inputs: the resolved HDR frame, the bloom
/// chain's level 0, its sampler, the post parameters.
pub struct TonemapFamily {
    pub layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
}

impl TonemapFamily {
    pub fn new(device: &wgpu::Device) -> Self {
        let layout = parts::bind_group_layout(
            device,
            "tonemap",
            &[texture(0, false), texture(1, true), sampler(2), storage(3, wgpu::ShaderStages::FRAGMENT)],
        );
        let pipeline_layout = parts::pipeline_layout(device, "tonemap", &[&layout]);
        Self { layout, pipeline_layout }
    }
}

impl PipelineFamily for TonemapFamily {
    type Key = TonemapKey;
    type Pipeline = wgpu::RenderPipeline;
    const NAME: &'static str = "tonemap";

    fn shader(&self, key: &TonemapKey) -> (&'static str, ShaderDefs) {
        let defs = ShaderDefs::default()
            .with("TONEMAP_NEUTRAL", key.tonemapper == Tonemapper::Neutral)
            .with("TONEMAP_ACES", key.tonemapper == Tonemapper::Aces)
            .with("ENCODE_SRGB", !key.format.is_srgb())
            .with("BLOOM", key.bloom)
            .with("AUTO_EXPOSURE", key.auto_exposure);
        ("tonemap.wgsl", defs)
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, key: &TonemapKey) -> wgpu::RenderPipeline {
        parts::fullscreen_pipeline(device, &self.pipeline_layout, module, key.format, "tonemap")
    }
}

fn encode(
    cx: &mut FrameContext,
    inputs: &wgpu::BindGroup,
    key: TonemapKey,
    output: &Target,
) -> Result<(), ShaderError> {
    let (encoder, device, pipelines, timer) =
        (&mut *cx.encoder, cx.device, &mut *cx.pipelines, cx.timer.as_deref_mut());
    let pipeline = pipelines.get::<TonemapFamily>(device, key)?;
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("tonemap"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: &output.view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: timer.and_then(|t| t.pass("tonemap")),
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, inputs, &[]);
    pass.draw(0..3, 0..1);
    Ok(())
}

/// `display.wgsl`'s `display_rgb` on the CPU: the display colour of an exposed linear HDR colour,
/// sRGB-encoded only when `encode_srgb` (an output format the hardware does not encode). The one
/// CPU copy of the curves: direct output's clear colour, and `penumbra report`'s reference images
/// (whose test holds this equal to the GPU's tonemap pass).
pub fn display_color(tonemapper: Tonemapper, rgb: [f64; 3], encode_srgb: bool) -> [f64; 3] {
    let c = rgb.map(|v| if v.is_nan() { 0.0 } else { v.max(0.0) });
    let mapped = match tonemapper {
        Tonemapper::Neutral => pbr_neutral(c),
        Tonemapper::Aces => aces_hill(c),
        Tonemapper::None => c,
    };
    mapped.map(|v| {
        let v = v.clamp(0.0, 1.0);
        if encode_srgb { srgb_encode(v) } else { v }
    })
}

fn pbr_neutral(mut c: [f64; 3]) -> [f64; 3] {
    const START: f64 = 0.8 - 0.04;
    const DESATURATION: f64 = 0.15;
    let x = c[0].min(c[1]).min(c[2]);
    let offset = if x < 0.08 { x - 6.25 * x * x } else { 0.04 };
    c = c.map(|v| v - offset);
    let peak = c[0].max(c[1]).max(c[2]);
    if peak < START {
        return c;
    }
    let d = 1.0 - START;
    let new_peak = 1.0 - d * d / (peak + d - START);
    let g = 1.0 - 1.0 / (DESATURATION * (peak - new_peak) + 1.0);
    c.map(|v| {
        let v = v * new_peak / peak;
        v + (new_peak - v) * g
    })
}

fn aces_hill(c: [f64; 3]) -> [f64; 3] {
    // Row-major, as in Hill's HLSL (display.wgsl holds the column-major transposes).
    const INPUT: [[f64; 3]; 3] =
        [[0.59719, 0.35458, 0.04823], [0.07600, 0.90834, 0.01566], [0.02840, 0.13383, 0.83777]];
    const OUTPUT: [[f64; 3]; 3] =
        [[1.60475, -0.53108, -0.07367], [-0.10208, 1.10813, -0.00605], [-0.00327, -0.07276, 1.07602]];
    let mul = |m: &[[f64; 3]; 3], v: [f64; 3]| m.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2]);
    let fit = mul(&INPUT, c).map(|v| (v * (v + 0.0245786) - 0.000090537) / (v * (0.983729 * v + 0.4329510) + 0.238081));
    mul(&OUTPUT, fit).map(|v| v.clamp(0.0, 1.0))
}

fn srgb_encode(c: f64) -> f64 {
    if c <= 0.0031308 { c * 12.92 } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_color_keeps_dark_colours_and_compresses_bright_ones() {
        // Neutral leaves colours below its knee (minus the toe offset) as authored.
        let dark = display_color(Tonemapper::Neutral, [0.5, 0.3, 0.2], false);
        assert!((dark[0] - 0.46).abs() < 1e-9 && (dark[2] - 0.16).abs() < 1e-9, "{dark:?}");
        for t in [Tonemapper::Neutral, Tonemapper::Aces, Tonemapper::None] {
            let bright = display_color(t, [1e6, 1e6, 1e6], false);
            assert!(bright.iter().all(|v| (0.0..=1.0).contains(v)), "{t:?}: {bright:?}");
            assert_eq!(display_color(t, [f64::NAN, -1.0, 0.0], true), [0.0; 3], "{t:?}");
        }
        assert!((display_color(Tonemapper::None, [0.5, 1.0, 0.0], true)[0] - 0.735_356_983).abs() < 1e-6);
    }
}
