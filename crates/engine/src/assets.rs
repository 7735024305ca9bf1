//! `Assets<T>`: the one store for meshes, materials and images in the main world.
//!
//! Storage is a dense `Vec` of slots addressed by [`Handle`]s that carry a generation. Removing
//! an asset bumps its slot's generation and pushes the slot on a free list; the next `add` reuses
//! the slot with the new generation, so a handle kept past `remove` can never reach the asset that
//! took its place: every lookup compares generations and a mismatch is a [`StaleHandle`] error.
//!
//! Values are stored behind `Arc` so that extraction can hand a snapshot of a changed asset to the
//! render world in O(1); `get_mut` is copy-on-write if the render world still holds the old one.
//! Each insert or mutation stamps the slot with a fresh `version` drawn from a counter owned by
//! the store, which is how the render world learns what to re-upload without diffing contents.

use std::fmt;
use std::hash::{Hash, Hasher};
use std::marker::PhantomData;
use std::sync::Arc;

use bevy_ecs::resource::Resource;

/// A typed, generational reference to an asset in an [`Assets<T>`] store.
pub struct Handle<T> {
    index: u32,
    generation: u32,
    _marker: PhantomData<fn() -> T>,
}

impl<T> Handle<T> {
    /// The slot index; dense, so render-side tables can be plain vectors indexed by it.
    pub fn index(self) -> u32 {
        self.index
    }
    pub fn generation(self) -> u32 {
        self.generation
    }
}

impl<T> Clone for Handle<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Handle<T> {}
impl<T> PartialEq for Handle<T> {
    fn eq(&self, other: &Self) -> bool {
        self.index == other.index && self.generation == other.generation
    }
}
impl<T> Eq for Handle<T> {}
impl<T> Hash for Handle<T> {
    fn hash<H: Hasher>(&self, state: &mut H) {
        self.index.hash(state);
        self.generation.hash(state);
    }
}
impl<T> PartialOrd for Handle<T> {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl<T> Ord for Handle<T> {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        (self.index, self.generation).cmp(&(other.index, other.generation))
    }
}
impl<T> fmt::Debug for Handle<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = std::any::type_name::<T>();
        let short = name.rsplit("::").next().unwrap_or(name);
        write!(f, "Handle<{short}>({}v{})", self.index, self.generation)
    }
}

/// A handle whose asset was removed (or that never belonged to this store).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("stale {type_name} handle: slot {index} generation {generation} (slot is now {current})")]
pub struct StaleHandle {
    pub type_name: &'static str,
    pub index: u32,
    pub generation: u32,
    /// The slot's current state: `generation N`, `free`, or `out of range`.
    pub current: SlotState,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SlotState {
    Live { generation: u32 },
    Free,
    OutOfRange,
}

impl fmt::Display for SlotState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SlotState::Live { generation } => write!(f, "generation {generation}"),
            SlotState::Free => f.write_str("free"),
            SlotState::OutOfRange => f.write_str("out of range"),
        }
    }
}

struct Slot<T> {
    generation: u32,
    value: Option<Arc<T>>,
    version: u64,
}

/// Dense generational storage for one asset type.
#[derive(Resource)]
pub struct Assets<T: Send + Sync + 'static> {
    slots: Vec<Slot<T>>,
    free: Vec<u32>,
    len: usize,
    next_version: u64,
}

impl<T: Send + Sync + 'static> Default for Assets<T> {
    fn default() -> Self {
        Self { slots: Vec::new(), free: Vec::new(), len: 0, next_version: 1 }
    }
}

