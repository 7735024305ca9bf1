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
//! load: the uniform walk makes the lit variant's code generation on lavapipe smaller, which
//! every hot reload waits for (docs/shaders.md, "What a lavapipe compile costs"); older
//! lavapipe, which reads uniforms no better, pays a little more for it.
//!
//! IES-profiled lights carry the slot of their profile in the store's [`ProfileTable`] (see
//! `ies_profiles.rs`); when the table is rebuilt, they are repacked.

use std::collections::HashMap;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::ies_profiles::{IES_DIMS_BASE, ProfileTable};
use crate::bindings::{GroupBuilder, GroupResources};
use crate::gpu::buffer::GrowableBuffer;
use crate::scene::world::{ExtractedLight, LightKey, LightKind, RenderScene};

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

    /// The light store's share of the view group: every light, the global lights again as a
    /// uniform array, the LTC table and the IES profiles.
    pub fn declare_view(b: &mut GroupBuilder) {
        let lit = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
        let storage = wgpu::BufferBindingType::Storage { read_only: true };
        b.buffer("lights", lit, storage)
            .buffer("global_lights", lit, wgpu::BufferBindingType::Uniform)
            .buffer("ltc_table", lit, storage)
            .buffer("ies_profiles", lit, storage);
    }

    pub fn view_resources<'a>(&'a self, r: &mut GroupResources<'a>) {
        r.buffer("lights", self.buffer())
            .add("global_lights", wgpu::BindingResource::Buffer(self.global_lights_binding()))
            .buffer("ltc_table", self.ltc_buffer())
            .buffer("ies_profiles", self.ies_buffer());
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
mod tests;
