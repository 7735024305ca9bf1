//! What every benchmark measures with: frames timed with at most two in flight, percentiles,
//! the recipe settings of the benchmark scenes, and FLIP between two frames.

use std::collections::VecDeque;
use std::time::Instant;

use anyhow::Result;
use bevy_ecs::schedule::ScheduleLabel;
use penumbra_render::{RenderSettings, Renderer};

use crate::cli::BenchArgs;

/// Keeps at most `max` frames in flight by waiting for the oldest submission.
pub fn bound_frames_in_flight(
    app: &mut penumbra_engine::App,
    in_flight: &mut VecDeque<wgpu::SubmissionIndex>,
    max: usize,
) {
    let renderer = app.world.resource::<Renderer>();
    if let Some(s) = renderer.last_submission() {
        in_flight.push_back(s.clone());
    }
    while in_flight.len() > max {
        let oldest = in_flight.pop_front().expect("non-empty");
        let _ = renderer.context().device.poll(wgpu::PollType::Wait { submission_index: Some(oldest), timeout: None });
    }
    if max == 0 {
        let _ = renderer.context().device.poll(wgpu::PollType::wait_indefinitely());
    }
}

/// Per-frame timings over the timed frames, in frame order.
pub struct FrameTimes {
    pub wall: Vec<f64>,
    pub cpu: Vec<f64>,
    /// `app.update()` on this thread: extraction, prepare and encode (not the GPU wait).
    pub update: Vec<f64>,
    pub gpu_total: Vec<f64>,
    /// First pass's beginning to last pass's end, per frame (see `FrameTimings::span_ms`).
    pub gpu_span: Vec<f64>,
    pub passes: Vec<(&'static str, Vec<f64>)>,
    /// The CPU frame split: the main world's stages (user systems, propagation), extraction,
    /// the renderer's prepare (and of it the instance upload), encode and submit.
    pub main: Vec<f64>,
    pub extract: Vec<f64>,
    pub prepare: Vec<f64>,
    pub instance_upload: Vec<f64>,
    pub submit: Vec<f64>,
    pub instance_bytes: Vec<f64>,
}

impl FrameTimes {
    pub fn pass(&self, label: &str) -> Option<&[f64]> {
        self.passes.iter().find(|(l, _)| *l == label).map(|(_, v)| v.as_slice())
    }

    /// Every stage of the CPU frame on this thread: main world, extraction, prepare and encode,
    /// and submission.
    pub fn cpu_frame(&self, i: usize) -> f64 {
        self.main[i] + self.extract[i] + self.cpu[i] + self.submit[i]
    }
}

/// Runs `warmup` unpipelined frames, then `frames` pipelined ones (at most two in flight).
pub fn time_frames(app: &mut penumbra_engine::App, warmup: u32, frames: u32) -> FrameTimes {
    for _ in 0..warmup {
        app.update();
        bound_frames_in_flight(app, &mut VecDeque::new(), 0);
    }
    let mut in_flight = VecDeque::new();
    let mut wall = Vec::new();
    let mut cpu = Vec::new();
    let mut update = Vec::new();
    let mut gpu_total = Vec::new();
    let mut gpu_span = Vec::new();
    let mut passes: Vec<(&'static str, Vec<f64>)> = Vec::new();
    let (mut main, mut extract, mut prepare, mut instance_upload, mut submit, mut instance_bytes) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (extract_stage, render_stage) = (penumbra_render::Extract.intern(), penumbra_render::Render.intern());
    let mut last_gpu_frame = 0;
    let mut record_gpu = |stats: &penumbra_render::FrameStats, gpu_total: &mut Vec<f64>, gpu_span: &mut Vec<f64>| {
        let Some(t) = stats.gpu.as_ref().filter(|t| t.frame > last_gpu_frame) else { return };
        last_gpu_frame = t.frame;
        gpu_total.push(t.passes.iter().map(|(_, ms)| ms).sum());
        gpu_span.push(t.span_ms);
        for (label, ms) in &t.passes {
            match passes.iter_mut().find(|(l, _)| l == label) {
                Some((_, v)) => v.push(*ms),
                None => passes.push((label, vec![*ms])),
            }
        }
    };
    let mut last = Instant::now();
    for _ in 0..frames {
        let t = Instant::now();
        let stages = app.update_timed();
        update.push(t.elapsed().as_secs_f64() * 1e3);
        let stage = |pick: &dyn Fn(bool, bool) -> bool| -> f64 {
            stages.iter().filter(|(l, _)| pick(*l == extract_stage, *l == render_stage)).map(|(_, ms)| ms).sum()
        };
        main.push(stage(&|e, r| !e && !r));
        extract.push(stage(&|e, _| e));
        bound_frames_in_flight(app, &mut in_flight, 2);
        let now = Instant::now();
        wall.push((now - last).as_secs_f64() * 1e3);
        last = now;
        let stats = app.world.resource::<Renderer>().stats().clone();
        cpu.push(stats.cpu_ms);
        prepare.push(stats.prepare_ms);
        instance_upload.push(stats.instance_upload_ms);
        submit.push(stats.submit_ms);
        instance_bytes.push(stats.instance_bytes_uploaded as f64);
        record_gpu(&stats, &mut gpu_total, &mut gpu_span);
    }
    app.world.resource_mut::<Renderer>().finish();
    let stats = app.world.resource::<Renderer>().stats().clone();
    record_gpu(&stats, &mut gpu_total, &mut gpu_span);
    // Unsorted, in frame order, so that samples of one frame can be summed (`cpu_frame`);
    // `percentile` sorts what it is given.
    FrameTimes {
        wall,
        cpu,
        update,
        gpu_total,
        gpu_span,
        passes,
        main,
        extract,
        prepare,
        instance_upload,
        submit,
        instance_bytes,
    }
}

/// Settings for the benchmark scenes (`many-cubes`, `many-lights`; crates/engine/src/scenes.rs):
/// GPU timing; display colours resolved unless `--msaa-resolve` says otherwise, since the recipe
/// draws without an HDR target. Everything else is what users get by default.
pub fn recipe_settings(args: &BenchArgs) -> Result<RenderSettings> {
    let mut settings = RenderSettings { gpu_timing: true, ..args.look.render_settings(false, None)? };
    if args.look.msaa_resolve.is_none() {
        settings.msaa_resolve = penumbra_render::MsaaResolve::Display;
    }
    Ok(settings)
}

/// The `p` quantile (0..=1) of `samples`, in any order; NaN when there are none.
pub fn percentile(samples: &[f64], p: f64) -> f64 {
    if samples.is_empty() {
        return f64::NAN;
    }
    let mut sorted = samples.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

/// FLIP's mean error between two RGBA8 frames of `w`×`h`.
pub fn flip_mean(a: &[u8], b: &[u8], (w, h): (u32, u32)) -> f32 {
    let rgb = |rgba: &[u8]| rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect::<Vec<u8>>();
    let reference = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(a));
    let test = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(b));
    let error = nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    nv_flip::FlipPool::from_image(&error).mean()
}

/// Steps the camera 25 cm sideways, left and right on alternate frames: every shadow cascade
/// follows it and redraws (a still camera keeps its cascades).
pub fn step_camera(
    mut cameras: bevy_ecs::system::Query<
        &mut penumbra_engine::components::Transform,
        bevy_ecs::query::With<penumbra_engine::components::Camera>,
    >,
    mut frame: bevy_ecs::system::Local<u64>,
) {
    *frame += 1;
    let step = if frame.is_multiple_of(2) { 0.25 } else { -0.25 };
    for mut t in &mut cameras {
        t.translation.x += step;
    }
}
