//! Axis-aligned bounding boxes: computed per mesh at import, transformed to world space for
//! auto-framing and (later) culling.

use glam::{Affine3A, Vec3, Vec3A};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    /// The empty box: `union` with it is the identity.
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    /// Bounds of the finite points; non-finite points are skipped.
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a Vec3>) -> Aabb {
        let mut b = Aabb::EMPTY;
        for p in points {
            if p.is_finite() {
                b.min = b.min.min(*p);
                b.max = b.max.max(*p);
            }
        }
        b
    }

    pub fn is_empty(&self) -> bool {
        !(self.min.cmple(self.max).all())
    }

    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    pub fn half_extents(&self) -> Vec3 {
        0.5 * (self.max - self.min)
    }

    /// Tight bounds of the transformed box (Arvo 1990: abs of the linear part times the extents).
    pub fn transformed(&self, world_from_local: &Affine3A) -> Aabb {
        if self.is_empty() {
            return *self;
        }
        let center = world_from_local.transform_point3a(Vec3A::from(self.center()));
        let m = world_from_local.matrix3;
        let abs = glam::Mat3A::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs());
        let half = abs * Vec3A::from(self.half_extents());
        Aabb { min: (center - half).into(), max: (center + half).into() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;

    #[test]
    fn rotated_box_bounds_contain_every_corner() {
        let b = Aabb { min: Vec3::new(-1.0, -2.0, -3.0), max: Vec3::new(1.0, 2.0, 3.0) };
        let t = Affine3A::from_rotation_translation(Quat::from_rotation_y(0.7), Vec3::new(5.0, 0.0, 0.0));
        let w = b.transformed(&t);
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            );
            let p = t.transform_point3(c);
            assert!(p.cmpge(w.min - 1e-5).all() && p.cmple(w.max + 1e-5).all());
        }
    }

    #[test]
    fn non_finite_points_are_ignored() {
        let pts = [Vec3::ONE, Vec3::splat(f32::NAN), Vec3::ZERO];
        let b = Aabb::from_points(&pts);
        assert_eq!(b, Aabb { min: Vec3::ZERO, max: Vec3::ONE });
        assert!(Aabb::from_points(&[]).is_empty());
    }
}
