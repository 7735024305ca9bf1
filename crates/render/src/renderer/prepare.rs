//! The renderer's prepare step: retained updates driven by extraction's change lists (lights,
//! environment, draws, materials, meshes, poses), each feature's preparation (cluster grid,
//! shadow cascades, culling's batches, post-processing's chain), the view group, the frame's
//! targets, and the frame plan ([`FramePlan`]) made from what all that found.

use std::time::Instant;

use bevy_ecs::entity::Entity;
use glam::Vec3;
use penumbra_engine::bounds::Aabb;
use penumbra_engine::mesh::SelfOverlap;

use super::Renderer;
use crate::features::clusters::{AUTO_COMPUTE_ENTER, AUTO_COMPUTE_LEAVE, LightWalk};
use crate::features::culling::{GpuCulling, OCCLUSION_AUTO_MIN, OcclusionCulling, RasterTarget, TriangleCulling};
use crate::features::deform::Visit;
use crate::features::post::PostPrepare;
use crate::features::shadows::local::LocalCandidate;
use crate::features::shadows::orchestrator::DirectionalCandidate;
use crate::features::visibility::OverlayRect;
use crate::frame::{FramePlan, SceneNeeds};
use crate::gpu::formats::FormatKey;
use crate::pipelines::ShaderError;
use crate::resources::draw_list::{DrawContext, FrameVariant, SceneBounds};
use crate::resources::draws::{Batch, DebugView, LocalLights};
use crate::resources::materials::MaterialFeatures;
use crate::scene::world::{LightKind, RenderScene};
use crate::targets::{FrameTargets, MsaaResolve, OpaqueDraws, TargetNeeds, TargetsError, TargetsMade};
use crate::view::ViewSources;

/// What prepare decided for the frame: the plan, the batches as this frame draws them, and what
/// the encode step and the frame's stats need besides.
pub(super) struct PreparedFrame {
    pub plan: FramePlan,
    /// The opaque batches, then one batch per blended draw (back to front), with the keys of
    /// this frame's targets (direct output, no depth).
    pub batches: Vec<Batch>,
    /// Opaque draw slots, and those with the blended ones.
    pub opaque_len: usize,
    pub total: usize,
    /// The frame draws straight into the output (no HDR target).
    pub direct: bool,
    /// Opaque draws go to the visibility buffer.
    pub visibility: bool,
    /// Local lights are shaded by the deferred-lights compute pass.
    pub deferred: bool,
    /// The environment is drawn behind the scene.
    pub background: bool,
    /// Transmissive surfaces are drawn: the opaque colour is copied before them.
    pub transmission: bool,
    pub variant: FrameVariant,
    /// The environment's solid background colour, if it has one (else the settings' clear colour).
    pub solid_background: Option<[f32; 3]>,
    pub camera_exposure: f32,
    /// The culling shaders did not compile: the frame draws without culling.
    pub cull_error: Option<ShaderError>,
    pub instance_upload_ms: f64,
    /// A hybrid frame's overlay rectangle (`features::visibility::overlay`).
    pub overlay: Option<OverlayRect>,
}

