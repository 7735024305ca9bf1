//! The light store: the one owner of the light storage buffer. Every extracted light (and the
//! default lights of a scene without any) is packed into one `array<Light>` with no fixed count.
//!
//! Layout: `[global lights | local lights]`. Global lights (directional, ambient) light every
//! fragment and are walked in full; local lights (every other kind) are binned into clusters and
//! walked through the cluster lists. Each section is dense: removal moves the section's last
//! light into the hole (one slot rewritten). Extraction's change lists drive `sync`; `upload`
//! then writes only the slots that changed, merged into runs. A change in the number of global
//! lights shifts every local slot, so it re-uploads the lot (rare: a directional light added).
//!
//! Ranges: a local light's influence ends at glTF's `range` when given, else where a white
//! Lambertian surface facing it would be lit to less than `cutoff` after exposure (see
//! [`influence_range`]); the shader windows the falloff smoothly to zero there. Since the
//! computed range depends on exposure, a change of exposure repacks every light.
//!
//! The first [`UNIFORM_GLOBAL_LIGHTS`] slots, where the global lights are, are bound a second
//! time as a uniform array (`global_lights` in `forward.wgsl`), which the forward shader's walk
//! of the global lights reads while they fit ([`LightStore::global_lights_fit_uniform`]; more
//! global lights than that select the `GLOBAL_LIGHTS_IN_STORAGE` variant, which walks the
//! storage array: no cap). Why: a fragment shader's storage reads are gathered lane by lane on
//! llvmpipe even at an index every lane shares, while uniform reads at such an index are one
//! load: the uniform walk takes 6 % off the lit DamagedHelmet variant's code generation on Mesa
//! 25's lavapipe (503 → 472 M instructions, `compile_cost.sh`), which every hot reload waits
//! for (README, "Reload latency"); on Mesa 22.3, which reads uniforms no better, it adds 2 %.
//!
//! IES-profiled lights carry the slot of their profile in the store's [`ProfileTable`] (see
//! `ies_profiles.rs`); when the table is rebuilt, they are repacked.

use std::collections::HashMap;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::buffer::GrowableBuffer;
use super::ies_profiles::{IES_DIMS_BASE, ProfileTable};
use crate::world::{ExtractedLight, LightKey, LightKind, RenderScene};

/// Global lights the forward shader reads from the uniform binding of the store's first slots
/// (mirrors `global_lights`' length in `shaders/forward.wgsl`). 64 lights are 4 KiB, the
/// store's first allocation, and far more directional and ambient lights than a scene uses.
pub const UNIFORM_GLOBAL_LIGHTS: u32 = 64;

/// Mirrors `struct Light` in `shaders/light_data.wgsl`. `size` and `shape` mean what each kind
/// needs (see [`pack`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    pub position: [f32; 3],
    pub kind: u32,
    /// Unit direction the light shines (spot, directional, rect, disk) or a tube's axis.
    pub direction: [f32; 3],
    /// Radius around `position` bounding everything a local light reaches (> 0): its influence
    /// range plus its own extent. 0 for global lights and for local lights that light nothing
    /// (zero intensity or area), which the binner skips.
    pub range: f32,
    pub color: [f32; 3],
    /// Spot: cone falloff scale. Sphere, tube, disk: radius. Rect: half width. IES: the
    /// profile's first index in the profile buffer, as a whole number.
    pub size: f32,
    /// Spot: (cone falloff offset, 0, 0, 0). Tube: (half length, 0, 0, 0). Rect: (unit width
    /// axis, half height). Disk: (unit axis in its plane, 0). IES: (unit C = 0° axis,
    /// `rows · 4096 + columns` of the profile's grid as a whole number).
    pub shape: [f32; 4],
}

pub const KIND_DIRECTIONAL: u32 = 0;
pub const KIND_POINT: u32 = 1;
pub const KIND_SPOT: u32 = 2;
pub const KIND_AMBIENT: u32 = 3;
pub const KIND_SPHERE: u32 = 4;
pub const KIND_TUBE: u32 = 5;
pub const KIND_RECT: u32 = 6;
pub const KIND_DISK: u32 = 7;
pub const KIND_IES: u32 = 8;

/// Display-referred luminance below which a light's contribution is cut off, by default:
/// 1/4096 of white, about a quarter of the smallest step of an 8-bit sRGB output near black.
pub const DEFAULT_CUTOFF: f32 = 1.0 / 4096.0;

/// Whether `kind` is binned into clusters (else it lights every fragment).
pub fn is_local(kind: &LightKind) -> bool {
    !matches!(kind, LightKind::Directional { .. } | LightKind::Ambient)
}

/// Luminous intensity (cd) of the brightest channel, as seen from afar along the light's
/// brightest direction: a rect or disk light's luminance times its area.
fn peak_intensity(light: &ExtractedLight) -> f32 {
    let area = match light.kind {
        LightKind::Rect { width, height } => width.max(0.0) * height.max(0.0),
        LightKind::Disk { radius } => std::f32::consts::PI * radius.max(0.0).powi(2),
        _ => 1.0,
    };
    (light.color.max_element().max(0.0) * area).min(f32::MAX)
}

