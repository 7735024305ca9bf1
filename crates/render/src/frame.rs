//! The frame plan: which passes run this frame, in what order, and why. A pass the scene does
//! not need is not encoded at all (no empty passes): cluster binning runs only with local lights
//! to bin, the transparent phase only with blended draws, shadow maps only for layers a shadowed
//! light's casters reach within sight (the shadow orchestrator decides which).

use std::fmt;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pass {
    /// Compute: cull opaque and masked draws against the view frustum into indirect draws.
    Cull,
    /// Compute: bin local lights into the froxel grid (count, prefix sum, fill, sort).
    ClusterBin,
    /// Depth-only passes of shadow casters into the shadow atlas, one per rendered layer.
    Shadows,
    /// Opaque and alpha-masked draws, front to back by batch.
    Opaque,
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
    /// HDR to display: exposure is already applied; tonemap and sRGB-encode into the output.
    Tonemap,
}

#[derive(Debug, Clone, Default)]
pub struct FramePlan {
    pub passes: Vec<(Pass, &'static str)>,
}

impl FramePlan {
    /// `binned_lights`: local lights the forward pass will find through clusters; `deferred`:
    /// a compute pass shades them for opaque surfaces.
    /// `shadow_layers`: shadow-map layers the orchestrator will render.
    /// `culled`: GPU culling runs (on, supported, and opaque draws to cull); `occlusion`: so
    /// does occlusion culling.
    pub fn new(
        binned_lights: u32,
        shadow_layers: usize,
        has_opaque: bool,
        has_blend: bool,
        deferred: bool,
        culled: bool,
        occlusion: bool,
    ) -> Self {
        let mut passes = Vec::new();
        if culled && has_opaque {
            passes.push((Pass::Cull, "opaque draws to cull (GPU culling on and supported)"));
        }
        if binned_lights > 0 && (has_opaque || has_blend) {
            passes.push((Pass::ClusterBin, "local lights to bin and draws to light"));
        }
        if shadow_layers > 0 {
            passes.push((Pass::Shadows, "a shadowed light's casters reach what the camera sees"));
        }
        passes.push((
            Pass::Opaque,
            if has_opaque { "opaque or masked draws exist" } else { "clears the targets (no opaque draws)" },
        ));
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
        passes.push((Pass::Tonemap, "every frame ends in the output target"));
        Self { passes }
    }

    pub fn runs(&self, pass: Pass) -> bool {
        self.passes.iter().any(|(p, _)| *p == pass)
    }
}

impl fmt::Display for FramePlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, (p, why)) in self.passes.iter().enumerate() {
            writeln!(f, "{}. {p:?}: {why}", i + 1)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transparent_phase_only_with_blended_draws() {
        assert!(!FramePlan::new(0, 0, true, false, false, false, false).runs(Pass::Transparent));
        assert!(FramePlan::new(0, 0, true, true, false, false, false).runs(Pass::Transparent));
        assert!(FramePlan::new(0, 0, false, false, false, false, false).runs(Pass::Tonemap));
    }

    #[test]
    fn cluster_binning_only_with_local_lights_and_something_to_light() {
        assert!(!FramePlan::new(0, 0, true, true, false, false, false).runs(Pass::ClusterBin));
        assert!(FramePlan::new(3, 0, true, false, false, false, false).runs(Pass::ClusterBin));
        assert!(!FramePlan::new(3, 0, false, false, false, false, false).runs(Pass::ClusterBin));
        assert_eq!(
            FramePlan::new(3, 0, true, false, false, false, false).passes[0].0,
            Pass::ClusterBin,
            "binning precedes the forward pass"
        );
    }

    #[test]
    fn shadow_passes_only_with_layers_to_render_and_before_the_forward_pass() {
        assert!(!FramePlan::new(3, 0, true, false, false, false, false).runs(Pass::Shadows));
        let plan = FramePlan::new(3, 2, true, false, false, false, false);
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::ClusterBin, Pass::Shadows, Pass::Opaque, Pass::Tonemap]);
    }

    #[test]
    fn culling_only_with_opaque_draws_and_first() {
        assert!(!FramePlan::new(0, 0, false, true, false, true, false).runs(Pass::Cull));
        assert!(!FramePlan::new(0, 0, true, false, false, false, false).runs(Pass::Cull));
        let plan = FramePlan::new(3, 2, true, false, false, true, false);
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::Cull, Pass::ClusterBin, Pass::Shadows, Pass::Opaque, Pass::Tonemap]);
    }

    #[test]
    fn occlusion_culling_splits_the_opaque_phase_only_when_culling_runs() {
        assert!(!FramePlan::new(0, 0, true, false, false, false, true).runs(Pass::OcclusionLate));
        let plan = FramePlan::new(0, 0, true, true, false, true, true);
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::Cull, Pass::Opaque, Pass::OcclusionLate, Pass::Transparent, Pass::Tonemap]);
    }

    #[test]
    fn deferred_lights_only_when_asked_for_between_opaque_and_blended_draws() {
        assert!(!FramePlan::new(3, 0, true, true, false, false, false).runs(Pass::DeferredLights));
        let plan = FramePlan::new(3, 0, true, true, true, false, false);
        let order: Vec<Pass> = plan.passes.iter().map(|p| p.0).collect();
        assert_eq!(order, [Pass::ClusterBin, Pass::Opaque, Pass::DeferredLights, Pass::Transparent, Pass::Tonemap]);
    }
}
