//! The renderer: owns every render-world resource and turns a [`RenderScene`] into a frame.
//!
//! `render` runs prepare (retained updates driven by extraction's change lists), builds the
//! frame plan, and encodes the passes. Owners: the mesh pool, texture cache, material table,
//! instance buffer and light store each own their GPU buffers, the cluster binner its grid and
//! lists; the pipeline cache owns the pipelines and layouts; this module owns only the view
//! uniform, the draw-slot list and the batches that index into it.

use std::collections::HashMap;
use std::time::Instant;

use bevy_ecs::entity::Entity;
use bevy_ecs::resource::Resource;
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};
use penumbra_engine::Handle;
use penumbra_engine::bounds::Aabb;
use penumbra_engine::components::Projection;
use penumbra_engine::mesh::{Mesh, SelfOverlap};

use crate::context::GpuContext;
use crate::entity_table::{EntityTable, Replaced};
use crate::environment::{EnvironmentLighting, EnvironmentSettings};
use crate::frame::{FramePlan, Pass, SceneNeeds};
use crate::passes::clusters::grid::ClusterConfig;
use crate::passes::clusters::{BinningTooLarge, ClusterBinner};
use crate::passes::culling::{CullInputs, GpuCulling, RasterTarget};
use crate::passes::deferred_lights::{self, GpuDeferredParams};
use crate::passes::forward::{self, Batch, DrawCounts, ForwardInputs, IndirectDraws, OpaquePhase};
use crate::passes::post::{PostProcess, PostSettings};
use crate::passes::shadows::local::LocalCandidate;
use crate::passes::shadows::orchestrator::{DirectionalCandidate, SceneBounds, ShadowOrchestrator};
use crate::passes::shadows::{ShadowSettings, ShadowSettingsError};
use crate::passes::tonemap;
use crate::pipelines::pipeline_cache::{
    AlphaTest, DebugView, DeferredKey, FormatKey, LocalLights, PipelineCache, PipelineKey, Tonemapper,
};
use crate::pipelines::pipeline_cache::{ReloadReport, ShadeOutput, TextureSet};
use crate::pipelines::shader_library::{ShaderError, ShaderLibrary};
use crate::pipelines::shader_watcher::ShaderWatcher;
use crate::prepare::buffer::GrowableBuffer;
use crate::prepare::deform::{MeshDeformer, Visit};
use crate::prepare::instances::{GpuInstance, InstanceBuffer};
use crate::prepare::light_store::{DEFAULT_CUTOFF, LightShapes, LightStore};
use crate::prepare::materials::{AlphaKey, MaterialKey, MaterialTable, SRGB_SLOTS};
use crate::prepare::mesh_pool::{MeshId, MeshPool};
use crate::prepare::textures::{TextureCache, TextureRequest};
use crate::readback::{self, ReadbackError};
use crate::targets::{DEPTH_FORMAT, FrameTargets, HDR_FORMAT, MsaaResolve, OpaqueDraws, TargetNeeds, TargetsMade};
use crate::timing::{FrameTimings, GpuTimer};
use crate::world::{LightKind, RenderScene};

#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    /// 1 or 4.
    pub msaa: u32,
    pub tonemapper: Tonemapper,
    /// Linear RGB written behind the scene (after exposure, before tonemapping).
    pub clear_color: [f64; 3],
    /// Collect per-pass GPU times (read back a few frames late, without stalling).
    pub gpu_timing: bool,
    /// Where the shaders come from.
    pub shaders: ShaderSource,
    /// The froxel grid local lights are binned into.
    pub clusters: ClusterConfig,
    /// How fragments find local lights (clusters, or the brute-force references).
    pub light_walk: LightWalk,
    /// Display-referred luminance (after exposure) below which a local light without a glTF
    /// `range` stops: its range is where it would light a facing white surface this bright.
    pub light_cutoff: f32,
    pub debug_view: DebugView,
    /// Shadow maps of directional lights.
    pub shadows: ShadowSettings,
    /// Cull opaque and masked draws against the view frustum on the GPU and draw them
    /// indirectly (see `passes::culling`). Adapters without indirect first-instance draws
    /// (GL) draw everything whatever this says.
    pub gpu_culling: bool,
    /// Occlusion culling on top of GPU culling: two-phase, against a hierarchical depth buffer
    /// of what this frame drew (see `passes::culling`).
    pub occlusion_culling: OcclusionCulling,
    /// Triangle culling on top of GPU culling (and in occlusion culling's phases): batches of
    /// small meshes draw only the triangles that can cover a sample (see `passes::culling`).
    pub triangle_culling: TriangleCulling,
    /// How the scene's `Environment` (if it has one) is prefiltered.
    pub environment: EnvironmentSettings,
    /// Bloom, automatic exposure, FXAA (all off by default).
    pub post: PostSettings,
    /// Always render into the HDR target, so that [`Renderer::read_hdr`] can read it. Without
    /// it a frame that nothing else reads HDR colour for (MSAA 1 or display-colour resolve, no
    /// post-processing, no environment background, no blended draws, no gizmos, no deferred
    /// lights) skips the HDR target and the tonemap pass: the forward shader tonemaps and draws
    /// into the output.
    pub keep_hdr: bool,
    /// Where multisampled frames average their samples: HDR radiance (the default, as the
    /// path-traced references filter it) or display colours, which spares a frame that nothing
    /// else needs HDR colour for its HDR target and tonemap pass (see [`MsaaResolve`]).
    pub msaa_resolve: MsaaResolve,
    /// Anisotropic filtering of trilinear material samplers, 1 (off) to 16. `None`: 8 on a GPU,
    /// 1 on a CPU rasteriser (see `auto_anisotropy`). Frames meant to match across adapters
    /// (the goldens) set it, since the automatic choice differs between them.
    pub max_anisotropy: Option<u16>,
    /// Where opaque surfaces are rasterised: by the GPU's fixed-function rasteriser, or in
    /// compute into a visibility buffer (see [`Raster`]).
    pub raster: Raster,
}

/// Where opaque draws are rasterised.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Raster {
    /// `Compute` on GPUs whose graphics units are a small part of the chip
    /// (`Capabilities::few_graphics_units`: NVIDIA's Hopper compute GPUs), `Hardware` elsewhere.
    /// The many-lights and many-cubes benchmarks use it; not yet the default, since the
    /// compute path is new and leaves out what it cannot draw yet (see `Compute`).
    Auto,
    /// The GPU's rasteriser, drawing each batch (the forward pass).
    #[default]
    Hardware,
    /// Compute shaders (`passes::visibility`): each sample's nearest triangle goes into a
    /// visibility buffer with 64-bit atomics, then a compute pass shades each pixel's
    /// triangles. For GPUs whose graphics units are few next to their compute units (the
    /// H100 rasterises on 2 of its 66 TPCs). Frames it cannot draw yet rasterise in hardware,
    /// and `--explain` says why: blended or masked draws, gizmos, line or point meshes,
    /// occlusion culling asked for, no GPU culling, an adapter without 64-bit atomics (GL), or
    /// a visibility buffer (8 bytes a sample) larger than the adapter's largest storage binding.
    Compute,
}

/// When occlusion culling runs (it needs GPU culling).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OcclusionCulling {
    Off,
    On,
    /// On where it pays: with at least [`OCCLUSION_AUTO_MIN`] opaque instances, on a GPU, while
    /// it hides at least 1 % of them (measured on the GPU and read back a few frames late; off,
    /// it is tried again for two frames in every 60: `passes::occlusion_feedback`). The depth
    /// pyramid, the late cull and the split render pass cost 0.29 ms on an H200 at 1920×1080;
    /// on a CPU rasteriser (lavapipe) 36 ms, more than hidden objects save there.
    #[default]
    Auto,
}

/// When triangle culling runs (it needs GPU culling).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TriangleCulling {
    Off,
    On,
    /// On a GPU; off on a CPU rasteriser, where the cull pass's work is the rasteriser's own
    /// (its cores do both) and instanced draws skip what covers nothing as cheaply.
    #[default]
    Auto,
}

/// Opaque instances from which `OcclusionCulling::Auto` culls occluded objects.
pub const OCCLUSION_AUTO_MIN: usize = 10_000;

/// How fragments find the local lights (every kind but directional and ambient) that reach them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LightWalk {
    /// Through cluster lists: in the fragment shader while the lists are short, by the compute
    /// pass of `ClusteredCompute` once they grow long (see [`AUTO_COMPUTE_ENTER`]).
    #[default]
    Auto,
    /// Through the fragment's cluster list, in the fragment shader.
    Clustered,
    /// Every local light for every fragment (windowed by range): the reference that clustered
    /// rendering must equal.
    AllLights,
    /// Every local light with no range window: the reference for the window's error.
    AllUnbounded,
    /// Through the cluster lists, by a compute pass over the opaque surfaces the forward pass
    /// wrote out (blended surfaces still walk their lists in the fragment shader). The same
    /// image as `Clustered`; much faster where fragment shaders run on few units (see
    /// `shaders/deferred_lights.wgsl`).
    ClusteredCompute,
}

/// `LightWalk::Auto` moves local lights to the compute pass when the cluster lists' CPU bound
/// (`ClusterBinner::index_bound`, a few times the lists' real mean length) exceeds this many
/// entries per cluster. Measured on an H100 at 1920×1080 MSAA 4 (`penumbra bench many-lights`,
/// README, release of 2299684): 1000 lights render in 2.81 ms in fragments and 5.85 ms in
/// compute, 10 000 in 9.90 and 6.59 ms. Both grow about linearly with the lists, so they cross
/// 48% of the way from 1000 to 10 000 lights. The bound there is 2.5 and 24.6 per cluster (the
/// bench's "bound per cluster"; it was 21.8 and 218 before the bound's boxes were tightened from
/// two tiles of slack to half a tile), so they cross near 13; the threshold sits below that,
/// since a frame running long in fragments loses more than one running long in compute.
pub const AUTO_COMPUTE_ENTER: f64 = 11.0;
/// Below this bound per cluster, `LightWalk::Auto` goes back to the fragment shader.
pub const AUTO_COMPUTE_LEAVE: f64 = 5.5;

/// Where the renderer's WGSL comes from.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum ShaderSource {
    /// The shaders compiled into the binary.
    #[default]
    Embedded,
    /// The `*.wgsl` files of a folder (missing ones from the embedded set); with `watch`, edits
    /// are picked up while running (hot reload).
    Folder { dir: std::path::PathBuf, watch: bool },
}

