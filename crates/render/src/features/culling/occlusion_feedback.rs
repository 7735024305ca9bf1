//! Whether occlusion culling pays, judged from what it hides: the owner of
//! `OcclusionCulling::Auto`'s decision.
//!
//! The late cull counts the entries in view that the depth pyramid hid (`shaders/cull.wgsl`, the
//! word after the late draws' arguments). Each frame that ran occlusion culling copies that
//! count into one of a few small buffers, mapped after submission and read without waiting one
//! or two frames later ([`Feedback`]). [`Advisor`] keeps occlusion culling on while the newest
//! measured frame hid at least [`MIN_HIDDEN_SHARE`] of the opaque entries; otherwise it is off,
//! and tried again for two frames every [`PROBE_EVERY`] (the first rebuilds the visible set
//! the early pass draws, the second is measured). A frame is measured only when the frame
//! before it also ran occlusion culling: with a stale visible set the early pass draws too
//! little for the pyramid to hide anything.
//!
//! Why: where it hides nothing (the many-cubes grid, everything in view) occlusion culling is
//! pure cost (depth pyramid, late cull, the late pass); where it hides even a few per cent of a
//! million cubes (the sphere layout) it saves more than it costs (docs/performance.md, "Many
//! objects").
//! Either way the image is the same: both modes draw exactly what is visible.

use crate::gpu::readback::{Arrival, AsyncSlot};

/// Frames between two tries while occlusion culling is off.
pub const PROBE_EVERY: u32 = 60;
/// The share of opaque entries occlusion culling must hide to stay on.
pub const MIN_HIDDEN_SHARE: f64 = 0.01;

/// One measured frame: the opaque entries in view that the depth pyramid hid, of `entries`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OcclusionMeasure {
    pub hidden: u32,
    pub entries: u32,
}

/// Decides, frame by frame, whether `Auto` runs occlusion culling.
#[derive(Debug)]
pub struct Advisor {
    pays: bool,
    /// Frames since occlusion culling was switched off or last tried.
    off_frames: u32,
}

impl Default for Advisor {
    /// On until the first measurement says otherwise.
    fn default() -> Self {
        Self { pays: true, off_frames: 0 }
    }
}

impl Advisor {
    /// Whether this frame should run occlusion culling; call once per frame that could.
    pub fn wants(&mut self) -> bool {
        if self.pays {
            return true;
        }
        self.off_frames += 1;
        let trying = self.off_frames >= PROBE_EVERY - 1;
        if self.off_frames >= PROBE_EVERY {
            self.off_frames = 0;
        }
        trying
    }

    /// Takes a measured frame into account.
    pub fn report(&mut self, m: OcclusionMeasure) {
        let pays = m.hidden > 0 && m.hidden as f64 >= MIN_HIDDEN_SHARE * m.entries as f64;
        if self.pays && !pays {
            self.off_frames = 0;
        }
        self.pays = pays;
    }
}

struct Slot {
    buffer: wgpu::Buffer,
    state: AsyncSlot,
    frame: u64,
    entries: u32,
}

/// The hidden counts of recent frames, on their way back from the GPU.
pub struct Feedback {
    slots: Vec<Slot>,
    recorded: Option<usize>,
    latest: Option<(u64, OcclusionMeasure)>,
}

impl Feedback {
    /// More than the frames in flight, so that a slot is free when a frame needs one.
    const SLOTS: usize = 4;

    pub fn new(device: &wgpu::Device) -> Self {
        let slots = (0..Self::SLOTS)
            .map(|_| Slot {
                buffer: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("occlusion feedback"),
                    size: 4,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                state: AsyncSlot::default(),
                frame: 0,
                entries: 0,
            })
            .collect();
        Self { slots, recorded: None, latest: None }
    }

    /// Copies frame `frame`'s hidden count (the word at `offset` of `source`) for reading back,
    /// when a slot is free (else the frame goes unmeasured).
    pub fn record(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        source: &wgpu::Buffer,
        offset: u64,
        frame: u64,
        entries: u32,
    ) {
        let Some(i) = self.slots.iter().position(|s| s.state.is_free()) else { return };
        let slot = &mut self.slots[i];
        encoder.copy_buffer_to_buffer(source, offset, &slot.buffer, 0, 4);
        slot.state.claim();
        slot.frame = frame;
        slot.entries = entries;
        self.recorded = Some(i);
    }

    /// After the frame's submission: maps what it recorded once the GPU is done with it.
    pub fn after_submit(&mut self) {
        let Some(i) = self.recorded.take() else { return };
        let slot = &self.slots[i];
        slot.state.map_after_submit(slot.buffer.slice(..));
    }

    /// Reads every slot that arrived, without waiting; returns the newest measure among them.
    pub fn collect(&mut self, device: &wgpu::Device) -> Option<OcclusionMeasure> {
        // Most frames of most scenes cull nothing by occlusion: nothing to poll for.
        if self.slots.iter().all(|s| s.state.is_free()) {
            return None;
        }
        let _ = device.poll(wgpu::PollType::Poll);
        let mut newest: Option<(u64, OcclusionMeasure)> = None;
        for slot in &self.slots {
            match slot.state.arrived() {
                Arrival::Mapped => {
                    let hidden = match slot.buffer.slice(..).get_mapped_range() {
                        Ok(data) => Some(u32::from_le_bytes([data[0], data[1], data[2], data[3]])),
                        Err(_) => None,
                    };
                    slot.buffer.unmap();
                    slot.state.release();
                    if let Some(hidden) = hidden
                        && newest.is_none_or(|(f, _)| f < slot.frame)
                    {
                        newest = Some((slot.frame, OcclusionMeasure { hidden, entries: slot.entries }));
                    }
                }
                Arrival::Failed => slot.state.release(),
                Arrival::NotYet => {}
            }
        }
        let newest = newest.filter(|(f, _)| self.latest.is_none_or(|(l, _)| l < *f))?;
        self.latest = Some(newest);
        Some(newest.1)
    }

    /// The newest measured frame's counts.
    pub fn latest(&self) -> Option<OcclusionMeasure> {
        self.latest.map(|(_, m)| m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn measure(hidden: u32) -> OcclusionMeasure {
        OcclusionMeasure { hidden, entries: 10_000 }
    }

    #[test]
    fn on_while_it_hides_enough_then_tried_two_frames_in_every_sixty() {
        let mut a = Advisor::default();
        assert!(a.wants(), "on until measured");
        a.report(measure(500));
        assert!(a.wants() && a.wants(), "5 % hidden: stays on");
        a.report(measure(99));
        let tries: Vec<bool> = (0..2 * PROBE_EVERY).map(|_| a.wants()).collect();
        let on: Vec<usize> = tries.iter().enumerate().filter(|(_, t)| **t).map(|(i, _)| i).collect();
        let p = PROBE_EVERY as usize;
        assert_eq!(on, [p - 2, p - 1, 2 * p - 2, 2 * p - 1], "below 1 %: off, tried twice every {p} frames");
        a.report(measure(100));
        assert!(a.wants(), "1 % hidden: on again");
        a.report(measure(0));
        assert!(!a.wants());
    }

    #[test]
    fn nothing_to_hide_never_pays() {
        let mut a = Advisor::default();
        a.report(OcclusionMeasure { hidden: 0, entries: 0 });
        assert!(!a.wants());
    }
}
