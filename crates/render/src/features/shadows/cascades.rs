//! Cascaded shadow maps for directional lights: where the view's depth range is split (the
//! practical split scheme of Zhang et al. 2006, a blend of logarithmic and uniform splits), and
//! each cascade's orthographic light projection, sized by the bounding sphere of its slice of
//! the view frustum and snapped to whole shadow-map texels (Valient, "Shadows in Killzone 3",
//! 2012), so that moving the camera moves a cascade by whole texels or not at all and turning
//! it never changes the cascade's size: shadow edges do not swim.
//!
//! Everything is computed in f64 from world-space positions, so a scene 1000 km from the origin
//! snaps exactly as one at it; the matrix the shaders get maps camera-relative positions (as
//! every other matrix in the shaders does) and is rounded to f32 once, at the end.

use glam::{DAffine3, DMat4, DVec3, DVec4, Mat4, Vec3};
use penumbra_engine::components::Projection;

/// The `count + 1` view depths bounding `count` cascades from `near` to `far`: each split is
/// `lambda` of the way from the uniform split to the logarithmic one.
pub fn practical_splits(near: f32, far: f32, count: u32, lambda: f32) -> Vec<f32> {
    let (n, f) = (near as f64, far as f64);
    // The logarithmic term needs a near plane above 0 (glTF allows an orthographic znear of 0):
    // it starts from a millionth of the range instead.
    let log_near = n.max(f * 1e-6);
    let mut splits: Vec<f32> = (0..=count)
        .map(|i| {
            let t = i as f64 / count as f64;
            let log = log_near * (f / log_near).powf(t);
            let uniform = n + (f - n) * t;
            (lambda as f64 * log + (1.0 - lambda as f64) * uniform) as f32
        })
        .collect();
    // Exact ends, whatever the rounding above.
    splits[0] = near;
    splits[count as usize] = far;
    splits
}

/// One cascade's projection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cascade {
    /// Light clip space (x, y in −1..1; reverse-Z depth, 1 nearest the light) from world space.
    pub clip_from_world: DMat4,
    /// The same from camera-relative positions: what the shaders use.
    pub clip_from_rel: Mat4,
    /// View depths the cascade covers.
    pub near: f32,
    pub far: f32,
    /// World-space size of one shadow-map texel (the map spans `resolution` of them).
    pub texel_size: f64,
    /// Radius of the sphere bounding the cascade's slice of the view frustum.
    pub radius: f64,
}

/// The camera a cascade is fitted to.
#[derive(Debug, Clone, Copy)]
pub struct CascadeCamera {
    /// Placement (rotation and translation only), in f64.
    pub world_from_view: DAffine3,
    pub projection: Projection,
    /// Width over height of the target.
    pub aspect: f32,
}

/// Centre (as a distance along the view direction) and radius of the smallest sphere around the
/// slice of the view volume between view depths `near` and `far`. It depends on the slice's
/// shape alone, never on the camera's orientation, so turning the camera cannot resize it.
fn slice_sphere(projection: &Projection, aspect: f64, near: f64, far: f64) -> (f64, f64) {
    match *projection {
        Projection::Perspective { yfov, aspect_ratio, .. } => {
            let aspect = aspect_ratio.map_or(aspect, f64::from);
            // Tangent of the half-angle to the frustum's corner edges.
            let t = (0.5 * yfov as f64).tan();
            let k2 = t * t * (1.0 + aspect * aspect);
            // On the axis, equidistant from the near and far corners; past the far plane the
            // far cap's corners alone decide.
            let centre = (0.5 * (far + near) * (1.0 + k2)).min(far);
            let to_far = ((far - centre).powi(2) + far * far * k2).sqrt();
            let to_near = ((centre - near).powi(2) + near * near * k2).sqrt();
            (centre, to_far.max(to_near))
        }
        Projection::Orthographic { xmag, ymag, .. } => {
            let ymag = ymag as f64;
            let xmag = xmag.map_or(ymag * aspect, f64::from);
            (0.5 * (near + far), (0.25 * (far - near).powi(2) + xmag * xmag + ymag * ymag).sqrt())
        }
    }
}

