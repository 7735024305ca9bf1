//! The frame plan: which passes run this frame, in what order, and why. A pass the scene does
//! not need is not encoded at all (no empty passes): cluster binning runs only with local lights
//! to bin, the transparent phase only with blended draws, shadow maps only for layers a shadowed
//! light's casters reach within sight (the shadow orchestrator decides which), environment
//! prefiltering only when the environment changed, the background only with an environment.
//!
//! The plan's own passes (deform to gizmos) are constants here and their conditions are in
//! [`FramePlan::new`]; the post-processing chain ([`post_chain`]) follows them, each stage
//! deciding for itself and the plan listing its decision ([`FramePlan::add_post`]).

use std::fmt;

use crate::features::bloom::Bloom;
use crate::features::exposure::Exposure;
use crate::features::fxaa::Fxaa;
use crate::features::post::{Decision, PostChain};
use crate::features::tonemap::Tonemap;
use crate::pipelines::PipelineCache;
use crate::settings::RenderSettings;

pub use crate::pass::Pass;

/// The post-processing chain, in the order its stages run, each bound to its settings. A new
/// post-process is its folder and one line here.
pub fn post_chain(device: &wgpu::Device, pipelines: &mut PipelineCache) -> PostChain<RenderSettings> {
    PostChain::<RenderSettings>::new(device)
        .with(Bloom::new(device, pipelines), |s| &s.post.bloom)
        .with(Exposure::new(device, pipelines), |s| &s.post.auto_exposure)
        .with(Tonemap::new(device, pipelines), |s| &s.tonemapper)
        .with(Fxaa::new(device, pipelines), |s| &s.post.fxaa)
}

impl Pass {
    /// Compute: make the environment's maps (source cube, specular levels, irradiance
    /// harmonics; the split-sum table once).
    pub const ENVIRONMENT_PREFILTER: Pass = Pass::new(
        "EnvironmentPrefilter",
        "environment source (sky, studio or image) -> source cube, GGX levels, SH [; the split-sum \
         table, once]",
    );
    /// Compute: skin and morph the draws whose pose changed into their vertex copies.
    pub const DEFORM: Pass =
        Pass::new("Deform", "mesh pool vertices, joint matrices, morph weights -> deformed vertex copies");
    /// Compute: cull opaque and masked draws against the view frustum into indirect draws.
    pub const CULL: Pass = Pass::new(
        "Cull",
        "view, instance buffer, draw slots [, mesh pool indices and vertices] -> indirect draw arguments [, triangle lists of small meshes]",
    );
    /// Compute: bin local lights into the froxel grid (count, prefix sum, fill, sort).
    pub const CLUSTER_BIN: Pass =
        Pass::new("ClusterBin", "view, light store (local lights) -> cluster counts, offsets, index lists");
    /// Depth-only passes of shadow casters into the shadow atlas, one per rendered layer.
    pub const SHADOWS: Pass =
        Pass::new("Shadows", "casters' vertices and instances, cascade matrices -> shadow atlas layers");
    /// Opaque and alpha-masked draws, front to back by batch.
    pub const OPAQUE: Pass = Pass::new(
        "Opaque",
        "view, mesh pool, instances, materials, textures, light store [, cluster lists] [, shadow \
         atlas] [, environment maps] -> HDR colour (or the output, tonemapped) [, depth]",
    );
    /// Compute: opaque draws rasterised into the visibility buffer (each sample's nearest
    /// triangle), in place of `OPAQUE` (`Raster::Compute`).
    pub const VISIBILITY_RASTER: Pass = Pass::new(
        "VisibilityRaster",
        "view, visible instances and their counts, mesh pool indices and vertices -> visibility buffer \
         (depth and triangle number per sample)",
    );
    /// Compute: each pixel's triangles in the visibility buffer shaded and resolved into the
    /// HDR colour (with transmissive draws twice: into the transmission copy's level 0, then,
    /// after the overlay, into the output).
    pub const VISIBILITY_SHADE: Pass = Pass::new(
        "VisibilityShade",
        "visibility buffer, mesh pool, instances, materials, textures, light store [, cluster lists] \
         [, shadow atlas] [, environment maps] -> HDR colour (resolved), or the displayed colour \
         copied into the output, or (transmissive draws) the transmission copy's level 0",
    );
    /// A hybrid frame's overlay: the forward pass draws line and point meshes, blended and
    /// transmissive draws and gizmo lines over the visibility buffer, each sample tested against
    /// its depth; the shading pass composites the result (with transmissive draws, which read
    /// what a first shading wrote, the plan lists `VISIBILITY_SHADE` before and after it).
    pub const VISIBILITY_OVERLAY: Pass = Pass::new(
        "VisibilityOverlay",
        "visibility buffer (depth), the forward pass's inputs -> overlay colour (premultiplied, \
         multisampled)",
    );
    /// The environment (or its blur) where no surface was drawn, in the opaque pass after the
    /// opaque draws (depth test: only where the depth is still the far plane).
    pub const BACKGROUND: Pass =
        Pass::new("Background", "environment cube (or its blurred level), HDR alpha -> HDR colour");
    /// Occlusion culling's second half, after `OPAQUE` drew what was visible last frame: the
    /// depth pyramid, the late cull, and a second pass drawing what became visible.
    pub const OCCLUSION_LATE: Pass =
        Pass::new("OcclusionLate", "depth -> depth pyramid -> late cull -> second opaque draws");
    /// Compute: local lights for opaque surfaces (`LightWalk::ClusteredCompute`, or `Auto` with
    /// long cluster lists), then a render pass that adds them to the frame and holds the
    /// `TRANSPARENT` phase.
    pub const DEFERRED_LIGHTS: Pass =
        Pass::new("DeferredLights", "surface buffer, depth, cluster lists, light store -> HDR colour");
    /// Alpha-blended draws, back to front, in the same render pass as `OPAQUE` (or, with
    /// deferred lights, as their composite; in a hybrid frame, as `VISIBILITY_OVERLAY`).
    pub const TRANSPARENT: Pass =
        Pass::new("Transparent", "view, blended draws sorted back to front, lights -> HDR colour");
    /// Gizmo lines (axes, selection boxes, debug lines), last in the render pass that ends the
    /// frame's drawing (or the hybrid frame's overlay), depth-tested against the scene.
    pub const GIZMOS: Pass = Pass::new("Gizmos", "gizmo line vertices, depth -> HDR colour");

