//! `App`: the main world, its schedules, and the plugins that fill them.
//!
//! One update runs the schedules in [`App::schedule_order`]: `Startup` (first update only), then
//! `Update` (user systems), `PostUpdate` (transform propagation, visibility, bounds), followed by
//! whatever later stages plugins append (the render crate appends its extract and render stages).
//! `Time` ticks before anything runs.
//!
//! Executors: `Startup` and `Update` hold user systems and run them in parallel where their
//! data allows (bevy's multi-threaded executor). `PostUpdate` and appended stages run their
//! systems in order on the calling thread: the engine's systems there form one chain, so a
//! thread pool could only add hand-off cost, more than a small frame's work itself
//! (docs/performance.md; `cargo bench --bench triangle`). A system with much work splits it
//! itself (`par_iter`).
//!
//! How updates are driven is the runner's business: a window event loop, a headless loop of N
//! fixed steps, or a test calling `update` by hand.

use bevy_ecs::intern::Interned;
use bevy_ecs::schedule::{IntoScheduleConfigs, Schedule, ScheduleLabel, Schedules, SingleThreadedExecutor};
use bevy_ecs::system::ScheduleSystem;
use bevy_ecs::world::World;

use crate::time::Time;

/// Runs once, before the first `Update`.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct Startup;

/// User logic: scripts, input handling, animation.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct Update;

/// Engine bookkeeping that must see this frame's `Update`: transforms, visibility, bounds.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct PostUpdate;

/// A unit of setup: adds resources, schedules and systems to an [`App`].
pub trait Plugin {
    fn build(&self, app: &mut App);
    fn name(&self) -> &str {
        std::any::type_name::<Self>()
    }
}

type Runner = Box<dyn FnOnce(App)>;

pub struct App {
    pub world: World,
    schedule_order: Vec<Interned<dyn ScheduleLabel>>,
    startup_done: bool,
    plugin_names: Vec<String>,
    runner: Option<Runner>,
}

impl Default for App {
    fn default() -> Self {
        Self::new()
    }
}

impl App {
    /// An app with `Time` and the three core schedules, and no plugins.
    pub fn new() -> Self {
        // `par_iter` in user and engine systems runs on bevy's compute pool, one per process.
        bevy_tasks::ComputeTaskPool::get_or_init(bevy_tasks::TaskPool::default);
        let mut world = World::new();
        world.init_resource::<Schedules>();
        world.init_resource::<Time>();
        let mut app =
            Self { world, schedule_order: Vec::new(), startup_done: false, plugin_names: Vec::new(), runner: None };
        app.add_schedule(Schedule::new(Startup));
        app.add_schedule(Schedule::new(Update));
        app.schedule_order.push(Update.intern());
        app.add_stage(PostUpdate);
        app
    }

    fn add_schedule(&mut self, schedule: Schedule) {
        self.world.resource_mut::<Schedules>().insert(schedule);
    }

    /// Appends a schedule that runs every update after the ones already in the order; its
    /// systems run in order on the calling thread (see the module doc).
    pub fn add_stage(&mut self, label: impl ScheduleLabel) -> &mut Self {
        let label = label.intern();
        if !self.schedule_order.contains(&label) {
            let mut schedule = Schedule::new(label);
            schedule.set_executor(SingleThreadedExecutor::new());
            self.add_schedule(schedule);
            self.schedule_order.push(label);
        }
        self
    }

    pub fn schedule_order(&self) -> &[Interned<dyn ScheduleLabel>] {
        &self.schedule_order
    }

    pub fn add_plugins(&mut self, plugin: impl Plugin) -> &mut Self {
        let name = plugin.name().to_owned();
        if self.plugin_names.contains(&name) {
            tracing::debug!("plugin {name} added twice; ignoring the second");
            return self;
        }
        self.plugin_names.push(name);
        plugin.build(self);
        self
    }

    pub fn has_plugin(&self, name_contains: &str) -> bool {
        self.plugin_names.iter().any(|n| n.contains(name_contains))
    }

    pub fn add_systems<M>(
        &mut self,
        schedule: impl ScheduleLabel,
        systems: impl IntoScheduleConfigs<ScheduleSystem, M>,
    ) -> &mut Self {
        let mut schedules = self.world.resource_mut::<Schedules>();
        schedules.add_systems(schedule, systems);
        self
    }

    pub fn insert_resource<R: bevy_ecs::resource::Resource>(&mut self, resource: R) -> &mut Self {
        self.world.insert_resource(resource);
        self
    }

    pub fn init_resource<R: bevy_ecs::resource::Resource + bevy_ecs::world::FromWorld>(&mut self) -> &mut Self {
        self.world.init_resource::<R>();
        self
    }

    /// Runs one frame: tick `Time`, `Startup` on the first call, then every stage in order.
    pub fn update(&mut self) {
        self.update_with(|_, _| {});
    }

    /// Runs one frame like [`App::update`] and returns each stage's wall time in ms, in order
    /// (`Startup` included on the first call). Benchmarks use it to split a frame's CPU time.
    pub fn update_timed(&mut self) -> Vec<(Interned<dyn ScheduleLabel>, f64)> {
        let mut times = Vec::new();
        self.update_with(|label, ms| times.push((label, ms)));
        times
    }

    fn update_with(&mut self, mut stage_done: impl FnMut(Interned<dyn ScheduleLabel>, f64)) {
        self.world.resource_mut::<Time>().tick();
        if !self.startup_done {
            self.startup_done = true;
            let start = std::time::Instant::now();
            self.world.run_schedule(Startup);
            stage_done(Startup.intern(), start.elapsed().as_secs_f64() * 1e3);
        }
        for label in self.schedule_order.clone() {
            let start = std::time::Instant::now();
            self.world.run_schedule(label);
            stage_done(label, start.elapsed().as_secs_f64() * 1e3);
        }
        self.world.clear_trackers();
    }

    /// Sets what [`App::run`] does (a window event loop, a headless loop).
    pub fn set_runner(&mut self, runner: impl FnOnce(App) + 'static) -> &mut Self {
        self.runner = Some(Box::new(runner));
        self
    }

    /// Hands the app to its runner; without one, runs a single update.
    pub fn run(&mut self) {
        let mut app = std::mem::take(self);
        match app.runner.take() {
            Some(runner) => runner(app),
            None => app.update(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy_ecs::prelude::*;

    #[derive(Resource, Default)]
    struct Log(Vec<&'static str>);

    #[test]
    fn startup_runs_once_and_stages_run_in_order() {
        let mut app = App::new();
        app.init_resource::<Log>();
        app.add_systems(Startup, |mut l: ResMut<Log>| l.0.push("startup"));
        app.add_systems(Update, |mut l: ResMut<Log>| l.0.push("update"));
        app.add_systems(PostUpdate, |mut l: ResMut<Log>| l.0.push("post"));
        app.update();
        app.update();
        assert_eq!(app.world.resource::<Log>().0, ["startup", "update", "post", "update", "post"]);
    }
}
