//! The renderer: owns every render-world resource and drives each frame through prepare
//! ([`prepare`]: retained updates, each feature's preparation, the targets and the frame plan),
//! encode ([`encode`]: the plan's passes, each recorded by its feature) and one submission.
//! It holds the owners and hands each the others it reads: the draw list, the shared
//! resources (`resources/`) and the features (`features/`) own their GPU state and pipeline
//! families; shader reloads are in [`reload`], readbacks for tests and tools in [`readback`].

use std::time::Instant;

use bevy_ecs::resource::Resource;

use crate::features::clusters::{BinningTooLarge, ClusterBinner};
use crate::features::culling::GpuCulling;
use crate::features::deferred_lights::DeferredLights;
use crate::features::deform::MeshDeformer;
use crate::features::environment::EnvironmentLighting;
use crate::features::forward::{self, DrawCounts, ForwardFamily};
use crate::features::gizmos::GizmoLines;
use crate::features::post::PostChain;
use crate::features::resolve;
use crate::features::shadows::orchestrator::ShadowOrchestrator;
use crate::features::transmission::Transmission;
use crate::features::visibility::{Raster, VisibilityBuffer};
use crate::frame::{self, Pass};
use crate::gpu::context::GpuContext;
use crate::gpu::readback::ReadbackError;
use crate::gpu::timing::GpuTimer;
use crate::pipelines::shader_watcher::ShaderWatcher;
use crate::pipelines::{PipelineCache, PipelineStore, ShaderError, ShaderLibrary};
use crate::resources::draw_list::{DrawList, FrameVariant};
use crate::resources::draws::PipelineKey;
use crate::resources::instances::InstanceBuffer;
use crate::resources::light_store::LightStore;
use crate::resources::materials::MaterialTable;
use crate::resources::mesh_pool::MeshPool;
use crate::resources::textures::TextureCache;
use crate::scene::world::RenderScene;
use crate::settings::{RenderSettings, SettingsError, ShaderSource, degrade_for_backend, max_anisotropy};
use crate::stats::{FrameStats, MemoryStats};
use crate::targets::FrameTargets;
use crate::view::ViewGroup;