    pub const TRANSMISSION: Pass = Pass::new(
        "Transmission",
        "HDR colour after the opaque draws and the background (or level 0 as the visibility buffer's \
         shading wrote it) -> its copy with a mip chain, which transmissive draws read",
    );
}

/// The plan's own passes in the order they usually run (with transmissive draws over the
/// visibility buffer, `VISIBILITY_SHADE` and `TRANSMISSION` come before `VISIBILITY_OVERLAY`);
/// the post-processing chain's follow. The order of `left_out`.
const CORE: [Pass; 15] = [
    Pass::ENVIRONMENT_PREFILTER,
    Pass::DEFORM,
    Pass::CULL,
    Pass::CLUSTER_BIN,
    Pass::SHADOWS,
    Pass::OPAQUE,
    Pass::VISIBILITY_RASTER,
    Pass::VISIBILITY_OVERLAY,
    Pass::VISIBILITY_SHADE,
    Pass::BACKGROUND,
    Pass::OCCLUSION_LATE,
    Pass::DEFERRED_LIGHTS,
    Pass::TRANSMISSION,
    Pass::TRANSPARENT,
    Pass::GIZMOS,
];

#[derive(Debug, Clone, Default)]
pub struct FramePlan {
    pub passes: Vec<(Pass, &'static str)>,
    /// The post-processing stages left out this frame, and why.
    post_left_out: Vec<(Pass, &'static str)>,
    /// What the plan was made from.
    pub needs: SceneNeeds,
}

/// What this frame's scene holds and asks for, as far as the plan is concerned.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SceneNeeds {
    /// Local lights the forward pass will find through clusters.
    pub binned_lights: u32,
    /// Shadow-map layers the orchestrator will render.
    pub shadow_layers: usize,
    pub has_opaque: bool,
    pub has_blend: bool,
    /// A compute pass shades local lights for opaque surfaces.
    pub deferred: bool,
    /// Opaque and masked instances.
    pub opaque_instances: usize,
    /// GPU culling runs (on, supported, and more than one opaque instance to cull).
    pub culled: bool,
    /// So does occlusion culling.
    pub occlusion: bool,
    /// Opaque draws are rasterised and shaded in compute (`features::visibility`).
    pub visibility: bool,
    /// Why they are, or are not (`RasterGate::decide`).
    pub raster_why: &'static str,
    /// The environment's maps must be (re)made this frame.
    pub environment_changed: bool,
    /// The split-sum table lit surfaces read must be made this frame (once per renderer).
    pub split_sum_table: bool,
    /// Deformed draws whose pose changed this frame.
    pub deform_jobs: usize,
    /// The scene has an environment to show behind it (not a solid colour: that is the clear).
    pub background: bool,
    /// Vertices of the gizmo lines to draw.
    pub gizmo_vertices: u32,
    /// The frame has a depth target (not when nothing drawn can cover a pixel twice).
    pub depth: bool,
    /// Transmissive draws exist (drawn with the blended ones, after the transmission copy).
    pub transmission: bool,
    /// The forward pass draws over the visibility buffer (line and point meshes, blended draws,
    /// gizmo lines).
    pub overlay: bool,
}

impl FramePlan {
    pub fn new(needs: SceneNeeds) -> Self {
        let SceneNeeds {
            binned_lights,
            shadow_layers,
            has_opaque,
            has_blend,
            deferred,
            opaque_instances: _,
            culled,
            occlusion,
            visibility,
            raster_why,
            environment_changed,
            split_sum_table,
            deform_jobs,
            background,
            gizmo_vertices,
            depth,
            transmission,
            overlay,
        } = needs;
        let mut passes = Vec::new();
        if environment_changed {
            passes.push((Pass::ENVIRONMENT_PREFILTER, "the environment changed (or is new): its maps are made"));
        } else if split_sum_table {
            passes.push((
                Pass::ENVIRONMENT_PREFILTER,
                "lit draws read their specular albedo from the split-sum table, made once (no environment: \
                 nothing else runs)",
            ));
        }
        if deform_jobs > 0 {
            passes.push((Pass::DEFORM, "skinned or morphed draws changed pose: their vertices are recomputed"));
        }
        if culled && has_opaque {
            passes.push((Pass::CULL, "opaque draws to cull (GPU culling on and supported)"));
        }
        if binned_lights > 0 && (has_opaque || has_blend) {
            passes.push((Pass::CLUSTER_BIN, "local lights to bin and draws to light"));
        }
        if shadow_layers > 0 {
            let why = if visibility {
                "a shadowed light's casters reach what the camera sees (cascade layers up to 8192 texels a side \
                 rasterised in compute, as the view is; local lights' maps by the hardware)"
            } else {
                "a shadowed light's casters reach what the camera sees"
            };
            passes.push((Pass::SHADOWS, why));
        }
        if visibility && overlay && transmission {
            // Transmissive draws see the opaque colour: it is shaded first, into the copy.
            passes.push((Pass::VISIBILITY_RASTER, raster_why));
            passes.push((
                Pass::VISIBILITY_SHADE,
                "the visibility buffer's samples to shade, into the transmission copy's level 0",
            ));
            passes.push((Pass::TRANSMISSION, "transmissive draws see the scene behind them: the copy's mip chain"));
            passes.push((
                Pass::VISIBILITY_OVERLAY,
                "transmissive draws (and any line or point meshes, blended draws or gizmo lines): the forward \
                 pass draws them over the visibility buffer, each sample tested against its depth",
            ));
            passes.push((
                Pass::VISIBILITY_SHADE,
                "again, compositing the overlay: pixels whose samples hold one triangle take the first \
                 shading's colour, the others are shaded again",
            ));
        } else if visibility {
            passes.push((Pass::VISIBILITY_RASTER, raster_why));
            if overlay {
                passes.push((
                    Pass::VISIBILITY_OVERLAY,
                    "line or point meshes, blended draws or gizmo lines: the forward pass draws them over \
                     the visibility buffer, each sample tested against its depth",
                ));
            }
            passes.push((Pass::VISIBILITY_SHADE, "the visibility buffer's samples to shade"));
        } else {
            passes.push((
                Pass::OPAQUE,
                match (has_opaque, depth) {
                    (true, true) => "opaque or masked draws exist",
                    (true, false) => {
                        "opaque or masked draws exist (one instance whose front faces cannot overlap: no \
                     depth target)"
                    }
                    (false, _) => "clears the targets (no opaque draws)",
                },
            ));
        }
        if background && !visibility {
            passes.push((Pass::BACKGROUND, "the scene has an environment, shown where no surface is"));
        }
        if culled && occlusion && has_opaque {
            passes.push((Pass::OCCLUSION_LATE, "occlusion culling (many opaque instances, or asked for)"));
        }
        if deferred {
            passes.push((
                Pass::DEFERRED_LIGHTS,
                "local lights shaded in compute (long cluster lists, or --light-walk compute)",
            ));
        }
        if transmission && !visibility {
            passes.push((
                Pass::TRANSMISSION,
                "transmissive draws see the scene behind them: the opaque colour is copied before they draw",
            ));
        }
        if has_blend {
            passes.push((
                Pass::TRANSPARENT,
                if transmission { "transmissive or blended draws exist, back to front" } else { "blended draws exist" },
            ));
        }
        if gizmo_vertices > 0 {
            passes.push((Pass::GIZMOS, "the scene has gizmo lines to draw"));
        }
        Self { passes, post_left_out: Vec::new(), needs }
    }