/// The distance, from the nearest point of the light, at which a local light stops: glTF's
/// `range` when given (and positive), else the distance where the light, after `exposure`,
/// would make a white Lambertian surface facing it reflect `cutoff` (display-referred
/// luminance): `L = k·I/(π·d²)`, so `d = √(k·I/(π·cutoff))` for the brightest channel's
/// intensity `I` (cd) and exposure scale `k`. For area lights `I` is the peak intensity, and
/// since no point of an emitter of area A is nearer than d, `L·A/d²` bounds its irradiance too.
pub fn influence_range(light: &ExtractedLight, exposure: f32, cutoff: f32) -> f32 {
    let intensity = peak_intensity(light);
    if intensity <= 0.0 {
        return 0.0;
    }
    match light.range {
        Some(r) if r > 0.0 && r.is_finite() => r,
        _ => (exposure * intensity / (std::f32::consts::PI * cutoff)).sqrt().min(f32::MAX),
    }
}

/// How far the light itself extends from its `position`: what the bounding radius adds to the
/// influence range (and what the shader subtracts again to window by distance to the light).
pub fn extent(kind: &LightKind) -> f32 {
    match *kind {
        LightKind::Tube { length, .. } => 0.5 * length.max(0.0),
        LightKind::Rect { width, height } => 0.5 * width.max(0.0).hypot(height.max(0.0)),
        LightKind::Disk { radius } => radius.max(0.0),
        _ => 0.0,
    }
}

/// Packs a light for the GPU. `profiles` places IES lights' profiles; an IES light whose
/// profile is not in the table packs dark (range 0), so nothing bins or shades it.
pub fn pack(light: &ExtractedLight, exposure: f32, cutoff: f32, profiles: &ProfileTable) -> GpuLight {
    let direction = light.direction.normalize_or(Vec3::NEG_Z);
    // The in-plane axis of rects and disks, made exactly perpendicular to the normal (a sheared
    // transform may not give perpendicular axes).
    let across =
        (light.right - direction * light.right.dot(direction)).normalize_or(direction.any_orthonormal_vector());
    let mut g = GpuLight {
        position: light.position.to_array(),
        kind: 0,
        direction: direction.to_array(),
        range: 0.0,
        color: light.color.max(Vec3::ZERO).to_array(),
        size: 0.0,
        shape: [0.0; 4],
    };
    match light.kind {
        LightKind::Directional { .. } => g.kind = KIND_DIRECTIONAL,
        LightKind::Point => g.kind = KIND_POINT,
        LightKind::Ambient => g.kind = KIND_AMBIENT,
        LightKind::Spot { inner_cone_angle, outer_cone_angle } => {
            // KHR_lights_punctual's smooth cone falloff as scale/offset of cos(angle); the
            // 0.001 floor keeps inner == outer from dividing by zero (a hard-edged cone). The
            // outer angle is clamped to π/2, the most glTF allows (the binner's cone test
            // needs it).
            let outer = outer_cone_angle.clamp(0.0, std::f32::consts::FRAC_PI_2);
            let cos_outer = outer.cos();
            let cos_inner = inner_cone_angle.clamp(0.0, outer).cos();
            let scale = 1.0 / (cos_inner - cos_outer).max(0.001);
            g.kind = KIND_SPOT;
            g.size = scale;
            g.shape[0] = -cos_outer * scale;
        }
        LightKind::Sphere { radius } => {
            g.kind = KIND_SPHERE;
            g.size = radius.max(0.0);
        }
        LightKind::Tube { length, radius } => {
            g.kind = KIND_TUBE;
            g.direction = light.right.normalize_or(Vec3::X).to_array();
            g.size = radius.max(0.0);
            g.shape[0] = 0.5 * length.max(0.0);
        }
        LightKind::Rect { width, height } => {
            g.kind = KIND_RECT;
            g.size = 0.5 * width.max(0.0);
            // The width axis scaled by the half height: shape.w stays free for the shadow layer.
            g.shape = (across * (0.5 * height.max(0.0))).extend(0.0).to_array();
        }
        LightKind::Disk { radius } => {
            g.kind = KIND_DISK;
            g.size = radius.max(0.0);
            g.shape = across.extend(0.0).to_array();
        }
        LightKind::Ies { profile } => {
            g.kind = KIND_IES;
            match profiles.slot(profile) {
                Some(slot) => {
                    // The shader reads the profile as a share of its peak.
                    g.color = (light.color.max(Vec3::ZERO) * slot.peak).min(Vec3::splat(f32::MAX)).to_array();
                    // Whole numbers below 2²⁴ (the table keeps them there), exact in f32: stored
                    // as values rather than bit patterns, which would be denormal floats that
                    // some drivers flush to zero.
                    g.size = slot.offset as f32;
                    g.shape = across.extend((slot.rows * IES_DIMS_BASE + slot.columns) as f32).to_array();
                }
                None => g.color = [0.0; 3],
            }
        }
    }
    if is_local(&light.kind) {
        // The packed colour: an IES light's includes its profile's peak.
        let reach = influence_range(&ExtractedLight { color: Vec3::from(g.color), ..*light }, exposure, cutoff);
        if reach > 0.0 {
            g.range = (reach + extent(&light.kind)).min(f32::MAX);
        }
    }
    g
}

