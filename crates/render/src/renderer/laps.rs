//! CPU time by step, logged at debug level: where a renderer's making and a first frame's time
//! go (textures, pipelines, targets) without a profiler.

use std::time::Instant;

pub(super) struct Laps {
    /// Whether debug logging is on: otherwise nothing is timed or kept.
    on: bool,
    last: Instant,
    laps: Vec<(&'static str, f64)>,
}

impl Laps {
    pub(super) fn start() -> Self {
        Self { on: tracing::enabled!(tracing::Level::DEBUG), last: Instant::now(), laps: Vec::new() }
    }

    pub(super) fn lap(&mut self, what: &'static str) {
        if !self.on {
            return;
        }
        let now = Instant::now();
        self.laps.push((what, (now - self.last).as_secs_f64() * 1e3));
        self.last = now;
    }

    pub(super) fn log(&mut self, what: std::fmt::Arguments) {
        self.lap("the rest");
        if self.on {
            let laps: Vec<String> = self.laps.iter().map(|(what, ms)| format!("{what} {ms:.1}")).collect();
            tracing::debug!("{what} (ms): {}", laps.join(", "));
        }
    }
}