    /// Appends the post-processing chain's decisions, in the chain's order.
    pub fn add_post(&mut self, decisions: impl IntoIterator<Item = (Pass, Decision)>) {
        for (pass, decision) in decisions {
            match decision {
                Decision::Runs(why) => self.passes.push((pass, why)),
                Decision::LeftOut(why) => self.post_left_out.push((pass, why)),
            }
        }
    }

    pub fn runs(&self, pass: Pass) -> bool {
        self.passes.iter().any(|(p, _)| *p == pass)
    }

    /// The passes this frame leaves out, each with the reason (what the scene lacks).
    pub fn left_out(&self) -> Vec<(Pass, &'static str)> {
        let n = &self.needs;
        CORE.into_iter()
            .filter(|p| !self.runs(*p))
            .map(|p| {
                let why = match p {
                    Pass::ENVIRONMENT_PREFILTER if n.background => "the environment's maps are unchanged",
                    Pass::ENVIRONMENT_PREFILTER => "no environment changed (or none exists)",
                    Pass::DEFORM => "no skinned or morphed draw changed pose",
                    Pass::CULL if !n.has_opaque => "no opaque draws",
                    Pass::CULL if n.opaque_instances == 1 => {
                        "one opaque instance: culling it could only save a frame that shows nothing"
                    }
                    Pass::CULL => "GPU culling off or unsupported by the adapter",
                    Pass::CLUSTER_BIN if n.binned_lights == 0 => "no local lights reach the fragment shader's lists",
                    Pass::CLUSTER_BIN => "nothing to light",
                    Pass::SHADOWS => "no shadowed light's casters reach what the camera sees",
                    Pass::OPAQUE => "opaque draws are rasterised and shaded in compute (see visibility-raster)",
                    Pass::VISIBILITY_RASTER | Pass::VISIBILITY_SHADE if n.has_opaque => n.raster_why,
                    Pass::VISIBILITY_RASTER | Pass::VISIBILITY_SHADE => "no opaque draws",
                    Pass::VISIBILITY_OVERLAY if n.visibility => "no line or point meshes, blended draws or gizmo lines",
                    Pass::VISIBILITY_OVERLAY => "opaque draws are not rasterised in compute",
                    Pass::BACKGROUND if n.background => {
                        "the visibility buffer's shading shows the environment where no surface is"
                    }
                    Pass::BACKGROUND => "no environment to show (none, or a solid background colour)",
                    Pass::OCCLUSION_LATE => {
                        "occlusion culling off (auto: fewer than 10 000 opaque instances or a CPU adapter)"
                    }
                    Pass::DEFERRED_LIGHTS => "local lights are shaded in the fragment shader, or there are none",
                    Pass::TRANSMISSION => "no transmissive draws",
                    Pass::TRANSPARENT => "no blended or transmissive draws",
                    Pass::GIZMOS => "no gizmo lines",
                    _ => unreachable!("every core pass has its reason"),
                };
                (p, why)
            })
            .chain(self.post_left_out.iter().copied())
            .collect()
    }
}

impl fmt::Display for FramePlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, (p, why)) in self.passes.iter().enumerate() {
            writeln!(f, "{:>2}. {p:?}: {why}", i + 1)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(needs: SceneNeeds) -> FramePlan {
        FramePlan::new(needs)
    }

