//! CPU time by step, logged at debug level: where a renderer's making and a first frame's time
//! go (textures, pipelines, targets) without a profiler.

use std::time::Instant;

pub(super) struct Laps {
    last: Instant,
    laps: Vec<(&'static str, f64)>,
}

impl Laps {
    pub(super) fn start() -> Self {
        Self { last: Instant::now(), laps: Vec::new() }
    }

    pub(super) fn lap(&mut self, what: &'static str) {
        let now = Instant::now();
        self.laps.push((what, (now - self.last).as_secs_f64() * 1e3));
        self.last = now;
    }

    pub(super) fn log(&mut self, what: std::fmt::Arguments) {
        self.lap("the rest");
        if tracing::enabled!(tracing::Level::DEBUG) {
            let laps: Vec<String> = self.laps.iter().map(|(what, ms)| format!("{what} {ms:.1}")).collect();
            tracing::debug!("{what} (ms): {}", laps.join(", "));
        }
    }
}