#[derive(Debug, thiserror::Error)]
pub enum RendererError {
    #[error(transparent)]
    Shader(#[from] ShaderError),
    #[error(transparent)]
    Frame(#[from] FrameError),
    #[error(transparent)]
    Settings(#[from] SettingsError),
    #[error(transparent)]
    Readback(#[from] ReadbackError),
    #[error(transparent)]
    Context(#[from] crate::gpu::context::ContextError),
}

/// Why a frame failed on the GPU side: what the device could not hold.
#[derive(Debug, Clone, thiserror::Error)]
pub enum FrameError {
    #[error(transparent)]
    Targets(#[from] crate::targets::TargetsError),
    #[error("the GPU ran out of memory while making the frame ({0}); try a smaller --size or --msaa 1")]
    OutOfMemory(String),
    #[error("a {}x{} frame is larger than this GPU's textures can be ({max} a side)", size.0, size.1)]
    Size { size: (u32, u32), max: u32 },
}

/// The draw list's view of the renderer's owners (a macro, so that its borrows stay of
/// disjoint fields beside the draw list's own).
macro_rules! draw_cx {
    ($r:ident) => {
        DrawContext {
            device: &$r.ctx.device,
            queue: &$r.ctx.queue,
            caps: &$r.ctx.caps,
            pipelines: &mut $r.pipelines,
            instances: &mut $r.instances,
            materials: &mut $r.materials,
            textures: &mut $r.textures,
            mesh_pool: &mut $r.mesh_pool,
            deformed: &|entity, mesh| $r.deformer.output(entity, mesh),
            any_deformed: $r.deformer.instance_count() > 0,
            frame: $r.frame,
        }
    };
}

mod encode;
mod laps;
mod prepare;
mod readback;
mod reload;

use prepare::PreparedFrame;

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
    /// The post-processing chain (bloom, automatic exposure, tonemap, FXAA).
    post: PostChain<RenderSettings>,
    /// The view uniform and the view group (group 0 of every lit pipeline).
    view: ViewGroup,
    /// Every drawable entity, the batches and the draw slots.
    draws: DrawList,
    gizmos: GizmoLines,
    culling: GpuCulling,
    /// The draw list's batch generation `culling` last prepared.
    cull_batches_seen: Option<u64>,
    /// Whether the cull batches were last prepared with triangle culling.
    cull_triangles_marked: bool,
    /// Whether this frame's opaque draws were culled (the view bind group binds the culled list).
    culling_active: bool,
    /// The visibility buffer (`Raster::Compute`).
    visibility: VisibilityBuffer,
    /// The draw list's batch generation `visibility` last prepared.
    visibility_batches_seen: Option<u64>,
    targets: Option<FrameTargets>,
    headless: Option<(wgpu::Texture, wgpu::TextureView)>,
    timer: Option<GpuTimer>,
    frame: u64,
    stats: FrameStats,
    /// `RenderScene::frame` of the last scene rendered.
    last_scene_frame: Option<u64>,
    last_submission: Option<wgpu::SubmissionIndex>,
    shader_watcher: Option<ShaderWatcher>,
    /// The newest shader problem; cleared by the next successful reload.
    shader_error: Option<ShaderError>,
    /// Why the last frame failed (`Renderer::frame_error`).
    frame_error: Option<FrameError>,
    deferred: DeferredLights,
    /// The opaque colour's copy that transmissive surfaces see through.
    transmission: Transmission,
    /// The last binning refusal, reported once until it changes.
    binning_error: Option<BinningTooLarge>,
    /// Devices lost and replaced so far.
    device_losses: u32,
    /// Spaces out attempts to replace a lost device.
    recovery: crate::gpu::context::RetryBackoff,
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
        let mut laps = laps::Laps::start();
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
        laps.lap("shader library");
        let mut pipelines = PipelineCache::new(shaders);
        let store_dir = ctx.pipeline_cache_dir().folder();
        pipelines.set_store(PipelineStore::open(device, &ctx.info, store_dir.as_deref()));
        laps.lap("pipeline cache file");
        let view = ViewGroup::new(device);
        let materials = MaterialTable::new(device, view.fragment_textures());
        // Each owner registers its pipeline families; registration order is the order reload
        // reports list families in.
        laps.lap("view and materials");
        let transmission = Transmission::new(device, &mut pipelines);
        // The visibility buffer's groups that a hybrid frame's forward and gizmo draws read.
        let occlusion = crate::features::visibility::occlusion_layouts(device);
        forward::register(&mut pipelines, view.layout(), &materials, transmission.layout(), &occlusion);
        let visibility = VisibilityBuffer::new(device, &mut pipelines, view.layout(), &materials, &occlusion);
        let shadows = ShadowOrchestrator::new(
            device,
            ctx.caps.array_layers,
            ctx.caps.exact_depth,
            &mut pipelines,
            materials.layout(),
        );
        laps.lap("forward, visibility, shadows");
        let culling = GpuCulling::new(device, &mut pipelines);
        let deformer = MeshDeformer::new(device, &mut pipelines);
        let clusters = ClusterBinner::new(device, &mut pipelines);
        let deferred = DeferredLights::new(device, &mut pipelines, view.layout());
        resolve::register(device, &mut pipelines);
        laps.lap("culling, deform, clusters, deferred, resolve");
        let textures = TextureCache::new(
            device,
            &ctx.queue,
            max_anisotropy(&ctx, &settings),
            ctx.caps.srgb_unorm_views,
            ctx.caps.host_import_alignment,
            &mut pipelines,
        );
        let gizmos = GizmoLines::new(device, &mut pipelines, view.layout(), &occlusion[0]);
        let environment = EnvironmentLighting::new(device, ctx.caps.array_layers, &mut pipelines, view.layout());
        let post = frame::post_chain(device, &mut pipelines);
        let timer = (settings.gpu_timing && ctx.caps.timestamps).then(|| GpuTimer::new(device, &ctx.queue));
        laps.log(format_args!("renderer made"));
        Ok(Self {
            mesh_pool: MeshPool::new(device),
            deformer,
            textures,
            materials,
            instances: InstanceBuffer::new(device),
            lights: LightStore::new(),
            clusters,
            shadows,
            environment,
            post,
            draws: DrawList::new(
                device,
                FrameVariant { msaa: settings.msaa, debug: settings.debug_view, ..Default::default() },
            ),
            view,
            pipelines,
            gizmos,
            culling,
            cull_batches_seen: None,
            cull_triangles_marked: false,
            culling_active: false,
            visibility,
            visibility_batches_seen: None,
            targets: None,
            headless: None,
            timer,
            frame: 0,
            stats: FrameStats::default(),
            last_scene_frame: None,
            last_submission: None,
            shader_watcher,
            shader_error,
            frame_error: None,
            deferred,
            transmission,
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
        self.draws.set_variant(FrameVariant {
            msaa: settings.msaa,
            debug: settings.debug_view,
            ..*self.draws.variant()
        });
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

    /// Forgets what earlier frames carry into the next (automatic exposure's adaptation): the
    /// next frame is drawn as a fresh renderer's first would be. For a renderer that moves on to
    /// another scene ([`crate::headless::SceneBatch`]).
    pub fn restart_history(&mut self) {
        self.post.restart();
    }

    /// Pipelines created since the renderer was made (each key once; a hot reload adds those it
    /// rebuilt).
    pub fn pipelines_created(&self) -> usize {
        self.pipelines.compiled
    }

    /// Compiles the pipelines a frame with these settings runs whatever its scene holds: the
    /// environment's prefilter steps (when `environment` says the scene will have one), and,
    /// where opaque draws are rasterised in compute, the frustum cull and the rasteriser's steps.
    /// For a program with time to spare before its first frame (`penumbra render` calls it
    /// while the scene decodes); the first frame compiles whatever is still missing. An error is
    /// left for the frame that needs the pipeline to report.
    pub fn warm_up(&mut self, environment: bool) {
        let device = self.ctx.device.clone();
        let mut laps = laps::Laps::start();
        if environment && let Err(e) = EnvironmentLighting::warm_up(&device, &mut self.pipelines) {
            tracing::debug!("warm-up: {e}");
        }
        laps.lap("environment");
        // The gate a frame passes, asked with what the scene alone can still change assumed
        // favourable (opaque draws, a buffer that fits).
        let gate = crate::features::visibility::RasterGate {
            setting: self.settings.raster,
            atomics: self.ctx.caps.visibility_raster,
            few_graphics_units: self.ctx.caps.few_graphics_units,
            culling: self.settings.gpu_culling && self.ctx.caps.indirect_first_instance,
            fits: true,
            occlusion_on: self.settings.occlusion_culling == crate::features::culling::OcclusionCulling::On,
            opaque: true,
        };
        if gate.decide().is_ok() {
            let culled = GpuCulling::compile(&device, &mut self.pipelines, false, false, self.settings.msaa);
            if let Err(e) = culled.and_then(|()| VisibilityBuffer::warm_up(&device, &mut self.pipelines)) {
                tracing::debug!("warm-up: {e}");
            }
        }
        laps.log(format_args!("warmed up"));
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
    pub fn shadow_frame(&self) -> &crate::features::shadows::orchestrator::ShadowFrame {
        self.shadows.frame()
    }

    /// Keys (with their shader variants) of the forward pipelines compiled so far.
    pub fn forward_pipeline_keys(&self) -> Vec<PipelineKey> {
        self.pipelines.keys::<ForwardFamily>()
    }

    /// The driver's pipeline cache kept between runs, `None` where there is none (off, no cache
    /// folder, or a backend without one).
    pub fn pipeline_store(&self) -> Option<&PipelineStore> {
        self.pipelines.store()
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
    pub fn occlusion_measure(&self) -> Option<crate::features::culling::OcclusionMeasure> {
        self.culling.occlusion_measure()
    }

    pub fn memory(&self) -> MemoryStats {
        let pool = self.mesh_pool.stats();
        MemoryStats {
            mesh_pool: pool.vertex_capacity_bytes + pool.index_capacity_bytes,
            textures: self.textures.gpu_bytes(),
            textures_rgba8: self.textures.rgba8_bytes(),
            instances: self.instances.buffer().size()
                + self.draws.slots().capacity()
                + self.culling.gpu_bytes()
                + self.shadows.caster_list_bytes()
                + self.visibility.gpu_bytes(),
            targets: self.targets.as_ref().map_or(0, |t| t.bytes()),
            lights: self.lights.gpu_bytes(),
            clusters: self.clusters.gpu_bytes(),
            shadows: self.shadows.gpu_bytes(),
            environment: self.environment.bytes(),
            post: self.post.gpu_bytes() + self.transmission.bytes(),
            deform: self.deformer.gpu_bytes(),
        }
    }

    /// Renders one frame of `scene` into `output`: prepare (retained updates driven by
    /// extraction's change lists, each feature's own preparation) and the frame plan, then the
    /// plan's passes encoded, then one submission.
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
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        let frame = match self.prepare_frame(scene, &mut encoder, output, output_format, size) {
            Ok(frame) => frame,
            Err(e) => {
                // Nothing is drawn: the frame fails with the reason, and the next frame tries
                // again (a smaller size or another setting may fit).
                // Headless reads return it and the viewer shows it: logged only for `-v`.
                tracing::info!("frame not drawn: {e}");
                self.frame_error = Some(FrameError::Targets(e));
                return;
            }
        };
        let prepare_ms = cpu_start.elapsed().as_secs_f64() * 1e3;
        if let Some(t) = self.timer.as_mut() {
            t.begin_frame(&device, self.frame);
        }
        let encode_start = Instant::now();
        let counts = self.encode_frame(&frame, &mut encoder, output, output_format, size);
        tracing::debug!("frame {} encoded in {:.1} ms", self.frame, encode_start.elapsed().as_secs_f64() * 1e3);
        self.submit(encoder, frame, counts, cpu_start, prepare_ms);
        self.frame_error = self.ctx.take_out_of_memory().map(FrameError::OutOfMemory);
    }

    /// Why the last frame was not drawn, or was drawn with something missing for lack of GPU
    /// memory; `None` after a good frame. Headless reads ([`Renderer::read_frame`]) fail with it.
    pub fn frame_error(&self) -> Option<&FrameError> {
        self.frame_error.as_ref()
    }

    /// Submits the frame's commands and records what it did.
    fn submit(
        &mut self,
        mut encoder: wgpu::CommandEncoder,
        frame: PreparedFrame,
        counts: DrawCounts,
        cpu_start: Instant,
        prepare_ms: f64,
    ) {
        let queue = self.ctx.queue.clone();
        let PreparedFrame { plan, instance_upload_ms, .. } = frame;
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
            cluster_index_bound: if plan.runs(Pass::CLUSTER_BIN) { self.clusters.index_bound() } else { 0 },
            light_bytes_uploaded: self.lights.last_upload_bytes,
            instance_bytes_uploaded: self.instances.last_upload_bytes,
            cpu_ms,
            prepare_ms,
            instance_upload_ms,
            submit_ms,
            gpu: self.timer.as_ref().and_then(|t| t.latest().cloned()),
            plan,
            pipelines: self.pipelines.count::<ForwardFamily>(),
            pipelines_compiled: self.pipelines.compiled,
            shader_generation: self.pipelines.generation,
            environment_prefilters: self.environment.prefilters,
        };
    }
}
