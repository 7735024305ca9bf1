//! The IES profiles on the GPU, owned by the light store: every profile some light uses, each
//! as its [`ProfileGrid`](penumbra_engine::ies::ProfileGrid) (normalised candela on a uniform angle grid), laid one after another
//! in one `array<f32>` storage buffer that `shaders/ies.wgsl` indexes. A light finds its
//! profile through the [`ProfileSlot`] packed into it.
//!
//! Data flow: the light store counts the lights using each profile handle as lights come and
//! go; each frame [`ProfileTable::sync`] compares the profiles in use (and their asset
//! versions) with what the buffer holds. Any difference rebuilds the table whole and tells the
//! store to repack its profiled lights, whose offsets moved. Profiles change rarely (loaded,
//! edited), and a few dozen kilobytes each, so rebuilding beats allocating ranges.

use std::collections::{HashMap, HashSet};

use penumbra_engine::Handle;
use penumbra_engine::ies::IesProfile;

use crate::scene::world::Snapshot;

/// A light packs its profile's grid size as `rows · IES_DIMS_BASE + columns` (columns stay
/// below it: at most 1440, for 0.25° planes).
pub const IES_DIMS_BASE: u32 = 4096;
/// Values the table may hold: lights carry offsets into it as f32, exact below 2²⁴ (64 MiB of
/// profiles, some 600 profiles at 1° × 2.5°).
pub const MAX_VALUES: usize = 1 << 24;

/// Where one profile's grid sits in the buffer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfileSlot {
    /// Index of its first value.
    pub offset: u32,
    pub rows: u32,
    pub columns: u32,
    /// Candela the grid's 1.0 stands for.
    pub peak: f32,
}

#[derive(Default)]
pub struct ProfileTable {
    /// Lights using each profile.
    users: HashMap<Handle<IesProfile>, u32>,
    /// What the buffer holds: slot and the asset version it was built from.
    slots: HashMap<Handle<IesProfile>, (u64, ProfileSlot)>,
    data: Vec<f32>,
    buffer: Option<wgpu::Buffer>,
    /// `data` changed since the last upload.
    stale: bool,
    /// Handles already reported missing (each is reported once).
    missing: HashSet<Handle<IesProfile>>,
}

impl ProfileTable {
    pub fn slot(&self, profile: Handle<IesProfile>) -> Option<ProfileSlot> {
        self.slots.get(&profile).map(|(_, s)| *s)
    }

    pub fn add_user(&mut self, profile: Handle<IesProfile>) {
        *self.users.entry(profile).or_default() += 1;
    }

    pub fn remove_user(&mut self, profile: Handle<IesProfile>) {
        if let Some(n) = self.users.get_mut(&profile) {
            *n -= 1;
            if *n == 0 {
                self.users.remove(&profile);
            }
        }
    }

    /// Bytes the table holds on the GPU.
    pub fn gpu_bytes(&self) -> u64 {
        self.buffer.as_ref().map_or(0, wgpu::Buffer::size)
    }

    /// Brings the table in line with the profiles in use, as extracted. Returns true when it
    /// was rebuilt: every profiled light must then be repacked.
    pub fn sync(&mut self, assets: &HashMap<Handle<IesProfile>, Snapshot<IesProfile>>) -> bool {
        let mut wanted: Vec<(Handle<IesProfile>, u64)> = Vec::with_capacity(self.users.len());
        for handle in self.users.keys() {
            match assets.get(handle) {
                Some(snapshot) => wanted.push((*handle, snapshot.version)),
                None => {
                    if self.missing.insert(*handle) {
                        tracing::error!(
                            "an IesLight names {handle:?}, which is not in Assets<IesProfile> (removed, or never added); lights using it give no light"
                        );
                    }
                }
            }
        }
        let unchanged = wanted.len() == self.slots.len()
            && wanted.iter().all(|(h, v)| self.slots.get(h).is_some_and(|(sv, _)| sv == v));
        if unchanged {
            return false;
        }
        // Sorted so that the layout does not depend on the hash maps' order.
        wanted.sort_unstable();
        self.slots.clear();
        self.data.clear();
        for (handle, version) in wanted {
            self.missing.remove(&handle);
            let grid = assets[&handle].data.grid();
            if self.data.len() + grid.values.len() > MAX_VALUES {
                tracing::error!(
                    "IES profiles in use exceed {MAX_VALUES} values; {handle:?} ({}) is left out and its lights give no light",
                    assets[&handle].data.label
                );
                continue;
            }
            let slot =
                ProfileSlot { offset: self.data.len() as u32, rows: grid.rows, columns: grid.columns, peak: grid.peak };
            self.data.extend_from_slice(&grid.values);
            self.slots.insert(handle, (version, slot));
        }
        self.stale = true;
        true
    }

    /// Writes a rebuilt table; returns true when the buffer was replaced (rebind).
    pub fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) -> bool {
        if !self.stale {
            return false;
        }
        self.stale = false;
        if self.data.is_empty() {
            return false;
        }
        let bytes: &[u8] = bytemuck::cast_slice(&self.data);
        let fits = self.buffer.as_ref().is_some_and(|b| b.size() >= bytes.len() as u64);
        if !fits {
            self.buffer = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("ies profiles"),
                size: bytes.len().next_power_of_two() as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        queue.write_buffer(self.buffer.as_ref().expect("just created"), 0, bytes);
        !fits
    }

    pub fn buffer(&self) -> Option<&wgpu::Buffer> {
        self.buffer.as_ref()
    }
}