/// One dense section of the buffer.
#[derive(Default)]
struct Section {
    keys: Vec<LightKey>,
    extracted: Vec<ExtractedLight>,
    packed: Vec<GpuLight>,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Which {
    Global,
    Local,
}

/// World-space bounds of every local light's sphere of influence, and the spheres' mean radius
/// (the cluster grid keeps its depth slices from getting much thinner than the lights).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightBounds {
    pub min: Vec3,
    pub max: Vec3,
    pub mean_range: f32,
}

pub struct LightStore {
    /// Created by the first `upload` (the CPU side works without a device, for tests).
    buffer: Option<GrowableBuffer>,
    global: Section,
    local: Section,
    index: HashMap<LightKey, (Which, u32)>,
    /// Slots to upload, as (section, index in section).
    dirty: Vec<(Which, u32)>,
    /// Upload everything (layout shifted, buffer grew, exposure changed).
    full: bool,
    exposure: f32,
    cutoff: f32,
    bounds: Option<LightBounds>,
    bounds_stale: bool,
    /// Incremented whenever any local light changes: cached cluster bounds key on it.
    pub local_generation: u64,
    /// Bytes written by the last `upload`.
    pub last_upload_bytes: u64,
    /// Lights of each kind (indexed by `GpuLight::kind`): which shading code the scene needs.
    kind_counts: [u32; KIND_COUNT],
    /// The LTC fit, uploaded with the first rect or disk light; until then a 16-byte stand-in
    /// fills its binding (no shader variant without those lights reads it).
    ltc_table: Option<wgpu::Buffer>,
    /// Stands in for the LTC and IES buffers while the scene needs neither.
    placeholder: Option<wgpu::Buffer>,
    profiles: ProfileTable,
    /// First layer of each shadowed local light's maps in the local shadow atlas.
    shadow_layers: HashMap<LightKey, u32>,
}

/// Number of light kinds (discriminants `0..KIND_COUNT`).
pub const KIND_COUNT: usize = 9;

/// The fitted LTC tables for GGX (see `shaders/ltc.wgsl` and `assets/ltc/README.md`): 64×64
/// cells of M⁻¹ as 4 f32, then 64×64 cells of (magnitude, Fresnel) as 2 f32, little-endian.
const LTC_TABLE: &[u8] = include_bytes!("../../../../assets/ltc/ggx_ltc_64x64.bin");

/// Which kinds of lights with a size the scene has: each brings its own shader code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct LightShapes {
    /// Sphere or tube lights (representative point).
    pub sphere_tube: bool,
    /// Rect or disk lights (linearly transformed cosines).
    pub ltc: bool,
    /// IES-profiled lights.
    pub ies: bool,
}

impl Default for LightStore {
    fn default() -> Self {
        Self::new()
    }
}

impl LightStore {
    pub fn new() -> Self {
        Self {
            buffer: None,
            global: Section::default(),
            local: Section::default(),
            index: HashMap::new(),
            dirty: Vec::new(),
            full: true,
            exposure: 1.0,
            cutoff: DEFAULT_CUTOFF,
            bounds: None,
            bounds_stale: false,
            local_generation: 0,
            last_upload_bytes: 0,
            kind_counts: [0; KIND_COUNT],
            ltc_table: None,
            placeholder: None,
            profiles: ProfileTable::default(),
            shadow_layers: HashMap::new(),
        }
    }

    /// Which local lights read shadow maps, from which first layer of the local shadow atlas:
    /// packed as `shape.w` = layer + 1 (0: unshadowed), which point and spot lights leave free.
    /// Repacks only the lights whose layer changed; returns whether any did.
    pub fn set_shadow_layers(&mut self, layers: HashMap<LightKey, u32>) -> bool {
        if layers == self.shadow_layers {
            return false;
        }
        let old = std::mem::replace(&mut self.shadow_layers, layers);
        let keys: Vec<LightKey> = old.keys().chain(self.shadow_layers.keys()).copied().collect();
        for key in keys {
            if old.get(&key) == self.shadow_layers.get(&key) {
                continue;
            }
            if let Some(&(which, i)) = self.index.get(&key) {
                let value = self.shadow_value(&key);
                self.section(which).packed[i as usize].shape[3] = value;
                self.dirty.push((which, i));
            }
        }
        true
    }

    fn shadow_value(&self, key: &LightKey) -> f32 {
        self.shadow_layers.get(key).map_or(0.0, |l| (l + 1) as f32)
    }

