//! The renderer's encode step: the frame plan's passes, in order, into one command encoder.
//! Each feature records its own passes; a pass whose pipeline does not compile is left out and
//! its error kept as the frame's shader error (the last good shaders keep drawing the rest).

use super::Renderer;
use super::prepare::PreparedFrame;
use crate::features::culling::CullInputs;
use crate::features::deferred_lights::DeferredKey;
use crate::features::forward::{self, DrawCounts, ForwardInputs, IndirectDraws, OpaquePhase, Rest};
use crate::features::post::Target;
use crate::features::tonemap;
use crate::features::visibility::ShadeOutput;
use crate::frame::Pass;
use crate::frame_context::FrameContext;
use crate::targets::MsaaResolve;

impl Renderer {
    /// Encodes the passes `frame.plan` runs; returns what the draws submitted.
    pub(super) fn encode_frame(
        &mut self,
        frame: &PreparedFrame,
        encoder: &mut wgpu::CommandEncoder,
        output: &wgpu::TextureView,
        output_format: wgpu::TextureFormat,
        size: (u32, u32),
    ) -> DrawCounts {
        let PreparedFrame {
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
            solid_background,
            camera_exposure,
            overlay: overlay_rect,
            ..
        } = frame;
        let (opaque_len, total, direct, visibility, deferred, background, transmission) =
            (*opaque_len, *total, *direct, *visibility, *deferred, *background, *transmission);
        let device = self.ctx.device.clone();
        let queue = self.ctx.queue.clone();
        let targets = self.targets.as_ref().expect("made by prepare");
        let mut cx = FrameContext {
            device: &device,
            queue: &queue,
            encoder,
            pipelines: &mut self.pipelines,
            timer: self.timer.as_mut(),
            targets,
        };
        let mut deform_error = None;
        if plan.runs(Pass::DEFORM) {
            deform_error = self.deformer.encode(&mut cx, &self.mesh_pool).err();
        }
        let mut env_error = None;
        if plan.runs(Pass::ENVIRONMENT_PREFILTER) {
            env_error = self.environment.encode(&mut cx).err();
        }
        let mut cluster_error = None;
        if plan.runs(Pass::CLUSTER_BIN) {
            cluster_error = self.clusters.encode(&mut cx).err();
        }
        let cull_inputs = CullInputs {
            view: self.view.uniform(),
            instances: self.instances.buffer(),
            draw_slots: self.draws.slots().buffer(),
            blended: opaque_len as u32..total as u32,
            pool_indices: self.mesh_pool.index_buffer(),
            pool_vertices: self.mesh_pool.vertex_buffer(),
        };
        if plan.runs(Pass::CULL) {
            self.culling.encode(&mut cx, &cull_inputs);
        }
        let computed = plan.runs(Pass::VISIBILITY_RASTER);
        if computed && self.visibility_batches_seen != Some(self.draws.batch_generation()) {
            // Before the shadows: their cascades' casters are rasterised from the same table.
            self.visibility.prepare_batches(&device, &queue, self.draws.opaque_batches(), &self.mesh_pool);
            self.visibility_batches_seen = Some(self.draws.batch_generation());
        }
        let mut shadow_error = None;
        if plan.runs(Pass::SHADOWS) {
            shadow_error = self.shadows.encode(
                &mut cx,
                &self.settings.shadows,
                &self.mesh_pool,
                &self.materials,
                [self.instances.buffer(), self.draws.slots().buffer(), self.materials.buffer()],
                self.draws.opaque_batches(),
                self.culling_active.then(|| self.culling.batch_buffers()),
                computed.then(|| self.visibility.raster_table()),
            );
        }
        // Handles (reference-counted), so the culling owner stays free to encode between passes.
        let (early_args, late_args) = (self.culling.args().clone(), self.culling.late_args().clone());
        let triangle_draws = self.culling.triangle_draws();
        // A solid background is the clear colour, exposed like the scene (f16-clamped).
        let mut clear = match solid_background {
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
        let view_bind_group = self.view.bind_group();
        // The background is composited over the resolved frame (one sample a pixel, after the
        // surfaces left their coverage in alpha), except with deferred local lights, whose
        // colour alpha carries roughness, and with transmissive draws, which must see it in the
        // copy: then the forward pass draws it where depth is clear.
        let composite_background = plan.runs(Pass::BACKGROUND) && !deferred && !transmission;
        let inputs = ForwardInputs {
            targets,
            output,
            view_bind_group,
            mesh_pool: &self.mesh_pool,
            materials: &self.materials,
            clear_color: if composite_background { wgpu::Color::TRANSPARENT } else { wgpu::Color { r, g, b, a: 1.0 } },
            indirect: self.culling_active.then_some(IndirectDraws {
                args: &early_args,
                batches: self.draws.opaque_batches().len(),
                triangles: triangle_draws.as_ref(),
            }),
            background: plan.runs(Pass::BACKGROUND) && !composite_background,
            gizmos: if plan.runs(Pass::GIZMOS) { self.gizmos.draw() } else { None },
            transmission: if transmission { self.transmission.bind_group() } else { None },
        };
        let opaque_count = self.draws.opaque_batches().len();
        let (mut counts, mut forward_error) = if plan.runs(Pass::OCCLUSION_LATE) {
            let (early, early_error) = forward::encode(&mut cx, &inputs, batches, opaque_count, OpaquePhase::Early);
            let depth = (targets.depth_view.as_ref().expect("occlusion culling keeps depth"), targets.samples);
            self.culling.encode_late(&mut cx, &cull_inputs, depth);
            let late_inputs = ForwardInputs {
                indirect: Some(IndirectDraws {
                    args: &late_args,
                    batches: opaque_count,
                    triangles: triangle_draws.as_ref(),
                }),
                ..inputs
            };
            let (late, error) = forward::encode(&mut cx, &late_inputs, batches, opaque_count, OpaquePhase::Late);
            // Both passes submit the opaque batches; count them once.
            let counts = DrawCounts { draw_calls: early.draw_calls + late.draw_calls, ..late };
            (counts, early_error.or(error))
        } else if computed {
            let tonemapper = self.settings.tonemapper;
            // Display colours are averaged only into an sRGB output, as the forward pass does.
            // A hybrid frame's overlay is composited over resolved radiance, as the forward pass
            // resolves radiance when it draws blended surfaces.
            let overlay = overlay_rect.is_some();
            let shade_output = match (direct, self.settings.msaa_resolve) {
                (false, _) => ShadeOutput::Hdr,
                (true, MsaaResolve::Display) if self.settings.msaa > 1 && output_format.is_srgb() && !overlay => {
                    ShadeOutput::DisplayPerSample(tonemapper)
                }
                (true, _) => ShadeOutput::DisplayResolved(tonemapper),
            };
            let vis_inputs = crate::features::visibility::FrameInputs {
                view: self.view.uniform(),
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
                overlay: *overlay_rect,
                transmission: if transmission { self.transmission.views() } else { None },
            };
            let error = self.visibility.prepare_frame(&device, &queue, cx.pipelines, &vis_inputs).err();
            self.visibility.encode_raster(&mut cx, &vis_inputs);
            let copied = vis_inputs.transmission.is_some();
            if copied {
                // Transmissive draws see the opaque colour: shaded into the copy's level 0 first.
                self.visibility.encode_first_shade(&mut cx, &vis_inputs);
                self.transmission.encode_downsample(&mut cx);
            }
            let mut drawn = (DrawCounts::default(), error);
            if let Some(o) = self.visibility.overlay().filter(|_| overlay) {
                // The forward pass draws the line and point meshes, the blended draws and the
                // gizmo lines over the visibility buffer; the shading pass composites them.
                let unrasterised: Vec<usize> =
                    (0..opaque_count).filter(|&i| !crate::features::visibility::batch_supported(&batches[i])).collect();
                let target = forward::Overlay {
                    colour: &o.colour,
                    depth: &o.depth,
                    occlusion: &o.occlusion.as_ref().expect("made by prepare_frame").1,
                    samples: o.samples,
                };
                let inputs = ForwardInputs { transmission: o.transmissive.as_ref().map(|(_, _, g)| g), ..inputs };
                let (counts, overlay_error) =
                    forward::encode_overlay(&mut cx, &inputs, batches, opaque_count, &unrasterised, target);
                drawn = (counts, drawn.1.or(overlay_error));
            }
            self.visibility.encode_shade(&mut cx, &vis_inputs);
            drawn
        } else if plan.runs(Pass::OPAQUE) {
            forward::encode(&mut cx, &inputs, batches, opaque_count, OpaquePhase::All)
        } else {
            (DrawCounts::default(), None)
        };
        if plan.runs(Pass::DEFERRED_LIGHTS) {
            let key = DeferredKey {
                multisampled: targets.samples > 1,
                light_shapes: variant.light_shapes,
                local_shadows: variant.local_shadows,
            };
            // Without its pipeline the pass does not run, and the composite must not add what an
            // earlier frame left in its output.
            let mut computed = true;
            if let Err(e) = self.deferred.encode(&mut cx, view_bind_group, key) {
                forward_error = Some(e);
                computed = false;
            }
            let rest = Rest { deferred: Some((&self.deferred, computed)), draws: !transmission };
            let (after, error) = forward::encode_rest(&mut cx, &inputs, batches, opaque_count, rest);
            counts += after;
            forward_error = forward_error.or(error);
        }
        if transmission && !visibility {
            // The opaque pass (or the deferred composite) resolved the colour and kept its
            // targets: copy it, then draw the transmissive and blended surfaces over it.
            if let Some(hdr) = targets.hdr_view() {
                self.transmission.encode_copy(&mut cx, hdr);
            }
            let rest = Rest { deferred: None, draws: true };
            let (after, error) = forward::encode_rest(&mut cx, &inputs, batches, opaque_count, rest);
            counts += after;
            forward_error = forward_error.or(error);
        }
        if composite_background && let Err(e) = forward::encode_background(&mut cx, view_bind_group) {
            forward_error = forward_error.or(Some(e));
        }
        let post_error = self.post.encode(&mut cx, Target { view: output.clone(), format: output_format });
        if let Some(e) = post_error
            .or(deform_error)
            .or(env_error)
            .or(cluster_error)
            .or(frame.cull_error.clone())
            .or(shadow_error)
            .or(forward_error)
            && self.shader_error.as_ref() != Some(&e)
        {
            tracing::error!("{e}");
            self.shader_error = Some(e);
        }
        counts
    }
}