impl<T: Send + Sync + 'static> Assets<T> {
    pub fn new() -> Self {
        Self::default()
    }

    fn bump_version(&mut self) -> u64 {
        let v = self.next_version;
        self.next_version += 1;
        v
    }

    /// Stores `value` and returns its handle, reusing a freed slot when one exists.
    pub fn add(&mut self, value: T) -> Handle<T> {
        self.add_arc(Arc::new(value))
    }

    pub fn add_arc(&mut self, value: Arc<T>) -> Handle<T> {
        let version = self.bump_version();
        self.len += 1;
        if let Some(index) = self.free.pop() {
            let slot = &mut self.slots[index as usize];
            slot.value = Some(value);
            slot.version = version;
            return Handle { index, generation: slot.generation, _marker: PhantomData };
        }
        let index = u32::try_from(self.slots.len()).expect("more than 2^32 assets of one type");
        self.slots.push(Slot { generation: 0, value: Some(value), version });
        Handle { index, generation: 0, _marker: PhantomData }
    }

    fn stale(&self, handle: Handle<T>) -> StaleHandle {
        let current = match self.slots.get(handle.index as usize) {
            None => SlotState::OutOfRange,
            Some(slot) if slot.value.is_none() => SlotState::Free,
            Some(slot) => SlotState::Live { generation: slot.generation },
        };
        StaleHandle {
            type_name: std::any::type_name::<T>(),
            index: handle.index,
            generation: handle.generation,
            current,
        }
    }

    fn slot(&self, handle: Handle<T>) -> Result<&Slot<T>, StaleHandle> {
        match self.slots.get(handle.index as usize) {
            Some(slot) if slot.generation == handle.generation && slot.value.is_some() => Ok(slot),
            _ => Err(self.stale(handle)),
        }
    }

    pub fn get(&self, handle: Handle<T>) -> Result<&T, StaleHandle> {
        self.get_arc(handle).map(|a| a.as_ref())
    }

    /// The shared snapshot of an asset (what extraction hands to the render world).
    pub fn get_arc(&self, handle: Handle<T>) -> Result<&Arc<T>, StaleHandle> {
        self.slot(handle).map(|s| s.value.as_ref().expect("checked by slot()"))
    }

    /// The version stamped on the asset's last insert or mutation.
    pub fn version(&self, handle: Handle<T>) -> Result<u64, StaleHandle> {
        self.slot(handle).map(|s| s.version)
    }

    pub fn contains(&self, handle: Handle<T>) -> bool {
        self.slot(handle).is_ok()
    }

    /// Removes the asset; every copy of `handle` becomes stale.
    pub fn remove(&mut self, handle: Handle<T>) -> Result<Arc<T>, StaleHandle> {
        self.slot(handle)?;
        let slot = &mut self.slots[handle.index as usize];
        let value = slot.value.take().expect("checked by slot()");
        self.len -= 1;
        // A slot whose generation would wrap is retired instead of reused, so no handle can
        // ever alias a later asset.
        if let Some(next) = slot.generation.checked_add(1) {
            slot.generation = next;
            self.free.push(handle.index);
        }
        Ok(value)
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Iterates live assets in slot order.
    pub fn iter(&self) -> impl Iterator<Item = (Handle<T>, &T)> {
        self.slots.iter().enumerate().filter_map(|(i, slot)| {
            slot.value
                .as_ref()
                .map(|v| (Handle { index: i as u32, generation: slot.generation, _marker: PhantomData }, v.as_ref()))
        })
    }
}

/// What an asset type does before it is edited in place ([`Assets::get_mut`]): drop what it
/// derived from the content the caller is about to change. Most types derive nothing; an
/// image drops the mip chain made from its texels (`Image::mips`).
pub trait AssetEdit {
    fn before_edit(&mut self) {}
}

impl<T: AssetEdit + Clone + Send + Sync + 'static> Assets<T> {
    /// Mutable access; stamps a new version so the render world re-uploads the asset.
    pub fn get_mut(&mut self, handle: Handle<T>) -> Result<&mut T, StaleHandle> {
        self.slot(handle)?;
        let version = self.bump_version();
        let slot = &mut self.slots[handle.index as usize];
        slot.version = version;
        let value = Arc::make_mut(slot.value.as_mut().expect("checked by slot()"));
        value.before_edit();
        Ok(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    impl AssetEdit for Vec<u8> {}

    #[test]
    fn removed_handle_is_stale_even_after_slot_reuse() {
        let mut assets = Assets::<u32>::new();
        let a = assets.add(1);
        assets.remove(a).unwrap();
        let b = assets.add(2);
        assert_eq!(a.index(), b.index(), "the freed slot is reused");
        let err = assets.get(a).unwrap_err();
        assert_eq!(err.current, SlotState::Live { generation: 1 });
        assert_eq!(*assets.get(b).unwrap(), 2);
        assert!(assets.remove(a).is_err(), "removing through a stale handle fails");
        assert_eq!(assets.len(), 1);
    }

    #[test]
    fn mutation_stamps_a_newer_version() {
        let mut assets = Assets::<Vec<u8>>::new();
        let h = assets.add(vec![1]);
        let v0 = assets.version(h).unwrap();
        let snapshot = assets.get_arc(h).unwrap().clone();
        assets.get_mut(h).unwrap().push(2);
        assert!(assets.version(h).unwrap() > v0);
        assert_eq!(*snapshot, vec![1], "copy-on-write keeps the render world's snapshot intact");
        assert_eq!(*assets.get(h).unwrap(), vec![1, 2]);
    }

    #[test]
    fn handle_from_another_store_is_out_of_range() {
        let mut big = Assets::<u8>::new();
        for i in 0..4 {
            big.add(i);
        }
        let foreign = big.add(9);
        let small = Assets::<u8>::new();
        assert_eq!(small.get(foreign).unwrap_err().current, SlotState::OutOfRange);
    }
}