/// World from light-view rotation for light travelling along `direction` (unit): the light looks
/// down its −Z. The up vector is fixed by the direction alone, so the light's frame does not turn
/// with the camera.
fn light_rotation(direction: DVec3) -> DMat4 {
    let forward = direction.normalize();
    let up = if forward.y.abs() < 0.99 { DVec3::Y } else { DVec3::Z };
    let right = forward.cross(up).normalize();
    let up = right.cross(forward);
    // Rows: right, up, −forward.
    DMat4::from_cols(
        DVec4::new(right.x, up.x, -forward.x, 0.0),
        DVec4::new(right.y, up.y, -forward.y, 0.0),
        DVec4::new(right.z, up.z, -forward.z, 0.0),
        DVec4::W,
    )
}

/// Fits the cascade covering view depths `near..far` for a light travelling along `direction`,
/// on a `resolution`² map; `caster_reach` is how far beyond the slice, toward the light, objects
/// may still cast into it.
pub fn fit_cascade(
    camera: &CascadeCamera,
    near: f32,
    far: f32,
    direction: Vec3,
    resolution: u32,
    caster_reach: f32,
) -> Cascade {
    let (centre_depth, radius) = slice_sphere(&camera.projection, camera.aspect as f64, near as f64, far as f64);
    let view_dir = camera.world_from_view.matrix3.mul_vec3(DVec3::NEG_Z).normalize();
    let eye = camera.world_from_view.translation;
    let centre = eye + view_dir * centre_depth;
    let light_from_world = light_rotation(direction.as_dvec3());
    // Snap the sphere's centre, in the light's frame, to whole texels on all three axes: across
    // the map so that edges move by whole texels, and in depth so that the depth mapping does
    // not change either while the camera moves less than a texel. The snapped centre is up to
    // half a texel off the true one, so the map reaches half a texel past the sphere on every
    // side: `resolution` texels of 2r / (resolution − 1) each.
    let texel = 2.0 * radius / (resolution.max(2) - 1) as f64;
    let half_extent = radius + 0.5 * texel;
    let c = light_from_world.transform_point3(centre);
    let snapped = (c / texel).round() * texel;
    // The light's eye sits above the sphere (toward the light) by the caster reach.
    let reach = caster_reach.max(0.0) as f64;
    let depth_range = 2.0 * half_extent + reach;
    let eye_in_light = DVec3::new(snapped.x, snapped.y, snapped.z + half_extent + reach);
    let view_from_world = DMat4::from_translation(-eye_in_light) * light_from_world;
    // Reverse-Z orthographic: depth 1 at the light's eye, 0 past the far side of the sphere.
    let clip_from_view = DMat4::from_cols(
        DVec4::new(1.0 / half_extent, 0.0, 0.0, 0.0),
        DVec4::new(0.0, 1.0 / half_extent, 0.0, 0.0),
        DVec4::new(0.0, 0.0, 1.0 / depth_range, 0.0),
        DVec4::new(0.0, 0.0, 1.0, 1.0),
    );
    let clip_from_world = clip_from_view * view_from_world;
    let clip_from_rel = (clip_from_world * DMat4::from_translation(eye)).as_mat4();
    Cascade { clip_from_world, clip_from_rel, near, far, texel_size: texel, radius }
}

/// The eight corners (world space) of the slice of the view between view depths `start` and
/// `far` (`start` below 0 counts as 0: the camera's position).
pub fn slice_corners(camera: &CascadeCamera, start: f64, far: f64) -> [DVec3; 8] {
    let (tx, ty, ortho) = match camera.projection {
        Projection::Perspective { yfov, aspect_ratio, .. } => {
            let ty = (yfov as f64 * 0.5).tan();
            (ty * aspect_ratio.unwrap_or(camera.aspect) as f64, ty, false)
        }
        Projection::Orthographic { xmag, ymag, .. } => (xmag.unwrap_or(ymag * camera.aspect) as f64, ymag as f64, true),
    };
    let mut corners = [DVec3::ZERO; 8];
    for (i, c) in corners.iter_mut().enumerate() {
        let depth = if i & 4 == 0 { start.max(0.0) } else { far };
        let scale = if ortho { 1.0 } else { depth };
        let x = if i & 1 == 0 { -tx } else { tx } * scale;
        let y = if i & 2 == 0 { -ty } else { ty } * scale;
        *c = camera.world_from_view.transform_point3(DVec3::new(x, y, -depth));
    }
    corners
}

