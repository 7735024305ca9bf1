//! [`ImportProgress`]: how far an import has got, for a viewer loading on another thread.
//!
//! The importer reports each stage it enters with the number of steps it has (meshes, images)
//! and counts them off as they finish; a watcher on any thread reads a snapshot. Stages and
//! counts are atomics, so reporting never blocks the import.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, AtomicU32, Ordering};

/// The stages of an import, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum ImportStage {
    Reading = 0,
    Buffers = 1,
    Meshes = 2,
    Images = 3,
    Done = 4,
}

impl ImportStage {
    pub fn describe(self) -> &'static str {
        match self {
            ImportStage::Reading => "reading the file",
            ImportStage::Buffers => "loading buffers",
            ImportStage::Meshes => "building meshes",
            ImportStage::Images => "decoding images",
            ImportStage::Done => "done",
        }
    }
}

#[derive(Debug, Default)]
struct Counters {
    stage: AtomicU8,
    done: AtomicU32,
    total: AtomicU32,
}

/// A shared progress report; clones watch the same import.
#[derive(Debug, Clone, Default)]
pub struct ImportProgress(Arc<Counters>);

/// What a watcher sees: the stage, and steps done of the stage's total (0 total: not counted).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ProgressSnapshot {
    pub stage: ImportStage,
    pub done: u32,
    pub total: u32,
}

impl ProgressSnapshot {
    /// Fraction of the whole import, for a progress bar: each stage is an equal share, counted
    /// steps fill their share.
    pub fn fraction(&self) -> f32 {
        let within = if self.total > 0 { self.done as f32 / self.total as f32 } else { 0.0 };
        ((self.stage as u8 as f32 + within.min(1.0)) / ImportStage::Done as u8 as f32).min(1.0)
    }
}

impl ImportProgress {
    pub fn enter(&self, stage: ImportStage, total: usize) {
        self.0.done.store(0, Ordering::Relaxed);
        self.0.total.store(total.min(u32::MAX as usize) as u32, Ordering::Relaxed);
        self.0.stage.store(stage as u8, Ordering::Release);
    }

    /// One more step of the current stage finished.
    pub fn step(&self) {
        self.0.done.fetch_add(1, Ordering::Relaxed);
    }

    pub fn snapshot(&self) -> ProgressSnapshot {
        let stage = match self.0.stage.load(Ordering::Acquire) {
            0 => ImportStage::Reading,
            1 => ImportStage::Buffers,
            2 => ImportStage::Meshes,
            3 => ImportStage::Images,
            _ => ImportStage::Done,
        };
        ProgressSnapshot {
            stage,
            done: self.0.done.load(Ordering::Relaxed),
            total: self.0.total.load(Ordering::Relaxed),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fraction_grows_through_the_stages() {
        let p = ImportProgress::default();
        let watcher = p.clone();
        assert_eq!(watcher.snapshot().fraction(), 0.0);
        p.enter(ImportStage::Images, 4);
        p.step();
        p.step();
        let s = watcher.snapshot();
        assert_eq!((s.stage, s.done, s.total), (ImportStage::Images, 2, 4));
        assert!((s.fraction() - 3.5 / 4.0).abs() < 1e-6);
        p.enter(ImportStage::Done, 0);
        assert_eq!(watcher.snapshot().fraction(), 1.0);
    }
}
