//! The shadow orchestrator: the one owner of shadow passes. It owns the atlases ([`super::atlas`]:
//! 2D arrays, one layer per cascade of the directional lights, and one per spot map or cube face
//! of the local lights), the cascades' staging, the shadow uniform and local-shadow table the
//! shaders read (`shaders/shadows.wgsl`), the per-layer caster views, and the decision of what to
//! render and by which rasteriser.
//!
//! Per frame, [`ShadowOrchestrator::prepare`] takes the camera, the light store's shadowed
//! lights and the bounds of casters and receivers, and produces the frame's [`ShadowFrame`]:
//! which directional lights get cascades (the brightest [`MAX_SHADOWED_DIRECTIONAL`]), each
//! cascade's fitted projection, whether its layer is in use and whether it must be drawn (a
//! layer still holding this projection's casters is kept), and (through
//! [`super::local`]) which local lights hold maps and which maps re-render within the budget. A
//! scene with no shadowed light, no caster or no camera gets no pass, and the atlases are
//! released (a 1×1 stand-in fills the bindings). The cascade atlas is a depth target, or floats
//! where the view (and so the casters) will be rasterised in compute. [`ShadowOrchestrator::encode`]
//! then draws each layer to render: where the view's culling prepared the batches, only the
//! casters [`super::caster_cull`] kept for that layer; into a depth atlas by the hardware's
//! caster passes (indirect draws), into a float atlas by [`super::raster`] (the compute raster,
//! into the staging buffer, whose window is copied into the layer), or, where that raster cannot
//! run this frame, by the caster passes into the staging's depth target, copied in the same way.

use glam::{DAffine3, DMat4, DVec3, DVec4, Mat4, Vec3};
use penumbra_engine::bounds::Aabb;

use super::atlas::{Atlas, LayerStaging};
use super::cascades::{self, Cascade, CascadeCamera};
use super::caster_cull::{CasterCulling, CasterSources, CullLayout, MapVolume};
use super::casters::{CasterFamily, CasterKey};
use super::local::{self, LocalCandidate, LocalFrame, LocalShadows};
use super::raster::{CasterRaster, MapRaster, RasterInputs};
use super::window::{self, TexelWindow};
use super::{ShadowFilter, ShadowSettings};
use crate::bindings::{GroupBuilder, GroupResources};
use crate::features::culling::BatchBuffers;
use crate::features::visibility::RasterTable;
use crate::frame_context::FrameContext;
use crate::gpu::array_layers::ArrayLayers;
use crate::pipelines::{PipelineCache, ShaderError};
use crate::resources::draw_list::{CasterChanges, SceneBounds};
use crate::resources::draws::{Batch, TopologyKey};
use crate::resources::materials::{AlphaKey, MaterialTable, TextureSet};
use crate::resources::mesh_pool::MeshPool;
use crate::scene::world::{ExtractedLight, ExtractedView, LightKey, LightKind};

/// Directional lights that get cascades at once; dimmer ones light the scene unshadowed (with a
/// warning). Mirrors `MAX_SHADOWED_DIRECTIONAL` in `shaders/shadows.wgsl`.
pub const MAX_SHADOWED_DIRECTIONAL: usize = 4;
/// Cascade slots in the shadow uniform: four lights of four cascades.
pub const MAX_CASCADES: usize = 16;
/// Caster views sit at this stride in their buffer (the minimum uniform offset alignment).
const CASTER_VIEW_STRIDE: u64 = 256;

/// Texels by which a cascade's caster planes reach beyond its receivers' lookups: a layer drawn
/// with them stays valid while the camera moves by less (see `HeldLayer`).
pub const HOLD_SLACK_TEXELS: f64 = 4.0;

/// Cascade layers are sized in steps of this many texels (up to the preset's size), so that a
/// moving camera whose receivers' windows change by a few texels does not reallocate the atlas.
const LAYER_STEP: u32 = 64;

/// What a cascade layer holds.
#[derive(Debug, Clone, PartialEq)]
struct HeldLayer {
    clip_from_world: DMat4,
    caster_generation: u64,
    /// The planes its casters were culled to (world space).
    planes: Vec<DVec4>,
    /// The texels of the cascade's map it stores.
    window: TexelWindow,
}

/// Timestamp labels of the caster passes, by layer.
const LAYER_LABELS: [&str; MAX_CASCADES] = [
    "shadow 0",
    "shadow 1",
    "shadow 2",
    "shadow 3",
    "shadow 4",
    "shadow 5",
    "shadow 6",
    "shadow 7",
    "shadow 8",
    "shadow 9",
    "shadow 10",
    "shadow 11",
    "shadow 12",
    "shadow 13",
    "shadow 14",
    "shadow 15",
];

/// A directional light the store holds, as the orchestrator sees it.
#[derive(Debug, Clone, Copy)]
pub struct DirectionalCandidate {
    pub key: LightKey,
    /// Its slot in the light buffer.
    pub slot: u32,
    pub light: ExtractedLight,
}

/// A light given cascades this frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowedLight {
    pub key: LightKey,
    pub slot: u32,
    /// Its first cascade's layer; the rest follow.
    pub first_layer: u32,
}

/// What the orchestrator decided for this frame.
#[derive(Debug, Clone, Default)]
pub struct ShadowFrame {
    pub lights: Vec<ShadowedLight>,
    /// Every light's cascades, light after light (index = atlas layer).
    pub cascades: Vec<Cascade>,
    /// Per layer: in use this frame (else no caster reaches it, or nothing visible lies in it).
    pub rendered: Vec<bool>,
    /// Per layer: the planes (world space) bounding the casters that can shadow what reads it
    /// ([`cascades::receiver_planes`]), moved out by the lookups' reach and
    /// [`HOLD_SLACK_TEXELS`]; the corners of the slice of the view that reads it; and how far
    /// (metres) a receiver's lookups reach.
    pub receiver_planes: Vec<Vec<DVec4>>,
    pub slice_corners: Vec<[DVec3; 8]>,
    pub receiver_reach: Vec<f64>,
    /// Per layer: the texels of the cascade's map that receivers reading it look up
    /// ([`TexelWindow::around`]); `None` where none does.
    pub receiver_windows: Vec<Option<TexelWindow>>,
    /// Per atlas layer in use: the window it stores (the receivers' window widened by
    /// [`HOLD_SLACK_TEXELS`] when drawn), at its top-left corner.
    pub stored: Vec<Option<TexelWindow>>,
    /// Texels across a cascade's whole map (`ShadowSettings::atlas_size`) and the atlas layers'
    /// size (width, height), which holds every stored window.
    pub resolution: u32,
    pub layer_extent: (u32, u32),
    /// The camera's position (f64), to make the planes camera-relative.
    pub eye: DVec3,
    /// Per layer: drawn this frame. A layer in use whose projection and casters are what it
    /// already holds is not drawn again (a still camera over a still scene costs nothing).
    pub redraw: Vec<bool>,
    /// Spot and point lights' maps.
    pub local: LocalFrame,
    /// The farthest a caster's bounds reach from the camera (metres): how large the
    /// camera-relative positions are whose depths the cascades store (see `DEPTH_PRECISION_ULPS`).
    pub caster_extent: f64,
}

