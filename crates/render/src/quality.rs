//! Quality presets: named bundles of the settings that trade image error for GPU time (shadow
//! atlas size, cascade count, shadow filter, MSAA, cluster grid, local-light range cutoff).
//!
//! A preset only writes those fields of a [`RenderSettings`]; every one of them can still be
//! set alone afterwards (the CLI applies `--quality` first, then the individual flags). `High`
//! is the renderer's default: `RenderSettings::default()` equals `High` applied to it, which a
//! unit test keeps true. `penumbra report` measures each preset's error against path-traced
//! references and its cost (see docs/quality.md).

use std::fmt;
use std::str::FromStr;

use crate::features::clusters::grid::ClusterConfig;
use crate::features::shadows::ShadowFilter;
use crate::resources::light_store::DEFAULT_CUTOFF;
use crate::settings::RenderSettings;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub enum QualityPreset {
    Low,
    Medium,
    /// The default settings.
    #[default]
    High,
    Ultra,
}

/// The fields a preset sets, in one place so the table in the docs and the code agree.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PresetValues {
    pub msaa: u32,
    /// Texels across each directional-shadow cascade layer.
    pub shadow_atlas: u32,
    pub cascades: u32,
    pub shadow_filter: ShadowFilter,
    /// Texels across each spot-light map and point-light cube face.
    pub local_shadow_map: u32,
    pub clusters: ClusterConfig,
    /// Display-referred luminance at which a local light's range ends.
    pub light_cutoff: f32,
}

impl QualityPreset {
    pub const ALL: [QualityPreset; 4] = [Self::Low, Self::Medium, Self::High, Self::Ultra];

    pub fn name(self) -> &'static str {
        match self {
            Self::Low => "low",
            Self::Medium => "medium",
            Self::High => "high",
            Self::Ultra => "ultra",
        }
    }

    pub fn values(self) -> PresetValues {
        let grid = |tiles_x, tiles_y, slices| ClusterConfig { tiles_x, tiles_y, slices };
        match self {
            // Built for CPU rasterisers and small integrated GPUs: no multisampling, two
            // cascades, and a coarse grid whose binning is cheap; lights end 4× sooner.
            Self::Low => PresetValues {
                msaa: 1,
                shadow_atlas: 1024,
                cascades: 2,
                shadow_filter: ShadowFilter::Pcf,
                local_shadow_map: 512,
                clusters: grid(8, 8, 16),
                light_cutoff: DEFAULT_CUTOFF * 4.0,
            },
            Self::Medium => PresetValues {
                msaa: 4,
                shadow_atlas: 2048,
                cascades: 3,
                shadow_filter: ShadowFilter::Pcf,
                local_shadow_map: 512,
                clusters: grid(16, 16, 24),
                light_cutoff: DEFAULT_CUTOFF * 2.0,
            },
            Self::High => PresetValues {
                msaa: 4,
                shadow_atlas: 4096,
                cascades: 4,
                shadow_filter: ShadowFilter::Pcf,
                local_shadow_map: 1024,
                clusters: ClusterConfig::default(),
                light_cutoff: DEFAULT_CUTOFF,
            },
            // Contact-hardening shadows, twice the texels, a finer grid and lights that reach
            // four times less bright before they stop.
            Self::Ultra => PresetValues {
                msaa: 4,
                shadow_atlas: 8192,
                cascades: 4,
                shadow_filter: ShadowFilter::Pcss,
                local_shadow_map: 2048,
                clusters: grid(32, 18, 48),
                light_cutoff: DEFAULT_CUTOFF / 4.0,
            },
        }
    }

    /// Writes this preset's fields into `settings`, leaving every other field as it was.
    pub fn apply(self, settings: &mut RenderSettings) {
        let v = self.values();
        settings.msaa = v.msaa;
        settings.shadows.atlas_size = v.shadow_atlas;
        settings.shadows.cascades = v.cascades;
        settings.shadows.filter = v.shadow_filter;
        settings.shadows.local_map_size = v.local_shadow_map;
        settings.clusters = v.clusters;
        settings.light_cutoff = v.light_cutoff;
    }

    /// The preset whose fields `settings` hold exactly, if any (the viewer highlights it;
    /// `None` reads as "custom").
    pub fn matching(settings: &RenderSettings) -> Option<Self> {
        Self::ALL.into_iter().find(|p| {
            let mut s = settings.clone();
            p.apply(&mut s);
            s == *settings
        })
    }

    /// The default settings with this preset applied.
    pub fn settings(self) -> RenderSettings {
        let mut s = RenderSettings::default();
        self.apply(&mut s);
        s
    }
}

impl fmt::Display for QualityPreset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for QualityPreset {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| format!("{s:?} is not a quality preset (low, medium, high, ultra)"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn high_is_the_default() {
        let high = QualityPreset::High.settings();
        let d = RenderSettings::default();
        assert_eq!(high.msaa, d.msaa);
        assert_eq!(high.shadows.atlas_size, d.shadows.atlas_size);
        assert_eq!(high.shadows.cascades, d.shadows.cascades);
        assert_eq!(high.shadows.filter, d.shadows.filter);
        assert_eq!(high.shadows.local_map_size, d.shadows.local_map_size);
        assert_eq!(high.clusters, d.clusters);
        assert_eq!(high.light_cutoff, d.light_cutoff);
    }

    #[test]
    fn every_preset_is_valid_and_round_trips_its_name() {
        for p in QualityPreset::ALL {
            p.settings().validate().unwrap_or_else(|e| panic!("{p}: {e}"));
            assert_eq!(p.name().parse::<QualityPreset>(), Ok(p));
        }
        assert!("HIGH".parse::<QualityPreset>().is_ok());
        assert!("extreme".parse::<QualityPreset>().unwrap_err().contains("low, medium, high, ultra"));
    }

    #[test]
    fn presets_only_grow_in_cost() {
        let v: Vec<PresetValues> = QualityPreset::ALL.iter().map(|p| p.values()).collect();
        for w in v.windows(2) {
            assert!(w[1].shadow_atlas >= w[0].shadow_atlas && w[1].cascades >= w[0].cascades);
            assert!(w[1].msaa >= w[0].msaa && w[1].clusters.count() >= w[0].clusters.count());
            assert!(w[1].light_cutoff <= w[0].light_cutoff);
        }
    }

    #[test]
    fn applying_a_preset_leaves_other_fields_alone() {
        let mut s = RenderSettings { gpu_culling: false, ..Default::default() };
        s.shadows.max_distance = 7.0;
        QualityPreset::Low.apply(&mut s);
        assert!(!s.gpu_culling);
        assert_eq!(s.shadows.max_distance, 7.0);
        assert_eq!(s.msaa, 1);
        assert_eq!(QualityPreset::matching(&s), Some(QualityPreset::Low));
        s.msaa = 4;
        assert_eq!(QualityPreset::matching(&s), None, "a preset changed alone is custom");
        assert_eq!(QualityPreset::matching(&RenderSettings::default()), Some(QualityPreset::High));
    }
}
