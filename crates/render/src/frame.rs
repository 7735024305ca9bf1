//! The frame plan: which passes run this frame, in what order, and why. A pass the scene does
//! not need is not encoded at all (no empty passes): cluster binning runs only with local lights
//! to bin, the transparent phase only with blended draws, shadow maps only for layers a shadowed
//! light's casters reach within sight (the shadow orchestrator decides which), environment
//! prefiltering only when the environment changed, the background only with an environment.

use std::fmt;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pass {
    /// Compute: make the environment's maps (source cube, specular levels, irradiance
    /// harmonics; the split-sum table once).
    EnvironmentPrefilter,
    /// Compute: skin and morph the draws whose pose changed into their vertex copies.
    Deform,
    /// Compute: cull opaque and masked draws against the view frustum into indirect draws.
    Cull,
    /// Compute: bin local lights into the froxel grid (count, prefix sum, fill, sort).
    ClusterBin,
    /// Depth-only passes of shadow casters into the shadow atlas, one per rendered layer.
    Shadows,
    /// Opaque and alpha-masked draws, front to back by batch.
    Opaque,
    /// Compute: opaque draws rasterised into the visibility buffer (each sample's nearest
    /// triangle), in place of `Opaque` (`Raster::Compute`).
    VisibilityRaster,
    /// Compute: each pixel's triangles in the visibility buffer shaded and resolved into the
    /// HDR colour.
    VisibilityShade,
    /// The environment (or its blur) where no surface was drawn, in the opaque pass after the
    /// opaque draws (depth test: only where the depth is still the far plane).
    Background,
    /// Occlusion culling's second half, after `Opaque` drew what was visible last frame: the
    /// depth pyramid, the late cull, and a second pass drawing what became visible.
    OcclusionLate,
    /// Compute: local lights for opaque surfaces (`LightWalk::ClusteredCompute`, or `Auto` with
    /// long cluster lists), then a render pass that adds them to the frame and holds the
    /// `Transparent` phase.
    DeferredLights,
    /// Alpha-blended draws, back to front, in the same render pass as `Opaque` (or, with
    /// deferred lights, as their composite).
    Transparent,
    /// Gizmo lines (axes, selection boxes, debug lines), last in the render pass that ends the
    /// frame's drawing, depth-tested against the scene.
    Gizmos,
    /// Bloom's half-size mip chain, down and up (render passes).
    Bloom,
    /// Compute: luminance histogram and the adapted exposure the tonemap pass applies.
    AutoExposure,
    /// HDR to display: exposure is already applied; tonemap and sRGB-encode into the output.
    /// Left out when nothing reads the HDR colour: the opaque pass then tonemaps itself.
    Tonemap,
    /// FXAA from the tonemapped image into the output.
    Fxaa,
}

impl Pass {
    pub const ALL: [Pass; 17] = [
        Pass::EnvironmentPrefilter,
        Pass::Deform,
        Pass::Cull,
        Pass::ClusterBin,
        Pass::Shadows,
        Pass::Opaque,
        Pass::VisibilityRaster,
        Pass::VisibilityShade,
        Pass::Background,
        Pass::OcclusionLate,
        Pass::DeferredLights,
        Pass::Transparent,
        Pass::Gizmos,
        Pass::Bloom,
        Pass::AutoExposure,
        Pass::Tonemap,
        Pass::Fxaa,
    ];