impl ShadowFrame {
    /// Layers drawn this frame, directional and local.
    pub fn rendered_layers(&self) -> usize {
        self.redraw.iter().filter(|r| **r).count() + self.local.render.len()
    }

    /// Atlas layer `layer`'s clip space from world space: its cascade's projection, moved so
    /// that the window it stores lands at the layer's top-left corner, on the same texel grid.
    fn layer_clip_from_world(&self, layer: usize) -> DMat4 {
        self.stored_clip(layer, |w| w.clip_to_layer(self.resolution, self.layer_extent))
    }

    /// The same from camera-relative positions (what the shaders take).
    pub fn layer_clip_from_rel(&self, layer: usize) -> Mat4 {
        self.relative(layer, self.layer_clip_from_world(layer))
    }

    /// The clip space of the window alone that layer `layer` stores (the window filling it), from
    /// camera-relative positions: what its casters are culled to.
    pub fn window_clip_from_rel(&self, layer: usize) -> Mat4 {
        self.relative(layer, self.stored_clip(layer, |w| w.clip_to_window(self.resolution)))
    }

    /// The cascade's projection followed by `to` of the window the layer stores (unchanged
    /// where it stores none).
    fn stored_clip(&self, layer: usize, to: impl Fn(TexelWindow) -> DMat4) -> DMat4 {
        let cascade = self.cascades[layer].clip_from_world;
        self.stored.get(layer).copied().flatten().map_or(cascade, |w| to(w) * cascade)
    }

    /// `clip_from_world` from camera-relative positions, rounded once; a layer storing no window
    /// keeps its cascade's own matrix.
    fn relative(&self, layer: usize, clip_from_world: DMat4) -> Mat4 {
        match self.stored.get(layer).copied().flatten() {
            Some(_) => (clip_from_world * DMat4::from_translation(self.eye)).as_mat4(),
            None => self.cascades[layer].clip_from_rel,
        }
    }
}

/// A caster's stored depth is its camera-relative position (f32) times the cascade's matrix, so
/// it is off by a few units in the last place of that position's size: for a caster vertex 10⁶ m
/// from the camera, centimetres, whatever the cascade's depth range. A receiver's own depth comes
/// from its position near the camera and is exact in comparison, so where the caster and the
/// receiver are one surface (a ground facing the light, which has no depth slope for the
/// slope-scaled bias to hide, or a huge ground) the comparison goes either way from texel to
/// texel: streaks, or a whole cascade in shadow. Receivers are moved this many ulps of the
/// farthest caster's distance toward the light (added to the depth translation of the
/// receivers' matrix); for a scene ten metres across, micrometres.
pub const DEPTH_PRECISION_ULPS: f64 = 4.0;

/// A receiver's depth tolerance on a backend that rounds depth at 2⁻²⁴ of 1 (GL, see
/// `Capabilities::exact_depth`): eight such steps. Without it a surface facing the light, whose
/// slope-scaled bias is zero, shadows itself there wherever the rounding goes the wrong way (a
/// disc around a spot light's axis). 4.8e-7 of reverse-Z depth is 4.8e-7 × d² / near metres at
/// distance d from a local light, and 4.8e-7 of a cascade's depth range.
pub const INEXACT_DEPTH_TOLERANCE: f32 = 8.0 / 16_777_216.0;

pub struct ShadowOrchestrator {
    uniform: wgpu::Buffer,
    /// Cascades' views first (`MAX_CASCADES`), then the local layers'.
    caster_views: wgpu::Buffer,
    atlas: Option<Atlas>,
    /// The cascades' full map size the atlas's layers were made for (their windows' grid).
    atlas_resolution: u32,
    local: LocalShadows,
    /// The local lights' layers (allocated while any local light has a map).
    local_atlas: Option<Atlas>,
    /// `array<LocalShadow>`, one per local layer.
    local_buffer: wgpu::Buffer,
    /// Where cascade layers are drawn before being copied into `atlas` (with it).
    staging: Option<LayerStaging>,
    /// Fill the atlases' bindings while no light casts (nothing samples them then): cascades',
    /// local lights'.
    placeholders: [Atlas; 2],
    /// The local atlas's comparisons.
    sampler: wgpu::Sampler,
    /// The cascade atlas's gathers (nearest, clamped).
    gather: wgpu::Sampler,
    array_layers: ArrayLayers,
    /// Added to a receiver's depth before comparing it with the map: 0 where depth is exact;
    /// [`INEXACT_DEPTH_TOLERANCE`] where the backend rounds it (`Capabilities::exact_depth`).
    depth_tolerance: f32,
    frame: ShadowFrame,
    /// Caster bind groups and the buffers each was made with (instances, draw list, materials),
    /// compared by identity to notice growth: at most one binding the full draw list and one the
    /// culled maps' lists.
    caster_bind_groups: Vec<([wgpu::Buffer; 3], wgpu::BindGroup)>,
    /// Each map's casters culled on the GPU: made by the first culled frame, released with the
    /// atlases.
    cull: Option<CasterCulling>,
    /// Cascade layers' casters rasterised in compute: made by the first such frame, released
    /// with the atlases.
    raster: Option<CasterRaster>,
    /// The camera's position this frame as the shaders take it (f32): caster vertices are
    /// placed relative to it. `ShadowFrame::eye` is the same point in f64, for the planes.
    camera_position: Vec3,
    /// Whether the last frame's maps were culled on the GPU.
    culled: bool,
    /// Lights already warned about for lack of a cascade slot.
    warned_excess: bool,
    /// What each cascade layer holds: the projection it was drawn with, the caster generation,
    /// and the planes its casters were culled to; and the settings (bias is raster state).
    held: Vec<Option<HeldLayer>>,
    held_settings: Option<ShadowSettings>,
    /// The caster generation of the last frame planned.
    seen_generation: u64,
}

