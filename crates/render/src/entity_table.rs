//! `EntityTable<T>`: per-entity state stored densely by entity index, for the retained render
//! world. Entity indices are small and reused (bevy's allocator recycles them), so a vector
//! indexed by them holds a million draws with one cache line per lookup and no hashing, where a
//! hash map spent most of a frame of a million moving objects on probing.
//!
//! An entry remembers the whole `Entity` (index and generation): a lookup for a despawned
//! entity whose index was reused finds nothing, and inserting the new entity reports the
//! displaced old one so that its owner can release what it held.

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

    pub fn get_mut(&mut self, entity: Entity) -> Option<&mut T> {
        match self.entries.get_mut(entity.index_u32() as usize) {
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

    /// Entries in entity-index order.
    pub fn iter(&self) -> impl Iterator<Item = (Entity, &T)> {
        self.entries.iter().filter_map(|e| e.as_ref().map(|(e, v)| (*e, v)))
    }

    pub fn values(&self) -> impl Iterator<Item = &T> {
        self.iter().map(|(_, v)| v)
    }

    pub fn keys(&self) -> impl Iterator<Item = Entity> + '_ {
        self.iter().map(|(e, _)| e)
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
}