    /// What the pass reads (buffers, textures) and writes, for `penumbra render --explain`.
    pub fn inputs(self) -> &'static str {
        match self {
            Pass::EnvironmentPrefilter => {
                "environment source (sky, studio or image) -> source cube, GGX levels, SH [; the \
                 split-sum table, once]"
            }
            Pass::Deform => "mesh pool vertices, joint matrices, morph weights -> deformed vertex copies",
            Pass::Cull => {
                "view, instance buffer, draw slots [, mesh pool indices and vertices] -> indirect draw arguments [, triangle lists of small meshes]"
            }
            Pass::ClusterBin => "view, light store (local lights) -> cluster counts, offsets, index lists",
            Pass::Shadows => "casters' vertices and instances, cascade matrices -> shadow atlas layers",
            Pass::Opaque => {
                "view, mesh pool, instances, materials, textures, light store [, cluster lists] \
                 [, shadow atlas] [, environment maps] -> HDR colour (or the output, tonemapped) \
                 [, depth]"
            }
            Pass::VisibilityRaster => {
                "view, visible instances and their counts, mesh pool indices and vertices -> visibility \
                 buffer (depth and triangle number per sample)"
            }
            Pass::VisibilityShade => {
                "visibility buffer, mesh pool, instances, materials, textures, light store [, cluster \
                 lists] [, shadow atlas] [, environment maps] -> HDR colour (resolved), or the \
                 displayed colour copied into the output"
            }
            Pass::Background => "environment cube (or its blurred level), HDR alpha -> HDR colour",
            Pass::OcclusionLate => "depth -> depth pyramid -> late cull -> second opaque draws",
            Pass::DeferredLights => "surface buffer, depth, cluster lists, light store -> HDR colour",
            Pass::Transparent => "view, blended draws sorted back to front, lights -> HDR colour",
            Pass::Gizmos => "gizmo line vertices, depth -> HDR colour",
            Pass::Bloom => "HDR colour -> half-size mip chain",
            Pass::AutoExposure => "HDR colour -> luminance histogram -> adapted exposure",
            Pass::Tonemap => "HDR colour [, bloom chain] [, exposure] -> output (sRGB)",
            Pass::Fxaa => "tonemapped intermediate -> output",
        }
    }
}