impl ShadowOrchestrator {
    /// `exact_depth`: see `Capabilities::exact_depth`. Registers the caster pipeline family
    /// (masked casters bind the `material` group).
    pub fn new(
        device: &wgpu::Device,
        array_layers: ArrayLayers,
        exact_depth: bool,
        pipelines: &mut PipelineCache,
        material: &wgpu::BindGroupLayout,
    ) -> Self {
        pipelines.register(CasterFamily::new(device, material));
        CasterCulling::register(device, pipelines);
        CasterRaster::register(device, pipelines, material);
        Self {
            uniform: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("shadows"),
                size: std::mem::size_of::<GpuShadows>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            caster_views: caster_views_buffer(device, 0),
            atlas: None,
            atlas_resolution: 0,
            local: LocalShadows::default(),
            local_atlas: None,
            local_buffer: local_buffer(device, 1),
            staging: None,
            placeholders: [
                Atlas::floats(device, array_layers, (1, 1), 1),
                Atlas::depth(device, array_layers, (1, 1), 1),
            ],
            array_layers,
            depth_tolerance: if exact_depth { 0.0 } else { INEXACT_DEPTH_TOLERANCE },
            // Reverse-Z: a receiver is lit where its depth is at least the nearest caster's.
            sampler: device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("shadow comparison"),
                address_mode_u: wgpu::AddressMode::ClampToEdge,
                address_mode_v: wgpu::AddressMode::ClampToEdge,
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                compare: Some(wgpu::CompareFunction::GreaterEqual),
                ..Default::default()
            }),
            gather: device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("shadow gather"),
                address_mode_u: wgpu::AddressMode::ClampToEdge,
                address_mode_v: wgpu::AddressMode::ClampToEdge,
                ..Default::default()
            }),
            frame: ShadowFrame::default(),
            caster_bind_groups: Vec::new(),
            cull: None,
            raster: None,
            camera_position: Vec3::ZERO,
            culled: false,
            warned_excess: false,
            held: Vec::new(),
            held_settings: None,
            seen_generation: 0,
        }
    }

    /// Forgets what every layer holds, so all are drawn again (settings changed, or the caster
    /// shader changed or failed).
    pub fn invalidate(&mut self) {
        self.held.clear();
        self.local = LocalShadows::default();
    }

    /// Whether directional lights read cascades this frame.
    pub fn active(&self) -> bool {
        self.frame.rendered.iter().any(|r| *r)
    }

    /// Whether any local light reads a shadow map this frame.
    pub fn local_active(&self) -> bool {
        !self.frame.local.first_layers.is_empty()
    }

    pub fn local_atlas_view(&self) -> &wgpu::TextureView {
        &self.local_atlas.as_ref().unwrap_or(&self.placeholders[1]).array_view
    }

    pub fn local_buffer(&self) -> &wgpu::Buffer {
        &self.local_buffer
    }

    pub fn frame(&self) -> &ShadowFrame {
        &self.frame
    }

    pub fn uniform(&self) -> &wgpu::Buffer {
        &self.uniform
    }

    /// The atlas as the shaders bind it (the stand-in while none is allocated).
    pub fn atlas_view(&self) -> &wgpu::TextureView {
        &self.atlas.as_ref().unwrap_or(&self.placeholders[0]).array_view
    }

    pub fn sampler(&self) -> &wgpu::Sampler {
        &self.sampler
    }

    /// The orchestrator's share of the view group (`shaders/shadows.wgsl`): the uniform, the
    /// cascade atlas, the local atlas's comparison sampler, the local lights' layers and atlas,
    /// and the cascade atlas's gather sampler.
    pub fn declare_view(b: &mut GroupBuilder) {
        let lit = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
        let atlas = |sample_type| wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        };
        b.buffer("shadows", lit, wgpu::BufferBindingType::Uniform)
            .add("shadow_atlas", lit, atlas(wgpu::TextureSampleType::Float { filterable: false }))
            .add("shadow_sampler", lit, wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison))
            .buffer("local_shadows", lit, wgpu::BufferBindingType::Storage { read_only: true })
            .add("local_atlas", lit, atlas(wgpu::TextureSampleType::Depth))
            .add("shadow_gather", lit, wgpu::BindingType::Sampler(wgpu::SamplerBindingType::NonFiltering));
    }

    pub fn view_resources<'a>(&'a self, r: &mut GroupResources<'a>) {
        r.buffer("shadows", self.uniform())
            .add("shadow_atlas", wgpu::BindingResource::TextureView(self.atlas_view()))
            .add("shadow_sampler", wgpu::BindingResource::Sampler(self.sampler()))
            .buffer("local_shadows", self.local_buffer())
            .add("local_atlas", wgpu::BindingResource::TextureView(self.local_atlas_view()))
            .add("shadow_gather", wgpu::BindingResource::Sampler(&self.gather));
    }

    /// The GPU cull's counts of the last frame's last cull pass: per map (in the order the
    /// layers were drawn: cascades, then local maps), the instances each opaque batch drew.
    /// `None` when no map was culled. Reads back (waits for the GPU): for tests and tools.
    pub fn read_culled_counts(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Option<Vec<Vec<u32>>>, crate::gpu::readback::ReadbackError> {
        match &self.cull {
            Some(cull) if self.culled => cull.read_counts(device, queue),
            _ => Ok(None),
        }
    }

    /// The window cascade layer `layer` stores (width, height) and its depths, row by row; `None`
    /// where the layer stores none. Reads back (waits for the GPU): for tests and tools.
    pub fn read_cascade_layer(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        layer: usize,
    ) -> Result<Option<((u32, u32), Vec<f32>)>, crate::gpu::readback::ReadbackError> {
        let (Some(atlas), Some(Some(window))) = (&self.atlas, self.frame.stored.get(layer)) else { return Ok(None) };
        let size = (window.width, window.height);
        Ok(Some((size, atlas.read_layer(device, queue, layer as u32, size)?)))
    }

    /// The atlases' bytes.
    pub fn gpu_bytes(&self) -> u64 {
        self.atlas.as_ref().map_or(0, Atlas::bytes)
            + self.local_atlas.as_ref().map_or(0, Atlas::bytes)
            + self.staging.as_ref().map_or(0, LayerStaging::bytes)
    }

    /// The culled maps' draw lists and arguments (counted with the other draw lists).
    pub fn caster_list_bytes(&self) -> u64 {
        self.cull.as_ref().map_or(0, CasterCulling::gpu_bytes) + self.raster.as_ref().map_or(0, CasterRaster::gpu_bytes)
    }

    /// Decides this frame's shadows and writes the uniform. `caster_generation` changes
    /// whenever any caster may have, and `changes` says where since the last call: a cascade
    /// layer whose stored window it does not reach, or a local map whose light's reach it does
    /// not meet, keeps what it holds (maps are otherwise drawn again only when their projection
    /// or light changes). Returns whether an atlas or buffer was (re)allocated or released, so that bind
    /// groups holding it must be rebuilt.
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        settings: &ShadowSettings,
        view: Option<(&ExtractedView, f32)>,
        candidates: &[DirectionalCandidate],
        local_candidates: &[LocalCandidate],
        bounds: &SceneBounds,
        caster_generation: u64,
        changes: CasterChanges,
        compute_casters: bool,
    ) -> bool {
        // Other settings (bias is raster state, sizes and filters change the maps): nothing held
        // is valid.
        if self.held_settings != Some(*settings) {
            self.invalidate();
            self.held_settings = Some(*settings);
        }
        // Until this frame's encode says otherwise, no map was culled (the read-back counts).
        self.culled = false;
        let seen = !bounds.casters.is_empty() && !bounds.receivers.is_empty();
        self.frame = match view {
            Some((view, aspect)) if seen => self.plan(settings, view, aspect, candidates, bounds),
            _ => ShadowFrame::default(),
        };
        let camera_position = view.map_or(Vec3::ZERO, |(v, _)| Vec3::from(v.world_from_view.translation));
        // The local atlas holds as many layers as the shadowed local lights take (whole cubes),
        // up to `local_layers`: one point light takes 6, not the high preset's 24 (72 MiB less
        // at 1024²). While local maps are in use it grows with the lights and does not shrink,
        // so lights that come and go do not reallocate it; where lights keep their layers and
        // the free ones end up split, a light that finds no room gets the whole `local_layers`.
        let cap = settings.local_layers;
        let mut local_settings = {
            let has = self.local_atlas.as_ref().map_or(0, |a| a.layers());
            let wanted = local::layers_wanted(local_candidates).next_multiple_of(6).max(has);
            ShadowSettings { local_layers: cap.min(wanted).max(1), ..*settings }
        };
        let plan_local = |local: &mut LocalShadows, settings: &ShadowSettings| {
            local.plan(settings, camera_position, local_candidates, &bounds.casters, caster_generation, changes)
        };
        if view.is_some() && seen {
            self.frame.local = plan_local(&mut self.local, &local_settings);
            if self.frame.local.unshadowed > 0 && local_settings.local_layers < cap {
                // A larger atlas holds nothing yet: every map is placed and drawn afresh.
                local_settings.local_layers = cap;
                self.local = LocalShadows::default();
                self.frame.local = plan_local(&mut self.local, &local_settings);
            }
        } else {
            // Nothing to shadow: forget the maps, so they render afresh when casters return.
            self.local = LocalShadows::default();
        }
        let settings = &local_settings;
        // The cascade atlas holds layers up to the farthest cascade that renders: the shader reads
        // no layer of a cascade that does not (it is lit there), and a small scene in front of the
        // camera often reaches only the first one or two. It grows with the cascades that render
        // and does not shrink, so a camera moving back and forth does not reallocate it.
        let has_layers = self.atlas.as_ref().map_or(0, |a| a.layers());
        let rendered_to = self.frame.rendered.iter().rposition(|r| *r).map_or(0, |i| i as u32 + 1);
        let layers = rendered_to.max(has_layers).min(self.frame.cascades.len() as u32) as usize;
        let resolution = settings.atlas_size;
        // Each layer in use stores its receivers' window. A layer is kept while its projection
        // and casters are the same, the receivers that read it now lie inside the planes its
        // casters were culled to (the camera moved by less than their slack), and inside the
        // window it stores; one drawn anew stores its receivers' window widened by that slack.
        self.held.resize(layers, None);
        if caster_generation != self.seen_generation {
            // A layer valid at the last generation stays valid while no caster that changed,
            // where it was or where it is, reaches the window it stores: a static cascade under
            // a moving object nearer the camera is kept.
            // (Held layers never outlive a change of the map size: new settings forget them.)
            for h in self.held.iter_mut().flatten() {
                let untouched = h.caster_generation == self.seen_generation
                    && match changes {
                        CasterChanges::Within(b) => {
                            !reaches(&(h.window.clip_to_window(resolution) * h.clip_from_world), &b)
                        }
                        CasterChanges::Nothing | CasterChanges::Anywhere => false,
                    };
                if untouched {
                    h.caster_generation = caster_generation;
                }
            }
            self.seen_generation = caster_generation;
        }
        let mut kept = vec![false; layers];
        let mut stored: Vec<Option<TexelWindow>> = vec![None; layers];
        for i in 0..layers {
            let frame = &self.frame;
            let Some(needed) = frame.receiver_windows[i].filter(|_| frame.rendered[i]) else { continue };
            let held = self.held[i].as_ref().filter(|h| {
                h.clip_from_world == frame.cascades[i].clip_from_world
                    && h.caster_generation == caster_generation
                    && h.window.contains(&needed)
                    && frame.slice_corners[i]
                        .iter()
                        .all(|c| h.planes.iter().all(|p| p.truncate().dot(*c) + p.w >= frame.receiver_reach[i]))
            });
            kept[i] = held.is_some();
            stored[i] = Some(held.map_or_else(|| needed.widened(HOLD_SLACK_TEXELS as u32, resolution), |h| h.window));
        }
        // Layers as large as the largest stored window, in steps, growing and never shrinking
        // while the cascades' map size stays (a camera moving back and forth does not
        // reallocate the atlas).
        // Floats where the casters will be rasterised in compute, a depth target where the
        // hardware draws them (a change of kind allocates afresh).
        let has = self.atlas.as_ref().map(|a| (self.atlas_resolution, a.extent, a.layers(), a.floats));
        let needs = self.active().then(|| {
            let grown = has.filter(|h| h.0 == resolution).map_or((0, 0), |h| h.1);
            let step = |texels: u32| texels.next_multiple_of(LAYER_STEP).min(resolution);
            let (w, h) = stored.iter().flatten().fold((1, 1), |(w, h), s| (w.max(s.width), h.max(s.height)));
            let extent = (step(w).max(grown.0), step(h).max(grown.1));
            let floats = compute_casters && CasterRaster::supports(&device.limits(), extent);
            (resolution, extent, layers as u32, floats)
        });
        let mut changed = needs != has;
        if changed {
            self.atlas = needs.map(|(_, extent, layers, floats)| match floats {
                true => Atlas::floats(device, self.array_layers, extent, layers),
                false => Atlas::depth(device, self.array_layers, extent, layers),
            });
            self.staging = None;
            if let Some(r) = self.raster.as_mut() {
                r.unbind();
            }
            self.atlas_resolution = resolution;
            // A fresh atlas holds nothing.
            self.held = vec![None; layers];
            kept.fill(false);
        }
        if !self.active() && !self.local_active() {
            // No map to draw: the culled lists and the raster's buffers go with the atlases.
            self.cull = None;
            self.raster = None;
            self.caster_bind_groups.clear();
        }
        self.frame.resolution = resolution;
        self.frame.layer_extent = needs.map_or((1, 1), |n| n.1);
        self.frame.redraw = (0..layers)
            .map(|i| {
                let frame = &self.frame;
                let redraw = frame.rendered[i] && !kept[i];
                if let (true, Some(window)) = (redraw, stored[i]) {
                    self.held[i] = Some(HeldLayer {
                        clip_from_world: frame.cascades[i].clip_from_world,
                        caster_generation,
                        planes: frame.receiver_planes[i].clone(),
                        window,
                    });
                }
                redraw
            })
            .collect();
        self.frame.stored = stored;
        let local_needs = self.local_active().then_some((settings.local_map_size, settings.local_layers));
        let local_has = self.local_atlas.as_ref().map(|a| (a.extent.0, a.layers()));
        if local_needs != local_has {
            changed = true;
            self.local_atlas =
                local_needs.map(|(size, layers)| Atlas::depth(device, self.array_layers, (size, size), layers));
            if local_has.is_some() {
                // The layers' contents are gone: every map renders again.
                self.local = LocalShadows::default();
                self.frame.local = plan_local(&mut self.local, settings);
            }
        }
        let local_layers = settings.local_layers as u64;
        if self.local_buffer.size() < local_layers * std::mem::size_of::<GpuLocalShadow>() as u64 {
            self.local_buffer = local_buffer(device, local_layers);
            changed = true;
        }
        if self.caster_views.size() < CASTER_VIEW_STRIDE * (MAX_CASCADES as u64 + local_layers) {
            self.caster_views = caster_views_buffer(device, local_layers);
            self.caster_bind_groups.clear();
        }
        self.camera_position = camera_position;
        self.write(queue, settings, candidates);
        changed
    }

    fn plan(
        &mut self,
        settings: &ShadowSettings,
        view: &ExtractedView,
        aspect: f32,
        candidates: &[DirectionalCandidate],
        bounds: &SceneBounds,
    ) -> ShadowFrame {
        let mut lit: Vec<&DirectionalCandidate> = candidates
            .iter()
            .filter(|c| {
                c.light.shadows
                    && matches!(c.light.kind, LightKind::Directional { .. })
                    && c.light.color.max_element() > 0.0
            })
            .collect();
        // The brightest lights get the cascades; the key orders ties so frames are deterministic.
        lit.sort_by(|a, b| b.light.color.max_element().total_cmp(&a.light.color.max_element()).then(a.key.cmp(&b.key)));
        if lit.len() > MAX_SHADOWED_DIRECTIONAL && !self.warned_excess {
            self.warned_excess = true;
            tracing::warn!(
                "{} directional lights cast shadows; the brightest {MAX_SHADOWED_DIRECTIONAL} get shadow maps, the rest light unshadowed",
                lit.len()
            );
        }
        lit.truncate(MAX_SHADOWED_DIRECTIONAL);
        let (rotation, eye) = {
            let (_, r, t) = view.world_from_view.to_scale_rotation_translation();
            (r.as_dquat(), t.as_dvec3())
        };
        let camera = CascadeCamera {
            world_from_view: DAffine3::from_rotation_translation(rotation, eye),
            projection: view.projection,
            aspect,
        };
        let forward = rotation * DVec3::NEG_Z;
        let caster_extent = corners(&bounds.casters).map(|p| (p - eye).length()).fold(0.0, f64::max);
        let receiver_depths = || corners(&bounds.receivers).map(|p| (p - eye).dot(forward));
        // The receivers' box spans these depths along the view (a linear function on a box is
        // extreme at its corners): a cascade whose slice lies wholly before or beyond them
        // shadows nothing that can be seen, however many casters its box holds.
        let deepest_receiver = receiver_depths().fold(f64::MIN, f64::max);
        let nearest_receiver = receiver_depths().fold(f64::MAX, f64::min);
        let mut frame = ShadowFrame { caster_extent, eye, ..Default::default() };
        for candidate in lit {
            let direction = candidate.light.direction;
            let towards_light = -direction.as_dvec3().normalize();
            let caster_top = corners(&bounds.casters).map(|p| p.dot(towards_light)).fold(f64::MIN, f64::max);
            let fitted = cascades::fit_cascades_to_casters(&camera, direction, settings, caster_top);
            frame.lights.push(ShadowedLight {
                key: candidate.key,
                slot: candidate.slot,
                first_layer: frame.cascades.len() as u32,
            });
            // A cascade is read from where the previous one starts blending into it: over the
            // last `cascade_blend` of the depths from the previous cascade's far end (0 for the
            // first, as shadows.wgsl counts it) to its own.
            let mut read_from = f64::MIN;
            let mut previous_far = 0.0;
            // How far from a receiver's texel its lookups reach: the filter's kernel, the normal
            // offset, and two texels for rounding and the texel grid.
            let reach_texels = match settings.filter {
                ShadowFilter::Pcf => 2.0,
                ShadowFilter::Pcss => settings.max_penumbra_texels as f64,
            } + settings.normal_bias as f64
                + 2.0;
            for cascade in fitted {
                let seen = read_from < deepest_receiver && nearest_receiver <= cascade.far as f64;
                let far = cascade.far as f64;
                let reach = reach_texels * cascade.texel_size;
                let slack = HOLD_SLACK_TEXELS * cascade.texel_size;
                let slice_planes = cascades::slice_planes(&camera, read_from, far);
                frame.receiver_planes.push(cascades::receiver_planes(&slice_planes, towards_light, reach + slack));
                let slice = cascades::slice_corners(&camera, read_from, far);
                // The texels the receivers reading this cascade look up: where its slice meets
                // their box (within a texel), and as far again as the lookups reach.
                let receivers = window::slice_box_vertices(
                    &slice,
                    &slice_planes,
                    bounds.receivers.min.as_dvec3(),
                    bounds.receivers.max.as_dvec3(),
                    cascade.texel_size,
                );
                let window =
                    TexelWindow::around(&cascade.clip_from_world, settings.atlas_size, receivers, reach_texels);
                // Casters must reach the texels receivers read, not merely the map.
                let reached = window.is_some_and(|w| {
                    reaches(&(w.clip_to_window(settings.atlas_size) * cascade.clip_from_world), &bounds.casters)
                });
                frame.slice_corners.push(slice);
                frame.receiver_reach.push(reach);
                frame.receiver_windows.push(window);
                read_from = far - settings.cascade_blend as f64 * (far - previous_far);
                previous_far = far;
                frame.rendered.push(seen && reached);
                frame.cascades.push(cascade);
            }
        }
        frame
    }

    fn write(&self, queue: &wgpu::Queue, settings: &ShadowSettings, candidates: &[DirectionalCandidate]) {
        let mut gpu: GpuShadows = bytemuck::Zeroable::zeroed();
        let frame = &self.frame;
        for (i, c) in frame.cascades.iter().enumerate().take(MAX_CASCADES) {
            // Depth is linear along the light: its row of the matrix is the light's direction
            // over the world distance depth runs 1 to 0.
            let depth_row =
                DVec3::new(c.clip_from_world.x_axis.z, c.clip_from_world.y_axis.z, c.clip_from_world.z_axis.z);
            let depth_range = 1.0 / depth_row.length().max(f64::MIN_POSITIVE);
            // Receivers' depth raised by the casters' precision: folded into the matrix's depth
            // translation, so the shader pays nothing for it.
            let mut clip_from_rel = frame.layer_clip_from_rel(i);
            clip_from_rel.w_axis.z +=
                (DEPTH_PRECISION_ULPS * f32::EPSILON as f64 * frame.caster_extent / depth_range) as f32;
            gpu.cascades[i] = GpuCascade {
                clip_from_rel: clip_from_rel.to_cols_array_2d(),
                far: c.far,
                texel_size: c.texel_size as f32,
                depth_range: depth_range as f32,
                rendered: frame.rendered[i] as u32,
                window: frame.stored.get(i).copied().flatten().map_or([1.0, 1.0], |w| {
                    [w.width as f32 / frame.layer_extent.0 as f32, w.height as f32 / frame.layer_extent.1 as f32]
                }),
                _pad: [0; 2],
            };
        }
        for (i, l) in frame.lights.iter().enumerate() {
            let angular = candidates.iter().find(|c| c.key == l.key).map_or(0.0, |c| match c.light.kind {
                LightKind::Directional { angular_radius } => angular_radius.clamp(0.0, 1.0),
                _ => 0.0,
            });
            gpu.lights[i] = GpuDirectionalShadow {
                light_slot: l.slot,
                first_cascade: l.first_layer,
                angular_tan: angular.tan(),
                _pad: 0,
            };
        }
        gpu.light_count = if self.active() { frame.lights.len() as u32 } else { 0 };
        gpu.cascade_count = settings.cascades;
        gpu.normal_bias = settings.normal_bias;
        gpu.blend = settings.cascade_blend;
        gpu.filter = match settings.filter {
            ShadowFilter::Pcf => 0,
            ShadowFilter::Pcss => 1,
        };
        gpu.max_kernel = settings.max_penumbra_texels;
        gpu.depth_tolerance = self.depth_tolerance;
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&gpu));
        if self.local_active() {
            let layers: Vec<GpuLocalShadow> = frame
                .local
                .layers
                .iter()
                .map(|l| match l {
                    Some(l) => GpuLocalShadow {
                        clip_from_rel: l.clip_from_rel.to_cols_array_2d(),
                        texel_scale: l.texel_scale,
                        valid: l.valid as u32,
                        faces: l.faces,
                        _pad: 0,
                    },
                    None => bytemuck::Zeroable::zeroed(),
                })
                .collect();
            queue.write_buffer(&self.local_buffer, 0, bytemuck::cast_slice(&layers));
        }
    }

    /// Encodes one depth pass per rendered layer, drawing every caster batch (opaque and masked
    /// triangles) into it. With `culled` (the view's cull prepared this frame's batches), each
    /// map's casters are culled on the GPU first, to its clip volume and, for a cascade, to the
    /// receiver planes it is held with, and drawn indirectly
    /// ([`CasterCulling`]); otherwise every caster is drawn into every map. A caster pipeline
    /// that fails to compile skips its batches and is returned as the error; a cull that fails to
    /// compile leaves the maps to direct draws.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &mut self,
        cx: &mut FrameContext,
        settings: &ShadowSettings,
        mesh_pool: &MeshPool,
        materials: &MaterialTable,
        buffers: [&wgpu::Buffer; 3],
        batches: &[Batch],
        culled: Option<BatchBuffers>,
        raster_table: Option<RasterTable>,
    ) -> Option<ShaderError> {
        let (encoder, device, queue, pipelines, mut timer) =
            (&mut *cx.encoder, cx.device, cx.queue, &mut *cx.pipelines, cx.timer.as_deref_mut());
        if self.atlas.is_none() && self.local_atlas.is_none() {
            return None;
        }
        // (index in `batches`, batch, pipeline key) of every caster batch.
        let casters: Vec<(usize, &Batch, CasterKey)> = batches
            .iter()
            .enumerate()
            .filter(|(_, b)| b.key.topology == TopologyKey::Triangles && b.key.alpha != AlphaKey::Blend)
            .map(|(i, b)| (i, b, caster_key(b, settings)))
            .collect();
        let mut error = None;
        // Every pass this frame: where it draws, the caster view's index, the timing label, what
        // the map holds (the casters are culled to), and the texels drawn (a cascade's stored
        // window: nothing reads the rest of its layer).
        let mut passes: Vec<Pass> = Vec::new();
        if let Some(atlas) = &self.atlas {
            for layer in 0..atlas.layers() as usize {
                if self.frame.redraw[layer] {
                    let label = LAYER_LABELS[layer.min(LAYER_LABELS.len() - 1)];
                    let mut volume = MapVolume::clip(self.frame.window_clip_from_rel(layer));
                    // The planes the layer is held with, made camera-relative in f64.
                    let planes = self.held.get(layer).and_then(Option::as_ref).map_or(&[][..], |h| &h.planes[..]);
                    for (slot, p) in volume.planes.iter_mut().zip(planes) {
                        *slot = p.truncate().extend(p.w + p.truncate().dot(self.frame.eye)).as_vec4();
                        volume.plane_count += 1;
                    }
                    let window = self.frame.stored[layer].map_or(atlas.extent, |w| (w.width, w.height));
                    let clip_from_rel = self.frame.layer_clip_from_rel(layer);
                    let target = Target::Cascade { layer: layer as u32, window };
                    // A float atlas's layers are drawn through the staging.
                    let view = atlas.layer_views.get(layer).filter(|_| !atlas.floats);
                    passes.push(Pass { view, target, index: layer as u64, label, volume, clip_from_rel });
                }
            }
        }
        if let Some(atlas) = &self.local_atlas {
            for &layer in &self.frame.local.render {
                if let Some(l) = &self.frame.local.layers[layer as usize] {
                    let view = &atlas.layer_views[layer as usize];
                    let volume = MapVolume::clip(l.clip_from_rel);
                    passes.push(Pass {
                        view: Some(view),
                        target: Target::Local,
                        index: MAX_CASCADES as u64 + layer as u64,
                        label: "shadow local",
                        volume,
                        clip_from_rel: l.clip_from_rel,
                    });
                }
            }
        }
        // A cull that does not compile leaves the maps to the full list: nothing is missing from
        // them, so what they hold stays valid (unlike after a caster pipeline's failure, below).
        let mut cull_error = None;
        let sources =
            culled.filter(|b| b.item_count > 0 && !passes.is_empty()).and_then(|batches| match CasterCulling::compile(
                device, pipelines,
            ) {
                Ok(()) => Some(CasterSources { instances: buffers[0], draw_slots: buffers[1], batches }),
                Err(e) => {
                    cull_error = Some(e);
                    None
                }
            });
        self.culled = sources.is_some();
        let layout = sources.map(|s| CullLayout::new(s.batches.item_count, s.batches.batch_count));
        let per_pass = layout.map_or(passes.len(), |l| l.maps_per_pass).max(1);
        if let (Some(sources), Some(layout)) = (&sources, layout) {
            let maps: Vec<MapVolume> = passes.iter().map(|p| p.volume).collect();
            let cull = self.cull.get_or_insert_with(|| CasterCulling::new(device));
            cull.prepare(device, queue, sources, layout, &maps, self.camera_position);
        }
        // A float atlas's layers are rasterised in compute, from the cull's lists (`prepare` made
        // the atlas floats where the view would be rasterised in compute).
        let extent = self.atlas.as_ref().map_or((1, 1), |a| a.extent);
        let floats = self.atlas.as_ref().is_some_and(|a| a.floats);
        let mut raster = match (raster_table, &sources, layout, &self.cull) {
            (Some(table), Some(s), Some(_), Some(cull)) if floats => Some(RasterInputs {
                table,
                instances: s.instances,
                lists: cull.slots().clone(),
                args: cull.args().clone(),
                mesh_pool,
                materials,
            }),
            _ => None,
        };
        let cascades = passes.iter().filter(|p| matches!(p.target, Target::Cascade { .. })).count();
        // A float atlas's staging: the buffer, and a depth target where the hardware draws.
        let staged = |compute: bool, staging: &mut Option<LayerStaging>| {
            if !floats {
                *staging = None;
            } else if cascades > 0 && !staging.as_ref().is_some_and(|s| s.fits(extent, !compute)) {
                *staging = Some(LayerStaging::new(device, extent, !compute));
            }
        };
        staged(raster.is_some(), &mut self.staging);
        if let (Some(inputs), Some(staging), Some(layout), Some(sources)) = (&raster, &self.staging, layout, &sources) {
            // The cull's arguments cover every opaque batch (line and point meshes too, which the
            // raster table leaves out).
            let batch_count = sources.batches.batch_count;
            let maps: Vec<MapRaster> = passes[..cascades]
                .iter()
                .enumerate()
                .map(|(k, p)| MapRaster {
                    clip_from_rel: p.clip_from_rel,
                    slot_base: layout.slot_base(k % per_pass),
                    args_base: (layout.args_offset(k % per_pass, batch_count, 0) / 4) as u32,
                })
                .collect();
            let caster_raster = self.raster.get_or_insert_with(|| CasterRaster::new(device));
            let prepared = caster_raster.prepare(
                device,
                queue,
                pipelines,
                inputs,
                staging,
                extent,
                self.camera_position,
                settings.slope_bias,
                &maps,
            );
            if let Err(e) = prepared {
                // A raster step that does not compile: this frame's layers in hardware.
                error = Some(e);
                raster = None;
                staged(false, &mut self.staging);
            }
        }
        if raster.is_none() {
            // The raster's bind groups would keep a staging buffer alive that is gone or unused.
            if let Some(r) = self.raster.as_mut() {
                r.unbind();
            }
        }
        // The hardware's pipelines, for the maps it draws.
        let hardware = if raster.is_some() { passes.len() - cascades } else { passes.len() };
        if hardware > 0 {
            for (_, _, key) in &casters {
                if let Err(e) = pipelines.get::<CasterFamily>(device, *key) {
                    error = Some(e);
                }
            }
        }
        for (k, pass) in passes.iter().enumerate() {
            let index = pass.index;
            let view = GpuCasterView {
                clip_from_rel: pass.clip_from_rel.to_cols_array_2d(),
                camera_position: self.camera_position.to_array(),
                slot_base: layout.map_or(0, |l| l.slot_base(k % per_pass)),
            };
            queue.write_buffer(&self.caster_views, index * CASTER_VIEW_STRIDE, bytemuck::bytes_of(&view));
        }
        let cull_lists = self.cull.as_ref().map(CasterCulling::slots);
        let draw_list = match (&sources, cull_lists) {
            (Some(_), Some(lists)) => lists,
            _ => buffers[1],
        };
        let bound = [buffers[0], draw_list, buffers[2]];
        let group =
            match self.caster_bind_groups.iter().position(|(held, _)| held.iter().zip(bound).all(|(a, b)| a == b)) {
                Some(i) => i,
                None => {
                    // The other draw list's group stays while the instances and materials it
                    // binds do; growth that replaced one of them drops it.
                    self.caster_bind_groups.retain(|(held, _)| {
                        held[0] == *bound[0]
                            && held[2] == *bound[2]
                            && (held[1] == *buffers[1] || cull_lists.is_some_and(|l| held[1] == *l))
                    });
                    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("shadow casters"),
                        layout: &pipelines.family::<CasterFamily>().layout,
                        entries: &[
                            wgpu::BindGroupEntry {
                                binding: 0,
                                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                                    buffer: &self.caster_views,
                                    offset: 0,
                                    size: wgpu::BufferSize::new(std::mem::size_of::<GpuCasterView>() as u64),
                                }),
                            },
                            wgpu::BindGroupEntry { binding: 1, resource: bound[0].as_entire_binding() },
                            wgpu::BindGroupEntry { binding: 2, resource: bound[1].as_entire_binding() },
                            wgpu::BindGroupEntry { binding: 3, resource: bound[2].as_entire_binding() },
                        ],
                    });
                    self.caster_bind_groups.push((bound.map(Clone::clone), group));
                    self.caster_bind_groups.len() - 1
                }
            };
        let group = &self.caster_bind_groups[group].1;
        for (pass_index, chunk) in passes.chunks(per_pass).enumerate() {
            if let (Some(sources), Some(cull)) = (&sources, self.cull.as_mut()) {
                cull.encode(encoder, device, pipelines, timer.as_deref_mut(), sources, pass_index, chunk.len());
            }
            for (j, p) in chunk.iter().enumerate() {
                let (index, label) = (p.index, p.label);
                if let (
                    Target::Cascade { layer, window },
                    Some(inputs),
                    Some(caster_raster),
                    Some(staging),
                    Some(atlas),
                ) = (p.target, &raster, &self.raster, &self.staging, &self.atlas)
                {
                    let k = pass_index * per_pass + j;
                    let timer = timer.as_deref_mut();
                    caster_raster.encode(encoder, pipelines, timer, inputs, staging, k, window.1, label);
                    staging.copy_to_layer(encoder, atlas, layer, window);
                    continue;
                }
                let Some(view) = p.view.or_else(|| self.staging.as_ref().and_then(LayerStaging::depth_view)) else {
                    continue;
                };
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some(label),
                    color_attachments: &[],
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view,
                        // Reverse-Z: 0 is the far side, where nothing casts.
                        depth_ops: Some(wgpu::Operations {
                            load: wgpu::LoadOp::Clear(0.0),
                            store: wgpu::StoreOp::Store,
                        }),
                        stencil_ops: None,
                    }),
                    timestamp_writes: timer.as_deref_mut().and_then(|t| t.pass(label)),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                if let Target::Cascade { window: (width, height), .. } = p.target {
                    pass.set_scissor_rect(0, 0, width, height);
                }
                pass.set_bind_group(0, group, &[(index * CASTER_VIEW_STRIDE) as u32]);
                pass.set_vertex_buffer(0, mesh_pool.vertex_buffer().slice(..));
                pass.set_index_buffer(mesh_pool.index_buffer().slice(..), wgpu::IndexFormat::Uint32);
                let mut bound = None;
                let compiled = pipelines.compiled::<CasterFamily>();
                for (batch_index, b, key) in &casters {
                    let Some(entry) = mesh_pool.entry(b.mesh_id) else { continue };
                    let Some(pipeline) = compiled.get(key) else { continue };
                    if bound != Some(*key) {
                        pass.set_pipeline(pipeline);
                        bound = Some(*key);
                    }
                    if key.alpha_mask {
                        let Some(material) = materials.get(&b.material) else { continue };
                        pass.set_bind_group(1, &material.bind_group, &[]);
                    }
                    match (&sources, layout, self.cull.as_ref(), &entry.indices) {
                        (Some(s), Some(layout), Some(cull), indices) => {
                            let offset = layout.args_offset(j, s.batches.batch_count, *batch_index);
                            if indices.is_some() {
                                pass.draw_indexed_indirect(cull.args(), offset);
                            } else {
                                pass.draw_indirect(cull.args(), offset);
                            }
                        }
                        (_, _, _, Some(r)) => {
                            pass.draw_indexed(r.clone(), entry.vertices.start as i32, b.first..b.first + b.count)
                        }
                        (_, _, _, None) => pass.draw(entry.vertices.clone(), b.first..b.first + b.count),
                    }
                }
                drop(pass);
                if let (Target::Cascade { layer, window }, Some(staging), Some(atlas)) =
                    (p.target, &self.staging, self.atlas.as_ref().filter(|a| a.floats))
                {
                    staging.copy_depth_to_buffer(encoder);
                    staging.copy_to_layer(encoder, atlas, layer, window);
                }
            }
        }
        if error.is_some() {
            // Batches whose pipeline failed were left out: draw everything again once fixed.
            self.invalidate();
        }
        error.or(cull_error)
    }
}

