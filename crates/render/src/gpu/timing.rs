//! GPU timing with timestamp queries written at pass boundaries.
//!
//! A ring of query sets and readback buffers, one per frame in flight: each frame's timestamps
//! are resolved and copied into its own slot and mapped asynchronously after submission;
//! `collect` picks up whatever has completed without waiting. So timing never stalls the CPU on
//! the GPU, and the stats show the most recent finished frame (usually one or two behind).
//! Enabled on request (stats panel, `penumbra bench`).

use crate::gpu::readback::{Arrival, AsyncSlot};

struct Slot {
    query_set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    labels: Vec<&'static str>,
    frame: u64,
    state: AsyncSlot,
}

/// Per-pass GPU milliseconds of one frame.
#[derive(Debug, Clone, Default)]
pub struct FrameTimings {
    pub frame: u64,
    pub passes: Vec<(&'static str, f64)>,
    /// From the first pass's beginning to the last pass's end. Unlike the sum of `passes`, this
    /// counts time two passes overlap once (a pass's beginning timestamp can be written while
    /// the previous frame's last pass still runs, on NVIDIA: the sum then counts that wait),
    /// and it includes the gaps between passes (copies, barriers).
    pub span_ms: f64,
}

pub struct GpuTimer {
    slots: Vec<Slot>,
    current: Option<usize>,
    period_ns: f64,
    latest: Option<FrameTimings>,
}

impl GpuTimer {
    // Room for four cascades and a few dozen local shadow maps beside the main passes.
    pub const MAX_PASSES: u32 = 64;
    /// Frames whose timings can be outstanding at once.
    pub const RING: usize = 4;

    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        let count = Self::MAX_PASSES * 2;
        let bytes = count as u64 * 8;
        let slots = (0..Self::RING)
            .map(|_| Slot {
                query_set: device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("pass timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count,
                }),
                resolve: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("timestamp resolve"),
                    size: bytes,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
                readback: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("timestamp readback"),
                    size: bytes,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                labels: Vec::new(),
                frame: 0,
                state: AsyncSlot::default(),
            })
            .collect();
        Self { slots, current: None, period_ns: queue.get_timestamp_period() as f64, latest: None }
    }

    /// Starts recording `frame` in a free slot. Returns false (and records nothing) when every
    /// slot still waits for the GPU: that frame goes untimed rather than stalling.
    pub fn begin_frame(&mut self, device: &wgpu::Device, frame: u64) -> bool {
        self.collect(device);
        self.current = self.slots.iter().position(|s| s.state.is_free());
        if let Some(i) = self.current {
            let slot = &mut self.slots[i];
            slot.labels.clear();
            slot.frame = frame;
            slot.state.claim();
        }
        self.current.is_some()
    }

    /// Timestamp writes for a render pass named `label` in the current frame.
    pub fn pass(&mut self, label: &'static str) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        let slot = &mut self.slots[self.current?];
        let i = slot.labels.len() as u32;
        if i >= Self::MAX_PASSES {
            return None;
        }
        slot.labels.push(label);
        Some(wgpu::RenderPassTimestampWrites {
            query_set: &slot.query_set,
            beginning_of_pass_write_index: Some(2 * i),
            end_of_pass_write_index: Some(2 * i + 1),
        })
    }

    /// Timestamp writes for a compute pass named `label` in the current frame.
    pub fn compute_pass(&mut self, label: &'static str) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        let w = self.pass(label)?;
        Some(wgpu::ComputePassTimestampWrites {
            query_set: w.query_set,
            beginning_of_pass_write_index: w.beginning_of_pass_write_index,
            end_of_pass_write_index: w.end_of_pass_write_index,
        })
    }

    /// Encodes the resolve and copy of the current frame's timestamps.
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        let Some(slot) = self.current.map(|i| &self.slots[i]) else { return };
        let n = slot.labels.len() as u32 * 2;
        if n > 0 {
            encoder.resolve_query_set(&slot.query_set, 0..n, &slot.resolve, 0);
            encoder.copy_buffer_to_buffer(&slot.resolve, 0, &slot.readback, 0, n as u64 * 8);
        }
    }

    /// After the frame's submission: maps its readback buffer when the GPU is done with it.
    pub fn after_submit(&mut self) {
        let Some(i) = self.current.take() else { return };
        let slot = &self.slots[i];
        let n = slot.labels.len() as u64 * 2;
        if n == 0 {
            slot.state.release();
            return;
        }
        slot.state.map_after_submit(slot.readback.slice(0..n * 8));
    }

    /// Reads every completed slot without blocking; remembers the newest frame's timings.
    pub fn collect(&mut self, device: &wgpu::Device) {
        let _ = device.poll(wgpu::PollType::Poll);
        for slot in &self.slots {
            match slot.state.arrived() {
                Arrival::Mapped => {
                    let n = slot.labels.len() * 2;
                    if let Ok(data) = slot.readback.slice(0..n as u64 * 8).get_mapped_range() {
                        let ticks: &[u64] = bytemuck::cast_slice(&data);
                        // Passes sharing a label (the local shadow maps) are summed into one.
                        let mut passes: Vec<(&'static str, f64)> = Vec::new();
                        for (i, l) in slot.labels.iter().enumerate() {
                            let ms = ticks[2 * i + 1].saturating_sub(ticks[2 * i]) as f64 * self.period_ns / 1e6;
                            match passes.iter_mut().find(|(p, _)| p == l) {
                                Some((_, sum)) => *sum += ms,
                                None => passes.push((l, ms)),
                            }
                        }
                        let first = ticks.iter().step_by(2).copied().min().unwrap_or(0);
                        let last = ticks.iter().skip(1).step_by(2).copied().max().unwrap_or(0);
                        let span_ms = last.saturating_sub(first) as f64 * self.period_ns / 1e6;
                        if self.latest.as_ref().is_none_or(|t| t.frame < slot.frame) {
                            self.latest = Some(FrameTimings { frame: slot.frame, passes, span_ms });
                        }
                    }
                    slot.readback.unmap();
                    slot.state.release();
                }
                Arrival::Failed => slot.state.release(),
                Arrival::NotYet => {}
            }
        }
    }

    /// Waits for every outstanding frame and collects it (end of a benchmark).
    pub fn finish(&mut self, device: &wgpu::Device) {
        let _ = device.poll(wgpu::PollType::wait_indefinitely());
        self.collect(device);
    }

    /// The newest completed frame's timings.
    pub fn latest(&self) -> Option<&FrameTimings> {
        self.latest.as_ref()
    }
}