#[derive(Debug, Clone, Default)]
pub struct FramePlan {
    pub passes: Vec<(Pass, &'static str)>,
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
    /// Opaque draws are rasterised and shaded in compute (`Raster::Compute`).
    pub visibility: bool,
    /// The environment's maps must be (re)made this frame.
    pub environment_changed: bool,
    /// The split-sum table lit surfaces read must be made this frame (once per renderer).
    pub split_sum_table: bool,
    /// Deformed draws whose pose changed this frame.
    pub deform_jobs: usize,
    /// The scene has an environment to show behind it (not a solid colour: that is the clear).
    pub background: bool,
    /// Post-processing switched on in the settings.
    pub bloom: bool,
    pub auto_exposure: bool,
    pub fxaa: bool,
    /// Vertices of the gizmo lines to draw.
    pub gizmo_vertices: u32,
    /// Nothing reads the HDR colour: the forward pass tonemaps into the output itself.
    pub direct_output: bool,
    /// The frame has a depth target (not when nothing drawn can cover a pixel twice).
    pub depth: bool,
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
            environment_changed,
            split_sum_table,
            deform_jobs,
            background,
            bloom,
            auto_exposure,
            fxaa,
            gizmo_vertices,
            direct_output,
            depth,
        } = needs;
        let mut passes = Vec::new();
        if environment_changed {
            passes.push((Pass::EnvironmentPrefilter, "the environment changed (or is new): its maps are made"));
        } else if split_sum_table {
            passes.push((
                Pass::EnvironmentPrefilter,
                "lit draws read their specular albedo from the split-sum table, made once (no environment: \
                 nothing else runs)",
            ));
        }
        if deform_jobs > 0 {
            passes.push((Pass::Deform, "skinned or morphed draws changed pose: their vertices are recomputed"));
        }
        if culled && has_opaque {
            passes.push((Pass::Cull, "opaque draws to cull (GPU culling on and supported)"));
        }
        if binned_lights > 0 && (has_opaque || has_blend) {
            passes.push((Pass::ClusterBin, "local lights to bin and draws to light"));
        }
        if shadow_layers > 0 {
            passes.push((Pass::Shadows, "a shadowed light's casters reach what the camera sees"));
        }
        if visibility {
            passes.push((
                Pass::VisibilityRaster,
                "opaque draws, rasterised in compute (--raster compute, or auto on a GPU with few graphics units)",
            ));
            passes.push((Pass::VisibilityShade, "the visibility buffer's samples to shade"));
        } else {
            passes.push((
                Pass::Opaque,
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
            passes.push((Pass::Background, "the scene has an environment, shown where no surface is"));
        }
        if culled && occlusion && has_opaque {
            passes.push((Pass::OcclusionLate, "occlusion culling (many opaque instances, or asked for)"));
        }
        if deferred {
            passes.push((
                Pass::DeferredLights,
                "local lights shaded in compute (long cluster lists, or --light-walk compute)",
            ));
        }
        if has_blend {
            passes.push((Pass::Transparent, "blended draws exist"));
        }
        if gizmo_vertices > 0 {
            passes.push((Pass::Gizmos, "the scene has gizmo lines to draw"));
        }
        if bloom {
            passes.push((Pass::Bloom, "bloom is on"));
        }
        if auto_exposure {
            passes.push((Pass::AutoExposure, "automatic exposure is on"));
        }
        if !direct_output {
            passes.push((Pass::Tonemap, "the HDR colour is tonemapped into the output"));
        }
        if fxaa {
            passes.push((Pass::Fxaa, "FXAA is on"));
        }
        Self { passes, needs }
    }

    pub fn runs(&self, pass: Pass) -> bool {
        self.passes.iter().any(|(p, _)| *p == pass)
    }

    /// The passes this frame leaves out, each with the reason (what the scene lacks).
    pub fn left_out(&self) -> Vec<(Pass, &'static str)> {
        let n = &self.needs;
        Pass::ALL
            .into_iter()
            .filter(|p| !self.runs(*p))
            .map(|p| {
                let why = match p {
                    Pass::EnvironmentPrefilter if n.background => "the environment's maps are unchanged",
                    Pass::EnvironmentPrefilter => "no environment changed (or none exists)",
                    Pass::Deform => "no skinned or morphed draw changed pose",
                    Pass::Cull if !n.has_opaque => "no opaque draws",
                    Pass::Cull if n.opaque_instances == 1 => {
                        "one opaque instance: culling it could only save a frame that shows nothing"
                    }
                    Pass::Cull => "GPU culling off or unsupported by the adapter",
                    Pass::ClusterBin if n.binned_lights == 0 => "no local lights reach the fragment shader's lists",
                    Pass::ClusterBin => "nothing to light",
                    Pass::Shadows => "no shadowed light's casters reach what the camera sees",
                    Pass::Tonemap => {
                        "nothing reads the HDR colour (MSAA 1, or MSAA resolving display colours; no \
                         post-processing, environment background, blended draws, gizmos, deferred \
                         lights or HDR readback): the opaque pass tonemaps and draws into the output"
                    }
                    Pass::Opaque => "opaque draws are rasterised and shaded in compute (--raster compute or auto)",
                    Pass::VisibilityRaster | Pass::VisibilityShade => {
                        "opaque draws rasterise in hardware (--raster hardware, or auto on a GPU with \
                         many graphics units; with compute: no opaque draws, no GPU culling, blended \
                         or masked draws, gizmos, lines or points, occlusion culling asked for, no \
                         64-bit atomics on the adapter, or a visibility buffer larger than one \
                         storage binding)"
                    }
                    Pass::Background if n.background => {
                        "the visibility buffer's shading shows the environment where no surface is"
                    }
                    Pass::Background => "no environment to show (none, or a solid background colour)",
                    Pass::OcclusionLate => {
                        "occlusion culling off (auto: fewer than 10 000 opaque instances or a CPU adapter)"
                    }
                    Pass::DeferredLights => "local lights are shaded in the fragment shader, or there are none",
                    Pass::Transparent => "no blended draws",
                    Pass::Gizmos => "no gizmo lines",
                    Pass::Bloom => "bloom is off",
                    Pass::AutoExposure => "automatic exposure is off",
                    Pass::Fxaa => "FXAA is off",
                };
                (p, why)
            })
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
    fn transparent_phase_only_with_blended_draws() {
        assert!(!plan(SceneNeeds { has_opaque: true, ..Default::default() }).runs(Pass::Transparent));
        assert!(plan(SceneNeeds { has_opaque: true, has_blend: true, ..Default::default() }).runs(Pass::Transparent));
        assert!(plan(SceneNeeds { ..Default::default() }).runs(Pass::Tonemap));
    }

    #[test]
    fn tonemap_pass_only_when_the_frame_has_hdr_colour() {
        let direct = plan(SceneNeeds { has_opaque: true, direct_output: true, ..Default::default() });
        let order: Vec<Pass> = direct.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::Opaque]);
        assert!(direct.left_out().iter().any(|(p, why)| *p == Pass::Tonemap && why.contains("nothing reads")));
    }

    #[test]
    fn cluster_binning_only_with_local_lights_and_something_to_light() {
        assert!(!plan(SceneNeeds { has_opaque: true, has_blend: true, ..Default::default() }).runs(Pass::ClusterBin));
        assert!(plan(SceneNeeds { binned_lights: 3, has_opaque: true, ..Default::default() }).runs(Pass::ClusterBin));
        assert!(!plan(SceneNeeds { binned_lights: 3, ..Default::default() }).runs(Pass::ClusterBin));
        assert_eq!(
            plan(SceneNeeds { binned_lights: 3, has_opaque: true, ..Default::default() }).passes[0].0,
            Pass::ClusterBin,
            "binning precedes the forward pass"
        );
    }

