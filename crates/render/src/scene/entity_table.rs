//! `EntityTable<T>`: per-entity state stored densely by entity index, for the retained render
//! world. Entity indices are small and reused (bevy's allocator recycles them), so a vector
//! indexed by them holds a million draws with one cache line per lookup and no hashing, where a
//! hash map spent most of a frame of a million moving objects on probing.
//!
//! An entry remembers the whole `Entity` (index and generation): a lookup for a despawned
//! entity whose index was reused finds nothing, and inserting the new entity reports the
//! displaced old one so that its owner can release what it held.

use std::marker::PhantomData;
use std::sync::atomic::{AtomicUsize, Ordering};

use bevy_ecs::entity::Entity;

#[derive(Debug, Clone)]
pub struct EntityTable<T> {
    entries: Vec<Option<(Entity, T)>>,
    len: usize,
}

impl<T> Default for EntityTable<T> {
    fn default() -> Self {
        Self { entries: Vec::new(), len: 0 }
    }
}

/// What an insertion replaced.
#[derive(Debug, PartialEq)]
pub enum Replaced<T> {
    Nothing,
    /// The same entity's earlier value.
    Same(T),
    /// Another (despawned) entity that had the same index.
    Other(Entity, T),
}

impl<T> EntityTable<T> {
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn get(&self, entity: Entity) -> Option<&T> {
        match self.entries.get(entity.index_u32() as usize) {
            Some(Some((e, value))) if *e == entity => Some(value),
            _ => None,
        }
    }

    pub fn contains(&self, entity: Entity) -> bool {
        self.get(entity).is_some()
    }

    pub fn insert(&mut self, entity: Entity, value: T) -> Replaced<T> {
        let i = entity.index_u32() as usize;
        if i >= self.entries.len() {
            // Geometric growth through Vec::resize_with's reserve.
            self.entries.resize_with(i + 1, || None);
        }
        match self.entries[i].replace((entity, value)) {
            None => {
                self.len += 1;
                Replaced::Nothing
            }
            Some((e, old)) if e == entity => Replaced::Same(old),
            Some((e, old)) => Replaced::Other(e, old),
        }
    }

    pub fn remove(&mut self, entity: Entity) -> Option<T> {
        let slot = self.entries.get_mut(entity.index_u32() as usize)?;
        if slot.as_ref().is_some_and(|(e, _)| *e == entity) {
            self.len -= 1;
            slot.take().map(|(_, v)| v)
        } else {
            None
        }
    }

    /// Makes room for entities with indices below `n` (bevy's `Entities::len()` bounds every
    /// live entity's index), so that a [`DisjointWriter`] can place them.
    pub fn reserve_indices(&mut self, n: usize) {
        if self.entries.len() < n {
            self.entries.resize_with(n, || None);
        }
    }

    /// Insertion from many threads at once, each entity at its own index (see
    /// [`DisjointWriter::insert`]).
    pub fn disjoint_writer(&mut self) -> DisjointWriter<'_, T> {
        DisjointWriter {
            entries: self.entries.as_mut_ptr(),
            capacity: self.entries.len(),
            added: AtomicUsize::new(0),
            len: &mut self.len,
            _entries: PhantomData,
        }
    }

    /// Entries in entity-index order.
    pub fn iter(&self) -> impl Iterator<Item = (Entity, &T)> {
        self.entries.iter().filter_map(|e| e.as_ref().map(|(e, v)| (*e, v)))
    }

    pub fn keys(&self) -> impl Iterator<Item = Entity> + '_ {
        self.iter().map(|(e, _)| e)
    }
}

/// Inserts into an [`EntityTable`] from several threads: every live entity has its own index,
/// so writers for different entities touch different entries. Extraction uses it to copy a
/// million changed draws on all cores without collecting them first.
pub struct DisjointWriter<'a, T> {
    entries: *mut Option<(Entity, T)>,
    capacity: usize,
    added: AtomicUsize,
    len: &'a mut usize,
    _entries: PhantomData<&'a mut [Option<(Entity, T)>]>,
}

