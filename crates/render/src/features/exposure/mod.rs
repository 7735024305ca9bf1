//! Automatic exposure: a luminance histogram of the HDR frame and its percentile-trimmed mean
//! (`exposure.wgsl`), turned into EV100, clamped, adapted over time, and written into the
//! parameters buffer the tonemap pass reads (no CPU read-back, no frame of delay).
//!
//! A post-processing stage (`features::post`), before the tonemap stage. While it runs the GPU
//! owns the correction and the adapted EV100 in the parameters buffer; the first frame it runs
//! jumps to the metered value, later frames adapt at `speed`.

use crate::features::post::{Decision, PostPrepare, PostShared, PostStage, Target};
use crate::frame_context::FrameContext;
use crate::pass::Pass;
use crate::pipelines::{PipelineCache, ShaderError};

mod pipeline;
pub use pipeline::{ExposureFamily, ExposureStep};

pub const PASS: Pass = Pass::new("AutoExposure", "HDR colour -> luminance histogram -> adapted exposure");

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

impl AutoExposure {
    pub fn validate(&self) -> Result<(), String> {
        if !(self.min_ev100.is_finite() && self.max_ev100.is_finite() && self.min_ev100 <= self.max_ev100) {
            return Err(format!(
                "auto exposure range {}..{} must be finite and ordered",
                self.min_ev100, self.max_ev100
            ));
        }
        if !self.compensation.is_finite() {
            return Err(format!("auto exposure compensation {} must be finite", self.compensation));
        }
        if !(self.speed.is_finite() && self.speed > 0.0) {
            return Err(format!("auto exposure speed {} must be positive", self.speed));
        }
        Ok(())
    }
}

pub struct Exposure {
    histogram: wgpu::Buffer,
    /// The group and the HDR view it reads.
    group: Option<(wgpu::BindGroup, wgpu::TextureView)>,
    /// No frame metered yet: the first jumps to its target.
    fresh: bool,
    size: (u32, u32),
}

impl Exposure {
    /// Registers automatic exposure's pipeline family.
    pub fn new(device: &wgpu::Device, pipelines: &mut PipelineCache) -> Self {
        pipelines.register(ExposureFamily::new(device));
        let histogram = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("luminance histogram"),
            size: 256 * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Self { histogram, group: None, fresh: true, size: (0, 0) }
    }
}

impl PostStage for Exposure {
    /// `None`: off (the camera's EV100 alone).
    type Settings = Option<AutoExposure>;
    const PASS: Pass = PASS;

    fn wants_hdr(settings: &Option<AutoExposure>) -> bool {
        settings.is_some()
    }

    fn prepare(&mut self, cx: &PostPrepare, settings: &Option<AutoExposure>, shared: &mut PostShared) -> Decision {
        let (Some(auto), Some(hdr)) = (settings, cx.hdr) else {
            self.group = None;
            self.fresh = true;
            return Decision::LeftOut("automatic exposure is off");
        };
        if self.group.as_ref().is_none_or(|(_, view)| view != hdr) {
            let group = cx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("automatic exposure"),
                layout: &cx.pipelines.family::<ExposureFamily>().layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(hdr) },
                    wgpu::BindGroupEntry { binding: 1, resource: self.histogram.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 2, resource: shared.buffer().as_entire_binding() },
                ],
            });
            self.group = Some((group, hdr.clone()));
        }
        self.size = cx.size;
        let p = &mut shared.params;
        p.min_ev = auto.min_ev100;
        p.max_ev = auto.max_ev100;
        p.compensation = auto.compensation;
        p.adaptation = if self.fresh { 1.0 } else { 1.0 - (-cx.delta_seconds.max(0.0) * auto.speed).exp() };
        shared.auto_exposure = true;
        Decision::Runs("automatic exposure is on")
    }

    fn restart(&mut self) {
        self.fresh = true;
    }

    fn encode(&mut self, cx: &mut FrameContext, _: &PostShared, _: &Target) -> Result<(), ShaderError> {
        let Some((group, _)) = &self.group else { return Ok(()) };
        let (encoder, device, pipelines, timer) =
            (&mut *cx.encoder, cx.device, &mut *cx.pipelines, cx.timer.as_deref_mut());
        pipelines.prepare::<ExposureFamily>(device, [ExposureStep::Histogram, ExposureStep::Average])?;
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("automatic exposure"),
            timestamp_writes: timer.and_then(|t| t.compute_pass("exposure")),
        });
        pass.set_bind_group(0, group, &[]);
        pass.set_pipeline(pipelines.cached::<ExposureFamily>(&ExposureStep::Histogram).expect("compiled above"));
        let (w, h) = self.size;
        pass.dispatch_workgroups(w.div_ceil(16), h.div_ceil(16), 1);
        pass.set_pipeline(pipelines.cached::<ExposureFamily>(&ExposureStep::Average).expect("compiled above"));
        pass.dispatch_workgroups(1, 1, 1);
        self.fresh = false;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_are_range_checked() {
        assert!(AutoExposure::default().validate().is_ok());
        let bad = AutoExposure { min_ev100: 5.0, max_ev100: 1.0, ..Default::default() };
        assert!(bad.validate().unwrap_err().contains("range"));
        assert!(AutoExposure { speed: 0.0, ..Default::default() }.validate().unwrap_err().contains("speed"));
    }
}
