//! `Camera`: projection and exposure. The view is the entity's `GlobalTransform` (looking down −Z).
//!
//! Projections are reverse-Z (near maps to depth 1, far to 0): floating-point depth is densest
//! near 0, and reverse-Z spends that density far away where perspective needs it. Perspective
//! cameras use an infinite far plane, so no scene is ever clipped at the back.

use bevy_ecs::prelude::*;
use glam::{Mat4, Vec4};

use super::transform::Transform;
use super::visibility::Visibility;

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Projection {
    /// `aspect_ratio: None` follows the render target.
    Perspective { yfov: f32, znear: f32, aspect_ratio: Option<f32> },
    /// Half-extents `xmag`/`ymag` as in glTF; `xmag: None` follows the target's aspect.
    Orthographic { xmag: Option<f32>, ymag: f32, znear: f32, zfar: f32 },
}

impl Default for Projection {
    fn default() -> Self {
        Projection::Perspective { yfov: 45f32.to_radians(), znear: 0.1, aspect_ratio: None }
    }
}

impl Projection {
    /// `clip_from_view` for a target of the given aspect (width / height).
    pub fn clip_from_view(&self, target_aspect: f32) -> Mat4 {
        match *self {
            Projection::Perspective { yfov, znear, aspect_ratio } => {
                reverse_z_infinite_perspective(yfov, aspect_ratio.unwrap_or(target_aspect), znear)
            }
            Projection::Orthographic { xmag, ymag, znear, zfar } => {
                reverse_z_orthographic(xmag.unwrap_or(ymag * target_aspect), ymag, znear, zfar)
            }
        }
    }

    pub fn znear(&self) -> f32 {
        match *self {
            Projection::Perspective { znear, .. } | Projection::Orthographic { znear, .. } => znear,
        }
    }
}

/// Right-handed, looking down −Z, clip depth `znear / −z_view`: 1 at the near plane, → 0 at
/// infinity. Written out because glam 0.34 has no reverse-Z infinite projection.
pub fn reverse_z_infinite_perspective(yfov: f32, aspect: f32, znear: f32) -> Mat4 {
    let f = 1.0 / (0.5 * yfov).tan();
    Mat4::from_cols(
        Vec4::new(f / aspect, 0.0, 0.0, 0.0),
        Vec4::new(0.0, f, 0.0, 0.0),
        Vec4::new(0.0, 0.0, 0.0, -1.0),
        Vec4::new(0.0, 0.0, znear, 0.0),
    )
}

/// Right-handed orthographic with depth 1 at `−znear` and 0 at `−zfar`.
pub fn reverse_z_orthographic(xmag: f32, ymag: f32, znear: f32, zfar: f32) -> Mat4 {
    let inv_depth = 1.0 / (zfar - znear);
    Mat4::from_cols(
        Vec4::new(1.0 / xmag, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 1.0 / ymag, 0.0, 0.0),
        Vec4::new(0.0, 0.0, inv_depth, 0.0),
        Vec4::new(0.0, 0.0, zfar * inv_depth, 1.0),
    )
}

/// Photographic exposure as EV100 (ISO 100). The scene's linear radiance is multiplied by
/// [`Exposure::scale`] before tonemapping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exposure {
    pub ev100: f32,
}

impl Exposure {
    /// EV100 0 gives a scale of 1/1.2: glTF sample scenes, authored for viewers that apply no
    /// exposure, come out at their intended brightness.
    pub const INDOOR_DEFAULT: Exposure = Exposure { ev100: 0.0 };

    /// Exposure that makes the pre-tonemap value equal to radiance (scale exactly 1).
    pub fn unit() -> Self {
        Exposure { ev100: (1.0f32 / 1.2).log2() }
    }

    /// Saturation-based exposure, `1 / (1.2 · 2^EV100)` (Lagarde & de Rousiers 2014, "Moving
    /// Frostbite to PBR", §5.1; the 1.2 is the ISO 2720 calibration constant 78/(100·0.65)).
    pub fn scale(&self) -> f32 {
        1.0 / (1.2 * 2f32.powf(self.ev100))
    }
}

impl Default for Exposure {
    fn default() -> Self {
        Self::INDOOR_DEFAULT
    }
}

#[derive(Component, Debug, Clone, Copy, PartialEq)]
#[require(Transform, Visibility)]
pub struct Camera {
    pub projection: Projection,
    pub exposure: Exposure,
    /// Inactive cameras are not rendered.
    pub is_active: bool,
    /// Among active cameras rendering to the same target, the highest order wins.
    pub order: i32,
}

impl Default for Camera {
    fn default() -> Self {
        Self { projection: Projection::default(), exposure: Exposure::default(), is_active: true, order: 0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn depth(m: Mat4, z_view: f32) -> f32 {
        let c = m * Vec3::new(0.0, 0.0, z_view).extend(1.0);
        c.z / c.w
    }

    #[test]
    fn reverse_z_perspective_maps_near_to_one_and_far_towards_zero() {
        let m = reverse_z_infinite_perspective(1.0, 1.5, 0.1);
        assert!((depth(m, -0.1) - 1.0).abs() < 1e-6);
        assert!(depth(m, -1.0e6) > 0.0 && depth(m, -1.0e6) < 1e-6);
        assert!(depth(m, -1.0) > depth(m, -2.0), "closer is greater");
    }

    #[test]
    fn reverse_z_orthographic_maps_near_to_one_and_far_to_zero() {
        let m = reverse_z_orthographic(2.0, 1.0, 0.5, 100.0);
        assert!((depth(m, -0.5) - 1.0).abs() < 1e-6);
        assert!(depth(m, -100.0).abs() < 1e-6);
    }

    #[test]
    fn unit_exposure_scale_is_one() {
        assert!((Exposure::unit().scale() - 1.0).abs() < 1e-6);
    }
}
