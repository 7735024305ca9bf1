//! The post-processing chain: what runs between the resolved HDR frame and the output, one
//! stage per post-process, each in its own folder (`bloom`, `exposure`, `tonemap`, `fxaa`), in
//! the order `frame::post_chain` lists them.
//!
//! Data flow, each frame:
//! 1. prepare: every stage in order says whether it runs and why (the frame plan lists both),
//!    sizes what it owns to the frame, and leaves in [`PostShared`] what later stages read
//!    (bloom's level 0 for the tonemap pass, whether automatic exposure runs, its fields of the
//!    parameters buffer). The chain then uploads the parameters once;
//! 2. encode: the running stages in order. A stage that writes the displayed image writes it
//!    into the next running stage's input (FXAA's intermediate) or, last, into the output.
//!
//! A new post-process is its folder (a [`PostStage`], its pipeline family and its shader) and
//! one line of `frame::post_chain`, which binds it to its settings.

use bytemuck::{Pod, Zeroable};

use crate::frame_context::FrameContext;
use crate::pass::Pass;
use crate::pipelines::{PipelineCache, ShaderError};

/// Whether a stage runs this frame, and why (or why not): the frame plan's words.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decision {
    Runs(&'static str),
    LeftOut(&'static str),
}

/// A texture a stage writes the displayed image into.
#[derive(Debug, Clone)]
pub struct Target {
    pub view: wgpu::TextureView,
    pub format: wgpu::TextureFormat,
}

/// What a stage's preparation reads.
pub struct PostPrepare<'a> {
    pub device: &'a wgpu::Device,
    pub queue: &'a wgpu::Queue,
    pub pipelines: &'a PipelineCache,
    /// The frame's resolved HDR colour; `None` when the frame draws straight into the output
    /// (nothing post-processes it: no stage runs, each lets go of what it sized to the frame).
    pub hdr: Option<&'a wgpu::TextureView>,
    pub size: (u32, u32),
    pub delta_seconds: f32,
}

/// One post-process: its pass, its settings, its preparation and its encoding.
pub trait PostStage: Send + Sync + 'static {
    type Settings: 'static;
    const PASS: Pass;

    /// Whether the stage, as set, needs the frame's HDR colour (which then keeps an HDR target
    /// and a tonemap pass).
    fn wants_hdr(settings: &Self::Settings) -> bool;

    fn prepare(&mut self, cx: &PostPrepare, settings: &Self::Settings, shared: &mut PostShared) -> Decision;

    /// Where the stage before it writes the displayed image, when this stage reads one.
    fn input(&self) -> Option<Target> {
        None
    }

    /// Records the stage's passes; a stage writing the displayed image writes it into `output`.
    fn encode(&mut self, cx: &mut FrameContext, shared: &PostShared, output: &Target) -> Result<(), ShaderError>;

    fn gpu_bytes(&self) -> u64 {
        0
    }

    /// Forgets what earlier frames left (an adapted exposure): the next frame starts as a fresh
    /// renderer's first would.
    fn restart(&mut self) {}
}

/// Mirrors `PostParams` in `shaders/post_params.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GpuPostParams {
    /// Automatic exposure's correction on top of the camera's exposure (1 without it).
    pub exposure_scale: f32,
    /// Automatic exposure's adapted EV100, its state from frame to frame.
    pub adapted_ev: f32,
    pub bloom_strength: f32,
    /// 1 / the number of bloom levels.
    pub bloom_norm: f32,
    pub min_ev: f32,
    pub max_ev: f32,
    pub compensation: f32,
    /// Fraction of the way to the metered exposure this frame (1 on the first).
    pub adaptation: f32,
    /// The exposure scale the lit passes applied.
    pub camera_exposure: f32,
    _pad: [f32; 3],
}