// SAFETY: the writer only hands out access to one entry per call, and `insert`'s contract
// keeps calls for the same index from overlapping; `T` values move between threads.
unsafe impl<T: Send> Sync for DisjointWriter<'_, T> {}
unsafe impl<T: Send> Send for DisjointWriter<'_, T> {}

impl<T> DisjointWriter<'_, T> {
    /// Like [`EntityTable::insert`]; `Err` gives the value back when the entity's index is
    /// beyond what [`EntityTable::reserve_indices`] made room for.
    ///
    /// # Safety
    /// No other call with an entity of the same index may run at the same time (through this
    /// writer). A list of distinct live entities satisfies this (two live entities never share an
    /// index), as do entities yielded by one query iteration.
    pub unsafe fn insert(&self, entity: Entity, value: T) -> Result<Replaced<T>, T> {
        let i = entity.index_u32() as usize;
        if i >= self.capacity {
            return Err(value);
        }
        // SAFETY: `i` is in bounds (checked above; the vector cannot be resized while the
        // writer borrows the table) and no other thread touches entry `i` (the contract).
        let slot = unsafe { &mut *self.entries.add(i) };
        Ok(match slot.replace((entity, value)) {
            None => {
                self.added.fetch_add(1, Ordering::Relaxed);
                Replaced::Nothing
            }
            Some((e, old)) if e == entity => Replaced::Same(old),
            Some((e, old)) => Replaced::Other(e, old),
        })
    }
}

impl<T> Drop for DisjointWriter<'_, T> {
    fn drop(&mut self) {
        *self.len += *self.added.get_mut();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reused_index_is_another_entity() {
        use bevy_ecs::entity::EntityGeneration;
        let old = Entity::from_raw_u32(7).expect("valid index");
        // What the allocator hands out when index 7 is reused after a despawn.
        let new = Entity::from_index_and_generation(old.index(), EntityGeneration::FIRST.after_versions(1));
        let mut table = EntityTable::default();
        assert_eq!(table.insert(old, 1), Replaced::Nothing);
        assert_eq!(table.insert(old, 2), Replaced::Same(1));
        assert_eq!(table.get(new), None);
        assert_eq!(table.remove(new), None);
        assert_eq!(table.insert(new, 3), Replaced::Other(old, 2));
        assert_eq!(table.get(old), None);
        assert_eq!(table.get(new), Some(&3));
        assert_eq!(table.len(), 1);
        assert_eq!(table.remove(new), Some(3));
        assert!(table.is_empty());
        assert_eq!(table.iter().count(), 0);
    }

    #[test]
    fn parallel_insertion_at_distinct_indices() {
        let mut table = EntityTable::default();
        let entities: Vec<Entity> = (0..10_000).map(|i| Entity::from_raw_u32(i).unwrap()).collect();
        table.insert(entities[5], 0u32);
        table.reserve_indices(entities.len());
        {
            let writer = table.disjoint_writer();
            std::thread::scope(|s| {
                for part in entities.chunks(1000) {
                    let writer = &writer;
                    s.spawn(move || {
                        for &e in part {
                            // SAFETY: the chunks hold distinct entities.
                            let r = unsafe { writer.insert(e, e.index_u32() + 1) };
                            assert!(matches!(r, Ok(Replaced::Nothing) | Ok(Replaced::Same(0))));
                        }
                    });
                }
            });
            let beyond = Entity::from_raw_u32(20_000).unwrap();
            // SAFETY: no other writer is running.
            assert_eq!(unsafe { writer.insert(beyond, 7) }, Err(7));
        }
        assert_eq!(table.len(), entities.len());
        assert!(entities.iter().all(|e| table.get(*e) == Some(&(e.index_u32() + 1))));
    }
}
