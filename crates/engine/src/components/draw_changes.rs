//! The draw change feed: which entities' drawable state (placement, visibility, mesh, material)
//! may have changed since the renderer last read it.
//!
//! Bevy's change ticks answer that question only by scanning every entity's ticks, one 4-byte
//! tick per entity per component; for a million drawable entities that is 16 MB read every
//! frame to learn that nothing moved. The writers know what they write, so they say so here:
//! - transform propagation records every `GlobalTransform` it writes,
//! - visibility propagation every `InheritedVisibility` it changes,
//! - `Mesh3d` and `MeshMaterial3d` are immutable components whose insertion (spawning, or
//!   inserting a new value over the old one) records the entity through a hook.
//!
//! Extraction drains the feed each frame and visits exactly those entities, so a still frame
//! costs it nothing per entity. Removals still come from `RemovedComponents`.
//!
//! `GlobalTransform` and `InheritedVisibility` are derived: written by propagation only. A
//! system that writes them directly is not seen here (as propagation would overwrite the value
//! anyway); write `Transform` and `Visibility` instead.
//!
//! Recording happens only while the resource exists: a main world without a renderer records
//! nothing. The resource starts *unprimed*: entities that existed before it was inserted were
//! never recorded, so its first reader must read every drawable entity once (`take_primed`).

use std::sync::Mutex;

use bevy_ecs::lifecycle::HookContext;
use bevy_ecs::prelude::*;
use bevy_ecs::world::DeferredWorld;

/// Entries kept (per list kind) before the feed gives up listing and asks its reader to read
/// everything: 128 MB of entity ids.
const MAX_PENDING: usize = 1 << 24;

/// Entities whose drawable state may have changed since the last [`DrawChanges::drain`].
#[derive(Resource, Default)]
pub struct DrawChanges {
    /// Recorded from one thread (hooks, hierarchy walks); may list an entity more than once.
    serial: Vec<Entity>,
    /// Lists recorded by parallel tasks, each handed over when its task ends, with its pass.
    parallel: Mutex<Vec<(u32, Vec<Entity>)>>,
    /// The current parallel pass.
    pass: u32,
    /// Whether a reader has drained the feed at least once (see the module docs).
    primed: bool,
}

/// The entities recorded since the last drain.
pub struct Drained {
    pub lists: Vec<Vec<Entity>>,
    /// Everything came from one parallel pass, which lists each entity at most once.
    pub unique: bool,
}

impl Drained {
    pub fn len(&self) -> usize {
        self.lists.iter().map(Vec::len).sum()
    }

    pub fn is_empty(&self) -> bool {
        self.lists.iter().all(Vec::is_empty)
    }
}

impl DrawChanges {
    /// Records one entity from the calling thread.
    pub fn record(&mut self, entity: Entity) {
        if self.serial.len() >= MAX_PENDING {
            self.overflow();
        }
        self.serial.push(entity);
    }

    /// Starts a parallel recording pass: tasks record into their own [`TaskRecorder`]s, which
    /// are handed over when dropped. A pass must record each entity at most once.
    pub fn begin_pass(&mut self) -> &Self {
        let parallel: usize =
            self.parallel.get_mut().unwrap_or_else(|e| e.into_inner()).iter().map(|(_, l)| l.len()).sum();
        if parallel >= MAX_PENDING {
            self.overflow();
        }
        self.pass = self.pass.wrapping_add(1);
        self
    }

    /// Too much recorded and not drained (an app that updates without extracting): the lists
    /// go, and the next reader reads every drawable entity instead.
    fn overflow(&mut self) {
        self.serial = Vec::new();
        *self.parallel.get_mut().unwrap_or_else(|e| e.into_inner()) = Vec::new();
        self.primed = false;
    }

    /// A task-local list for the pass begun by [`begin_pass`](Self::begin_pass).
    pub fn task_recorder(&self) -> TaskRecorder<'_> {
        TaskRecorder { pass: self.pass, list: Vec::new(), sink: &self.parallel }
    }

    /// Hands over everything recorded since the last drain. The second value is whether this
    /// is the first drain (or the lists overflowed): a reader must then read every drawable
    /// entity, recorded or not.
    pub fn drain(&mut self) -> (Drained, bool) {
        let tagged = std::mem::take(self.parallel.get_mut().unwrap_or_else(|e| e.into_inner()));
        let unique = self.serial.is_empty() && tagged.iter().all(|(pass, _)| *pass == tagged[0].0);
        let mut lists: Vec<Vec<Entity>> = tagged.into_iter().map(|(_, list)| list).collect();
        if !self.serial.is_empty() {
            lists.push(std::mem::take(&mut self.serial));
        }
        let first = !std::mem::replace(&mut self.primed, true);
        (Drained { lists, unique }, first)
    }
}

/// One task's recorded entities, appended to the feed when the task ends.
pub struct TaskRecorder<'a> {
    pass: u32,
    list: Vec<Entity>,
    sink: &'a Mutex<Vec<(u32, Vec<Entity>)>>,
}

impl TaskRecorder<'_> {
    pub fn record(&mut self, entity: Entity) {
        self.list.push(entity);
    }
}

impl Drop for TaskRecorder<'_> {
    fn drop(&mut self) {
        if !self.list.is_empty() {
            let list = std::mem::take(&mut self.list);
            self.sink.lock().unwrap_or_else(|e| e.into_inner()).push((self.pass, list));
        }
    }
}

/// The hook `Mesh3d` and `MeshMaterial3d` run when inserted (spawned with, or replaced).
pub(crate) fn record_insert(mut world: DeferredWorld, context: HookContext) {
    if let Some(mut feed) = world.get_resource_mut::<DrawChanges>() {
        feed.record(context.entity);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_pass_is_unique_and_several_are_not() {
        let mut feed = DrawChanges::default();
        let (_, first) = feed.drain();
        assert!(first);
        let (a, b) = (Entity::from_raw_u32(1).unwrap(), Entity::from_raw_u32(2).unwrap());
        {
            let pass = feed.begin_pass();
            let mut task = pass.task_recorder();
            task.record(a);
            task.record(b);
        }
        let (d, first) = feed.drain();
        assert!(!first);
        assert!(d.unique);
        assert_eq!(d.len(), 2);
        {
            let pass = feed.begin_pass();
            pass.task_recorder().record(a);
        }
        {
            // A pass that records nothing does not count.
            let pass = feed.begin_pass();
            drop(pass.task_recorder());
        }
        assert!(feed.drain().0.unique);
        for _ in 0..2 {
            let pass = feed.begin_pass();
            pass.task_recorder().record(a);
        }
        let (d, _) = feed.drain();
        assert!(!d.unique, "two passes may both list an entity");
        assert_eq!(d.len(), 2);
        feed.record(b);
        assert!(!feed.drain().0.unique, "hooks may list an entity twice");
        assert!(feed.drain().0.is_empty());
    }
}