impl Renderer {
    /// Prepares everything the frame draws and makes its plan.
    pub(super) fn prepare_frame(
        &mut self,
        scene: &RenderScene,
        encoder: &mut wgpu::CommandEncoder,
        output: &wgpu::TextureView,
        output_format: wgpu::TextureFormat,
        size: (u32, u32),
    ) -> Result<PreparedFrame, TargetsError> {
        let device = self.ctx.device.clone();
        let queue = self.ctx.queue.clone();

        let mut laps = super::laps::Laps::start();
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
        laps.lap("lights and environment");
        self.draws.set_variant(FrameVariant { ibl: env_frame.active, ..*self.draws.variant() });
        self.draws.apply_changes(&mut draw_cx!(self), scene, in_step);
        laps.lap("draw changes");
        self.draws.prepare_materials(&mut draw_cx!(self), scene, encoder);
        laps.lap("materials and textures");
        let meshes_changed = self.draws.prepare_meshes(&mut draw_cx!(self), scene);
        laps.lap("meshes");
        let deform_frame = {
            let draws = &self.draws;
            let draw_mesh = |e: Entity| draws.draw_mesh(e);
            let visit = match (in_step, meshes_changed || scene.meshes_changed) {
                (false, _) => Visit::Resync,
                (true, true) => Visit::Scan,
                (true, false) => Visit::Changes,
            };
            self.deformer.prepare(&device, &queue, &mut self.mesh_pool, scene, draw_mesh, visit)
        };
        if deform_frame.outputs_changed {
            self.draws.invalidate();
        }
        if deform_frame.jobs > 0 {
            // A pose changed: shadow maps of what it casts into, and the scene's bounds, follow.
            self.draws.casters_changed();
        }
        if self.materials.is_dirty() {
            // A masked caster's cutoff may have changed.
            self.draws.casters_changed();
        }
        // Batches first, so that caster changes count in this frame's shadow decisions; again if
        // shadows switched on or off (new pipeline keys, the same casters).
        self.draws.rebuild_if_dirty(&draw_cx!(self));
        laps.lap("deformation and batches");
        rebind |= self.prepare_shadows(scene, size);
        self.draws.rebuild_if_dirty(&draw_cx!(self));
        laps.lap("shadows");
        let blend_batches = self.draws.sort_blended(&draw_cx!(self), scene);
        let transmission = blend_batches.iter().any(|(b, _)| b.key.features.has(MaterialFeatures::TRANSMISSION));
        // Every lit surface reads its specular albedo from the split-sum table (brdf.wgsl).
        let opaque = self.draws.opaque_batches();
        let lit_draws = || opaque.iter().chain(blend_batches.iter().map(|(b, _)| b)).any(|b| !b.key.unlit);
        laps.lap("blended order");
        rebind |= self.environment.require_table(&device, lit_draws);
        laps.lap("split-sum table");

        // Uploads: draw slots (opaque part only when rebuilt, blended part every frame).
        let opaque_len = self.draws.opaque_slots().len();
        let total = opaque_len + blend_batches.len();
        rebind |= self.draws.upload_slots(&device, &queue, &blend_batches);
        // One instance is not culled: that could only save a frame showing nothing, and the
        // dispatch and its barrier are not free (`cargo bench --bench triangle` measures them).
        // The visibility buffer rasterises the cull pass's visible lists, one instance or many.
        let culling = self.settings.gpu_culling
            && self.ctx.caps.indirect_first_instance
            && (opaque_len > 1 || (opaque_len == 1 && self.raster_in_compute()))
            && scene.view.is_some();
        // The visibility buffer, if asked for and this frame's draws allow it (see `Raster`);
        // the cull pass's readiness, known only below, can still send the frame to the forward
        // pass.
        let mut raster_gate = crate::features::visibility::RasterGate {
            setting: self.settings.raster,
            atomics: self.ctx.caps.visibility_raster,
            few_graphics_units: self.ctx.caps.few_graphics_units,
            culling,
            fits: crate::features::visibility::fits(&device.limits(), size, self.settings.msaa),
            occlusion_on: self.settings.occlusion_culling == OcclusionCulling::On,
            opaque: self.draws.opaque_batches().iter().any(crate::features::visibility::batch_supported),
        };
        let visibility_wanted = raster_gate.decide().is_ok();
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
        laps.lap("slots");
        let mut cull_error = None;
        let culling = culling && {
            let ready = GpuCulling::compile(&device, &mut self.pipelines, occlusion, triangles, self.settings.msaa);
            cull_error = ready.err();
            cull_error.is_none()
        };
        occlusion &= culling;
        if culling {
            let batches = self.draws.opaque_batches();
            let cull_dirty = self.cull_batches_seen != Some(self.draws.batch_generation());
            if !cull_dirty {
                // Deformed copies' bounds follow their pose (after a rebuild they are read fresh).
                for id in &deform_frame.moved {
                    if let Some(i) = self.draws.deformed_batch(*id) {
                        self.culling.update_batch_bounds(&queue, i, &batches[i], &self.mesh_pool);
                    }
                }
            }
            if cull_dirty || self.cull_triangles_marked != triangles {
                // The late draws' region follows every blended entry there can be.
                let late_base = (opaque_len + self.draws.blend_count()) as u32;
                let max_slot = triangles.then(|| self.draws.opaque_slots().iter().copied().max().unwrap_or(0));
                self.culling.prepare_batches(&device, &queue, batches, &self.mesh_pool, late_base, max_slot);
                self.cull_batches_seen = Some(self.draws.batch_generation());
                self.cull_triangles_marked = triangles;
            }
            let target = RasterTarget { size, samples: self.settings.msaa, subpixel_bits: self.ctx.caps.subpixel_bits };
            rebind |= self.culling.prepare_frame(&device, &queue, total, occlusion.then_some(size), target, self.frame);
        }
        laps.lap("culling");
        // The view bind group binds the culled list or the full one.
        rebind |= culling != self.culling_active;
        self.culling_active = culling;
        let upload_start = Instant::now();
        rebind |= self.instances.upload(&device, &queue);
        let instance_upload_ms = upload_start.elapsed().as_secs_f64() * 1e3;
        rebind |= self.materials.upload(&device, &queue);
        let light_counts = (self.lights.global_count(), self.lights.local_count());
        let clip_from_rel = self.view.write(&queue, scene.view.as_ref(), size, light_counts);
        if let (true, Some(clip_from_rel)) = (self.draws.variant().deferred_lights, clip_from_rel) {
            self.deferred.write_params(&queue, clip_from_rel, size);
        }
        let sources = ViewSources {
            instances: self.instances.buffer(),
            draw_slots: if self.culling_active { self.culling.visible_slots() } else { self.draws.slots().buffer() },
            materials: self.materials.buffer(),
            lights: &self.lights,
            clusters: &self.clusters,
            shadows: &self.shadows,
            environment: &self.environment,
            mesh_pool: &self.mesh_pool,
        };
        self.view.bind(&device, rebind, &sources);
        laps.lap("uploads and bindings");

        // Without a camera there is nothing to draw lines for.
        let gizmo_vertices = match scene.view {
            Some(v) => self.gizmos.prepare(&device, &queue, &scene.gizmos, v.world_from_view.translation.into()),
            None => 0,
        };
        let background = env_frame.active && env_frame.solid_background.is_none() && scene.view.is_some();
        raster_gate.culling = self.culling_active;
        let raster_why = raster_gate.decide();
        // The cull pass's readiness, known only now, can still say no.
        let visibility = raster_why.is_ok();
        // A hybrid frame: the forward pass draws line and point meshes, blended draws and gizmo
        // lines over the visibility buffer (features/visibility/overlay.rs).
        let unrasterised = !self.draws.opaque_batches().iter().all(crate::features::visibility::batch_supported);
        let overlay = visibility && (unrasterised || !blend_batches.is_empty() || gizmo_vertices > 0);
        // What its draws can cover: line and point meshes (instanced, culled on the GPU) count as
        // the whole frame.
        let overlay_rect = overlay.then(|| match (clip_from_rel, scene.view.as_ref()) {
            (Some(clip_from_rel), Some(v)) if !unrasterised => OverlayRect::covering(
                &self.draws.blended_bounds(&draw_cx!(self), scene),
                scene.gizmos.iter().flat_map(|l| [l.start, l.end]),
                clip_from_rel,
                v.world_from_view.translation.into(),
                size,
            ),
            _ => OverlayRect::full(size),
        });
        // The visibility buffer's shading walks the cluster lists itself, in compute.
        let deferred = self.draws.variant().deferred_lights && !visibility;
        let needs = TargetNeeds {
            msaa: self.settings.msaa,
            display_resolve: self.settings.msaa_resolve == MsaaResolve::Display && output_format.is_srgb(),
            keep_hdr: self.settings.keep_hdr,
            deferred_lights: deferred,
            blended_draws: !blend_batches.is_empty(),
            background,
            gizmos: gizmo_vertices > 0,
            post_processing: self.post.wants_hdr(&self.settings),
            occlusion_culling: occlusion,
            opaque: match self.draws.opaque_batches() {
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
            // The old targets go first: their memory may be what the new ones need.
            self.targets = None;
            let made = FrameTargets::try_new(
                &device,
                size,
                target_samples,
                deferred,
                TargetsMade {
                    hdr: !direct,
                    depth: !depth_free,
                    depth_sampled: occlusion,
                    output_format,
                    shader_resolve: self.ctx.caps.shader_msaa_resolve,
                    hdr_storage,
                },
            );
            // The shadow maps this frame planned are not drawn when it stops here: what they
            // were to hold is not held.
            self.targets = Some(made.inspect_err(|_| self.shadows.invalidate())?);
        }
        laps.lap("targets");
        self.deferred.prepare(&device, &self.pipelines, self.targets.as_ref().expect("made above"));
        let transmission_error =
            self.transmission.prepare(&device, &mut self.pipelines, size, transmission, visibility).err();

        let mut batches = self.draws.opaque_batches().to_vec();
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
        if overlay {
            // The overlay's draws: HDR colour and depth of their own, tested against the
            // visibility buffer.
            let opaque_batches = self.draws.opaque_batches().len();
            for (i, b) in batches.iter_mut().enumerate() {
                if i >= opaque_batches || !crate::features::visibility::batch_supported(b) {
                    b.key = crate::features::visibility::overlay_key(b.key);
                }
            }
        }
        let camera_exposure = scene.view.map_or(1.0, |v| v.exposure);
        let targets = self.targets.as_ref().expect("made above");
        let post_cx = PostPrepare {
            device: &device,
            queue: &queue,
            pipelines: &self.pipelines,
            hdr: targets.hdr_view(),
            size: targets.size,
            delta_seconds: scene.delta_seconds,
        };
        self.post.prepare(&post_cx, &self.settings, camera_exposure);
        let variant = *self.draws.variant();
        let binned = if variant.local_lights == LocalLights::Clustered { self.lights.local_count() } else { 0 };
        let shadow_layers = self.shadows.frame().rendered_layers();
        let mut plan = FramePlan::new(SceneNeeds {
            binned_lights: binned,
            shadow_layers,
            has_opaque: !self.draws.opaque_batches().is_empty(),
            opaque_instances: opaque_len,
            has_blend: !blend_batches.is_empty(),
            deferred,
            culled: self.culling_active,
            visibility,
            raster_why: match raster_why {
                Ok(why) | Err(why) => why,
            },
            occlusion,
            environment_changed: env_frame.prefilter,
            split_sum_table: self.environment.table_pending(),
            deform_jobs: deform_frame.jobs,
            background,
            gizmo_vertices,
            depth: !depth_free,
            transmission,
            overlay,
        });
        plan.add_post(self.post.decisions());
        laps.log(format_args!("frame {} prepared", self.frame));
        Ok(PreparedFrame {
            plan,
            batches,
            opaque_len,
            total,
            direct,
            visibility,
            deferred,
            background,
            transmission,
            variant,
            solid_background: env_frame.solid_background,
            camera_exposure,
            cull_error: cull_error.or(transmission_error),
            instance_upload_ms,
            overlay: overlay_rect,
        })
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
                per_cluster > if self.draws.variant().deferred_lights { AUTO_COMPUTE_LEAVE } else { AUTO_COMPUTE_ENTER }
            }
            _ => false,
        };
        // The heat view colours fragments by their cluster, which only the forward shader does.
        let deferred = walk == LocalLights::Clustered
            && wants_compute
            && self.ctx.caps.deferred_lights
            && self.settings.debug_view == DebugView::None;
        let in_storage = !self.lights.global_lights_fit_uniform();
        self.draws.set_variant(FrameVariant {
            local_lights: walk,
            light_shapes: shapes,
            deferred_lights: deferred,
            global_lights_in_storage: in_storage,
            ..*self.draws.variant()
        });
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
            self.draws.scene_bounds(&draw_cx!(self), scene)
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
            self.draws.caster_generation(),
            self.draws.take_caster_changes(),
            // The cascades' casters are rasterised in compute where the view will be.
            self.raster_in_compute() && self.settings.gpu_culling && self.ctx.caps.indirect_first_instance,
        );
        // Local lights carry their first shadow layer; the store uploads what that changed.
        if self.lights.set_shadow_layers(self.shadows.frame().local.first_layers.clone()) {
            let earlier = self.lights.last_upload_bytes;
            rebind |= self.lights.upload(&self.ctx.device, &self.ctx.queue);
            self.lights.last_upload_bytes += earlier;
        }
        let (active, local) = (self.shadows.active(), self.shadows.local_active());
        self.draws.set_variant(FrameVariant { shadows: active, local_shadows: local, ..*self.draws.variant() });
        rebind
    }
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