impl GpuPostParams {
    /// No bloom, no correction: what the stages that run then change.
    fn neutral(camera_exposure: f32) -> Self {
        Self { exposure_scale: 1.0, bloom_norm: 1.0, adaptation: 1.0, camera_exposure, ..Self::zeroed() }
    }
}

/// Bytes of `GpuPostParams` the GPU owns while automatic exposure runs.
const GPU_OWNED: usize = 8;

/// What stages leave for later stages this frame.
pub struct PostShared {
    /// This frame's parameters: each stage writes its own fields while preparing.
    pub params: GpuPostParams,
    buffer: wgpu::Buffer,
    /// The sampler of every filtered read in the chain (linear, clamped).
    pub sampler: wgpu::Sampler,
    /// Bloom's level 0, when bloom runs: the tonemap pass mixes it in.
    pub bloom: Option<wgpu::TextureView>,
    /// Automatic exposure runs: the GPU owns the parameters' first fields, and the tonemap
    /// pass applies its correction.
    pub auto_exposure: bool,
}

impl PostShared {
    /// The parameters buffer (`post_params.wgsl`'s `PostParams`).
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }
}

/// A stage bound to where its settings are in the renderer's settings `S`.
trait BoundStage<S>: Send + Sync {
    fn pass(&self) -> Pass;
    fn wants_hdr(&self, settings: &S) -> bool;
    fn prepare(&mut self, cx: &PostPrepare, settings: &S, shared: &mut PostShared) -> Decision;
    fn input(&self) -> Option<Target>;
    fn encode(&mut self, cx: &mut FrameContext, shared: &PostShared, output: &Target) -> Result<(), ShaderError>;
    fn gpu_bytes(&self) -> u64;
    fn restart(&mut self);
}

struct Bound<St: PostStage, S> {
    stage: St,
    settings: fn(&S) -> &St::Settings,
}

impl<St: PostStage, S: 'static> BoundStage<S> for Bound<St, S> {
    fn pass(&self) -> Pass {
        St::PASS
    }
    fn wants_hdr(&self, settings: &S) -> bool {
        St::wants_hdr((self.settings)(settings))
    }
    fn prepare(&mut self, cx: &PostPrepare, settings: &S, shared: &mut PostShared) -> Decision {
        self.stage.prepare(cx, (self.settings)(settings), shared)
    }
    fn input(&self) -> Option<Target> {
        self.stage.input()
    }
    fn encode(&mut self, cx: &mut FrameContext, shared: &PostShared, output: &Target) -> Result<(), ShaderError> {
        self.stage.encode(cx, shared, output)
    }
    fn gpu_bytes(&self) -> u64 {
        self.stage.gpu_bytes()
    }
    fn restart(&mut self) {
        self.stage.restart()
    }
}

/// The stages, in order, and what they share.
pub struct PostChain<S> {
    stages: Vec<Box<dyn BoundStage<S>>>,
    /// This frame's decision of each stage.
    decisions: Vec<Decision>,
    shared: PostShared,
}

