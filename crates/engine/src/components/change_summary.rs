//! Whole-table change checks. Components marked `#[component(summary_tick)]` keep, per table,
//! the tick of the newest write to any row (bevy_ecs updates it on every write, insertion and
//! archetype move). A system that reacts to changes asks it first: on a still frame it reads
//! one tick per table instead of one per entity, which for a million entities is the
//! difference between nothing and a pass over 4 MB of change ticks on every core.

use bevy_ecs::change_detection::ContiguousRef;
use bevy_ecs::prelude::*;
use bevy_ecs::query::ArchetypeFilter;

/// Whether any entity `probe` matches may have had its `T` written since the calling system
/// last ran. True when it cannot tell (a component without a summary tick).
pub fn any_changed<T: Component, F: ArchetypeFilter>(probe: &Query<Ref<T>, F>) -> bool {
    let Ok(tables) = probe.contiguous_iter() else {
        return true;
    };
    tables.map(|t| ContiguousRef::split(t).1.summary_tick_is_changed()).any(|changed| changed != Some(false))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Component)]
    #[component(summary_tick)]
    struct Tracked(u32);

    #[derive(Component)]
    struct Untracked;

    #[derive(Resource, Default)]
    struct Seen(Vec<bool>);

    fn probe(q: Query<Ref<Tracked>>, mut seen: ResMut<Seen>) {
        seen.0.push(any_changed(&q));
    }

    fn probe_untracked(q: Query<Ref<Untracked>>, mut seen: ResMut<Seen>) {
        seen.0.push(any_changed(&q));
    }

    #[test]
    fn a_write_to_any_row_is_seen_once_and_a_still_frame_is_not() {
        let mut world = World::new();
        world.init_resource::<Seen>();
        let mut schedule = bevy_ecs::schedule::Schedule::default();
        schedule.add_systems(probe);
        let entities: Vec<Entity> = (0..1000).map(|i| world.spawn(Tracked(i)).id()).collect();
        // One in another table.
        let odd = world.spawn((Tracked(7), Untracked)).id();
        schedule.run(&mut world); // spawned
        schedule.run(&mut world); // still
        world.get_mut::<Tracked>(entities[500]).unwrap().0 = 1;
        schedule.run(&mut world); // one row written
        schedule.run(&mut world); // still
        world.get_mut::<Tracked>(odd).unwrap().0 = 2;
        schedule.run(&mut world); // a row of the other table
        world.entity_mut(entities[3]).insert(Tracked(9));
        schedule.run(&mut world); // replaced by insertion
        assert_eq!(world.resource::<Seen>().0, [true, false, true, false, true, true]);
    }

    #[test]
    fn without_a_summary_tick_it_cannot_tell() {
        let mut world = World::new();
        world.init_resource::<Seen>();
        let mut schedule = bevy_ecs::schedule::Schedule::default();
        schedule.add_systems(probe_untracked);
        world.spawn(Untracked);
        schedule.run(&mut world);
        schedule.run(&mut world);
        assert_eq!(world.resource::<Seen>().0, [true, true]);
    }
}