    #[test]
    fn the_shadow_pass_says_when_cascades_are_rasterised_in_compute() {
        let why = |visibility| {
            let p = plan(SceneNeeds { has_opaque: true, shadow_layers: 2, visibility, ..Default::default() });
            p.passes.into_iter().find(|(p, _)| *p == Pass::SHADOWS).unwrap().1
        };
        let limit = crate::features::shadows::raster::MAX_EXTENT.to_string();
        assert!(why(true).contains("rasterised in compute") && why(true).contains(&limit), "{}", why(true));
        assert!(!why(false).contains("compute"), "{}", why(false));
    }

    #[test]
    fn transparent_phase_only_with_blended_draws() {
        assert!(!plan(SceneNeeds { has_opaque: true, ..Default::default() }).runs(Pass::TRANSPARENT));
        assert!(plan(SceneNeeds { has_opaque: true, has_blend: true, ..Default::default() }).runs(Pass::TRANSPARENT));
    }

    #[test]
    fn a_hybrid_frame_draws_its_overlay_between_raster_and_shade() {
        let compute =
            SceneNeeds { has_opaque: true, visibility: true, raster_why: "--raster compute", ..Default::default() };
        let alone = plan(compute);
        assert!(alone.runs(Pass::VISIBILITY_SHADE) && !alone.runs(Pass::VISIBILITY_OVERLAY));
        let why = alone.left_out().into_iter().find(|(p, _)| *p == Pass::VISIBILITY_OVERLAY).unwrap().1;
        assert_eq!(why, "no line or point meshes, blended draws or gizmo lines");
        let hybrid = plan(SceneNeeds { has_blend: true, overlay: true, ..compute });
        let order: Vec<Pass> = hybrid.passes.iter().map(|(p, _)| *p).collect();
        let at = |pass| order.iter().position(|p| *p == pass).unwrap();
        assert!(at(Pass::VISIBILITY_RASTER) < at(Pass::VISIBILITY_OVERLAY));
        assert!(at(Pass::VISIBILITY_OVERLAY) < at(Pass::VISIBILITY_SHADE));
        assert!(hybrid.runs(Pass::TRANSPARENT));
        assert!(!hybrid.runs(Pass::OPAQUE));
        // Transmissive draws read what the shading pass wrote: shade, copy, then the overlay,
        // each once.
        let transmissive = plan(SceneNeeds { transmission: true, ..hybrid.needs });
        let order: Vec<Pass> = transmissive.passes.iter().map(|(p, _)| *p).collect();
        let at = |pass| order.iter().position(|p| *p == pass).unwrap();
        assert!(at(Pass::VISIBILITY_RASTER) < at(Pass::VISIBILITY_SHADE));
        assert!(at(Pass::VISIBILITY_SHADE) < at(Pass::TRANSMISSION));
        assert!(at(Pass::TRANSMISSION) < at(Pass::VISIBILITY_OVERLAY));
        assert_eq!(order.iter().filter(|p| **p == Pass::TRANSMISSION).count(), 1);
        let last_shade = order.iter().rposition(|p| *p == Pass::VISIBILITY_SHADE).unwrap();
        assert!(at(Pass::VISIBILITY_OVERLAY) < last_shade, "{order:?}");
        assert!(!transmissive.runs(Pass::OPAQUE));
    }