impl<S: 'static> PostChain<S> {
    pub fn new(device: &wgpu::Device) -> Self {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("post parameters"),
            size: std::mem::size_of::<GpuPostParams>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("post linear clamp"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let shared =
            PostShared { params: GpuPostParams::neutral(1.0), buffer, sampler, bloom: None, auto_exposure: false };
        Self { stages: Vec::new(), decisions: Vec::new(), shared }
    }

    /// Appends `stage`, which reads its settings where `settings` finds them.
    pub fn with<St: PostStage>(mut self, stage: St, settings: fn(&S) -> &St::Settings) -> Self {
        self.stages.push(Box::new(Bound { stage, settings }));
        self
    }

    /// Whether any stage, as set, needs the frame's HDR colour.
    pub fn wants_hdr(&self, settings: &S) -> bool {
        self.stages.iter().any(|s| s.wants_hdr(settings))
    }

    /// Prepares every stage in order, then uploads the parameters they wrote.
    pub fn prepare(&mut self, cx: &PostPrepare, settings: &S, camera_exposure: f32) {
        self.shared.params = GpuPostParams::neutral(camera_exposure);
        self.shared.bloom = None;
        self.shared.auto_exposure = false;
        self.decisions = self.stages.iter_mut().map(|s| s.prepare(cx, settings, &mut self.shared)).collect();
        if cx.hdr.is_some() {
            let bytes = bytemuck::bytes_of(&self.shared.params);
            let from = if self.shared.auto_exposure { GPU_OWNED } else { 0 };
            cx.queue.write_buffer(&self.shared.buffer, from as u64, &bytes[from..]);
        }
    }

    /// Each stage's pass and this frame's decision, in order.
    pub fn decisions(&self) -> impl Iterator<Item = (Pass, Decision)> + '_ {
        self.stages.iter().zip(&self.decisions).map(|(s, d)| (s.pass(), *d))
    }

    /// Encodes the running stages in order; returns the first shader error (a stage whose
    /// pipeline does not compile is left out, the rest still run).
    pub fn encode(&mut self, cx: &mut FrameContext, output: Target) -> Option<ShaderError> {
        let running: Vec<usize> =
            (0..self.stages.len()).filter(|&i| matches!(self.decisions.get(i), Some(Decision::Runs(_)))).collect();
        let mut error = None;
        for (n, &i) in running.iter().enumerate() {
            let next_input = running[n + 1..].iter().find_map(|&j| self.stages[j].input());
            let target = next_input.unwrap_or_else(|| output.clone());
            if let Err(e) = self.stages[i].encode(cx, &self.shared, &target) {
                error = error.or(Some(e));
            }
        }
        error
    }

    /// Every stage forgets what earlier frames left ([`PostStage::restart`]).
    pub fn restart(&mut self) {
        for stage in &mut self.stages {
            stage.restart();
        }
    }

    pub fn gpu_bytes(&self) -> u64 {
        self.stages.iter().map(|s| s.gpu_bytes()).sum()
    }

    /// The parameters buffer (automatic exposure's correction and adapted EV first): for tests
    /// and tools.
    pub fn params_buffer(&self) -> &wgpu::Buffer {
        &self.shared.buffer
    }
}

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Mutex};

    use super::*;
    use crate::pipelines::ShaderLibrary;
    use crate::targets::{FrameTargets, TargetsMade};

    /// Stand-in stages: each records, when encoded, its name and the view it was handed.
    type Log = Arc<Mutex<Vec<(&'static str, wgpu::TextureView)>>>;

    struct Writer {
        name: &'static str,
        log: Log,
    }

    /// A stage that reads the image the stage before it writes, from its own input.
    struct Reader {
        name: &'static str,
        input: wgpu::TextureView,
        log: Log,
    }

    impl PostStage for Writer {
        type Settings = bool;
        const PASS: Pass = Pass::new("Writer", "");
        fn wants_hdr(on: &bool) -> bool {
            *on
        }
        fn prepare(&mut self, _: &PostPrepare, on: &bool, shared: &mut PostShared) -> Decision {
            shared.params.bloom_strength += 1.0;
            if *on { Decision::Runs("on") } else { Decision::LeftOut("off") }
        }
        fn encode(&mut self, _: &mut FrameContext, _: &PostShared, output: &Target) -> Result<(), ShaderError> {
            self.log.lock().unwrap().push((self.name, output.view.clone()));
            Ok(())
        }
    }

    impl PostStage for Reader {
        type Settings = bool;
        const PASS: Pass = Pass::new("Reader", "");
        fn wants_hdr(on: &bool) -> bool {
            *on
        }
        fn prepare(&mut self, _: &PostPrepare, on: &bool, _: &mut PostShared) -> Decision {
            if *on { Decision::Runs("on") } else { Decision::LeftOut("off") }
        }
        fn input(&self) -> Option<Target> {
            Some(Target { view: self.input.clone(), format: wgpu::TextureFormat::Rgba8Unorm })
        }
        fn encode(&mut self, _: &mut FrameContext, _: &PostShared, output: &Target) -> Result<(), ShaderError> {
            self.log.lock().unwrap().push((self.name, output.view.clone()));
            Ok(())
        }
    }

    #[test]
    fn stages_run_in_order_each_writing_into_the_next_running_stages_input_or_the_output() {
        let ctx = crate::GpuContext::new_headless(&crate::AdapterRequest::default()).expect(crate::INSTALL_HINT);
        let device = &ctx.device;
        let view = |label| {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d { width: 4, height: 4, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::Rgba8Unorm,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                    view_formats: &[],
                })
                .create_view(&Default::default())
        };
        let (first_input, second_input, output) = (view("first input"), view("second input"), view("output"));
        let log = Log::default();
        let mut chain = PostChain::<[bool; 4]>::new(device)
            .with(Writer { name: "tonemap", log: log.clone() }, |s| &s[0])
            .with(Reader { name: "first", input: first_input.clone(), log: log.clone() }, |s| &s[1])
            .with(Reader { name: "second", input: second_input.clone(), log: log.clone() }, |s| &s[2])
            .with(Writer { name: "unused", log: log.clone() }, |s| &s[3]);
        let made = TargetsMade {
            hdr: true,
            depth: false,
            depth_sampled: false,
            output_format: wgpu::TextureFormat::Rgba8Unorm,
            shader_resolve: false,
            hdr_storage: false,
        };
        let targets = FrameTargets::new(device, (4, 4), 1, false, made);
        let mut pipelines = PipelineCache::new(ShaderLibrary::embedded().expect("the embedded shaders compose"));
        let mut run = |settings: [bool; 4]| {
            log.lock().unwrap().clear();
            let cx = PostPrepare {
                device,
                queue: &ctx.queue,
                pipelines: &pipelines,
                hdr: targets.hdr_view(),
                size: (4, 4),
                delta_seconds: 0.0,
            };
            chain.prepare(&cx, &settings, 1.0);
            let mut encoder = device.create_command_encoder(&Default::default());
            let mut fcx = FrameContext {
                device,
                queue: &ctx.queue,
                encoder: &mut encoder,
                pipelines: &mut pipelines,
                timer: None,
                targets: &targets,
            };
            let target = Target { view: output.clone(), format: wgpu::TextureFormat::Rgba8Unorm };
            assert!(chain.encode(&mut fcx, target).is_none());
            let decisions: Vec<bool> = chain.decisions().map(|(_, d)| matches!(d, Decision::Runs(_))).collect();
            assert_eq!(decisions, settings);
            assert!(chain.wants_hdr(&settings) == settings.iter().any(|on| *on));
            log.lock().unwrap().clone()
        };
        let written = |log: Vec<(&'static str, wgpu::TextureView)>| -> Vec<(&'static str, &'static str)> {
            log.into_iter()
                .map(|(name, v)| {
                    let into = if v == first_input {
                        "first input"
                    } else if v == second_input {
                        "second input"
                    } else if v == output {
                        "output"
                    } else {
                        "elsewhere"
                    };
                    (name, into)
                })
                .collect()
        };
        assert_eq!(
            written(run([true, true, true, false])),
            [("tonemap", "first input"), ("first", "second input"), ("second", "output")]
        );
        // A stage left out hands its place on: the one before writes into the next running input.
        assert_eq!(written(run([true, false, true, false])), [("tonemap", "second input"), ("second", "output")]);
        assert_eq!(written(run([true, false, false, false])), [("tonemap", "output")]);
        assert_eq!(written(run([false, false, false, true])), [("unused", "output")]);
        // Each stage wrote its share of the parameters (the chain starts them neutral each frame).
        assert_eq!(chain.shared.params.bloom_strength, 2.0);
    }

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
}