    #[test]
    fn shadow_passes_only_with_layers_to_render_and_before_the_forward_pass() {
        assert!(!plan(SceneNeeds { binned_lights: 3, has_opaque: true, ..Default::default() }).runs(Pass::Shadows));
        let plan = plan(SceneNeeds { binned_lights: 3, shadow_layers: 2, has_opaque: true, ..Default::default() });
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::ClusterBin, Pass::Shadows, Pass::Opaque, Pass::Tonemap]);
    }

    #[test]
    fn deformation_only_when_a_pose_changed_and_before_everything_that_draws() {
        assert!(!plan(SceneNeeds { has_opaque: true, shadow_layers: 1, ..Default::default() }).runs(Pass::Deform));
        let plan =
            plan(SceneNeeds { deform_jobs: 2, has_opaque: true, culled: true, shadow_layers: 1, ..Default::default() });
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::Deform, Pass::Cull, Pass::Shadows, Pass::Opaque, Pass::Tonemap]);
    }

    #[test]
    fn culling_only_with_opaque_draws_and_first() {
        assert!(!plan(SceneNeeds { has_blend: true, culled: true, ..Default::default() }).runs(Pass::Cull));
        assert!(!plan(SceneNeeds { has_opaque: true, ..Default::default() }).runs(Pass::Cull));
        let plan = plan(SceneNeeds {
            binned_lights: 3,
            shadow_layers: 2,
            has_opaque: true,
            culled: true,
            ..Default::default()
        });
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::Cull, Pass::ClusterBin, Pass::Shadows, Pass::Opaque, Pass::Tonemap]);
    }

    #[test]
    fn occlusion_culling_splits_the_opaque_phase_only_when_culling_runs() {
        assert!(
            !plan(SceneNeeds { has_opaque: true, occlusion: true, ..Default::default() }).runs(Pass::OcclusionLate)
        );
        let plan =
            plan(SceneNeeds { has_opaque: true, has_blend: true, culled: true, occlusion: true, ..Default::default() });
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::Cull, Pass::Opaque, Pass::OcclusionLate, Pass::Transparent, Pass::Tonemap]);
    }

    #[test]
    fn deferred_lights_only_when_asked_for_between_opaque_and_blended_draws() {
        assert!(
            !plan(SceneNeeds { binned_lights: 3, has_opaque: true, has_blend: true, ..Default::default() })
                .runs(Pass::DeferredLights)
        );
        let plan = plan(SceneNeeds {
            binned_lights: 3,
            has_opaque: true,
            has_blend: true,
            deferred: true,
            ..Default::default()
        });
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::ClusterBin, Pass::Opaque, Pass::DeferredLights, Pass::Transparent, Pass::Tonemap]);
    }

    #[test]
    fn environment_prefilter_only_when_it_changed_and_first() {
        let still = plan(SceneNeeds { has_opaque: true, background: true, ..Default::default() });
        assert!(!still.runs(Pass::EnvironmentPrefilter));
        let order: Vec<Pass> = still.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::Opaque, Pass::Background, Pass::Tonemap]);
        let changed = plan(SceneNeeds {
            has_opaque: true,
            environment_changed: true,
            culled: true,
            background: true,
            ..Default::default()
        });
        assert_eq!(changed.passes[0].0, Pass::EnvironmentPrefilter);
        assert!(!plan(SceneNeeds { has_opaque: true, ..Default::default() }).runs(Pass::Background));
    }

    #[test]
    fn post_processing_only_when_on_and_around_the_tonemap_pass() {
        let off = plan(SceneNeeds { has_opaque: true, ..Default::default() });
        assert!(!off.runs(Pass::Bloom) && !off.runs(Pass::AutoExposure) && !off.runs(Pass::Fxaa));
        let on =
            plan(SceneNeeds { has_opaque: true, bloom: true, auto_exposure: true, fxaa: true, ..Default::default() });
        let order: Vec<Pass> = on.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::Opaque, Pass::Bloom, Pass::AutoExposure, Pass::Tonemap, Pass::Fxaa]);
    }
}