/// Where a caster pass's depths end up.
#[derive(Clone, Copy)]
enum Target {
    /// A layer of the local atlas, drawn into directly.
    Local,
    /// Cascade layer `layer`, of which `window` (width, height from the top-left) is drawn: into
    /// the layer itself, or (a float atlas) into the staging and copied in.
    Cascade { layer: u32, window: (u32, u32) },
}

/// One caster pass: see [`ShadowOrchestrator::encode`].
struct Pass<'a> {
    /// The depth target drawn into: the layer's (a float atlas's cascades: the staging's).
    view: Option<&'a wgpu::TextureView>,
    target: Target,
    /// The caster view's slot.
    index: u64,
    label: &'static str,
    volume: MapVolume,
    /// The layer's clip space from camera-relative positions.
    clip_from_rel: Mat4,
}

fn caster_views_buffer(device: &wgpu::Device, local_layers: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("shadow caster views"),
        size: CASTER_VIEW_STRIDE * (MAX_CASCADES as u64 + local_layers),
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

fn local_buffer(device: &wgpu::Device, layers: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("local shadows"),
        size: layers.max(1) * std::mem::size_of::<GpuLocalShadow>() as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

fn caster_key(b: &Batch, settings: &ShadowSettings) -> CasterKey {
    let mask = b.key.alpha == AlphaKey::Mask;
    CasterKey {
        alpha_mask: mask,
        base_color_texture: mask && b.key.textures.has(TextureSet::BASE_COLOR),
        slope_bias_bits: settings.slope_bias.to_bits(),
    }
}

fn corners(b: &Aabb) -> impl Iterator<Item = DVec3> + '_ {
    (0..8).map(move |i| {
        DVec3::new(
            if i & 1 == 0 { b.min.x } else { b.max.x } as f64,
            if i & 2 == 0 { b.min.y } else { b.max.y } as f64,
            if i & 4 == 0 { b.min.z } else { b.max.z } as f64,
        )
    })
}

/// Whether any of the casters' box can land in the cascade: its light-space bounds overlap the
/// map across, and it is not wholly below the map's far side.
fn reaches(clip_from_world: &DMat4, casters: &Aabb) -> bool {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in corners(casters) {
        let c = clip_from_world.project_point3(p);
        lo = lo.min(c);
        hi = hi.max(c);
    }
    lo.x <= 1.0 && hi.x >= -1.0 && lo.y <= 1.0 && hi.y >= -1.0 && hi.z >= 0.0
}

mod gpu;
use gpu::{GpuCascade, GpuCasterView, GpuDirectionalShadow, GpuLocalShadow, GpuShadows};
