//! Light components, in the photometric units of glTF's KHR_lights_punctual: directional lights
//! in lux (lm/m²), point and spot lights in candela (lm/sr). Lights shine down their local −Z.
//! `AmbientLight` is uniform radiance from every direction, in cd/m² (nits).

use bevy_ecs::prelude::*;
use glam::Vec3;

use super::transform::Transform;
use super::visibility::Visibility;

#[derive(Component, Debug, Clone, Copy, PartialEq)]
#[require(Transform, Visibility)]
pub struct DirectionalLight {
    /// Linear RGB.
    pub color: Vec3,
    /// Lux.
    pub illuminance: f32,
    pub shadows: bool,
}

impl Default for DirectionalLight {
    fn default() -> Self {
        Self { color: Vec3::ONE, illuminance: 1.0, shadows: true }
    }
}

#[derive(Component, Debug, Clone, Copy, PartialEq)]
#[require(Transform, Visibility)]
pub struct PointLight {
    pub color: Vec3,
    /// Candela.
    pub intensity: f32,
    /// Distance where the light's influence ends; `None` derives one from the intensity.
    pub range: Option<f32>,
    pub shadows: bool,
}

impl Default for PointLight {
    fn default() -> Self {
        Self { color: Vec3::ONE, intensity: 1.0, range: None, shadows: true }
    }
}

#[derive(Component, Debug, Clone, Copy, PartialEq)]
#[require(Transform, Visibility)]
pub struct SpotLight {
    pub color: Vec3,
    /// Candela, on the axis.
    pub intensity: f32,
    pub range: Option<f32>,
    /// Radians from the axis where the falloff begins.
    pub inner_cone_angle: f32,
    /// Radians from the axis where the light ends (≤ π/2).
    pub outer_cone_angle: f32,
    pub shadows: bool,
}

impl Default for SpotLight {
    fn default() -> Self {
        Self {
            color: Vec3::ONE,
            intensity: 1.0,
            range: None,
            inner_cone_angle: 0.0,
            outer_cone_angle: std::f32::consts::FRAC_PI_4,
            shadows: true,
        }
    }
}

/// Uniform incoming radiance from the whole sphere.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
#[require(Visibility)]
pub struct AmbientLight {
    pub color: Vec3,
    /// cd/m².
    pub intensity: f32,
}

impl Default for AmbientLight {
    fn default() -> Self {
        Self { color: Vec3::ONE, intensity: 1.0 }
    }
}
