//! `Time`: frame delta and elapsed time, from the wall clock or from a fixed step.
//!
//! Interactive runs use [`TimeMode::Real`]. Headless and test runs use [`TimeMode::Fixed`]: every
//! update advances by exactly the step, so N updates always reach the same simulated state, which
//! is what makes screenshots of animated scenes byte-identical between runs.

use std::time::{Duration, Instant};

use bevy_ecs::resource::Resource;

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeMode {
    /// Delta is the wall-clock time since the previous update (clamped, see [`Time::MAX_DELTA`]).
    Real,
    /// Delta is always this step.
    Fixed(Duration),
}

#[derive(Resource, Debug, Clone)]
pub struct Time {
    mode: TimeMode,
    delta: Duration,
    elapsed: Duration,
    frame: u64,
    last_tick: Option<Instant>,
}

impl Default for Time {
    fn default() -> Self {
        Self::new(TimeMode::Real)
    }
}

impl Time {
    /// A stall (debugger, window drag, swap-chain recreation) must not make a simulation jump
    /// by seconds; 0.25 s is the usual game-loop clamp.
    pub const MAX_DELTA: Duration = Duration::from_millis(250);

    pub fn new(mode: TimeMode) -> Self {
        Self { mode, delta: Duration::ZERO, elapsed: Duration::ZERO, frame: 0, last_tick: None }
    }

    /// Fixed step of `1/hz` seconds.
    pub fn fixed_hz(hz: f64) -> Self {
        Self::new(TimeMode::Fixed(Duration::from_secs_f64(1.0 / hz)))
    }

    pub fn mode(&self) -> TimeMode {
        self.mode
    }

    pub fn set_mode(&mut self, mode: TimeMode) {
        self.mode = mode;
        self.last_tick = None;
    }

    /// Advances the clock; called once at the start of every `App::update`.
    pub fn tick(&mut self) {
        self.delta = match self.mode {
            TimeMode::Fixed(step) => step,
            TimeMode::Real => {
                let now = Instant::now();
                let delta = self.last_tick.map_or(Duration::ZERO, |t| now - t);
                self.last_tick = Some(now);
                delta.min(Self::MAX_DELTA)
            }
        };
        self.elapsed += self.delta;
        self.frame += 1;
    }

    pub fn delta(&self) -> Duration {
        self.delta
    }
    pub fn delta_secs(&self) -> f32 {
        self.delta.as_secs_f32()
    }
    pub fn elapsed(&self) -> Duration {
        self.elapsed
    }
    pub fn elapsed_secs(&self) -> f32 {
        self.elapsed.as_secs_f32()
    }
    /// Number of completed ticks.
    pub fn frame(&self) -> u64 {
        self.frame
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_step_is_exact_and_repeatable() {
        let mut t = Time::fixed_hz(60.0);
        for _ in 0..120 {
            t.tick();
        }
        assert_eq!(t.frame(), 120);
        assert_eq!(t.elapsed(), Duration::from_secs_f64(1.0 / 60.0) * 120);
    }
}