impl Default for RenderSettings {
    fn default() -> Self {
        // A dark neutral grey: silhouettes of dark and light objects both stay visible.
        Self {
            msaa: 4,
            tonemapper: Tonemapper::Neutral,
            clear_color: [0.02, 0.02, 0.025],
            gpu_timing: false,
            shaders: ShaderSource::Embedded,
            clusters: ClusterConfig::default(),
            light_walk: LightWalk::Auto,
            light_cutoff: DEFAULT_CUTOFF,
            debug_view: DebugView::None,
            shadows: ShadowSettings::default(),
            gpu_culling: true,
            occlusion_culling: OcclusionCulling::Auto,
            triangle_culling: TriangleCulling::Auto,
            environment: EnvironmentSettings::default(),
            post: PostSettings::default(),
            keep_hdr: false,
            msaa_resolve: MsaaResolve::Radiance,
            max_anisotropy: None,
            raster: Raster::Hardware,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum SettingsError {
    #[error("MSAA sample count {0} is not supported (use 1 or 4)")]
    Msaa(u32),
    #[error("{0}")]
    Clusters(String),
    #[error("light cutoff {0} must be a positive finite luminance")]
    LightCutoff(f32),
    #[error(transparent)]
    Shadows(#[from] ShadowSettingsError),
    #[error("{0}")]
    Environment(String),
    #[error("{0}")]
    Post(String),
    #[error("anisotropy {0} must lie in 1..=16")]
    Anisotropy(u16),
}

impl RenderSettings {
    pub fn validate(&self) -> Result<(), SettingsError> {
        if !matches!(self.msaa, 1 | 4) {
            return Err(SettingsError::Msaa(self.msaa));
        }
        self.clusters.validate().map_err(SettingsError::Clusters)?;
        if !(self.light_cutoff > 0.0 && self.light_cutoff.is_finite()) {
            return Err(SettingsError::LightCutoff(self.light_cutoff));
        }
        self.shadows.validate()?;
        self.environment.validate().map_err(SettingsError::Environment)?;
        self.post.validate().map_err(SettingsError::Post)?;
        if let Some(n) = self.max_anisotropy
            && !(1..=16).contains(&n)
        {
            return Err(SettingsError::Anisotropy(n));
        }
        Ok(())
    }
}

/// What the last frame did, for stats panels and benchmarks.
#[derive(Debug, Clone, Default)]
pub struct FrameStats {
    pub frame: u64,
    pub draw_calls: u32,
    pub instances: u32,
    pub primitives: u64,
    /// Lights in the store (global + local).
    pub lights: u32,
    /// Of which local (every kind but directional and ambient), binned into clusters when binning runs.
    pub local_lights: u32,
    /// Upper bound of the cluster lists' total length that sized the index buffer (0 without
    /// binning).
    pub cluster_index_bound: u64,
    pub light_bytes_uploaded: u64,
    pub instance_bytes_uploaded: u64,
    /// CPU time of the whole frame on this thread up to submission: prepare + encode.
    pub cpu_ms: f64,
    /// Of `cpu_ms`, syncing the render world's retained state and uploading what changed.
    pub prepare_ms: f64,
    /// Of `prepare_ms`, handing changed instance records to wgpu (`queue.write_buffer`).
    pub instance_upload_ms: f64,
    /// `queue.submit` alone (outside `cpu_ms`: a driver busy with earlier frames may block it).
    pub submit_ms: f64,
    /// GPU time per pass of the newest frame the GPU has finished (timing enabled only).
    pub gpu: Option<FrameTimings>,
    pub plan: FramePlan,
    /// Forward pipelines in the cache.
    pub pipelines: usize,
    /// Pipelines compiled since start-up.
    pub pipelines_compiled: usize,
    /// Shader library generation: incremented by every successful hot reload.
    pub shader_generation: u64,
    /// Environment prefilter chains run since start-up (one per environment change).
    pub environment_prefilters: u64,
}

impl FrameStats {
    pub fn gpu_total_ms(&self) -> Option<f64> {
        self.gpu.as_ref().map(|t| t.passes.iter().map(|(_, ms)| ms).sum())
    }
}

/// Memory held by the main GPU pools, in bytes.
#[derive(Debug, Clone, Copy, Default)]
pub struct MemoryStats {
    pub mesh_pool: u64,
    pub textures: u64,
    pub instances: u64,
    pub targets: u64,
    pub lights: u64,
    /// Cluster grid, counts, ranges and index lists.
    pub clusters: u64,
    /// The shadow atlas (0 while no light casts).
    pub shadows: u64,
    /// The environment's cubes and split-sum table (0 without an environment).
    pub environment: u64,
    /// Bloom's chain and FXAA's intermediate (0 with both off).
    pub post: u64,
    /// Skinning and morph-target data (deformed vertex copies count in `mesh_pool`).
    pub deform: u64,
}

impl MemoryStats {
    /// Every pool together.
    pub fn total(&self) -> u64 {
        self.mesh_pool
            + self.textures
            + self.instances
            + self.targets
            + self.lights
            + self.clusters
            + self.shadows
            + self.environment
            + self.post
            + self.deform
    }
}

/// Mirrors `struct View` in `shaders/forward.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuView {
    clip_from_rel: [[f32; 4]; 4],
    camera_position: [f32; 3],
    exposure: f32,
    camera_forward: [f32; 3],
    is_orthographic: u32,
    global_light_count: u32,
    local_light_count: u32,
    /// The target's size in pixels (line quads are a pixel wide).
    target_size: [f32; 2],
    rel_from_clip: [[f32; 4]; 4],
}

/// What the renderer last knew about a drawable entity.
#[derive(Debug, Clone, Copy, PartialEq)]
struct DrawState {
    slot: u32,
    mesh: Handle<Mesh>,
    material: MaterialKey,
    mirrored: bool,
    visible: bool,
}

/// A changed draw that only moved (the common case, animation): its slot and new record, to be
/// written with no other change. Anything else (new, re-keyed, gone) is `None` and goes the slow
/// way.
fn pack_move(
    draws: &EntityTable<DrawState>,
    materials: &MaterialTable,
    scene: &RenderScene,
    entity: Entity,
) -> Option<(u32, GpuInstance)> {
    let (item, d) = (scene.draws.get(entity)?, draws.get(entity)?);
    let mirrored = item.world_from_local.matrix3.determinant() < 0.0;
    if (d.mesh, d.material, d.mirrored, d.visible) != (item.mesh, item.material, mirrored, item.visible) {
        return None;
    }
    let material_slot = materials.get(&item.material).map_or(0, |m| m.slot);
    Some((d.slot, GpuInstance::new(&item.world_from_local, material_slot)))
}

/// Change lists at least this long are packed on all cores.
const PARALLEL_PACK_MIN: usize = 20_000;

#[derive(Debug, thiserror::Error)]
pub enum RendererError {
    #[error(transparent)]
    Shader(#[from] ShaderError),
    #[error(transparent)]
    Settings(#[from] SettingsError),
    #[error(transparent)]
    Readback(#[from] ReadbackError),
    #[error(transparent)]
    Context(#[from] crate::context::ContextError),
}

/// 8× anisotropic filtering keeps textures sharp at grazing angles on GPUs, where it is nearly
/// free. On CPU rasterisers it is not: llvmpipe's anisotropic path made a 256² DamagedHelmet
/// frame take over two minutes instead of 0.3 s (measured here), so software adapters get none.
fn auto_anisotropy(ctx: &GpuContext) -> u16 {
    if ctx.info.device_type == wgpu::DeviceType::Cpu { 1 } else { 8 }
}

fn max_anisotropy(ctx: &GpuContext, settings: &RenderSettings) -> u16 {
    settings.max_anisotropy.unwrap_or_else(|| auto_anisotropy(ctx))
}

#[derive(Resource)]
pub struct Renderer {
    ctx: GpuContext,
    settings: RenderSettings,
    pipelines: PipelineCache,
    mesh_pool: MeshPool,
    deformer: MeshDeformer,
    textures: TextureCache,
    materials: MaterialTable,
    instances: InstanceBuffer,
    lights: LightStore,
    clusters: ClusterBinner,
    shadows: ShadowOrchestrator,
    environment: EnvironmentLighting,
    post: PostProcess,
    /// The scene has an environment this frame (part of every pipeline key).
    ibl_active: bool,
    /// Forward pipelines read directional shadow maps (part of every pipeline key).
    shadows_active: bool,
    /// Local lights read shadow maps (part of every pipeline key).
    local_shadows_active: bool,
    /// Incremented whenever a caster may have changed (draws, batches, materials): local
    /// shadow maps re-render only then or when their light changes.
    caster_generation: u64,
    /// `scene_bounds()` as of a caster generation: every draw change moves the generation.
    bounds_cache: Option<(u64, SceneBounds)>,
    view_buffer: wgpu::Buffer,
    draw_slots: GrowableBuffer,
    /// With the mesh pool's vertex-buffer generation it binds (line quads read the pool).
    view_bind_group: Option<(u64, wgpu::BindGroup)>,
    gizmos: crate::passes::gizmos::GizmoLines,
    draws: EntityTable<DrawState>,
    mesh_users: HashMap<Handle<Mesh>, u32>,
    material_users: HashMap<MaterialKey, u32>,
    mesh_ids: HashMap<Handle<Mesh>, MeshId>,
    /// Material pipeline bits last seen, to notice a material switching alpha mode.
    material_bits: HashMap<MaterialKey, (AlphaKey, bool, bool, TextureSet)>,
    opaque_batches: Vec<Batch>,
    /// Batch index of each deformed draw's vertex copy (each is a batch of its own).
    deformed_batches: HashMap<MeshId, usize>,
    opaque_slots: Vec<u32>,
    /// `opaque_slots` changed since it was last uploaded.
    opaque_slots_dirty: bool,
    culling: GpuCulling,
    /// The batches changed since `culling` last saw them.
    cull_batches_dirty: bool,
    /// Whether the cull batches were last prepared with triangle culling.
    cull_triangles_marked: bool,
    /// Whether this frame's opaque draws were culled (the view bind group binds the culled list).
    culling_active: bool,
    /// The visibility buffer (`Raster::Compute`).
    visibility: crate::passes::visibility::VisibilityBuffer,
    /// The batches changed since `visibility` last saw them.
    visibility_batches_dirty: bool,
    blend_entities: Vec<Entity>,
    batches_dirty: bool,
    targets: Option<FrameTargets>,
    headless: Option<(wgpu::Texture, wgpu::TextureView)>,
    timer: Option<GpuTimer>,
    frame: u64,
    stats: FrameStats,
    warned_missing: std::collections::HashSet<Handle<Mesh>>,
    /// `RenderScene::frame` of the last scene rendered.
    last_scene_frame: Option<u64>,
    last_submission: Option<wgpu::SubmissionIndex>,
    shader_watcher: Option<ShaderWatcher>,
    /// The newest shader problem; cleared by the next successful reload.
    shader_error: Option<ShaderError>,
    /// How this frame's pipelines find local lights (part of every pipeline key).
    local_lights: LocalLights,
    light_shapes: LightShapes,
    /// More global lights than the uniform array of them holds (part of every pipeline key).
    global_lights_in_storage: bool,
    /// Opaque surfaces get their local lights from the deferred-lights compute pass.
    deferred_lights: bool,
    deferred_params: wgpu::Buffer,
    /// The last binning refusal, reported once until it changes.
    binning_error: Option<BinningTooLarge>,
    /// Devices lost and replaced so far.
    device_losses: u32,
    /// Spaces out attempts to replace a lost device.
    recovery: crate::context::RetryBackoff,
}

impl Renderer {
    pub fn new(ctx: GpuContext, settings: RenderSettings) -> Result<Self, RendererError> {
        settings.validate()?;
        let settings = degrade_for_backend(settings, &ctx);
        if !ctx.caps.exact_depth {
            tracing::warn!(
                "the {:?} backend rounds depth at 2^-24 of 1 (wgpu rewrites it for GL's -1..1 range): far surfaces \
                 close together can z-fight where Vulkan keeps them apart",
                ctx.info.backend
            );
        }
        let device = &ctx.device;
        let (shaders, shader_error, shader_watcher) = match &settings.shaders {
            ShaderSource::Embedded => (ShaderLibrary::embedded()?, None, None),
            ShaderSource::Folder { dir, watch } => {
                let (lib, error) = ShaderLibrary::for_dir(dir);
                if let Some(e) = &error {
                    // Only a watched folder is read again by itself once the file is fixed.
                    let until = if *watch { " until it is fixed" } else { "" };
                    tracing::error!("{e} (using the embedded shaders{until})");
                }
                let watcher = watch
                    .then(|| {
                        ShaderWatcher::new(dir).map_err(|e| tracing::warn!("not watching {}: {e}", dir.display())).ok()
                    })
                    .flatten();
                (lib, error, watcher)
            }
        };
        let pipelines = PipelineCache::new(device, shaders);
        let view_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view"),
            size: std::mem::size_of::<GpuView>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let timer = (settings.gpu_timing && ctx.caps.timestamps).then(|| GpuTimer::new(device, &ctx.queue));
        Ok(Self {
            mesh_pool: MeshPool::new(device),
            deformer: MeshDeformer::new(device),
            textures: TextureCache::new(
                device,
                &ctx.queue,
                max_anisotropy(&ctx, &settings),
                ctx.caps.srgb_unorm_views,
                ctx.caps.host_import_alignment,
            ),
            materials: MaterialTable::new(device),
            instances: InstanceBuffer::new(device),
            lights: LightStore::new(),
            clusters: ClusterBinner::new(device),
            shadows: ShadowOrchestrator::new(device, ctx.caps.array_layers, ctx.caps.exact_depth),
            environment: EnvironmentLighting::new(device, ctx.caps.array_layers),
            post: PostProcess::new(device),
            ibl_active: false,
            shadows_active: false,
            local_shadows_active: false,
            caster_generation: 0,
            bounds_cache: None,
            draw_slots: GrowableBuffer::new(
                device,
                "draw slots",
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                4096 * 4,
            ),
            view_buffer,
            pipelines,
            view_bind_group: None,
            gizmos: Default::default(),
            draws: EntityTable::default(),
            mesh_users: HashMap::new(),
            material_users: HashMap::new(),
            mesh_ids: HashMap::new(),
            material_bits: HashMap::new(),
            opaque_batches: Vec::new(),
            deformed_batches: HashMap::new(),
            opaque_slots: Vec::new(),
            opaque_slots_dirty: true,
            culling: GpuCulling::new(device),
            cull_batches_dirty: true,
            cull_triangles_marked: false,
            culling_active: false,
            visibility: crate::passes::visibility::VisibilityBuffer::new(device),
            visibility_batches_dirty: true,
            blend_entities: Vec::new(),
            batches_dirty: true,
            targets: None,
            headless: None,
            timer,
            frame: 0,
            stats: FrameStats::default(),
            warned_missing: Default::default(),
            last_scene_frame: None,
            last_submission: None,
            shader_watcher,
            shader_error,
            local_lights: LocalLights::None,
            light_shapes: LightShapes::default(),
            global_lights_in_storage: false,
            deferred_lights: false,
            deferred_params: deferred_lights::params_buffer(&ctx.device),
            binning_error: None,
            device_losses: 0,
            recovery: Default::default(),
            settings,
            ctx,
        })
    }

    /// Whether the GPU device is lost: nothing renders until [`Renderer::replace_device`] (the
    /// headless path does it by itself; a window must make a new surface first).
    pub fn is_device_lost(&self) -> bool {
        // A non-blocking poll first: wgpu reports a destroyed device's loss from its maintenance,
        // not from `destroy` itself.
        let _ = self.ctx.device.poll(wgpu::PollType::Poll);
        self.ctx.is_lost()
    }

    /// How many lost devices this renderer has replaced.
    pub fn device_losses(&self) -> u32 {
        self.device_losses
    }

    /// Starts again on `ctx` after a device loss: every GPU resource is made anew from the
    /// render world, which the first frame then syncs in full (it missed the change lists), so
    /// the scene comes back as it was. Settings and the shader source stay.
    pub fn replace_device(&mut self, ctx: GpuContext) -> Result<(), RendererError> {
        // Nothing of the old renderer is kept: every buffer it holds (the gizmo lines' too) belongs
        // to the lost device. Gizmo lines come again from the scene each frame.
        let mut fresh = Renderer::new(ctx, self.settings.clone())?;
        fresh.device_losses = self.device_losses + 1;
        *self = fresh;
        tracing::info!("rendering again on a new device ({} lost so far)", self.device_losses);
        Ok(())
    }

    /// A headless renderer's recovery: a new device chosen as the old one was. `false` while
    /// none can be had (the next frame tries again).
    fn recover_headless(&mut self) -> bool {
        if !self.recovery.due() {
            return false;
        }
        match self.ctx.recreate_headless().map_err(RendererError::from).and_then(|ctx| self.replace_device(ctx)) {
            Ok(()) => true,
            Err(e) => {
                self.recovery.failed();
                let wait = self.recovery.delay();
                tracing::error!("the GPU device was lost and cannot be replaced yet ({e}); trying again in {wait:?}");
                false
            }
        }
    }

    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// Changes settings; targets and pipelines follow on the next frame.
    pub fn set_settings(&mut self, settings: RenderSettings) -> Result<(), SettingsError> {
        settings.validate()?;
        let settings = degrade_for_backend(settings, &self.ctx);
        if settings.gpu_timing && self.timer.is_none() && self.ctx.caps.timestamps {
            self.timer = Some(GpuTimer::new(&self.ctx.device, &self.ctx.queue));
        }
        if !settings.gpu_timing {
            self.timer = None;
        }
        let anisotropy = max_anisotropy(&self.ctx, &settings);
        if anisotropy != max_anisotropy(&self.ctx, &self.settings) {
            self.textures.set_max_anisotropy(anisotropy);
            self.materials.forget_bind_groups();
        }
        // The sample count and debug view are part of every batch's pipeline key.
        if settings.msaa != self.settings.msaa || settings.debug_view != self.settings.debug_view {
            self.batches_dirty = true;
        }
        self.settings = settings;
        Ok(())
    }

    /// Whether opaque draws go to the visibility buffer when the frame allows (see `Raster`).
    fn raster_in_compute(&self) -> bool {
        self.ctx.caps.visibility_raster
            && match self.settings.raster {
                Raster::Hardware => false,
                Raster::Compute => true,
                Raster::Auto => self.ctx.caps.few_graphics_units,
            }
    }

    /// How many records of large triangles the visibility buffer's list holds (see
    /// `passes::visibility`): for tests and tuning; a triangle whose record does not fit is
    /// rasterised whole by its own thread, the same samples more slowly.
    pub fn set_visibility_large_triangle_capacity(&mut self, capacity: u32) {
        self.visibility.set_large_triangle_capacity(&self.ctx.device, capacity);
    }

    pub fn stats(&self) -> &FrameStats {
        &self.stats
    }

    /// The newest shader error (a hot reload that failed, or a broken shader folder at start),
    /// cleared when a reload succeeds. Frames keep drawing with the last good pipelines.
    pub fn shader_error(&self) -> Option<&ShaderError> {
        self.shader_error.as_ref()
    }

    /// The shader library in use.
    pub fn shaders(&self) -> &ShaderLibrary {
        self.pipelines.shaders()
    }

    /// The light store (what the GPU's light buffer holds).
    pub fn light_store(&self) -> &LightStore {
        &self.lights
    }

    /// The cluster binner (this frame's grid, its lists for tests).
    pub fn cluster_binner(&self) -> &ClusterBinner {
        &self.clusters
    }

    /// What the shadow orchestrator decided for the last frame: shadowed lights, their
    /// cascades, which layers were rendered.
    pub fn shadow_frame(&self) -> &crate::passes::shadows::orchestrator::ShadowFrame {
        self.shadows.frame()
    }

    /// Keys (with their shader variants) of the forward pipelines compiled so far.
    pub fn forward_pipeline_keys(&self) -> Vec<PipelineKey> {
        self.pipelines.forward_keys().copied().collect()
    }

    /// Re-reads the shader folder because `files` changed, rebuilding the pipelines that use them.
    pub fn reload_shaders(&mut self, files: &[String]) -> Result<ReloadReport, ShaderError> {
        let start = Instant::now();
        let result = self.pipelines.reload(&self.ctx.device, files);
        self.report_reload(&result, start);
        result
    }

    /// Logs a reload's outcome and shows its error, or applies what it changed.
    fn report_reload(&mut self, result: &Result<ReloadReport, ShaderError>, start: Instant) {
        match result {
            Ok(report) => self.reloaded(report, start),
            Err(e) => {
                tracing::error!("{e} (keeping the last good shaders)");
                self.shader_error = Some(e.clone());
            }
        }
    }

    /// What a successful reload changes beyond the pipelines.
    fn reloaded(&mut self, report: &ReloadReport, start: Instant) {
        if report.rebuilt > 0 {
            // A changed caster shader may draw other depths: every shadow map is redrawn.
            self.shadows.invalidate();
        }
        if report.environment_steps {
            self.environment.remake();
        }
        if report.files.is_empty() {
            tracing::debug!("shaders unchanged (a save of the same text)");
        } else {
            let families: Vec<String> = report.families.iter().map(|(family, n)| format!("{family} {n}")).collect();
            tracing::info!(
                "shaders reloaded ({}): {} pipeline{} rebuilt{} in {:.1} ms",
                report.files.join(", "),
                report.rebuilt,
                if report.rebuilt == 1 { "" } else { "s" },
                if families.is_empty() { String::new() } else { format!(" ({})", families.join(", ")) },
                start.elapsed().as_secs_f64() * 1e3
            );
        }
        // The library in use now holds the folder's sources, every changed one of them checked.
        self.shader_error = None;
    }

    /// Applies the watcher's changes, if any; returns the outcome of a reload that changed
    /// something or reported an error. A file is tried as soon as its event arrives and kept if
    /// it compiles; one that does not is left alone until its events settle (a save may still be
    /// under way), then reloaded again and its error reported (see `shader_watcher.rs`).
    pub fn poll_shader_changes(&mut self) -> Option<Result<ReloadReport, ShaderError>> {
        let changes = self.shader_watcher.as_mut()?.poll();
        if !changes.settled.is_empty() {
            let start = Instant::now();
            let result = self.pipelines.reload(&self.ctx.device, &changes.settled);
            // A reload reads the whole folder: the error may be in another file whose save is
            // still under way. That one is reported when it settles, as it would be alone.
            if let Err(e) = &result
                && self.shader_watcher.as_ref().is_some_and(|w| w.is_pending(&e.file))
            {
                tracing::debug!("{e} (not reported yet: the save of {} may still be under way)", e.file);
                return None;
            }
            self.report_reload(&result, start);
            return Some(result);
        }
        if changes.fresh.is_empty() {
            return None;
        }
        let start = Instant::now();
        match self.pipelines.reload(&self.ctx.device, &changes.fresh) {
            Ok(report) => {
                if let Some(w) = self.shader_watcher.as_mut() {
                    w.accept(&changes.fresh);
                }
                self.reloaded(&report, start);
                Some(Ok(report))
            }
            Err(e) => {
                tracing::debug!("{e} (not reported yet: the save may still be under way)");
                None
            }
        }
    }

    /// Whether file events are waiting to settle into a reload.
    pub fn shader_changes_pending(&self) -> bool {
        self.shader_watcher.as_ref().is_some_and(ShaderWatcher::busy)
    }

    /// The submission of the last frame, to wait on (bounding frames in flight).
    pub fn last_submission(&self) -> Option<&wgpu::SubmissionIndex> {
        self.last_submission.as_ref()
    }

    /// Waits for the GPU to finish everything submitted and collects outstanding timings.
    pub fn finish(&mut self) {
        let device = self.ctx.device.clone();
        match self.timer.as_mut() {
            Some(t) => t.finish(&device),
            None => {
                let _ = device.poll(wgpu::PollType::wait_indefinitely());
            }
        }
        self.stats.gpu = self.timer.as_ref().and_then(|t| t.latest().cloned());
        self.culling.collect_feedback(&device);
    }

    /// The newest frame measured by occlusion culling (a frame that ran it after a frame that
    /// did): how many opaque entries in view it left out, of how many. Arrives a frame or two
    /// late; [`Renderer::finish`] waits for it.
    pub fn occlusion_measure(&self) -> Option<crate::passes::occlusion_feedback::OcclusionMeasure> {
        self.culling.occlusion_measure()
    }

    pub fn memory(&self) -> MemoryStats {
        let pool = self.mesh_pool.stats();
        MemoryStats {
            mesh_pool: pool.vertex_capacity_bytes + pool.index_capacity_bytes,
            textures: self.textures.gpu_bytes(),
            instances: self.instances.buffer().size()
                + self.draw_slots.capacity()
                + self.culling.gpu_bytes()
                + self.visibility.gpu_bytes(),
            targets: self.targets.as_ref().map_or(0, |t| t.bytes()),
            lights: self.lights.gpu_bytes(),
            clusters: self.clusters.gpu_bytes(),
            shadows: self.shadows.gpu_bytes(),
            environment: self.environment.bytes(),
            post: self.post.gpu_bytes(),
            deform: self.deformer.gpu_bytes(),
        }
    }

    /// Instances each opaque batch drew in the last frame after GPU culling, in batch order;
    /// `None` when the last frame was not culled. Reads back (waits for the GPU): for tests and
    /// tools, not for frames.
    pub fn visible_instance_counts(&self) -> Result<Option<Vec<u32>>, ReadbackError> {
        if !self.culling_active {
            return Ok(None);
        }
        self.culling.read_visible_counts(&self.ctx.device, &self.ctx.queue).map(Some)
    }

    /// Triangles each opaque batch drew in the last frame, for batches the cull pass culled
    /// triangle by triangle (`None` where a batch drew instances; `Ok(None)`: the frame culled
    /// no triangles). Reads back (waits for the GPU): for tests and tools.
    pub fn triangle_culled_counts(&self) -> Result<Option<Vec<Option<u32>>>, ReadbackError> {
        if !self.culling_active {
            return Ok(None);
        }
        self.culling.read_triangle_counts(&self.ctx.device, &self.ctx.queue)
    }

    /// Automatic exposure's state after the last frame: (the correction the tonemap pass
    /// applied on top of the camera's exposure, the adapted EV100). Reads back (waits for the
    /// GPU): for tests and tools.
    pub fn auto_exposure_state(&self) -> Result<(f32, f32), ReadbackError> {
        let bytes = readback::read_buffer(&self.ctx.device, &self.ctx.queue, self.post.params_buffer(), 8)?;
        let f = |i: usize| f32::from_le_bytes(bytes[4 * i..4 * i + 4].try_into().expect("4 bytes"));
        Ok((f(0), f(1)))
    }

    /// Renders into the renderer's own offscreen output of `size`: `Rgba8Unorm`, sRGB-encoded by
    /// the shaders (display.wgsl's exact curve, so a screenshot does not depend on a driver's
    /// sRGB encoder; NVIDIA's and lavapipe's round differently, which alone put FLIP 0.016
    /// between the two on TextureCoordinateTest's flat colours). With MSAA resolving display
    /// colours (`MsaaResolve::Display`) it is `Rgba8UnormSrgb` instead, encoded by the driver:
    /// that resolve averages in linear light through sRGB targets.
    pub fn render_headless(&mut self, scene: &RenderScene, size: (u32, u32)) {
        if self.is_device_lost() && !self.recover_headless() {
            return;
        }
        // A 0×0 request draws into a 1×1 texture: compare with what was made, or it is made again
        // every frame.
        let size = (size.0.max(1), size.1.max(1));
        // Resolving display colours averages them in linear light, through an sRGB target (the
        // driver then encodes); otherwise the shaders encode into a unorm target.
        let format = if self.settings.msaa > 1 && self.settings.msaa_resolve == MsaaResolve::Display {
            wgpu::TextureFormat::Rgba8UnormSrgb
        } else {
            wgpu::TextureFormat::Rgba8Unorm
        };
        let needs_new =
            self.headless.as_ref().is_none_or(|(t, _)| (t.width(), t.height()) != size || t.format() != format);
        if needs_new {
            let texture = self.ctx.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("headless output"),
                size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                // Copied into by the visibility buffer's shading pass, which writes through a
                // storage texture (passes::visibility).
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            let view = texture.create_view(&Default::default());
            self.headless = Some((texture, view));
        }
        let view = self.headless.as_ref().expect("just made").1.clone();
        self.render(scene, &view, format, size);
    }

    /// The last headless frame as tightly packed sRGB-encoded RGBA8 rows, whatever drew it (see
    /// [`Renderer::read_frame`]).
    pub fn read_headless(&self) -> Result<Vec<u8>, ReadbackError> {
        let (texture, _) = self.headless.as_ref().ok_or_else(|| ReadbackError::Map("nothing rendered yet".into()))?;
        readback::read_texture(&self.ctx.device, &self.ctx.queue, texture, 4)
    }

    /// The last headless frame, as [`Renderer::read_headless`], or the shader error that kept it
    /// from being the frame the shaders describe: a draw whose pipeline did not compile is left
    /// out, and after a failed reload older shaders drew. Headless renders read this, so a
    /// screenshot with a part missing is an error rather than an image; the viewer draws on
    /// and shows the error beside the frame. The error stands until a reload succeeds, so with
    /// the embedded shaders (nothing to reload) every later read fails too.
    pub fn read_frame(&self) -> Result<Vec<u8>, RendererError> {
        if let Some(e) = &self.shader_error {
            return Err(RendererError::Shader(e.clone()));
        }
        Ok(self.read_headless()?)
    }

    /// The last frame's linear HDR colour (exposed, before tonemapping) as RGBA f32. Alpha is
    /// not opacity: with deferred local lights it held surface roughness (see gbuffer.wgsl).
    pub fn read_hdr(&self) -> Result<Vec<[f32; 4]>, ReadbackError> {
        let targets = self.targets.as_ref().ok_or_else(|| ReadbackError::Map("nothing rendered yet".into()))?;
        let hdr = targets.hdr.as_ref().ok_or_else(|| {
            ReadbackError::Map(
                "the last frame had no HDR target (it drew straight into the output); set \
                 RenderSettings::keep_hdr to read HDR colour"
                    .into(),
            )
        })?;
        let bytes = readback::read_texture(&self.ctx.device, &self.ctx.queue, &hdr.texture, 8)?;
        Ok(bytes
            .chunks_exact(8)
            .map(|px| std::array::from_fn(|c| readback::f16_to_f32(u16::from_le_bytes([px[2 * c], px[2 * c + 1]]))))
            .collect())
    }

    /// Renders one frame of `scene` into `output`.
    pub fn render(
        &mut self,
        scene: &RenderScene,
        output: &wgpu::TextureView,
        output_format: wgpu::TextureFormat,
        size: (u32, u32),
    ) {
        let cpu_start = Instant::now();
        self.frame += 1;
        self.poll_shader_changes();
        let device = self.ctx.device.clone();
        let queue = self.ctx.queue.clone();
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });

        // What occlusion culling hid a frame or two ago decides whether `Auto` runs it now.
        self.culling.collect_feedback(&device);
        let in_step = self.last_scene_frame.is_some_and(|f| f + 1 == scene.frame);
        self.last_scene_frame = Some(scene.frame);
        let mut rebind = self.prepare_lights(scene, in_step, size);
        let env_frame = self.environment.prepare(
            &device,
            &queue,
            &self.pipelines,
            &self.settings.environment,
            scene.environment.as_ref(),
            sun(scene),
            self.ctx.info.device_type == wgpu::DeviceType::Cpu,
        );
        rebind |= env_frame.rebind;
        if env_frame.active != self.ibl_active {
            // Every pipeline key changes.
            self.ibl_active = env_frame.active;
            self.batches_dirty = true;
        }
        self.apply_draw_changes(scene, in_step);
        let t = Instant::now();
        self.prepare_materials(scene, &mut encoder);
        tracing::debug!("materials and textures prepared in {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        let meshes_changed = self.prepare_meshes(scene);
        tracing::debug!("meshes prepared in {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
        let deform_frame = {
            let (draws, mesh_ids) = (&self.draws, &self.mesh_ids);
            let draw_mesh = |e: Entity| draws.get(e).and_then(|d| Some((d.mesh, *mesh_ids.get(&d.mesh)?)));
            let visit = match (in_step, meshes_changed || scene.meshes_changed) {
                (false, _) => Visit::Resync,
                (true, true) => Visit::Scan,
                (true, false) => Visit::Changes,
            };
            self.deformer.prepare(&device, &queue, &mut self.mesh_pool, scene, draw_mesh, visit)
        };
        if deform_frame.outputs_changed {
            self.batches_dirty = true;
        }
        if deform_frame.jobs > 0 {
            // A pose changed: shadow maps of what it casts into, and the scene's bounds, follow.
            self.caster_generation += 1;
        }
        if self.materials.is_dirty() {
            // A masked caster's cutoff may have changed.
            self.caster_generation += 1;
        }
        // Batches first, so that caster changes count in this frame's shadow decisions; again if
        // shadows switched on or off (new pipeline keys, the same casters).
        if self.batches_dirty {
            self.rebuild_batches();
        }
        rebind |= self.prepare_shadows(scene, size);
        if self.batches_dirty {
            self.rebuild_batches();
        }
        let blend_batches = self.sort_blended(scene);
        // Every lit surface reads its specular albedo from the split-sum table (brdf.wgsl).
        let opaque = &self.opaque_batches;
        let lit_draws = || opaque.iter().chain(blend_batches.iter().map(|(b, _)| b)).any(|b| !b.key.unlit);
        rebind |= self.environment.require_table(&device, lit_draws);

        // Uploads: draw slots (opaque part only when rebuilt, blended part every frame).
        let opaque_len = self.opaque_slots.len();
        let total = opaque_len + blend_batches.len();
        let grew = self.draw_slots.reserve(&device, (total.max(1) * 4) as u64);
        rebind |= grew;
        if (self.opaque_slots_dirty || grew) && opaque_len > 0 {
            queue.write_buffer(self.draw_slots.buffer(), 0, bytemuck::cast_slice(&self.opaque_slots));
        }
        self.opaque_slots_dirty = false;
        if !blend_batches.is_empty() {
            let blend_slots: Vec<u32> = blend_batches.iter().map(|(_, slot)| *slot).collect();
            queue.write_buffer(self.draw_slots.buffer(), opaque_len as u64 * 4, bytemuck::cast_slice(&blend_slots));
        }
        // One instance is not culled: that could only save a frame showing nothing, and the
        // dispatch and its barrier cost 0.027 ms on the H100 (cargo bench --bench triangle).
        // The visibility buffer rasterises the cull pass's visible lists, one instance or many.
        let culling = self.settings.gpu_culling
            && self.ctx.caps.indirect_first_instance
            && (opaque_len > 1 || (opaque_len == 1 && self.raster_in_compute()))
            && scene.view.is_some();
        // The visibility buffer, if asked for and this frame's draws allow it (see `Raster`);
        // gizmos, known only below, can still send the frame to the forward pass.
        let visibility_wanted = culling
            && self.raster_in_compute()
            && crate::passes::visibility::fits(&device.limits(), size, self.settings.msaa)
            && self.settings.occlusion_culling != OcclusionCulling::On
            && blend_batches.is_empty()
            && !self.opaque_batches.is_empty()
            && self.opaque_batches.iter().all(crate::passes::visibility::batch_supported);
        let mut occlusion = culling
            && !visibility_wanted
            && match self.settings.occlusion_culling {
                OcclusionCulling::Off => false,
                OcclusionCulling::On => true,
                OcclusionCulling::Auto => {
                    self.ctx.caps.occlusion_culling
                        && opaque_len >= OCCLUSION_AUTO_MIN
                        && self.ctx.info.device_type != wgpu::DeviceType::Cpu
                        && self.culling.occlusion_wanted()
                }
            };
        // A culling shader that does not compile (a broken shader folder) leaves this frame to
        // direct draws of the full list rather than to stale indirect arguments.
        let triangles = culling
            && !visibility_wanted
            && match self.settings.triangle_culling {
                TriangleCulling::Off => false,
                TriangleCulling::On => true,
                TriangleCulling::Auto => self.ctx.info.device_type != wgpu::DeviceType::Cpu,
            };
        let mut cull_error = None;
        let culling = culling && {
            let ready = GpuCulling::compile(&device, &mut self.pipelines, occlusion, triangles, self.settings.msaa);
            cull_error = ready.err();
            cull_error.is_none()
        };
        occlusion &= culling;
        if culling {
            if !self.cull_batches_dirty {
                // Deformed copies' bounds follow their pose (after a rebuild they are read fresh).
                for id in &deform_frame.moved {
                    if let Some(&i) = self.deformed_batches.get(id) {
                        self.culling.update_batch_bounds(&queue, i, &self.opaque_batches[i], &self.mesh_pool);
                    }
                }
            }
            if self.cull_batches_dirty || self.cull_triangles_marked != triangles {
                // The late draws' region follows every blended entry there can be.
                let late_base = (opaque_len + self.blend_entities.len()) as u32;
                let max_slot = triangles.then(|| self.opaque_slots.iter().copied().max().unwrap_or(0));
                self.culling.prepare_batches(
                    &device,
                    &queue,
                    &self.opaque_batches,
                    &self.mesh_pool,
                    late_base,
                    max_slot,
                );
                self.cull_batches_dirty = false;
                self.cull_triangles_marked = triangles;
            }
            let target = RasterTarget { size, samples: self.settings.msaa, subpixel_bits: self.ctx.caps.subpixel_bits };
            rebind |= self.culling.prepare_frame(&device, &queue, total, occlusion.then_some(size), target, self.frame);
        }
        // The view bind group binds the culled list or the full one.
        rebind |= culling != self.culling_active;
        self.culling_active = culling;
        let upload_start = Instant::now();
        rebind |= self.instances.upload(&device, &queue);
        let instance_upload_ms = upload_start.elapsed().as_secs_f64() * 1e3;
        rebind |= self.materials.upload(&device, &queue);
        self.write_view(scene, &queue, size);
        let vertices = self.mesh_pool.vertex_generation();
        if rebind || self.view_bind_group.as_ref().is_none_or(|(g, _)| *g != vertices) {
            self.view_bind_group = Some((vertices, self.create_view_bind_group(&device)));
        }

        // Without a camera there is nothing to draw lines for.
        let gizmo_vertices = match scene.view {
            Some(v) => self.gizmos.prepare(&device, &queue, &scene.gizmos, v.world_from_view.translation.into()),
            None => 0,
        };
        let background = env_frame.active && env_frame.solid_background.is_none() && scene.view.is_some();
        let visibility = visibility_wanted && self.culling_active && gizmo_vertices == 0;
        // The visibility buffer's shading walks the cluster lists itself, in compute.
        let deferred = self.deferred_lights && !visibility;
        let post_settings = &self.settings.post;
        let needs = TargetNeeds {
            msaa: self.settings.msaa,
            display_resolve: self.settings.msaa_resolve == MsaaResolve::Display && output_format.is_srgb(),
            keep_hdr: self.settings.keep_hdr,
            deferred_lights: deferred,
            blended_draws: !blend_batches.is_empty(),
            background,
            gizmos: gizmo_vertices > 0,
            post_processing: post_settings.bloom.is_some()
                || post_settings.auto_exposure.is_some()
                || post_settings.fxaa,
            occlusion_culling: occlusion,
            opaque: match self.opaque_batches.as_slice() {
                [] => OpaqueDraws::None,
                [only] if only.count == 1 => OpaqueDraws::One {
                    overlap: self.mesh_pool.entry(only.mesh_id).map_or(SelfOverlap::Possible, |e| e.self_overlap),
                    cull_back_faces: only.key.cull_back_faces,
                },
                _ => OpaqueDraws::Many,
            },
        };
        // Direct output (no HDR target, no tonemap pass) and no depth target: see TargetNeeds.
        // The visibility buffer needs no depth, resolves its samples itself and shows the
        // background itself: it writes the displayed colour (copied into the output) unless
        // post-processing or a readback wants HDR colour, or the output cannot take the copy.
        let visibility_direct = visibility
            && !needs.keep_hdr
            && !needs.post_processing
            && matches!(output_format, wgpu::TextureFormat::Rgba8Unorm | wgpu::TextureFormat::Rgba8UnormSrgb)
            && output.texture().usage().contains(wgpu::TextureUsages::COPY_DST);
        let (direct, depth_free) = if visibility { (visibility_direct, true) } else { (!needs.hdr(), !needs.depth()) };
        let hdr_storage = visibility && !direct;
        let target_samples = if visibility { 1 } else { self.settings.msaa };
        if self.targets.as_ref().is_none_or(|t| {
            t.size != size
                || t.samples != target_samples
                || t.hdr_storage != hdr_storage
                || t.deferred.is_some() != deferred
                || t.hdr.is_none() != direct
                || t.depth_view.is_none() != depth_free
                || t.depth_sampled != occlusion
                || t.display_msaa.as_ref().is_some_and(|v| v.texture().format() != output_format)
        }) {
            let params = deferred.then_some(&self.deferred_params);
            self.targets = Some(FrameTargets::new(
                &device,
                &self.pipelines,
                size,
                target_samples,
                params,
                TargetsMade {
                    hdr: !direct,
                    depth: !depth_free,
                    depth_sampled: occlusion,
                    output_format,
                    shader_resolve: self.ctx.caps.shader_msaa_resolve,
                    hdr_storage,
                },
            ));
        }

        let mut batches = self.opaque_batches.clone();
        let blend_first = opaque_len as u32;
        for (i, (batch, _)) in blend_batches.iter().enumerate() {
            batches.push(Batch { first: blend_first + i as u32, count: 1, ..*batch });
        }
        for b in &mut batches {
            if direct {
                b.key.color_format = FormatKey(output_format);
                b.key.tonemap = Some(self.settings.tonemapper);
            }
            if depth_free {
                b.key.depth_format = None;
            }
        }
        let camera_exposure = scene.view.map_or(1.0, |v| v.exposure);
        let post = self.post.prepare(
            &device,
            &queue,
            &self.pipelines,
            self.targets.as_ref().expect("made above"),
            &self.settings.post,
            scene.delta_seconds,
            camera_exposure,
        );
        let binned = if self.local_lights == LocalLights::Clustered { self.lights.local_count() } else { 0 };
        let shadow_layers = self.shadows.frame().rendered_layers();
        let plan = FramePlan::new(SceneNeeds {
            binned_lights: binned,
            shadow_layers,
            has_opaque: !self.opaque_batches.is_empty(),
            opaque_instances: opaque_len,
            has_blend: !blend_batches.is_empty(),
            deferred,
            culled: self.culling_active,
            visibility,
            occlusion,
            environment_changed: env_frame.prefilter,
            split_sum_table: self.environment.table_pending(),
            deform_jobs: deform_frame.jobs,
            background,
            bloom: post.bloom,
            auto_exposure: post.auto_exposure,
            fxaa: post.fxaa,
            gizmo_vertices,
            direct_output: direct,
            depth: !depth_free,
        });

        let prepare_ms = cpu_start.elapsed().as_secs_f64() * 1e3;
        if let Some(t) = self.timer.as_mut() {
            t.begin_frame(&device, self.frame);
        }
        let mut deform_error = None;
        if plan.runs(Pass::Deform) {
            deform_error = self
                .deformer
                .encode(&mut encoder, &device, &mut self.pipelines, &self.mesh_pool, self.timer.as_mut())
                .err();
        }
        let mut env_error = None;
        if plan.runs(Pass::EnvironmentPrefilter) {
            env_error = self.environment.encode(&mut encoder, &device, &mut self.pipelines, self.timer.as_mut()).err();
        }
        let mut cluster_error = None;
        if plan.runs(Pass::ClusterBin) {
            cluster_error = self.clusters.encode(&mut encoder, &device, &mut self.pipelines, self.timer.as_mut()).err();
        }
        let cull_inputs = CullInputs {
            view: &self.view_buffer,
            instances: self.instances.buffer(),
            draw_slots: self.draw_slots.buffer(),
            blended: opaque_len as u32..total as u32,
            pool_indices: self.mesh_pool.index_buffer(),
            pool_vertices: self.mesh_pool.vertex_buffer(),
        };
        if plan.runs(Pass::Cull) {
            self.culling.encode(&mut encoder, &device, &self.pipelines, &cull_inputs, self.timer.as_mut());
        }
        let mut shadow_error = None;
        if plan.runs(Pass::Shadows) {
            shadow_error = self.shadows.encode(
                &mut encoder,
                &device,
                &mut self.pipelines,
                &self.settings.shadows,
                &self.mesh_pool,
                &self.materials,
                [self.instances.buffer(), self.draw_slots.buffer(), self.materials.buffer()],
                &self.opaque_batches,
                self.timer.as_mut(),
            );
        }
        let targets = self.targets.as_ref().expect("made above");
        // Handles (reference-counted), so the culling owner stays free to encode between passes.
        let (early_args, late_args) = (self.culling.args().clone(), self.culling.late_args().clone());
        let triangle_draws = self.culling.triangle_draws();
        // A solid background is the clear colour, exposed like the scene (f16-clamped).
        let mut clear = match env_frame.solid_background {
            Some(c) => c.map(|v| (v * camera_exposure).clamp(0.0, 65504.0) as f64),
            None => self.settings.clear_color,
        };
        // The visibility buffer's shading pass transforms the clear colour itself.
        let clear_radiance = clear.map(|c| c as f32);
        if direct && !visibility {
            // No shader touches the clear colour: it gets the display transform here.
            clear = tonemap::display_color(self.settings.tonemapper, clear, !output_format.is_srgb());
        }
        let [r, g, b] = clear;
        let view_bind_group = &self.view_bind_group.as_ref().expect("made above").1;
        // The background is composited over the resolved frame (one sample a pixel, after the
        // surfaces left their coverage in alpha), except with deferred local lights, whose
        // colour alpha carries roughness: then the forward pass draws it where depth is clear.
        let composite_background = plan.runs(Pass::Background) && !deferred;
        let inputs = ForwardInputs {
            targets,
            output,
            view_bind_group,
            mesh_pool: &self.mesh_pool,
            materials: &self.materials,
            clear_color: if composite_background { wgpu::Color::TRANSPARENT } else { wgpu::Color { r, g, b, a: 1.0 } },
            indirect: self.culling_active.then_some(IndirectDraws {
                args: &early_args,
                batches: self.opaque_batches.len(),
                triangles: triangle_draws.as_ref(),
            }),
            background: plan.runs(Pass::Background) && !composite_background,
            gizmos: if plan.runs(Pass::Gizmos) { self.gizmos.draw() } else { None },
        };
        let opaque_count = self.opaque_batches.len();
        let (mut counts, mut forward_error) = if plan.runs(Pass::OcclusionLate) {
            let (early, early_error) = forward::encode(
                &mut encoder,
                &device,
                &mut self.pipelines,
                &inputs,
                &batches,
                opaque_count,
                OpaquePhase::Early,
                self.timer.as_mut(),
            );
            let depth = (targets.depth_view.as_ref().expect("occlusion culling keeps depth"), targets.samples);
            self.culling.encode_late(&mut encoder, &device, &self.pipelines, &cull_inputs, depth, self.timer.as_mut());
            let late_inputs = ForwardInputs {
                indirect: Some(IndirectDraws {
                    args: &late_args,
                    batches: opaque_count,
                    triangles: triangle_draws.as_ref(),
                }),
                ..inputs
            };
            let (late, error) = forward::encode(
                &mut encoder,
                &device,
                &mut self.pipelines,
                &late_inputs,
                &batches,
                opaque_count,
                OpaquePhase::Late,
                self.timer.as_mut(),
            );
            // Both passes submit the opaque batches; count them once.
            let counts = DrawCounts { draw_calls: early.draw_calls + late.draw_calls, ..late };
            (counts, early_error.or(error))
        } else if plan.runs(Pass::VisibilityRaster) {
            if self.visibility_batches_dirty {
                self.visibility.prepare_batches(&device, &queue, &self.opaque_batches, &self.mesh_pool);
                self.visibility_batches_dirty = false;
            }
            let tonemapper = self.settings.tonemapper;
            // Display colours are averaged only into an sRGB output, as the forward pass does.
            let shade_output = match (direct, self.settings.msaa_resolve) {
                (false, _) => ShadeOutput::Hdr,
                (true, MsaaResolve::Display) if self.settings.msaa > 1 && output_format.is_srgb() => {
                    ShadeOutput::DisplayPerSample(tonemapper)
                }
                (true, _) => ShadeOutput::DisplayResolved(tonemapper),
            };
            let inputs = crate::passes::visibility::FrameInputs {
                view: &self.view_buffer,
                view_bind_group,
                instances: self.instances.buffer(),
                visible_slots: self.culling.visible_slots(),
                cull_args: &early_args,
                mesh_pool: &self.mesh_pool,
                materials: &self.materials,
                shade_output,
                hdr: targets.hdr_view(),
                output: output.texture(),
                size,
                samples: self.settings.msaa,
                background,
                clear: clear_radiance,
            };
            let error = self.visibility.prepare_frame(&device, &queue, &mut self.pipelines, &inputs).err();
            self.visibility.encode(&mut encoder, &device, &mut self.pipelines, &inputs, self.timer.as_mut());
            (DrawCounts::default(), error)
        } else if plan.runs(Pass::Opaque) {
            forward::encode(
                &mut encoder,
                &device,
                &mut self.pipelines,
                &inputs,
                &batches,
                opaque_count,
                OpaquePhase::All,
                self.timer.as_mut(),
            )
        } else {
            (DrawCounts::default(), None)
        };
        if plan.runs(Pass::DeferredLights) {
            let key = DeferredKey {
                multisampled: targets.samples > 1,
                light_shapes: self.light_shapes,
                local_shadows: self.local_shadows_active,
            };
            // Without its pipeline the pass does not run, and the composite must not add what an
            // earlier frame left in its output.
            let mut computed = true;
            if let Err(e) = deferred_lights::encode(
                &mut encoder,
                &device,
                &mut self.pipelines,
                targets,
                view_bind_group,
                key,
                self.timer.as_mut(),
            ) {
                forward_error = Some(e);
                computed = false;
            }
            let (after, error) = forward::encode_after_deferred(
                &mut encoder,
                &device,
                &mut self.pipelines,
                &inputs,
                &batches,
                opaque_count,
                computed,
                self.timer.as_mut(),
            );
            counts += after;
            forward_error = forward_error.or(error);
        }
        if composite_background
            && let Err(e) = forward::encode_background(
                &mut encoder,
                &device,
                &mut self.pipelines,
                targets,
                view_bind_group,
                self.timer.as_mut(),
            )
        {
            forward_error = forward_error.or(Some(e));
        }
        let mut post_error = None;
        if plan.runs(Pass::Bloom) || plan.runs(Pass::AutoExposure) {
            post_error = self
                .post
                .encode_before_tonemap(&mut encoder, &device, &mut self.pipelines, targets, self.timer.as_mut())
                .err();
        }
        // With FXAA the tonemap pass writes the intermediate FXAA reads.
        let mut tonemap_result = Ok(());
        if plan.runs(Pass::Tonemap) {
            let tonemap_key = self.post.tonemap_key(self.settings.tonemapper, output_format);
            let tonemap_output =
                tonemap::Output { view: self.post.tonemap_target().unwrap_or(output), format: tonemap_key.format };
            tonemap_result = tonemap::encode(
                &mut encoder,
                &device,
                &mut self.pipelines,
                self.post.tonemap_group(),
                tonemap_key,
                tonemap_output,
                self.timer.as_mut(),
            );
        }
        if plan.runs(Pass::Fxaa) {
            let fxaa = self.post.encode_fxaa(
                &mut encoder,
                &device,
                &mut self.pipelines,
                output,
                output_format,
                self.timer.as_mut(),
            );
            tonemap_result = tonemap_result.and(fxaa);
        }
        if let Some(e) = post_error
            .or(deform_error)
            .or(env_error)
            .or(cluster_error)
            .or(cull_error)
            .or(shadow_error)
            .or(forward_error)
            .or(tonemap_result.err())
            && self.shader_error.as_ref() != Some(&e)
        {
            tracing::error!("{e}");
            self.shader_error = Some(e);
        }
        if let Some(t) = &self.timer {
            t.resolve(&mut encoder);
        }
        let command_buffer = encoder.finish();
        // CPU time is our work up to here; submission can block on a software driver busy
        // with the previous frame, which is GPU time, not ours.
        let cpu_ms = cpu_start.elapsed().as_secs_f64() * 1e3;
        let submit_start = Instant::now();
        self.last_submission = Some(queue.submit([command_buffer]));
        let submit_ms = submit_start.elapsed().as_secs_f64() * 1e3;
        self.culling.after_submit();
        if let Some(t) = self.timer.as_mut() {
            t.after_submit();
        }
        tracing::debug!(
            "frame {} encoded and submitted after {:.1} ms",
            self.frame,
            cpu_start.elapsed().as_secs_f64() * 1e3
        );
        self.mesh_pool.evict(self.frame);

        self.stats = FrameStats {
            frame: self.frame,
            draw_calls: counts.draw_calls,
            instances: counts.instances,
            primitives: counts.primitives,
            lights: self.lights.count(),
            local_lights: self.lights.local_count(),
            cluster_index_bound: if plan.runs(Pass::ClusterBin) { self.clusters.index_bound() } else { 0 },
            light_bytes_uploaded: self.lights.last_upload_bytes,
            instance_bytes_uploaded: self.instances.last_upload_bytes,
            cpu_ms,
            prepare_ms,
            instance_upload_ms,
            submit_ms,
            gpu: self.timer.as_ref().and_then(|t| t.latest().cloned()),
            plan,
            pipelines: self.pipelines.forward_pipeline_count(),
            pipelines_compiled: self.pipelines.compiled,
            shader_generation: self.pipelines.generation,
            environment_prefilters: self.environment.prefilters,
        };
    }

    /// Syncs and uploads the light store, chooses how fragments find local lights, and prepares
    /// the cluster grid when binning runs. Returns whether the view bind group must be rebuilt.
    fn prepare_lights(&mut self, scene: &RenderScene, in_step: bool, size: (u32, u32)) -> bool {
        let device = self.ctx.device.clone();
        let exposure = scene.view.map_or(1.0, |v| v.exposure);
        self.lights.sync(scene, in_step, exposure, self.settings.light_cutoff);
        let mut rebind = self.lights.upload(&device, &self.ctx.queue);
        if rebind {
            self.clusters.light_buffer_replaced();
        }
        let mut walk = match (self.lights.local_count(), self.settings.light_walk) {
            (0, _) => LocalLights::None,
            (_, LightWalk::Auto | LightWalk::Clustered | LightWalk::ClusteredCompute) => LocalLights::Clustered,
            (_, LightWalk::AllLights) => LocalLights::All,
            (_, LightWalk::AllUnbounded) => LocalLights::AllUnbounded,
        };
        // Without a camera nothing is seen; the brute-force walk needs no grid.
        if walk == LocalLights::Clustered && scene.view.is_none() {
            walk = LocalLights::All;
        }
        if let (LocalLights::Clustered, Some(view)) = (walk, scene.view) {
            let prepared = self.clusters.prepare(
                &self.ctx,
                &self.pipelines,
                &view,
                size,
                self.settings.clusters,
                &mut self.lights,
            );
            match prepared {
                Ok(grew) => {
                    rebind |= grew;
                    self.binning_error = None;
                }
                Err(e) => {
                    if self.binning_error.as_ref() != Some(&e) {
                        tracing::error!("{e}");
                        self.binning_error = Some(e);
                    }
                    walk = LocalLights::All;
                }
            }
        }
        let shapes = self.lights.shapes();
        let wants_compute = match self.settings.light_walk {
            LightWalk::ClusteredCompute => true,
            LightWalk::Auto => {
                let clusters = self.clusters.grid().map_or(1, |g| g.cluster_count().max(1));
                let per_cluster = self.clusters.index_bound() as f64 / clusters as f64;
                // Hysteresis: a scene near the threshold does not flip paths (and targets)
                // every frame.
                per_cluster > if self.deferred_lights { AUTO_COMPUTE_LEAVE } else { AUTO_COMPUTE_ENTER }
            }
            _ => false,
        };
        // The heat view colours fragments by their cluster, which only the forward shader does.
        let deferred = walk == LocalLights::Clustered
            && wants_compute
            && self.ctx.caps.deferred_lights
            && self.settings.debug_view == DebugView::None;
        let in_storage = !self.lights.global_lights_fit_uniform();
        if walk != self.local_lights
            || shapes != self.light_shapes
            || deferred != self.deferred_lights
            || in_storage != self.global_lights_in_storage
        {
            self.local_lights = walk;
            self.light_shapes = shapes;
            self.deferred_lights = deferred;
            self.global_lights_in_storage = in_storage;
            self.batches_dirty = true;
        }
        rebind
    }

    /// Fits this frame's shadow cascades to the camera, the shadowed directional lights and the
    /// bounds of what is drawn. Returns whether the view bind group must be rebuilt (the atlas
    /// was allocated or released).
    fn prepare_shadows(&mut self, scene: &RenderScene, size: (u32, u32)) -> bool {
        let candidates: Vec<DirectionalCandidate> = self
            .lights
            .global_lights()
            .filter(|(_, _, l)| l.shadows)
            .map(|(slot, key, light)| DirectionalCandidate { key, slot, light: *light })
            .collect();
        let local_candidates: Vec<LocalCandidate> = self
            .lights
            .local_entries()
            .filter(|(_, _, l, _)| l.shadows)
            .map(|(_, key, light, packed)| LocalCandidate { key, light: *light, reach: packed.range })
            .collect();
        let bounds = if candidates.is_empty() && local_candidates.is_empty() {
            SceneBounds { casters: Aabb::EMPTY, receivers: Aabb::EMPTY }
        } else {
            match self.bounds_cache {
                Some((generation, bounds)) if generation == self.caster_generation => bounds,
                _ => {
                    let bounds = self.scene_bounds(scene);
                    self.bounds_cache = Some((self.caster_generation, bounds));
                    bounds
                }
            }
        };
        let aspect = size.0.max(1) as f32 / size.1.max(1) as f32;
        let view = scene.view.as_ref().map(|v| (v, aspect));
        let mut rebind = self.shadows.prepare(
            &self.ctx.device,
            &self.ctx.queue,
            &self.settings.shadows,
            view,
            &candidates,
            &local_candidates,
            &bounds,
            self.caster_generation,
        );
        // Local lights carry their first shadow layer; the store uploads what that changed.
        if self.lights.set_shadow_layers(self.shadows.frame().local.first_layers.clone()) {
            let earlier = self.lights.last_upload_bytes;
            rebind |= self.lights.upload(&self.ctx.device, &self.ctx.queue);
            self.lights.last_upload_bytes += earlier;
        }
        let (active, local) = (self.shadows.active(), self.shadows.local_active());
        if (active, local) != (self.shadows_active, self.local_shadows_active) {
            self.shadows_active = active;
            self.local_shadows_active = local;
            self.batches_dirty = true;
        }
        rebind
    }

    /// World bounds of the visible draws, and of those among them that cast shadows (opaque and
    /// masked triangles). A pass over every draw, made only when a draw changed (the caster
    /// generation moved; see `bounds_cache`).
    fn scene_bounds(&self, scene: &RenderScene) -> SceneBounds {
        let mut bounds = SceneBounds { casters: Aabb::EMPTY, receivers: Aabb::EMPTY };
        for (entity, d) in self.draws.iter().filter(|(_, d)| d.visible) {
            let Some(entry) = self.draw_mesh_id(entity, d).and_then(|id| self.mesh_pool.entry(id)) else { continue };
            let Some(item) = scene.draws.get(entity) else { continue };
            let world = entry.aabb.transformed(&item.world_from_local);
            if world.is_empty() || !world.min.is_finite() || !world.max.is_finite() {
                continue;
            }
            bounds.receivers = bounds.receivers.union(&world);
            let casts = entry.topology == penumbra_engine::mesh::Topology::TriangleList
                && self.materials.get(&d.material).is_some_and(|m| m.alpha != AlphaKey::Blend);
            if casts {
                bounds.casters = bounds.casters.union(&world);
            }
        }
        bounds
    }

    fn apply_draw_changes(&mut self, scene: &RenderScene, in_step: bool) {
        if !in_step {
            // Missed change lists: diff against the full draw set instead.
            let gone: Vec<Entity> = self.draws.keys().filter(|e| !scene.draws.contains(*e)).collect();
            let all: Vec<Entity> = scene.draws.keys().collect();
            self.apply_changes(scene, &gone, &all);
        } else {
            self.apply_changes(scene, &scene.removed_draws, &scene.changed_draws);
        }
    }

    fn apply_changes(&mut self, scene: &RenderScene, removed: &[Entity], changed: &[Entity]) {
        if !removed.is_empty() || !changed.is_empty() {
            self.caster_generation += 1;
        }
        for entity in removed {
            if let Some(old) = self.draws.remove(*entity) {
                self.forget_draw(&old);
            }
        }
        // Moves first, in any order; then new and re-keyed draws in entity order, so instance
        // slots are allocated the same way whatever order extraction listed them in.
        // Moves write their record straight into their own slot; anything else is listed.
        let mut rekeyed = Vec::new();
        if changed.len() < PARALLEL_PACK_MIN {
            for &entity in changed {
                match pack_move(&self.draws, &self.materials, scene, entity) {
                    Some((slot, instance)) => self.instances.write(slot, instance),
                    None => rekeyed.push(entity),
                }
            }
        } else {
            // Packing a million moved instances is most of a frame's CPU time on one core.
            let pool = bevy_tasks::ComputeTaskPool::get_or_init(bevy_tasks::TaskPool::default);
            let chunk = changed.len().div_ceil(pool.thread_num().max(1) * 4);
            // The writer borrows the instance records; packing reads the draw and material tables.
            let writer = self.instances.disjoint_writer();
            let (draws, materials) = (&self.draws, &self.materials);
            let parts = pool.scope(|s| {
                for entities in changed.chunks(chunk) {
                    let writer = &writer;
                    s.spawn(async move {
                        let mut rekeyed = Vec::new();
                        let (mut lowest, mut highest) = (u32::MAX, 0);
                        for &entity in entities {
                            match pack_move(draws, materials, scene, entity) {
                                Some((slot, instance)) => {
                                    // SAFETY: `changed` lists each entity once (extraction's
                                    // contract) and every drawn entity owns its own slot.
                                    unsafe { writer.write(slot, instance) };
                                    lowest = lowest.min(slot);
                                    highest = highest.max(slot);
                                }
                                None => rekeyed.push(entity),
                            }
                        }
                        writer.wrote_span(lowest, highest);
                        rekeyed
                    });
                }
            });
            drop(writer);
            rekeyed = parts.into_iter().flatten().collect();
        }
        rekeyed.sort_unstable();
        for entity in rekeyed {
            let Some(item) = scene.draws.get(entity) else {
                continue;
            };
            let mirrored = item.world_from_local.matrix3.determinant() < 0.0;
            // The material slot is assigned by prepare_materials; slot 0 until then is harmless
            // because the instance is re-packed there once the slot is known.
            let material_slot = self.materials.get(&item.material).map_or(0, |m| m.slot);
            let instance = GpuInstance::new(&item.world_from_local, material_slot);
            let previous = self.draws.get(entity).copied();
            if let Some(old) = &previous
                && (old.mesh != item.mesh || old.material != item.material)
            {
                self.release_users(old);
            }
            if previous.is_none_or(|o| o.mesh != item.mesh || o.material != item.material) {
                *self.mesh_users.entry(item.mesh).or_default() += 1;
                *self.material_users.entry(item.material).or_default() += 1;
            }
            let slot = match previous {
                Some(d) => {
                    self.instances.write(d.slot, instance);
                    d.slot
                }
                None => self.instances.allocate(instance),
            };
            let state = DrawState { slot, mesh: item.mesh, material: item.material, mirrored, visible: item.visible };
            self.batches_dirty = true;
            if let Replaced::Other(_, stale) = self.draws.insert(entity, state) {
                // Not reported removed (extraction reports reused indices; this is a backstop).
                self.forget_draw(&stale);
            }
        }
    }

    /// Releases what a draw that is gone held: its instance slot, its mesh and material uses.
    fn forget_draw(&mut self, old: &DrawState) {
        self.instances.free(old.slot);
        self.release_users(old);
        self.batches_dirty = true;
    }

    fn release_users(&mut self, old: &DrawState) {
        if let Some(n) = self.mesh_users.get_mut(&old.mesh) {
            *n -= 1;
            if *n == 0 {
                self.mesh_users.remove(&old.mesh);
                self.mesh_ids.remove(&old.mesh);
            }
        }
        if let Some(n) = self.material_users.get_mut(&old.material) {
            *n -= 1;
            if *n == 0 {
                self.material_users.remove(&old.material);
            }
        }
    }

    fn prepare_materials(&mut self, scene: &RenderScene, encoder: &mut wgpu::CommandEncoder) {
        let users = &self.material_users;
        self.materials.retain(scene, |k| users.contains_key(k));
        let keys: Vec<MaterialKey> = self.material_users.keys().copied().collect();
        // New or changed images are uploaded together so their mip chains build in parallel.
        let mut requests = Vec::new();
        for m in keys.iter().flatten().filter_map(|h| scene.materials.get(h)) {
            for (slot, tex) in m.data.textures().into_iter().enumerate() {
                let Some(t) = tex else { continue };
                let Some(img) = scene.images.get(&t.image) else { continue };
                let srgb = SRGB_SLOTS[slot];
                let queued = requests.iter().any(|r: &TextureRequest| r.image == t.image && r.srgb == srgb);
                if !queued && self.textures.is_stale(t.image, srgb, img.version) {
                    requests.push(TextureRequest {
                        image: t.image,
                        srgb,
                        version: img.version,
                        data: img.data.clone(),
                    });
                }
            }
        }
        self.textures.upload_many(&self.ctx.device, &self.ctx.queue, encoder, &mut self.pipelines, &requests);
        let mut new_slots = false;
        for key in keys {
            let before = self.materials.get(&key).map(|m| m.slot);
            let ok = self.materials.prepare(
                &self.ctx.device,
                &mut self.textures,
                &self.pipelines.material_layout,
                scene,
                key,
            );
            if !ok {
                continue;
            }
            let m = self.materials.get(&key).expect("prepared");
            let bits = (m.alpha, m.unlit, m.double_sided, m.textures);
            if self.material_bits.insert(key, bits) != Some(bits) {
                self.batches_dirty = true;
            }
            new_slots |= before != Some(m.slot);
        }
        self.textures.retain(|h| scene.images.contains_key(&h));
        self.material_bits.retain(|k, _| self.material_users.contains_key(k));
        if new_slots {
            // Instances packed before their material had a slot get the real one now.
            for (entity, d) in self.draws.iter() {
                if let (Some(m), Some(item)) = (self.materials.get(&d.material), scene.draws.get(entity)) {
                    self.instances.write(d.slot, GpuInstance::new(&item.world_from_local, m.slot));
                }
            }
        }
    }

    /// Returns whether any mesh asset now maps to another pool entry (or to none).
    fn prepare_meshes(&mut self, scene: &RenderScene) -> bool {
        let mut changed = false;
        // Mesh assets that vanished release their pool entries; entries nothing refers to are
        // evicted at the end of the frame.
        self.mesh_pool.retain_assets(|h| scene.meshes.contains_key(&h));
        self.warned_missing.retain(|h| self.mesh_users.contains_key(h) && !scene.meshes.contains_key(h));
        let handles: Vec<Handle<Mesh>> = self.mesh_users.keys().copied().collect();
        for handle in handles {
            let Some(snapshot) = scene.meshes.get(&handle) else {
                if self.warned_missing.insert(handle) {
                    tracing::warn!("a draw refers to mesh {handle:?}, which no longer exists; not drawn");
                }
                if self.mesh_ids.remove(&handle).is_some() {
                    self.batches_dirty = true;
                    changed = true;
                }
                self.mesh_pool.release_asset(handle);
                continue;
            };
            let id = self.mesh_pool.get_or_upload(&self.ctx.device, &self.ctx.queue, handle, snapshot, self.frame);
            if self.mesh_ids.insert(handle, id) != Some(id) {
                self.batches_dirty = true;
                changed = true;
            }
        }
        changed
    }

    fn pipeline_key(&self, d: &DrawState) -> Option<PipelineKey> {
        let m = self.materials.get(&d.material)?;
        let entry = self.mesh_pool.entry(*self.mesh_ids.get(&d.mesh)?)?;
        let triangles = entry.topology == penumbra_engine::mesh::Topology::TriangleList;
        Some(PipelineKey {
            unlit: m.unlit,
            alpha: m.alpha,
            textures: m.textures,
            // Blended surfaces are not in the surface targets: they walk their own lists.
            local_lights: if self.deferred_lights && m.alpha != AlphaKey::Blend {
                LocalLights::Deferred
            } else {
                self.local_lights
            },
            light_shapes: self.light_shapes,
            global_lights_in_storage: self.global_lights_in_storage,
            shadows: self.shadows_active,
            local_shadows: self.local_shadows_active,
            ibl: self.ibl_active,
            debug: self.settings.debug_view,
            topology: entry.topology.into(),
            vertex_colors: entry.vertex_colors,
            // Only triangles have a back (lines are drawn as quads whose winding follows the
            // segment on screen; points face the viewer), so only their keys cull and wind.
            cull_back_faces: !m.double_sided && triangles,
            front_face_cw: d.mirrored && triangles,
            sample_count: self.settings.msaa,
            alpha_test: AlphaTest::choose(
                m.alpha,
                self.settings.msaa,
                m.textures.has(TextureSet::BASE_COLOR) || entry.vertex_colors,
                &self.ctx.caps,
            ),
            // Frames with direct output or without depth replace these per frame (see `render`).
            color_format: FormatKey(HDR_FORMAT),
            depth_format: Some(FormatKey(DEPTH_FORMAT)),
            tonemap: None,
            pulled_vertices: false,
        })
    }

    /// The pool entry `entity` draws: its deformed copy if it has one, else its mesh's entry.
    fn draw_mesh_id(&self, entity: Entity, d: &DrawState) -> Option<MeshId> {
        self.deformer.output(entity, d.mesh).or_else(|| self.mesh_ids.get(&d.mesh).copied())
    }

    /// Sorts visible opaque and masked draws into instanced batches; collects blended draws.
    fn rebuild_batches(&mut self) {
        self.batches_dirty = false;
        let casters_before = self.caster_signature();
        let mut items: Vec<(PipelineKey, MaterialKey, MeshId, Handle<Mesh>, u32)> = Vec::new();
        self.blend_entities.clear();
        for (entity, d) in self.draws.iter() {
            if !d.visible {
                continue;
            }
            let (Some(key), Some(mesh_id)) = (self.pipeline_key(d), self.draw_mesh_id(entity, d)) else { continue };
            if key.alpha == AlphaKey::Blend {
                self.blend_entities.push(entity);
            } else {
                items.push((key, d.material, mesh_id, d.mesh, d.slot));
            }
        }
        // Opaque before masked (AlphaKey order), then by pipeline, material and pool entry (mesh
        // assets with identical content share an entry, so they batch together); the slot makes
        // the order total, so the frame is deterministic whatever the hash-map order.
        items.sort_unstable_by_key(|&(key, material, mesh_id, _, slot)| (key.alpha, key, material, mesh_id, slot));
        self.blend_entities.sort_unstable();
        self.opaque_batches.clear();
        self.deformed_batches.clear();
        self.opaque_slots.clear();
        self.opaque_slots_dirty = true;
        self.cull_batches_dirty = true;
        self.visibility_batches_dirty = true;
        for (key, material, mesh_id, mesh, slot) in items {
            let i = self.opaque_slots.len() as u32;
            self.opaque_slots.push(slot);
            match self.opaque_batches.last_mut() {
                Some(b) if b.key == key && b.material == material && b.mesh_id == mesh_id => b.count += 1,
                _ => self.opaque_batches.push(Batch { key, material, mesh, mesh_id, first: i, count: 1 }),
            }
        }
        if self.deformer.instance_count() > 0 {
            for (i, b) in self.opaque_batches.iter().enumerate() {
                if self.mesh_pool.entry(b.mesh_id).is_some_and(|e| e.is_derived()) {
                    self.deformed_batches.insert(b.mesh_id, i);
                }
            }
        }
        // New pipeline keys alone (shadows switched on, a debug view) change no caster.
        if self.caster_signature() != casters_before {
            self.caster_generation += 1;
        }
    }

    /// What the shadow passes draw: each opaque or masked batch's mesh, material, alpha mode
    /// and instances.
    fn caster_signature(&self) -> (Vec<(MeshId, MaterialKey, AlphaKey, u32, u32)>, Vec<u32>) {
        let batches =
            self.opaque_batches.iter().map(|b| (b.mesh_id, b.material, b.key.alpha, b.first, b.count)).collect();
        (batches, self.opaque_slots.clone())
    }

    /// Blended draws, farthest first (by the centre of their world bounds along the view axis).
    fn sort_blended(&self, scene: &RenderScene) -> Vec<(Batch, u32)> {
        let Some(view) = scene.view else {
            return Vec::new();
        };
        let eye = Vec3::from(view.world_from_view.translation);
        let forward = (view.world_from_view.matrix3 * glam::Vec3A::NEG_Z).normalize_or_zero();
        let mut out: Vec<(f32, Entity, Batch, u32)> = Vec::new();
        for entity in &self.blend_entities {
            let Some(d) = self.draws.get(*entity) else { continue };
            let (Some(key), Some(mesh_id)) = (self.pipeline_key(d), self.draw_mesh_id(*entity, d)) else {
                continue;
            };
            let (Some(entry), Some(item)) = (self.mesh_pool.entry(mesh_id), scene.draws.get(*entity)) else {
                continue;
            };
            let center = entry.aabb.transformed(&item.world_from_local).center();
            let depth = (center - eye).dot(forward.into());
            let batch = Batch { key, material: d.material, mesh: d.mesh, mesh_id, first: 0, count: 1 };
            out.push((depth, *entity, batch, d.slot));
        }
        // Farthest first; ties broken by entity so the order is deterministic.
        out.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        out.into_iter().map(|(_, _, b, s)| (b, s)).collect()
    }

    fn write_view(&self, scene: &RenderScene, queue: &wgpu::Queue, size: (u32, u32)) {
        let aspect = size.0.max(1) as f32 / size.1.max(1) as f32;
        let gpu = match scene.view {
            Some(view) => {
                let rotation = glam::Mat3::from(view.world_from_view.matrix3);
                let view_from_rel = Mat4::from_mat3(rotation.transpose());
                let clip_from_rel = view.projection.clip_from_view(aspect) * view_from_rel;
                if self.deferred_lights {
                    let params = GpuDeferredParams::new(clip_from_rel, size);
                    queue.write_buffer(&self.deferred_params, 0, bytemuck::bytes_of(&params));
                }
                GpuView {
                    clip_from_rel: clip_from_rel.to_cols_array_2d(),
                    camera_position: Vec3::from(view.world_from_view.translation).to_array(),
                    exposure: view.exposure,
                    camera_forward: (rotation * Vec3::NEG_Z).normalize().to_array(),
                    is_orthographic: matches!(view.projection, Projection::Orthographic { .. }) as u32,
                    global_light_count: self.lights.global_count(),
                    local_light_count: self.lights.local_count(),
                    target_size: [size.0 as f32, size.1 as f32],
                    rel_from_clip: clip_from_rel.inverse().to_cols_array_2d(),
                }
            }
            None => GpuView::zeroed(),
        };
        queue.write_buffer(&self.view_buffer, 0, bytemuck::bytes_of(&gpu));
    }

    fn create_view_bind_group(&self, device: &wgpu::Device) -> wgpu::BindGroup {
        fn buf(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry { binding, resource: buffer.as_entire_binding() }
        }
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("view"),
            layout: &self.pipelines.view_layout,
            entries: &[
                buf(0, &self.view_buffer),
                buf(1, self.instances.buffer()),
                buf(2, if self.culling_active { self.culling.visible_slots() } else { self.draw_slots.buffer() }),
                buf(3, self.materials.buffer()),
                buf(4, self.lights.buffer()),
                buf(5, self.clusters.grid_buffer()),
                buf(6, self.clusters.ranges()),
                buf(7, self.clusters.indices()),
                buf(8, self.lights.ltc_buffer()),
                buf(9, self.lights.ies_buffer()),
                buf(10, self.shadows.uniform()),
                wgpu::BindGroupEntry {
                    binding: 11,
                    resource: wgpu::BindingResource::TextureView(self.shadows.atlas_view()),
                },
                wgpu::BindGroupEntry { binding: 12, resource: wgpu::BindingResource::Sampler(self.shadows.sampler()) },
                buf(13, self.shadows.local_buffer()),
                wgpu::BindGroupEntry {
                    binding: 14,
                    resource: wgpu::BindingResource::TextureView(self.shadows.local_atlas_view()),
                },
                buf(15, self.environment.uniform()),
                buf(16, self.environment.irradiance_buffer()),
                wgpu::BindGroupEntry {
                    binding: 17,
                    resource: wgpu::BindingResource::TextureView(self.environment.specular_view()),
                },
                wgpu::BindGroupEntry {
                    binding: 18,
                    resource: wgpu::BindingResource::TextureView(self.environment.lut_view()),
                },
                wgpu::BindGroupEntry {
                    binding: 19,
                    resource: wgpu::BindingResource::Sampler(self.environment.sampler()),
                },
                wgpu::BindGroupEntry {
                    binding: 20,
                    resource: wgpu::BindingResource::TextureView(self.shadows.atlas_view()),
                },
                // At most the largest storage binding the device allows (128 MiB on lavapipe).
                wgpu::BindGroupEntry {
                    binding: 21,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: self.mesh_pool.vertex_buffer(),
                        offset: 0,
                        size: std::num::NonZeroU64::new(self.mesh_pool.readable_vertex_bytes()),
                    }),
                },
                wgpu::BindGroupEntry {
                    binding: 22,
                    resource: wgpu::BindingResource::Buffer(self.lights.global_lights_binding()),
                },
            ],
        })
    }
}

/// What a backend cannot do as asked, done the way it can, with a warning (never silently):
/// see `Capabilities`. (What the renderer picks on its own, such as `LightWalk::Auto`'s path,
/// it picks among what the backend can do.)
fn degrade_for_backend(mut settings: RenderSettings, ctx: &GpuContext) -> RenderSettings {
    if !ctx.caps.deferred_lights && settings.light_walk == LightWalk::ClusteredCompute {
        tracing::warn!(
            "local lights cannot be shaded in a compute pass on the {:?} backend: shading them in the fragment shader",
            ctx.info.backend
        );
        settings.light_walk = LightWalk::Clustered;
    }
    if !ctx.caps.occlusion_culling && settings.occlusion_culling == OcclusionCulling::On {
        tracing::warn!(
            "occlusion culling's depth pyramid cannot be built on the {:?} backend: culling by the view only",
            ctx.info.backend
        );
        settings.occlusion_culling = OcclusionCulling::Off;
    }
    settings
}

/// The scene's brightest directional light (by luminance) as (direction towards it,
/// illuminance in lux): the sun the procedural sky is made for. Default lights do not count:
/// the default key light turns with the camera.
fn sun(scene: &RenderScene) -> Option<(Vec3, f32)> {
    let luminance = |c: Vec3| c.dot(Vec3::new(0.2126, 0.7152, 0.0722));
    scene
        .lights
        .iter()
        .filter(|(_, l)| matches!(l.kind, LightKind::Directional { .. }))
        // Ties broken by key, so which light is the sun does not depend on hash order.
        .max_by(|(ka, a), (kb, b)| luminance(a.color).total_cmp(&luminance(b.color)).then(kb.cmp(ka)))
        .map(|(_, l)| (-l.direction, luminance(l.color)))
}

#[cfg(test)]
mod wgsl_layout_tests {
    use super::*;

    #[test]
    fn gpu_view_mirrors_the_shaders_view() {
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuView,
            "forward.wgsl",
            [],
            "View",
            [
                clip_from_rel,
                camera_position,
                exposure,
                camera_forward,
                is_orthographic,
                global_light_count,
                local_light_count,
                target_size,
                rel_from_clip
            ]
        );
    }
}
