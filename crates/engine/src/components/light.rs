//! Light components, in the photometric units of glTF's KHR_lights_punctual: directional lights
//! in lux (lm/m²), point and spot lights in candela (lm/sr). Lights shine down their local −Z.
//! `AmbientLight` is uniform radiance from every direction, in cd/m² (nits).
//!
//! Area lights have a size. `SphereLight` and `TubeLight` take a point light's units (candela,
//! as seen from afar; a tube broadside), so that shrinking one to nothing leaves the point light
//! of the same intensity. `RectLight` and `DiskLight` are one-sided emitting surfaces facing
//! their local −Z, given by their luminance in cd/m². Sizes are in metres and ignore the
//! transform's scale (a scaled parent does not resize a light).
//!
//! `IesLight` is a point light whose intensity in each direction comes from a measured
//! luminaire's IES LM-63 profile (candela, as the file gives them), turned with the entity:
//! the profile's nadir along local −Z, its C = 0° plane through local +X.

use bevy_ecs::prelude::*;
use glam::Vec3;

use crate::assets::Handle;
use crate::ies::IesProfile;

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
    /// Angular radius of the light's disk, in radians: how soft its shadows' penumbrae are
    /// with PCSS filtering (the sun's, about 0.27°, by default).
    pub angular_radius: f32,
}

/// The sun's angular radius seen from the Earth (0.266°), in radians.
pub const SUN_ANGULAR_RADIUS: f32 = 0.004_65;

impl Default for DirectionalLight {
    fn default() -> Self {
        Self { color: Vec3::ONE, illuminance: 1.0, shadows: true, angular_radius: SUN_ANGULAR_RADIUS }
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

/// A glowing ball of `radius` metres: lights like a point light from outside, with the broad,
/// round highlight of its size.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
#[require(Transform, Visibility)]
pub struct SphereLight {
    pub color: Vec3,
    /// Candela, as a point light of the same intensity.
    pub intensity: f32,
    /// Metres.
    pub radius: f32,
    pub range: Option<f32>,
    pub shadows: bool,
}

impl Default for SphereLight {
    fn default() -> Self {
        Self { color: Vec3::ONE, intensity: 1.0, radius: 0.05, range: None, shadows: true }
    }
}

/// A glowing capsule (a fluorescent tube) along the light's local X axis: `length` metres
/// between the centres of its round ends, `radius` metres thick.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
#[require(Transform, Visibility)]
pub struct TubeLight {
    pub color: Vec3,
    /// Candela, seen broadside from afar (spread evenly along the length).
    pub intensity: f32,
    pub length: f32,
    pub radius: f32,
    pub range: Option<f32>,
    pub shadows: bool,
}

impl Default for TubeLight {
    fn default() -> Self {
        Self { color: Vec3::ONE, intensity: 1.0, length: 1.0, radius: 0.02, range: None, shadows: true }
    }
}

/// A one-sided emitting rectangle centred on the entity, `width` along local X and `height`
/// along local Y, shining down local −Z (a softbox, a window, a panel light).
#[derive(Component, Debug, Clone, Copy, PartialEq)]
#[require(Transform, Visibility)]
pub struct RectLight {
    pub color: Vec3,
    /// cd/m² of the emitting face.
    pub luminance: f32,
    pub width: f32,
    pub height: f32,
    pub range: Option<f32>,
    pub shadows: bool,
}

impl Default for RectLight {
    fn default() -> Self {
        Self { color: Vec3::ONE, luminance: 1.0, width: 1.0, height: 1.0, range: None, shadows: true }
    }
}

/// A one-sided emitting disk of `radius` metres in the local XY plane, shining down local −Z.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
#[require(Transform, Visibility)]
pub struct DiskLight {
    pub color: Vec3,
    /// cd/m² of the emitting face.
    pub luminance: f32,
    pub radius: f32,
    pub range: Option<f32>,
    pub shadows: bool,
}

impl Default for DiskLight {
    fn default() -> Self {
        Self { color: Vec3::ONE, luminance: 1.0, radius: 0.5, range: None, shadows: true }
    }
}

/// A point light shaped by a measured luminaire's photometric profile (see [`crate::ies`]).
#[derive(Component, Debug, Clone, Copy, PartialEq)]
#[require(Transform, Visibility)]
pub struct IesLight {
    pub profile: Handle<IesProfile>,
    /// Linear RGB tint (the profile says how much light, not its colour).
    pub color: Vec3,
    /// Multiplies the profile's candela (1: as measured).
    pub scale: f32,
    pub range: Option<f32>,
    pub shadows: bool,
}

impl IesLight {
    /// White, as measured.
    pub fn new(profile: Handle<IesProfile>) -> Self {
        Self { profile, color: Vec3::ONE, scale: 1.0, range: None, shadows: true }
    }
}