/// The planes (world space, `xyz · p + w >= 0` inside, unit normals) bounding the slice of the
/// view between view depths `start` and `far` (`start` below 0 counts as 0): its four sides and
/// its two depth planes (for a perspective camera none in front where `start <= 0`: the slice
/// narrows to the camera).
pub fn slice_planes(camera: &CascadeCamera, start: f64, far: f64) -> Vec<DVec4> {
    let mut view_planes: Vec<DVec4> = Vec::with_capacity(6);
    match camera.projection {
        Projection::Perspective { yfov, aspect_ratio, .. } => {
            let ty = (yfov as f64 * 0.5).tan();
            let tx = ty * aspect_ratio.unwrap_or(camera.aspect) as f64;
            // Looking down −z: x >= z·tx on the left, and so on.
            view_planes.extend([
                DVec4::new(1.0, 0.0, -tx, 0.0),
                DVec4::new(-1.0, 0.0, -tx, 0.0),
                DVec4::new(0.0, 1.0, -ty, 0.0),
                DVec4::new(0.0, -1.0, -ty, 0.0),
            ]);
        }
        Projection::Orthographic { xmag, ymag, .. } => {
            let (ty, tx) = (ymag as f64, xmag.unwrap_or(ymag * camera.aspect) as f64);
            view_planes.extend([
                DVec4::new(1.0, 0.0, 0.0, tx),
                DVec4::new(-1.0, 0.0, 0.0, tx),
                DVec4::new(0.0, 1.0, 0.0, ty),
                DVec4::new(0.0, -1.0, 0.0, ty),
            ]);
        }
    }
    // A perspective slice starting at the camera narrows to it; an orthographic one starts at
    // the camera's plane.
    if start > 0.0 || matches!(camera.projection, Projection::Orthographic { .. }) {
        view_planes.push(DVec4::new(0.0, 0.0, -1.0, -start.max(0.0)));
    }
    view_planes.push(DVec4::new(0.0, 0.0, 1.0, far));
    let eye = camera.world_from_view.translation;
    view_planes
        .into_iter()
        .map(|p| {
            let length = p.truncate().length();
            let normal = camera.world_from_view.matrix3.mul_vec3(p.truncate() / length);
            // Through the eye in view space: n · (x − eye) + w >= 0.
            normal.extend(p.w / length - normal.dot(eye))
        })
        .collect()
}

/// Planes (world space, `xyz · p + w >= 0` inside, unit normals) bounding every caster that can
/// shadow a point of a slice of the view, the receivers that read one cascade: of the planes
/// bounding that slice (`slice`, from [`slice_planes`]), those whose inward normal faces the
/// light, each moved out by `margin` metres. A caster's shadow falls
/// away from the light, so a caster that can shadow a point of the slice lies on that point's
/// ray toward the light, inside every plane the slice's sweep toward the light does not cross;
/// planes nearly along the light are left out (which only keeps more).
pub fn receiver_planes(slice: &[DVec4], towards_light: DVec3, margin: f64) -> Vec<DVec4> {
    let light = towards_light.normalize();
    slice.iter().filter(|p| p.truncate().dot(light) > 1e-3).map(|p| *p + DVec4::W * margin).collect()
}

/// The view depths bounding the camera's cascades, from its near plane to `max_distance`.
pub fn cascade_splits(camera: &CascadeCamera, settings: &super::ShadowSettings) -> Vec<f32> {
    let near = camera.projection.znear();
    let far = match camera.projection {
        Projection::Orthographic { zfar, .. } => zfar.min(settings.max_distance),
        Projection::Perspective { .. } => settings.max_distance,
    }
    .max(near * 1.0001);
    practical_splits(near, far, settings.cascades, settings.split_lambda)
}

