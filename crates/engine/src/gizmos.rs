//! [`Gizmos`]: debug lines drawn over the scene, depth-tested against it (hidden behind
//! surfaces, like the geometry they annotate). Immediate mode: whoever draws them (the viewer's
//! axes and selection box, a script's debug output) clears and refills the resource each frame;
//! extraction copies the lines when the resource changed, and the renderer draws them in the
//! forward pass after the scene. No lines, no gizmo pass and no gizmo pipeline.

use bevy_ecs::resource::Resource;
use glam::{Affine3A, Vec3};

use crate::bounds::Aabb;

/// One line segment, in world space, with a display colour (linear RGB, not exposed: red is red
/// whatever the camera's exposure).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GizmoLine {
    pub start: Vec3,
    pub end: Vec3,
    pub color: Vec3,
}

/// The axis colours of the convention used everywhere: X red, Y green, Z blue.
pub const AXIS_COLORS: [Vec3; 3] = [Vec3::new(1.0, 0.08, 0.08), Vec3::new(0.1, 0.9, 0.1), Vec3::new(0.15, 0.3, 1.0)];

#[derive(Resource, Debug, Clone, Default, PartialEq)]
pub struct Gizmos {
    lines: Vec<GizmoLine>,
}

impl Gizmos {
    pub fn clear(&mut self) {
        self.lines.clear();
    }

    pub fn line(&mut self, start: Vec3, end: Vec3, color: Vec3) {
        self.lines.push(GizmoLine { start, end, color });
    }

    /// A transform's local axes from its origin, `length` long in its local units (so they
    /// scale, rotate and shear with it).
    pub fn axes(&mut self, transform: &Affine3A, length: f32) {
        let origin: Vec3 = transform.translation.into();
        for (axis, color) in [Vec3::X, Vec3::Y, Vec3::Z].into_iter().zip(AXIS_COLORS) {
            self.line(origin, origin + transform.matrix3 * (axis * length), color);
        }
    }

    /// The twelve edges of a box.
    pub fn aabb(&mut self, b: &Aabb, color: Vec3) {
        if b.is_empty() {
            return;
        }
        let corner = |i: usize| {
            Vec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            )
        };
        for i in 0..8 {
            for bit in [1, 2, 4] {
                if i & bit == 0 {
                    self.line(corner(i), corner(i | bit), color);
                }
            }
        }
    }

    pub fn lines(&self) -> &[GizmoLine] {
        &self.lines
    }

    pub fn is_empty(&self) -> bool {
        self.lines.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_box_has_twelve_edges_each_along_one_axis() {
        let mut g = Gizmos::default();
        g.aabb(&Aabb { min: Vec3::ZERO, max: Vec3::new(1.0, 2.0, 3.0) }, Vec3::ONE);
        assert_eq!(g.lines().len(), 12);
        for l in g.lines() {
            let d = (l.end - l.start).abs();
            assert_eq!([d.x, d.y, d.z].iter().filter(|c| **c > 0.0).count(), 1, "{l:?}");
        }
        g.clear();
        g.aabb(&Aabb::EMPTY, Vec3::ONE);
        assert!(g.is_empty());
    }

    #[test]
    fn axes_follow_the_transform() {
        let mut g = Gizmos::default();
        let t = Affine3A::from_scale_rotation_translation(
            Vec3::splat(2.0),
            glam::Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
            Vec3::new(5.0, 0.0, 0.0),
        );
        g.axes(&t, 1.0);
        let x = g.lines()[0];
        assert!((x.start - Vec3::new(5.0, 0.0, 0.0)).length() < 1e-5);
        // Local X turned a quarter about Z is world +Y, twice as long.
        assert!((x.end - Vec3::new(5.0, 2.0, 0.0)).length() < 1e-5, "{x:?}");
        assert_eq!(x.color, AXIS_COLORS[0]);
    }
}
