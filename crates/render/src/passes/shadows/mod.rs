//! Shadows (issue #4). The shadow orchestrator will be the one module that emits shadow passes,
//! owning cascade state, the atlas, budgets and the round-robin of local-light shadows. What is
//! here so far is its first piece: the settings and the cascade fit for directional lights
//! ([`cascades`]), CPU-only and unit-tested; the atlas, the depth passes and the sampling in
//! the shaders come next.

pub mod cascades;

/// Shadow quality and extent for directional lights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowSettings {
    /// Cascades per directional light, 1 to 4.
    pub cascades: u32,
    /// The practical split scheme's blend: 0 uniform, 1 logarithmic.
    pub split_lambda: f32,
    /// Distance from the camera (along its view direction) beyond which nothing is shadowed.
    pub max_distance: f32,
    /// Width and height of each cascade's layer of the atlas, in texels.
    pub atlas_size: u32,
}

impl Default for ShadowSettings {
    fn default() -> Self {
        Self { cascades: 4, split_lambda: 0.85, max_distance: 100.0, atlas_size: 4096 }
    }
}

/// A setting out of its range, naming it and the range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("shadow setting {name} is {value}; it must be {range}")]
pub struct ShadowSettingsError {
    pub name: &'static str,
    pub value: String,
    pub range: &'static str,
}

impl ShadowSettings {
    pub fn validate(&self) -> Result<(), ShadowSettingsError> {
        let err = |name, value: &dyn std::fmt::Display, range| {
            Err(ShadowSettingsError { name, value: value.to_string(), range })
        };
        if !(1..=4).contains(&self.cascades) {
            return err("cascades", &self.cascades, "1 to 4");
        }
        if !(0.0..=1.0).contains(&self.split_lambda) {
            return err("split_lambda", &self.split_lambda, "between 0 and 1");
        }
        if !(self.max_distance > 0.0 && self.max_distance.is_finite()) {
            return err("max_distance", &self.max_distance, "a finite distance above 0");
        }
        if !(16..=16384).contains(&self.atlas_size) {
            return err("atlas_size", &self.atlas_size, "16 to 16384 texels");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn out_of_range_settings_are_named() {
        assert!(ShadowSettings::default().validate().is_ok());
        let bad = [
            ShadowSettings { cascades: 5, ..Default::default() },
            ShadowSettings { split_lambda: 1.5, ..Default::default() },
            ShadowSettings { max_distance: f32::NAN, ..Default::default() },
            ShadowSettings { atlas_size: 0, ..Default::default() },
        ];
        for (s, name) in bad.iter().zip(["cascades", "split_lambda", "max_distance", "atlas_size"]) {
            let e = s.validate().unwrap_err();
            assert_eq!(e.name, name);
            assert!(e.to_string().starts_with(&format!("shadow setting {name} is")), "{e}");
        }
    }
}