/// Every cascade for the camera, from its near plane to `max_distance`.
pub fn fit_cascades(
    camera: &CascadeCamera,
    direction: Vec3,
    settings: &super::ShadowSettings,
    caster_reach: f32,
) -> Vec<Cascade> {
    let splits = cascade_splits(camera, settings);
    splits.windows(2).map(|w| fit_cascade(camera, w[0], w[1], direction, settings.atlas_size, caster_reach)).collect()
}

/// How far above the top of the sphere bounding the slice `near..far` (toward the light) the
/// map must reach so that the highest caster, `caster_top` (the largest `dot(p, −direction)` of
/// any caster point, world space), still lands in it: 0 when every caster lies below the top,
/// else rounded up to a power of two times `texel`, so that a moving camera changes it (and with
/// it the depth mapping) only when it crosses a doubling, never by a little every frame.
pub fn caster_reach(
    camera: &CascadeCamera,
    near: f32,
    far: f32,
    direction: Vec3,
    resolution: u32,
    caster_top: f64,
) -> f32 {
    let (centre_depth, radius) = slice_sphere(&camera.projection, camera.aspect as f64, near as f64, far as f64);
    let view_dir = camera.world_from_view.matrix3.mul_vec3(DVec3::NEG_Z).normalize();
    let centre = camera.world_from_view.translation + view_dir * centre_depth;
    let towards_light = -direction.as_dvec3().normalize();
    let texel = 2.0 * radius / (resolution.max(2) - 1) as f64;
    let needed = caster_top - (centre.dot(towards_light) + radius);
    if needed.is_nan() || needed <= 0.0 || texel <= 0.0 {
        return 0.0;
    }
    // One texel more keeps a caster exactly at the top off the clip plane.
    let texels = (needed / texel + 1.0).max(1.0);
    (texel * texels.log2().ceil().exp2()).min(f32::MAX as f64) as f32
}