    #[test]
    fn every_core_pass_left_out_has_a_reason() {
        let empty = plan(SceneNeeds::default());
        let left: Vec<Pass> = empty.left_out().into_iter().map(|(p, _)| p).collect();
        assert_eq!(left.len() + empty.passes.len(), CORE.len(), "{left:?}");
    }

    #[test]
    fn cluster_binning_only_with_local_lights_and_something_to_light() {
        assert!(!plan(SceneNeeds { has_opaque: true, has_blend: true, ..Default::default() }).runs(Pass::CLUSTER_BIN));
        assert!(plan(SceneNeeds { binned_lights: 3, has_opaque: true, ..Default::default() }).runs(Pass::CLUSTER_BIN));
        assert!(!plan(SceneNeeds { binned_lights: 3, ..Default::default() }).runs(Pass::CLUSTER_BIN));
        assert_eq!(
            plan(SceneNeeds { binned_lights: 3, has_opaque: true, ..Default::default() }).passes[0].0,
            Pass::CLUSTER_BIN,
            "binning precedes the forward pass"
        );
    }

    #[test]
    fn shadow_passes_only_with_layers_to_render_and_before_the_forward_pass() {
        assert!(!plan(SceneNeeds { binned_lights: 3, has_opaque: true, ..Default::default() }).runs(Pass::SHADOWS));
        let plan = plan(SceneNeeds { binned_lights: 3, shadow_layers: 2, has_opaque: true, ..Default::default() });
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::CLUSTER_BIN, Pass::SHADOWS, Pass::OPAQUE]);
    }

    #[test]
    fn deformation_only_when_a_pose_changed_and_before_everything_that_draws() {
        assert!(!plan(SceneNeeds { has_opaque: true, shadow_layers: 1, ..Default::default() }).runs(Pass::DEFORM));
        let plan =
            plan(SceneNeeds { deform_jobs: 2, has_opaque: true, culled: true, shadow_layers: 1, ..Default::default() });
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::DEFORM, Pass::CULL, Pass::SHADOWS, Pass::OPAQUE]);
    }

    #[test]
    fn culling_only_with_opaque_draws_and_first() {
        assert!(!plan(SceneNeeds { has_blend: true, culled: true, ..Default::default() }).runs(Pass::CULL));
        assert!(!plan(SceneNeeds { has_opaque: true, ..Default::default() }).runs(Pass::CULL));
        let plan = plan(SceneNeeds {
            binned_lights: 3,
            shadow_layers: 2,
            has_opaque: true,
            culled: true,
            ..Default::default()
        });
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::CULL, Pass::CLUSTER_BIN, Pass::SHADOWS, Pass::OPAQUE]);
    }

    #[test]
    fn occlusion_culling_splits_the_opaque_phase_only_when_culling_runs() {
        assert!(
            !plan(SceneNeeds { has_opaque: true, occlusion: true, ..Default::default() }).runs(Pass::OCCLUSION_LATE)
        );
        let plan =
            plan(SceneNeeds { has_opaque: true, has_blend: true, culled: true, occlusion: true, ..Default::default() });
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::CULL, Pass::OPAQUE, Pass::OCCLUSION_LATE, Pass::TRANSPARENT]);
    }

    #[test]
    fn deferred_lights_only_when_asked_for_between_opaque_and_blended_draws() {
        assert!(
            !plan(SceneNeeds { binned_lights: 3, has_opaque: true, has_blend: true, ..Default::default() })
                .runs(Pass::DEFERRED_LIGHTS)
        );
        let plan = plan(SceneNeeds {
            binned_lights: 3,
            has_opaque: true,
            has_blend: true,
            deferred: true,
            ..Default::default()
        });
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::CLUSTER_BIN, Pass::OPAQUE, Pass::DEFERRED_LIGHTS, Pass::TRANSPARENT]);
    }

    #[test]
    fn environment_prefilter_only_when_it_changed_and_first() {
        let still = plan(SceneNeeds { has_opaque: true, background: true, ..Default::default() });
        assert!(!still.runs(Pass::ENVIRONMENT_PREFILTER));
        let order: Vec<Pass> = still.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::OPAQUE, Pass::BACKGROUND]);
        let changed = plan(SceneNeeds {
            has_opaque: true,
            environment_changed: true,
            culled: true,
            background: true,
            ..Default::default()
        });
        assert_eq!(changed.passes[0].0, Pass::ENVIRONMENT_PREFILTER);
        assert!(!plan(SceneNeeds { has_opaque: true, ..Default::default() }).runs(Pass::BACKGROUND));
    }

    #[test]
    fn post_stages_follow_the_core_passes_in_chain_order_and_say_why_they_are_left_out() {
        let bloom = Pass::new("Bloom", "");
        let tonemap = Pass::new("Tonemap", "");
        let fxaa = Pass::new("Fxaa", "");
        let mut plan = plan(SceneNeeds { has_opaque: true, ..Default::default() });
        plan.add_post([
            (bloom, Decision::Runs("bloom is on")),
            (tonemap, Decision::Runs("tonemapped")),
            (fxaa, Decision::LeftOut("FXAA is off")),
        ]);
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::OPAQUE, bloom, tonemap]);
        assert!(plan.left_out().contains(&(fxaa, "FXAA is off")));
    }
}
