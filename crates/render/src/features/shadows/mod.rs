//! Shadows. The shadow orchestrator ([`orchestrator`]) is the one module that emits shadow
//! passes: it owns the cascade state, the atlas and the caster passes. [`cascades`] fits the
//! cascades of directional lights (CPU, f64, texel-snapped), [`window`] the part of each
//! cascade's map that receivers read (all a layer stores); `shaders/shadow_caster.wgsl`
//! renders casters into the atlas and `shaders/shadows.wgsl` reads it while shading.
//!
//! Data flow per frame: the renderer hands the orchestrator the camera, the shadowed
//! directional lights from the light store (with their slots) and the bounds of casters and
//! receivers; the orchestrator fits cascades, decides which layers need rendering (a cascade
//! no caster reaches, or that lies beyond everything visible, is skipped), writes the shadow
//! uniform, and encodes one depth pass per rendered layer before the forward pass samples them;
//! [`caster_cull`] first culls each layer's casters to its clip volume on the GPU, and the
//! passes draw what it kept indirectly.
//!
//! Local lights ([`local`]): spot lights get a perspective map, point lights (and spot lights
//! wider than 60°) six cube faces, each a layer of a second atlas, allocated to the lights that
//! matter most on screen and re-rendered within a per-frame budget.

pub mod atlas;
pub mod cascades;
pub mod caster_cull;
pub mod casters;
pub mod local;
pub mod orchestrator;
pub mod raster;
pub mod window;

/// How shadow maps are filtered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum ShadowFilter {
    /// Percentage-closer filtering over a fixed 4×4-texel footprint (3×3 bilinear
    /// comparisons): soft edges one texel wide, the same everywhere.
    #[default]
    Pcf,
    /// Percentage-closer soft shadows: a blocker search, then a kernel as wide as the penumbra
    /// the light's angular size casts from the blockers' distance (contact-hardening).
    Pcss,
}

/// Shadow quality and extent for directional lights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowSettings {
    /// Cascades per directional light, 1 to 4.
    pub cascades: u32,
    /// The practical split scheme's blend: 0 uniform, 1 logarithmic.
    pub split_lambda: f32,
    /// Distance from the camera (along its view direction) beyond which nothing is shadowed.
    pub max_distance: f32,
    /// Width and height of each cascade's map, in texels (its atlas layer stores only the part
    /// receivers read: [`window`]).
    pub atlas_size: u32,
    pub filter: ShadowFilter,
    /// Casters' depth bias, in multiples of their depth slope across one texel (raster state).
    pub slope_bias: f32,
    /// Receivers' offset along their geometric normal, in texels of the cascade they read.
    pub normal_bias: f32,
    /// Fraction of each cascade's depth range over which it blends into the next.
    pub cascade_blend: f32,
    /// PCSS: the widest blocker search and filter kernel, in texels.
    pub max_penumbra_texels: f32,
    /// Texels across each layer of the local-light shadow atlas (a spot light's map, one face
    /// of a point light's cube).
    pub local_map_size: u32,
    /// Layers of the local-light atlas: how many spot lights (one layer each) and point lights
    /// (six) can have shadow maps at once. Shadowed lights beyond it light unshadowed, the
    /// least visible first.
    pub local_layers: u32,
    /// Local-light layers re-rendered per frame at most: maps whose light or casters changed
    /// wait their turn beyond it (the most visible first, then the longest waiting).
    pub local_updates: u32,
}

impl Default for ShadowSettings {
    fn default() -> Self {
        Self {
            cascades: 4,
            split_lambda: 0.85,
            max_distance: 100.0,
            atlas_size: 4096,
            filter: ShadowFilter::Pcf,
            slope_bias: 4.0,
            normal_bias: 1.5,
            cascade_blend: 0.1,
            max_penumbra_texels: 24.0,
            local_map_size: 1024,
            local_layers: 24,
            local_updates: 12,
        }
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
        if !(0.0..=16.0).contains(&self.slope_bias) {
            return err("slope_bias", &self.slope_bias, "between 0 and 16");
        }
        if !(0.0..=16.0).contains(&self.normal_bias) {
            return err("normal_bias", &self.normal_bias, "between 0 and 16 texels");
        }
        if !(0.0..=0.5).contains(&self.cascade_blend) {
            return err("cascade_blend", &self.cascade_blend, "between 0 and 0.5");
        }
        if !(16..=8192).contains(&self.local_map_size) {
            return err("local_map_size", &self.local_map_size, "16 to 8192 texels");
        }
        if !(1..=256).contains(&self.local_layers) {
            return err("local_layers", &self.local_layers, "1 to 256");
        }
        if !(1..=256).contains(&self.local_updates) {
            return err("local_updates", &self.local_updates, "1 to 256 layers per frame");
        }
        if !(1.0..=64.0).contains(&self.max_penumbra_texels) {
            return err("max_penumbra_texels", &self.max_penumbra_texels, "between 1 and 64 texels");
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