/// [`fit_cascades`] with each cascade reaching up to the highest caster (see [`caster_reach`]).
pub fn fit_cascades_to_casters(
    camera: &CascadeCamera,
    direction: Vec3,
    settings: &super::ShadowSettings,
    caster_top: f64,
) -> Vec<Cascade> {
    let splits = cascade_splits(camera, settings);
    splits
        .windows(2)
        .map(|w| {
            let reach = caster_reach(camera, w[0], w[1], direction, settings.atlas_size, caster_top);
            fit_cascade(camera, w[0], w[1], direction, settings.atlas_size, reach)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::shadows::ShadowSettings;
    use glam::DQuat;

    /// Every caster that can shadow a point of the slice (the point moved toward the light, also
    /// from points up to `margin` beside the slice) lies inside the receiver planes, for several
    /// light directions, including lights from behind the camera and grazing ones; points beyond
    /// the slice's far end away from the light, and far beside the view, lie outside one. The
    /// slice's corners lie inside the planes by the margin, and a camera moved by less than the
    /// margin still has its corners inside (what keeps a drawn layer), by more not.
    #[test]
    fn receiver_planes_hold_every_caster_that_can_shadow_the_slice() {
        let camera = camera_at(DVec3::new(1e6, 30.0, -2e5), DQuat::from_rotation_y(0.7) * DQuat::from_rotation_x(-0.4));
        let (start, far, margin) = (12.0, 40.0, 0.05);
        let inside = |planes: &[DVec4], p: DVec3, by: f64| planes.iter().all(|q| q.truncate().dot(p) + q.w >= by);
        let lights = [
            DVec3::new(0.3, 1.0, 0.6),
            DVec3::new(-0.2, 0.3, -1.0),
            DVec3::new(0.0, 0.05, 1.0),
            DVec3::new(1.0, 0.001, 0.0),
            DVec3::new(0.0, -1.0, 0.0),
        ];
        let corners = slice_corners(&camera, start, far);
        for light in lights {
            let l = light.normalize();
            let planes = receiver_planes(&slice_planes(&camera, start, far), l, margin);
            // Points of the slice (blends of its corners), and casters up to 1 km toward the light.
            let mut state = 0x9E37_79B9_7F4A_7C15u64;
            let mut next = || {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (state >> 11) as f64 / (1u64 << 53) as f64
            };
            for _ in 0..2000 {
                let w: Vec<f64> = (0..8).map(|_| next()).collect();
                let sum: f64 = w.iter().sum();
                let r = corners.iter().zip(&w).fold(DVec3::ZERO, |acc, (c, w)| acc + *c * (*w / sum));
                let t = next() * 1000.0;
                let beside = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize_or_zero() * margin * 0.99;
                assert!(inside(&planes, r + beside + l * t, -1e-6), "light {light}: a caster of the slice is culled");
            }
            for c in corners {
                assert!(inside(&planes, c, margin - 1e-6), "light {light}: a corner within the margin");
            }
            // The far end's plane culls what lies beyond it, away from a light above the view.
            if light == lights[0] {
                let beyond = camera.world_from_view.transform_point3(DVec3::new(0.0, 0.0, -(far + 5.0)));
                assert!(!inside(&planes, beyond - l * 20.0, 0.0), "beyond the slice, away from the light");
            }
        }
        // A moved camera's slice stays inside the planes made for the old pose while the move is
        // under the slack (the planes' margin beyond the reach).
        let (reach, slack) = (0.02, 0.03);
        let planes = receiver_planes(&slice_planes(&camera, start, far), lights[0].normalize(), reach + slack);
        let moved = |d: f64| {
            let mut c = camera;
            c.world_from_view.translation += DVec3::new(d, 0.0, 0.0);
            slice_corners(&c, start, far)
        };
        assert!(moved(0.02).iter().all(|c| inside(&planes, *c, reach)));
        assert!(!moved(0.2).iter().all(|c| inside(&planes, *c, reach)));
    }

    /// An orthographic slice is the box between its depth planes and its sides: its corners lie
    /// on its planes, its centre inside, and points behind the camera, beyond the far end or
    /// beside it outside.
    #[test]
    fn an_orthographic_slice_is_bounded_on_every_side() {
        let camera = CascadeCamera {
            world_from_view: DAffine3::from_rotation_translation(
                DQuat::from_rotation_y(0.4),
                DVec3::new(5e5, 2.0, 1.0),
            ),
            projection: Projection::Orthographic { xmag: Some(3.0), ymag: 2.0, znear: 0.0, zfar: 50.0 },
            aspect: 1.5,
        };
        let planes = slice_planes(&camera, -1.0, 20.0);
        assert_eq!(planes.len(), 6);
        let inside = |p: DVec3| planes.iter().map(|q| q.truncate().dot(p) + q.w).fold(f64::MAX, f64::min);
        for c in slice_corners(&camera, -1.0, 20.0) {
            assert!(inside(c).abs() < 1e-6, "corner {c}: {}", inside(c));
        }
        let at = |x: f64, y: f64, depth: f64| camera.world_from_view.transform_point3(DVec3::new(x, y, -depth));
        assert!(inside(at(0.0, 0.0, 10.0)) > 1.0);
        for outside in [at(0.0, 0.0, -0.5), at(0.0, 0.0, 20.5), at(3.5, 0.0, 5.0), at(0.0, -2.5, 5.0)] {
            assert!(inside(outside) < -0.4, "{outside}: {}", inside(outside));
        }
    }

    fn camera_at(eye: DVec3, rotation: DQuat) -> CascadeCamera {
        CascadeCamera {
            world_from_view: DAffine3::from_rotation_translation(rotation, eye),
            projection: Projection::Perspective { yfov: 50f32.to_radians(), znear: 0.1, aspect_ratio: None },
            aspect: 16.0 / 9.0,
        }
    }

    fn sun() -> Vec3 {
        Vec3::new(-0.3, -1.0, -0.45).normalize()
    }

    #[test]
    fn practical_splits_blend_uniform_and_logarithmic() {
        let uniform = practical_splits(1.0, 101.0, 4, 0.0);
        assert_eq!(uniform, vec![1.0, 26.0, 51.0, 76.0, 101.0]);
        let log = practical_splits(1.0, 10000.0, 4, 1.0);
        for (got, want) in log.iter().zip([1.0, 10.0, 100.0, 1000.0, 10000.0]) {
            assert!((got / want - 1.0).abs() < 1e-6, "{log:?}");
        }
        let mixed = practical_splits(0.1, 100.0, 4, 0.85);
        assert!(mixed.windows(2).all(|w| w[0] < w[1]), "{mixed:?}");
        assert_eq!((mixed[0], mixed[4]), (0.1, 100.0));
        // An orthographic camera may have its near plane at 0.
        let from_zero = practical_splits(0.0, 100.0, 4, 0.85);
        assert!(from_zero.iter().all(|s| s.is_finite()) && from_zero.windows(2).all(|w| w[0] < w[1]), "{from_zero:?}");
    }

    #[test]
    fn every_slice_corner_lies_inside_its_cascade() {
        // Many placements, so that snapping rounds every way.
        for i in 0..64 {
            let f = i as f64;
            let eye = DVec3::new(3.0 + 0.37 * f, 2.0 + 0.11 * f, 5.0 - 0.23 * f);
            let rotation = DQuat::from_rotation_y(0.7 + 0.5 * f) * DQuat::from_rotation_x(-0.3 - 0.02 * f);
            corners_inside(&camera_at(eye, rotation));
        }
    }

    fn corners_inside(camera: &CascadeCamera) {
        let settings = ShadowSettings::default();
        let cascades = fit_cascades(camera, sun(), &settings, 50.0);
        assert_eq!(cascades.len(), 4);
        let t = (25f64.to_radians()).tan();
        for c in &cascades {
            for d in [c.near as f64, c.far as f64] {
                for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
                    let view = DVec3::new(sx * d * t * 16.0 / 9.0, sy * d * t, -d);
                    let world = camera.world_from_view.transform_point3(view);
                    let clip = c.clip_from_world.project_point3(world);
                    assert!(clip.x.abs() <= 1.0 && clip.y.abs() <= 1.0, "{clip}");
                    assert!((0.0..=1.0).contains(&clip.z), "{clip}");
                }
            }
        }
    }

    /// A start position where every cascade's snapped centre sits well inside its texel (at
    /// least 0.15 texel from rounding to another), so a move of 0.1 of the finest texel cannot
    /// cross a snapping boundary in any cascade.
    fn safe_start(rotation: DQuat, base: DVec3, settings: &ShadowSettings) -> DVec3 {
        let light = light_rotation(sun().as_dvec3());
        for i in 0..10_000 {
            let eye = base + DVec3::new(i as f64 * 0.0137, i as f64 * 0.0071, i as f64 * 0.0053);
            let camera = camera_at(eye, rotation);
            let safe = fit_cascades(&camera, sun(), settings, 50.0).iter().all(|c| {
                let view_dir = camera.world_from_view.matrix3.mul_vec3(DVec3::NEG_Z);
                let (depth, _) = slice_sphere(&camera.projection, 16.0 / 9.0, c.near as f64, c.far as f64);
                let p = light.transform_point3(eye + view_dir * depth) / c.texel_size;
                let off = (p - p.round()).abs();
                off.max_element() < 0.35
            });
            if safe {
                return eye;
            }
        }
        panic!("no start position found");
    }

    /// The test: the camera moves by 0.1 texel (of the finest cascade, so at most that
    /// in every cascade) along each axis, and every snapped matrix is unchanged. The comparison
    /// is exact (tolerance 0): the snapped centre is the same f64 value, and nothing else in the
    /// matrix depends on the camera's position. Checked near the origin and 1000 km from it.
    #[test]
    fn moving_the_camera_by_a_tenth_of_a_texel_leaves_every_cascade_unchanged() {
        let settings = ShadowSettings::default();
        let rotation = DQuat::from_rotation_y(0.4) * DQuat::from_rotation_x(-0.5);
        for base in [DVec3::new(1.0, 2.0, 3.0), DVec3::new(1.0e6, 20.0, -1.0e6)] {
            let eye = safe_start(rotation, base, &settings);
            let before = fit_cascades(&camera_at(eye, rotation), sun(), &settings, 50.0);
            let step = 0.1 * before[0].texel_size;
            for axis in [DVec3::X, DVec3::Y, DVec3::Z, DVec3::new(1.0, -1.0, 1.0).normalize()] {
                for sign in [1.0, -1.0] {
                    let after = fit_cascades(&camera_at(eye + axis * step * sign, rotation), sun(), &settings, 50.0);
                    for (i, (a, b)) in before.iter().zip(&after).enumerate() {
                        assert_eq!(a.clip_from_world, b.clip_from_world, "cascade {i}, move {axis} × {sign}");
                    }
                }
            }
        }
    }

    /// Turning the camera moves each cascade only by whole texels and never resizes it.
    #[test]
    fn turning_the_camera_moves_cascades_by_whole_texels() {
        let settings = ShadowSettings::default();
        let eye = DVec3::new(2.0, 1.5, -4.0);
        let before = fit_cascades(&camera_at(eye, DQuat::from_rotation_y(0.2)), sun(), &settings, 50.0);
        for angle in [0.21, 0.5, 1.7, -2.9] {
            let after = fit_cascades(&camera_at(eye, DQuat::from_rotation_y(angle)), sun(), &settings, 50.0);
            for (i, (a, b)) in before.iter().zip(&after).enumerate() {
                assert_eq!(a.radius, b.radius, "cascade {i} resized");
                // Same scale and rotation; the translation differs by whole texels in x and y
                // (clip units of 2 / resolution).
                for col in 0..3 {
                    assert_eq!(a.clip_from_world.col(col), b.clip_from_world.col(col), "cascade {i}");
                }
                let shift = (b.clip_from_world.w_axis - a.clip_from_world.w_axis) * settings.atlas_size as f64 / 2.0;
                for v in [shift.x, shift.y] {
                    assert!((v - v.round()).abs() < 1e-6, "cascade {i} moved by {v} texels at {angle} rad");
                }
            }
        }
    }

    #[test]
    fn the_map_reaches_up_to_the_highest_caster_and_no_further() {
        let camera = camera_at(DVec3::new(1.0, 2.0, 3.0), DQuat::from_rotation_y(0.4));
        let settings = ShadowSettings::default();
        let towards_light = -sun().as_dvec3().normalize();
        // A caster 200 m from the camera toward the light, far above every cascade's sphere.
        let caster = camera.world_from_view.translation + towards_light * 200.0;
        let fitted = fit_cascades_to_casters(&camera, sun(), &settings, caster.dot(towards_light));
        for c in &fitted {
            let z = c.clip_from_world.project_point3(caster).z;
            assert!((0.0..1.0).contains(&z), "the caster lands in the map at depth {z}");
        }
        // Reach comes in doublings of the texel: a caster a little lower gives the same maps.
        let lower = caster - towards_light * 0.01 * fitted[3].texel_size;
        assert_eq!(fitted, fit_cascades_to_casters(&camera, sun(), &settings, lower.dot(towards_light)));
        // With every caster below the spheres' tops the maps reach no further.
        assert_eq!(
            fit_cascades_to_casters(&camera, sun(), &settings, f64::MIN),
            fit_cascades(&camera, sun(), &settings, 0.0)
        );
    }

    #[test]
    fn the_relative_matrix_agrees_with_the_world_one_far_from_the_origin() {
        let eye = DVec3::new(1.0e6, 10.0, -1.0e6);
        let camera = camera_at(eye, DQuat::from_rotation_y(0.3));
        let c = &fit_cascades(&camera, sun(), &ShadowSettings::default(), 50.0)[0];
        // A point 2 m in front of the camera, through both matrices.
        let world = eye + DVec3::new(0.3, -0.5, -2.0);
        let want = c.clip_from_world.project_point3(world);
        let got = c.clip_from_rel.project_point3((world - eye).as_vec3());
        // One texel of the first cascade is 2 / 4096 in clip units; agree to a hundredth of it.
        assert!((got.as_dvec3() - want).abs().max_element() < 0.01 * 2.0 / 4096.0, "{got} vs {want}");
    }
}
