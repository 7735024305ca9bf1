//! Orbit camera: a target point, a distance, yaw and pitch. Input sets the goal; the camera
//! eases towards it with an exponential filter whose rate is per second, so motion feels the
//! same at 30 and 240 frames per second.

use glam::{Quat, Vec3};
use penumbra_engine::components::Transform;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrbitState {
    pub target: Vec3,
    pub distance: f32,
    /// Radians about +Y, 0 looking down −Z.
    pub yaw: f32,
    /// Radians, positive looking down on the target.
    pub pitch: f32,
}

impl OrbitState {
    /// The state that reproduces a camera at `eye` looking at `target`.
    pub fn looking_at(eye: Vec3, target: Vec3) -> Self {
        let offset = eye - target;
        let distance = offset.length().max(1e-6);
        let dir = offset / distance;
        Self { target, distance, yaw: dir.x.atan2(dir.z), pitch: dir.y.clamp(-1.0, 1.0).asin() }
    }

    pub fn transform(&self) -> Transform {
        let rotation = Quat::from_rotation_y(self.yaw) * Quat::from_rotation_x(-self.pitch);
        Transform::from_translation(self.target + rotation * Vec3::Z * self.distance).with_rotation(rotation)
    }
}

pub struct OrbitCamera {
    pub current: OrbitState,
    pub goal: OrbitState,
    /// Distances below this are not allowed (zooming through the target).
    pub min_distance: f32,
}

/// How fast the camera closes the gap to its goal: 1 − e^(−rate·dt) of it per frame.
const SMOOTHING_RATE: f32 = 18.0;
const PITCH_LIMIT: f32 = 1.55;
/// The fraction of the way to the point under the cursor one wheel notch moves the camera.
pub const ZOOM_STEP: f32 = 0.12;

impl OrbitCamera {
    pub fn new(state: OrbitState) -> Self {
        Self { current: state, goal: state, min_distance: state.distance * 1e-3 }
    }

    /// Left drag: pixels to radians (a full window width turns half a circle).
    pub fn orbit(&mut self, dx: f32, dy: f32, window_height: f32) {
        let k = std::f32::consts::PI / window_height.max(1.0);
        self.goal.yaw -= dx * k;
        self.goal.pitch = (self.goal.pitch + dy * k).clamp(-PITCH_LIMIT, PITCH_LIMIT);
    }

    /// Middle or shift drag: the target moves with the cursor in the view plane.
    pub fn pan(&mut self, dx: f32, dy: f32, window_height: f32, yfov: f32) {
        let world_per_pixel = 2.0 * self.goal.distance * (0.5 * yfov).tan() / window_height.max(1.0);
        let t = self.goal.transform();
        let right = t.rotation * Vec3::X;
        let up = t.rotation * Vec3::Y;
        self.goal.target += (-dx * right + dy * up) * world_per_pixel;
    }

    /// Wheel: each notch in moves the camera [`ZOOM_STEP`] of the way to `towards` (the surface
    /// or the point under the cursor; without one, the target), so it never reaches or passes
    /// it; a notch out undoes one in. The target moves along in proportion.
    pub fn zoom(&mut self, notches: f32, towards: Option<Vec3>) {
        let factor = (1.0 - ZOOM_STEP).powf(notches);
        let new_distance = (self.goal.distance * factor).max(self.min_distance);
        if let Some(p) = towards {
            let moved = 1.0 - new_distance / self.goal.distance;
            self.goal.target += (p - self.goal.target) * moved;
        }
        self.goal.distance = new_distance;
    }