    /// The local lights with their slots, in buffer order.
    pub fn local_entries(&self) -> impl Iterator<Item = (u32, LightKey, &ExtractedLight, &GpuLight)> {
        let first = self.global_count();
        self.local
            .keys
            .iter()
            .zip(&self.local.extracted)
            .zip(&self.local.packed)
            .enumerate()
            .map(move |(i, ((k, l), p))| (first + i as u32, *k, l, p))
    }

    /// The kinds of lights with a size present now.
    pub fn shapes(&self) -> LightShapes {
        let c = &self.kind_counts;
        LightShapes {
            sphere_tube: c[KIND_SPHERE as usize] + c[KIND_TUBE as usize] > 0,
            ltc: c[KIND_RECT as usize] + c[KIND_DISK as usize] > 0,
            ies: c[KIND_IES as usize] > 0,
        }
    }

    /// The buffer behind `ltc_table` in the shaders (a stand-in until a rect or disk light
    /// needs the real one). Exists once `upload` has run.
    pub fn ltc_buffer(&self) -> &wgpu::Buffer {
        self.ltc_table.as_ref().or(self.placeholder.as_ref()).expect("LightStore::upload runs before binding")
    }

    /// The buffer behind `ies_profiles` in the shaders (a stand-in while no light uses one).
    /// Exists once `upload` has run.
    pub fn ies_buffer(&self) -> &wgpu::Buffer {
        self.profiles.buffer().or(self.placeholder.as_ref()).expect("LightStore::upload runs before binding")
    }

    fn count_kind(&mut self, kind: u32, delta: i32) {
        if let Some(c) = self.kind_counts.get_mut(kind as usize) {
            *c = c.saturating_add_signed(delta);
        }
    }

    /// The storage buffer; exists once `upload` has run.
    pub fn buffer(&self) -> &wgpu::Buffer {
        self.buffer.as_ref().expect("LightStore::upload runs before the buffer is bound").buffer()
    }

    pub fn global_count(&self) -> u32 {
        self.global.keys.len() as u32
    }

