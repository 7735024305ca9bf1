//! The frame plan: which passes run this frame, in what order, and why. A pass the scene does
//! not need is not encoded at all (no empty passes): today that is the transparent phase; the
//! cluster binning (#3) and shadow (#4) passes join the plan with their own conditions.

use std::fmt;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pass {
    /// Opaque and alpha-masked draws, front to back by batch.
    Opaque,
    /// Alpha-blended draws, back to front, in the same render pass as `Opaque`.
    Transparent,
    /// HDR to display: exposure is already applied; tonemap and sRGB-encode into the output.
    Tonemap,
}

#[derive(Debug, Clone, Default)]
pub struct FramePlan {
    pub passes: Vec<(Pass, &'static str)>,
}

impl FramePlan {
    pub fn new(has_opaque: bool, has_blend: bool) -> Self {
        let mut passes = vec![(
            Pass::Opaque,
            if has_opaque { "opaque or masked draws exist" } else { "clears the targets (no opaque draws)" },
        )];
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
        assert!(!FramePlan::new(true, false).runs(Pass::Transparent));
        assert!(FramePlan::new(true, true).runs(Pass::Transparent));
        assert!(FramePlan::new(false, false).runs(Pass::Tonemap));
    }
}