    /// Advances the eased state by `dt` seconds.
    pub fn update(&mut self, dt: f32) -> Transform {
        let a = 1.0 - (-SMOOTHING_RATE * dt.max(0.0)).exp();
        let (c, g) = (&mut self.current, &self.goal);
        c.target = c.target.lerp(g.target, a);
        // Distance eases in log space so zooming feels uniform at every scale.
        c.distance = (c.distance.ln() + (g.distance.ln() - c.distance.ln()) * a).exp();
        c.yaw += (g.yaw - c.yaw) * a;
        c.pitch += (g.pitch - c.pitch) * a;
        // Close enough to see no difference: arrive. Exponential easing alone never does, and a
        // camera still creeping by float noise redraws a different image every frame.
        const ARRIVED: f32 = 1e-5;
        if (c.target - g.target).length() <= ARRIVED * g.distance
            && (c.distance / g.distance - 1.0).abs() <= ARRIVED
            && (c.yaw - g.yaw).abs() <= ARRIVED
            && (c.pitch - g.pitch).abs() <= ARRIVED
        {
            *c = *g;
        }
        c.transform()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn looking_at_round_trips() {
        let s = OrbitState::looking_at(Vec3::new(3.0, 2.0, 5.0), Vec3::new(1.0, 0.0, 0.0));
        let t = s.transform();
        assert!((t.translation - Vec3::new(3.0, 2.0, 5.0)).length() < 1e-4);
        let forward = t.rotation * Vec3::NEG_Z;
        assert!((forward - (Vec3::new(1.0, 0.0, 0.0) - t.translation).normalize()).length() < 1e-4);
    }

    #[test]
    fn the_camera_arrives_exactly_and_then_stays_still() {
        let start = OrbitState { target: Vec3::ZERO, distance: 10.0, yaw: 0.0, pitch: 0.0 };
        let mut cam = OrbitCamera::new(start);
        cam.orbit(100.0, 20.0, 500.0);
        cam.zoom(2.0, Some(Vec3::new(1.0, 0.5, 0.0)));
        let mut frames = 0;
        while cam.current != cam.goal {
            cam.update(1.0 / 60.0);
            frames += 1;
            assert!(frames < 600, "still easing after 10 s: {:?} vs {:?}", cam.current, cam.goal);
        }
        let settled = cam.update(1.0 / 60.0);
        assert_eq!(cam.update(1.0 / 60.0), settled);
    }

    #[test]
    fn zooming_in_never_passes_the_point_it_heads_for() {
        let start = OrbitState { target: Vec3::ZERO, distance: 10.0, yaw: 0.3, pitch: 0.2 };
        let mut cam = OrbitCamera::new(start);
        // A surface point between the camera and the target, off the axis.
        let eye = start.transform().translation;
        let surface = eye.lerp(Vec3::new(0.5, 0.2, 0.0), 0.6);
        let mut last = eye.distance(surface);
        for notch in 0..200 {
            cam.zoom(1.0, Some(surface));
            let now = cam.goal.transform().translation;
            let gap = now.distance(surface);
            // Each notch covers ZOOM_STEP of what is left, and the camera stays on its side.
            assert!(
                (gap / last - (1.0 - ZOOM_STEP)).abs() < 1e-3 || cam.goal.distance <= cam.min_distance * 1.0001,
                "notch {notch}: {last} -> {gap}"
            );
            assert!((surface - now).dot(eye - surface) < 0.0, "notch {notch}: passed the surface");
            last = gap;
        }
        // Out again: one notch out undoes one in.
        let mut cam = OrbitCamera::new(start);
        cam.zoom(1.0, None);
        cam.zoom(-1.0, None);
        assert!((cam.goal.distance - start.distance).abs() < 1e-4);
    }

    #[test]
    fn easing_is_frame_rate_independent() {
        let start = OrbitState { target: Vec3::ZERO, distance: 10.0, yaw: 0.0, pitch: 0.0 };
        let run = |steps: u32| {
            let mut cam = OrbitCamera::new(start);
            cam.orbit(100.0, 0.0, 500.0);
            for _ in 0..steps {
                cam.update(0.25 / steps as f32);
            }
            cam.current.yaw
        };
        assert!((run(8) - run(64)).abs() < 1e-3);
    }
}