    /// The store's first [`UNIFORM_GLOBAL_LIGHTS`] slots, bound as the forward shader's
    /// `global_lights` uniform array (the buffer never holds fewer: it starts at that size and
    /// only grows). Exists once `upload` has run.
    pub fn global_lights_binding(&self) -> wgpu::BufferBinding<'_> {
        wgpu::BufferBinding {
            buffer: self.buffer(),
            offset: 0,
            size: wgpu::BufferSize::new(UNIFORM_GLOBAL_LIGHTS as u64 * std::mem::size_of::<GpuLight>() as u64),
        }
    }

    /// Whether every global light is within [`Self::global_lights_binding`]; otherwise the
    /// forward shader walks them in the storage array (the `GLOBAL_LIGHTS_IN_STORAGE` variant).
    pub fn global_lights_fit_uniform(&self) -> bool {
        self.global_count() <= UNIFORM_GLOBAL_LIGHTS
    }

    pub fn local_count(&self) -> u32 {
        self.local.keys.len() as u32
    }

    pub fn count(&self) -> u32 {
        self.global_count() + self.local_count()
    }

    pub fn gpu_bytes(&self) -> u64 {
        self.buffer.as_ref().map_or(0, GrowableBuffer::capacity)
            + self.ltc_table.as_ref().map_or(0, wgpu::Buffer::size)
            + self.profiles.gpu_bytes()
    }

    /// The global lights (directional, ambient) with their slots, in buffer order.
    pub fn global_lights(&self) -> impl Iterator<Item = (u32, LightKey, &ExtractedLight)> {
        self.global.keys.iter().zip(&self.global.extracted).enumerate().map(|(i, (k, l))| (i as u32, *k, l))
    }

    /// The packed local lights, in buffer order (slot `global_count() + i`).
    pub fn local_lights(&self) -> &[GpuLight] {
        &self.local.packed
    }

    /// Every packed light in buffer order.
    pub fn packed(&self) -> Vec<GpuLight> {
        self.global.packed.iter().chain(&self.local.packed).copied().collect()
    }

    /// Bounds of the local lights' spheres of influence (None without local lights).
    pub fn local_bounds(&mut self) -> Option<LightBounds> {
        if self.bounds_stale {
            self.bounds_stale = false;
            // (min, max, sum of ranges, count) over the lights that reach anywhere.
            let mut acc: Option<(Vec3, Vec3, f64, u32)> = None;
            for l in self.local.packed.iter().filter(|l| l.range > 0.0) {
                let p = Vec3::from(l.position);
                let (lo, hi) = (p - l.range, p + l.range);
                let (min, max, sum, n) = acc.unwrap_or((lo, hi, 0.0, 0));
                acc = Some((min.min(lo), max.max(hi), sum + l.range as f64, n + 1));
            }
            self.bounds = acc.map(|(min, max, sum, n)| LightBounds { min, max, mean_range: (sum / n as f64) as f32 });
        }
        self.bounds
    }

    /// Applies this frame's light changes. `in_step` is false when the renderer missed an
    /// extraction: then the store is rebuilt from the full light set.
    pub fn sync(&mut self, scene: &RenderScene, in_step: bool, exposure: f32, cutoff: f32) {
        if exposure != self.exposure || cutoff != self.cutoff {
            self.exposure = exposure;
            self.cutoff = cutoff;
            self.repack_all();
        }
        if !in_step {
            let stale: Vec<LightKey> = self.index.keys().filter(|k| !scene.lights.contains_key(k)).copied().collect();
            for key in stale {
                self.remove(key);
            }
            let mut all: Vec<(&LightKey, &ExtractedLight)> = scene.lights.iter().collect();
            // Deterministic slot order whatever the hash map's order.
            all.sort_by_key(|(k, _)| **k);
            for (key, light) in all {
                self.upsert(*key, light);
            }
        } else {
            for key in &scene.removed_lights {
                self.remove(*key);
            }
            for key in &scene.changed_lights {
                match scene.lights.get(key) {
                    Some(light) => self.upsert(*key, light),
                    None => self.remove(*key),
                }
            }
        }
        for i in 0..=u8::MAX {
            let key = LightKey::Default(i);
            match scene.default_lights.get(i as usize) {
                Some(light) => self.upsert(key, light),
                None if self.index.contains_key(&key) => self.remove(key),
                None => break,
            }
        }
        if self.profiles.sync(&scene.ies_profiles) {
            self.repack_profiled();
        }
    }

    /// Repacks the IES lights after their profiles moved in the table.
    fn repack_profiled(&mut self) {
        let (exposure, cutoff) = (self.exposure, self.cutoff);
        for (i, light) in self.local.extracted.iter().enumerate() {
            if matches!(light.kind, LightKind::Ies { .. }) {
                self.local.packed[i] = pack(light, exposure, cutoff, &self.profiles);
                self.dirty.push((Which::Local, i as u32));
            }
        }
        self.bounds_stale = true;
        self.local_generation += 1;
    }

    /// Keeps the profile table's count of lights per profile.
    fn count_profile_user(&mut self, light: &ExtractedLight, delta: i32) {
        if let LightKind::Ies { profile } = light.kind {
            if delta > 0 { self.profiles.add_user(profile) } else { self.profiles.remove_user(profile) }
        }
    }

    fn section(&mut self, which: Which) -> &mut Section {
        match which {
            Which::Global => &mut self.global,
            Which::Local => &mut self.local,
        }
    }

    fn repack_all(&mut self) {
        let (exposure, cutoff) = (self.exposure, self.cutoff);
        for s in [&mut self.global, &mut self.local] {
            for ((packed, light), key) in s.packed.iter_mut().zip(&s.extracted).zip(&s.keys) {
                *packed = pack(light, exposure, cutoff, &self.profiles);
                packed.shape[3] += self.shadow_layers.get(key).map_or(0.0, |l| (l + 1) as f32);
            }
        }
        self.full = true;
        self.bounds_stale = true;
        self.local_generation += 1;
    }

    fn upsert(&mut self, key: LightKey, light: &ExtractedLight) {
        let which = if is_local(&light.kind) { Which::Local } else { Which::Global };
        match self.index.get(&key).copied() {
            Some((w, i)) if w == which => {
                let old = self.section(which).extracted[i as usize];
                if old == *light {
                    return;
                }
                self.count_profile_user(&old, -1);
                self.count_profile_user(light, 1);
                let mut packed = pack(light, self.exposure, self.cutoff, &self.profiles);
                packed.shape[3] += self.shadow_value(&key);
                let s = self.section(which);
                let old_kind = std::mem::replace(&mut s.packed[i as usize], packed).kind;
                s.extracted[i as usize] = *light;
                self.count_kind(old_kind, -1);
                self.count_kind(packed.kind, 1);
                self.dirty.push((which, i));
            }
            Some(_) => {
                // Changed type across sections (an entity's light swapped for another kind).
                self.remove(key);
                self.insert(key, which, light);
            }
            None => self.insert(key, which, light),
        }
        if which == Which::Local {
            self.bounds_stale = true;
            self.local_generation += 1;
        }
    }

    fn insert(&mut self, key: LightKey, which: Which, light: &ExtractedLight) {
        self.count_profile_user(light, 1);
        let mut packed = pack(light, self.exposure, self.cutoff, &self.profiles);
        packed.shape[3] += self.shadow_value(&key);
        self.count_kind(packed.kind, 1);
        let s = self.section(which);
        let i = s.keys.len() as u32;
        s.keys.push(key);
        s.extracted.push(*light);
        s.packed.push(packed);
        self.index.insert(key, (which, i));
        self.dirty.push((which, i));
        if which == Which::Global {
            self.full = true;
        }
    }

    fn remove(&mut self, key: LightKey) {
        let Some((which, i)) = self.index.remove(&key) else { return };
        let s = self.section(which);
        s.keys.swap_remove(i as usize);
        let removed = s.extracted.swap_remove(i as usize);
        let removed_kind = s.packed.swap_remove(i as usize).kind;
        let moved = s.keys.get(i as usize).copied();
        self.count_profile_user(&removed, -1);
        if let Some(moved) = moved {
            self.index.insert(moved, (which, i));
            self.dirty.push((which, i));
        }
        self.count_kind(removed_kind, -1);
        match which {
            Which::Global => self.full = true,
            Which::Local => {
                self.bounds_stale = true;
                self.local_generation += 1;
            }
        }
    }

    /// Writes what changed since the last upload; returns true when a buffer was replaced or
    /// created (bind groups holding it must be rebuilt).
    pub fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) -> bool {
        const SIZE: u64 = std::mem::size_of::<GpuLight>() as u64;
        let total = self.count() as u64 * SIZE;
        let created = self.buffer.is_none();
        let buffer = self.buffer.get_or_insert_with(|| {
            let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::UNIFORM;
            GrowableBuffer::new(device, "lights", usage, UNIFORM_GLOBAL_LIGHTS as u64 * SIZE)
        });
        let grew = buffer.reserve(device, total.max(SIZE)) || created;
        let mut ltc_created = false;
        let buffer = buffer.buffer().clone();
        if self.placeholder.is_none() {
            self.placeholder = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("ltc table and ies profiles stand-in"),
                size: 16,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            }));
        }
        if self.shapes().ltc && self.ltc_table.is_none() {
            let table = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("ltc table"),
                size: LTC_TABLE.len() as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            queue.write_buffer(&table, 0, LTC_TABLE);
            self.ltc_table = Some(table);
            ltc_created = true;
        }
        let profiles_moved = self.profiles.upload(device, queue);
        self.last_upload_bytes = 0;
        if grew || self.full {
            let all = self.packed();
            if !all.is_empty() {
                queue.write_buffer(&buffer, 0, bytemuck::cast_slice(&all));
            }
            self.last_upload_bytes = total;
        } else if !self.dirty.is_empty() {
            let global = self.global_count();
            let mut slots: Vec<u32> = self
                .dirty
                .iter()
                .filter_map(|&(w, i)| {
                    let len = if w == Which::Global { self.global.keys.len() } else { self.local.keys.len() };
                    // A slot past the end was vacated by a removal; nothing reads it.
                    ((i as usize) < len).then_some(if w == Which::Global { i } else { global + i })
                })
                .collect();
            slots.sort_unstable();
            slots.dedup();
            let all_local = &self.local.packed;
            let light_at = |slot: u32| {
                if slot < global { self.global.packed[slot as usize] } else { all_local[(slot - global) as usize] }
            };
            // Merge into runs; a gap of a few slots is cheaper to rewrite than to split on.
            let mut run: Vec<GpuLight> = Vec::new();
            let mut run_start = 0u32;
            let mut flush = |start: u32, run: &mut Vec<GpuLight>| {
                if !run.is_empty() {
                    queue.write_buffer(&buffer, start as u64 * SIZE, bytemuck::cast_slice(run));
                    self.last_upload_bytes += run.len() as u64 * SIZE;
                    run.clear();
                }
            };
            for slot in slots {
                let next = run_start + run.len() as u32;
                if !run.is_empty() && slot > next + 4 {
                    flush(run_start, &mut run);
                }
                if run.is_empty() {
                    run_start = slot;
                }
                for s in run_start + run.len() as u32..=slot {
                    run.push(light_at(s));
                }
            }
            flush(run_start, &mut run);
        }
        self.dirty.clear();
        self.full = false;
        grew || ltc_created || profiles_moved
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy_ecs::entity::Entity;

    fn light(kind: LightKind) -> ExtractedLight {
        ExtractedLight {
            kind,
            color: Vec3::ONE,
            position: Vec3::ZERO,
            direction: Vec3::NEG_Z,
            right: Vec3::X,
            range: None,
            shadows: false,
        }
    }

    fn test_profile() -> penumbra_engine::ies::IesProfile {
        let text = "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 0\n0 45 90\n0\n400 200 0\n";
        penumbra_engine::ies::IesProfile::parse(text, "test.ies").expect("valid")
    }

    #[test]
    fn every_light_kind_packs_its_own_discriminant() {
        let kinds = [
            (LightKind::Directional { angular_radius: 0.0 }, KIND_DIRECTIONAL),
            (LightKind::Point, KIND_POINT),
            (LightKind::Spot { inner_cone_angle: 0.1, outer_cone_angle: 0.5 }, KIND_SPOT),
            (LightKind::Ambient, KIND_AMBIENT),
            (LightKind::Sphere { radius: 0.1 }, KIND_SPHERE),
            (LightKind::Tube { length: 1.0, radius: 0.1 }, KIND_TUBE),
            (LightKind::Rect { width: 1.0, height: 0.5 }, KIND_RECT),
            (LightKind::Disk { radius: 0.3 }, KIND_DISK),
            (LightKind::Ies { profile: penumbra_engine::Assets::new().add(test_profile()) }, KIND_IES),
        ];
        let mut seen = std::collections::HashSet::new();
        for (k, want) in kinds {
            assert_eq!(pack(&light(k), 1.0, DEFAULT_CUTOFF, &ProfileTable::default()).kind, want, "{k:?}");
            assert!(seen.insert(want), "{k:?} shares a discriminant");
        }
        assert_eq!(seen.len(), KIND_COUNT);
        assert_eq!(std::mem::size_of::<GpuLight>(), 64);
    }

    #[test]
    fn gpu_light_mirrors_the_shaders_light() {
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuLight,
            "forward.wgsl",
            [],
            "Light",
            [position, kind, direction, range, color, size, shape]
        );
    }

    #[test]
    fn the_uniform_array_of_global_lights_has_the_length_the_binding_gives_it() {
        use crate::pipelines::shader_library::{ShaderDefs, ShaderLibrary};
        let module = ShaderLibrary::embedded().unwrap().compose("forward.wgsl", &ShaderDefs::default()).unwrap();
        let (_, global) =
            module.global_variables.iter().find(|(_, v)| v.name.as_deref() == Some("global_lights")).unwrap();
        let size = match module.types[global.ty].inner {
            naga::TypeInner::Array { size: naga::ArraySize::Constant(n), stride, .. } => (n.get(), stride),
            ref other => panic!("global_lights is {other:?}"),
        };
        assert_eq!(size, (UNIFORM_GLOBAL_LIGHTS, std::mem::size_of::<GpuLight>() as u32));
        // The variant that walks the storage array binds no uniform array.
        let storage = ShaderDefs::default().with("GLOBAL_LIGHTS_IN_STORAGE", true);
        let module = ShaderLibrary::embedded().unwrap().compose("forward.wgsl", &storage).unwrap();
        assert!(module.global_variables.iter().all(|(_, v)| v.name.as_deref() != Some("global_lights")));
    }

    #[test]
    fn ies_lights_find_their_profile_and_are_repacked_when_it_moves() {
        let mut assets = penumbra_engine::Assets::new();
        let a = assets.add(test_profile());
        let e = |i: u32| Entity::from_raw_u32(i).expect("valid index");
        let mut ies = light(LightKind::Ies { profile: a });
        ies.color = Vec3::splat(0.5);
        ies.range = Some(2.0);
        let mut scene = scene_with(&[(LightKey::Ies(e(1)), ies)]);
        let mut store = LightStore::new();
        // The profile is not extracted yet: the light packs dark and is not binned.
        store.sync(&scene, true, 1.0, DEFAULT_CUTOFF);
        assert_eq!((store.local_lights()[0].range, store.local_lights()[0].color), (0.0, [0.0; 3]));
        let snapshot = |v: u64| crate::world::Snapshot { version: v, data: std::sync::Arc::new(test_profile()) };
        scene.ies_profiles.insert(a, snapshot(1));
        scene.changed_lights.clear();
        store.sync(&scene, true, 1.0, DEFAULT_CUTOFF);
        let g = store.local_lights()[0];
        assert_eq!((g.kind, g.range, g.color), (KIND_IES, 2.0, [200.0; 3]), "peak 400 cd × 0.5");
        let slot = store.profiles.slot(a).expect("in the table");
        assert_eq!((g.size, g.shape[3]), (slot.offset as f32, (slot.rows * 4096 + slot.columns) as f32));
        assert_eq!((slot.rows, slot.columns), (5, 1), "45° steps, one plane");
        // A second profile rebuilds the table; each light finds its own.
        let b = assets.add(test_profile());
        scene.ies_profiles.insert(b, snapshot(2));
        let mut other = ies;
        other.kind = LightKind::Ies { profile: b };
        scene.lights.insert(LightKey::Ies(e(2)), other);
        scene.changed_lights = vec![LightKey::Ies(e(2))];
        store.sync(&scene, true, 1.0, DEFAULT_CUTOFF);
        for (g, h) in store.local_lights().iter().zip([a, b]) {
            assert_eq!(g.size, store.profiles.slot(h).expect("in the table").offset as f32);
        }
        assert_ne!(store.profiles.slot(a), store.profiles.slot(b));
        // Removing the lights releases the profiles.
        scene.changed_lights.clear();
        for k in [LightKey::Ies(e(1)), LightKey::Ies(e(2))] {
            scene.lights.remove(&k);
            scene.removed_lights.push(k);
        }
        store.sync(&scene, true, 1.0, DEFAULT_CUTOFF);
        assert!(store.profiles.slot(a).is_none() && store.profiles.slot(b).is_none());
        assert!(!store.shapes().ies);
    }

    #[test]
    fn spot_falloff_is_one_inside_and_zero_outside() {
        let g = pack(
            &light(LightKind::Spot { inner_cone_angle: 0.2, outer_cone_angle: 0.4 }),
            1.0,
            DEFAULT_CUTOFF,
            &ProfileTable::default(),
        );
        let at = |angle: f32| (angle.cos() * g.size + g.shape[0]).clamp(0.0, 1.0);
        assert!((at(0.1) - 1.0).abs() < 1e-5);
        assert!(at(0.41) == 0.0);
        let g = pack(
            &light(LightKind::Spot { inner_cone_angle: 0.4, outer_cone_angle: 0.4 }),
            1.0,
            DEFAULT_CUTOFF,
            &ProfileTable::default(),
        );
        assert!(g.size.is_finite());
    }

    #[test]
    fn computed_range_is_where_the_light_falls_to_the_cutoff() {
        let mut l = light(LightKind::Point);
        l.color = Vec3::new(100.0, 50.0, 10.0);
        let r = influence_range(&l, 0.5, 0.001);
        // A white surface facing the light at distance r: k·I/(π r²) = cutoff.
        let luminance = 0.5 * 100.0 / (std::f32::consts::PI * r * r);
        assert!((luminance - 0.001).abs() < 1e-6, "{luminance}");
        l.range = Some(3.0);
        assert_eq!(influence_range(&l, 0.5, 0.001), 3.0);
        l.color = Vec3::ZERO;
        assert_eq!(influence_range(&l, 0.5, 0.001), 0.0, "a dark light has no influence");
        l.range = None;
        l.color = Vec3::splat(f32::MAX);
        assert!(influence_range(&l, 1e30, 1e-30).is_finite());
    }

    #[test]
    fn area_lights_are_bounded_by_their_reach_plus_their_extent() {
        let mut rect = light(LightKind::Rect { width: 2.0, height: 1.0 });
        rect.range = Some(3.0);
        // A sheared transform's axes: the packed width axis is made perpendicular to the normal.
        rect.right = Vec3::new(1.0, 0.0, 0.5);
        let g = pack(&rect, 1.0, DEFAULT_CUTOFF, &ProfileTable::default());
        assert!((g.range - (3.0 + 0.5 * 5f32.sqrt())).abs() < 1e-5, "{}", g.range);
        // The width axis scaled by the half height; shape.w is left for the shadow layer.
        let axis = Vec3::new(g.shape[0], g.shape[1], g.shape[2]);
        assert!(axis.dot(Vec3::from(g.direction)).abs() < 1e-6 && (axis.length() - 0.5).abs() < 1e-6);
        assert_eq!((g.size, g.shape[3]), (1.0, 0.0));
        // Computed reach: a rect of luminance L and area A reaches as far as a point light of
        // intensity L·A.
        let mut point = light(LightKind::Point);
        point.color = Vec3::splat(2.0);
        rect.range = None;
        assert!((influence_range(&rect, 1.0, 1e-3) - influence_range(&point, 1.0, 1e-3)).abs() < 1e-3);
        let tube =
            pack(&light(LightKind::Tube { length: 4.0, radius: 0.1 }), 1.0, DEFAULT_CUTOFF, &ProfileTable::default());
        let sphere = pack(&light(LightKind::Sphere { radius: 0.1 }), 1.0, DEFAULT_CUTOFF, &ProfileTable::default());
        assert!((tube.range - sphere.range - 2.0).abs() < 1e-4);
        // No area, no light: not binned.
        assert_eq!(
            pack(&light(LightKind::Rect { width: 0.0, height: 1.0 }), 1.0, DEFAULT_CUTOFF, &ProfileTable::default())
                .range,
            0.0
        );
        assert_eq!(
            pack(&light(LightKind::Disk { radius: -1.0 }), 1.0, DEFAULT_CUTOFF, &ProfileTable::default()).range,
            0.0
        );
    }

    fn scene_with(lights: &[(LightKey, ExtractedLight)]) -> RenderScene {
        let mut scene = RenderScene::default();
        for (k, l) in lights {
            scene.lights.insert(*k, *l);
            scene.changed_lights.push(*k);
        }
        scene
    }

    #[test]
    fn sections_stay_dense_and_keyed_through_removals() {
        let e = |i: u32| Entity::from_raw_u32(i).expect("valid index");
        let mut store = LightStore::new();
        let mut lights = Vec::new();
        for i in 0..5 {
            let mut l = light(LightKind::Point);
            l.position = Vec3::splat(i as f32);
            lights.push((LightKey::Point(e(i)), l));
        }
        lights.push((LightKey::Directional(e(9)), light(LightKind::Directional { angular_radius: 0.0 })));
        let scene = scene_with(&lights);
        store.sync(&scene, true, 1.0, DEFAULT_CUTOFF);
        assert_eq!((store.global_count(), store.local_count()), (1, 5));
        let mut scene = RenderScene { lights: scene.lights, ..Default::default() };
        scene.lights.remove(&LightKey::Point(e(1)));
        scene.removed_lights.push(LightKey::Point(e(1)));
        store.sync(&scene, true, 1.0, DEFAULT_CUTOFF);
        assert_eq!(store.local_count(), 4);
        // The last light moved into the hole; every key still finds its own light.
        for (key, &(w, i)) in &store.index {
            let s = if w == Which::Global { &store.global } else { &store.local };
            assert_eq!(s.keys[i as usize], *key);
            assert_eq!(s.extracted[i as usize], scene.lights[key]);
        }
    }
}
