//! The part of a cascade's map that is stored. A cascade's projection covers the sphere around
//! its whole slice of the view, but only the texels that the receivers reading it project into
//! are ever looked up: a small scene in front of the camera covers a corner of its far
//! cascades, and only the bottom of the view's near slice. A [`TexelWindow`] is that part, in
//! whole texels of the cascade's full texel grid: the light-space bounds of where the slice
//! meets the receivers' box ([`slice_box_vertices`]), widened by how far a receiver's lookups
//! reach. The orchestrator stores each cascade's window at the top-left of a layer sized to the
//! largest window ([`TexelWindow::clip_to_layer`]), so the texel grid, and with it every stored
//! depth and every lookup, is the full map's: the same pixels for a fraction of the memory and
//! of the texels drawn.

use glam::{DMat4, DVec2, DVec3, DVec4};

/// A rectangle of whole texels of a cascade's `resolution`² grid: texels `x..x + width` across
/// and `y..y + height` down (texture coordinates: v grows down, clip y up).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TexelWindow {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

impl TexelWindow {
    /// The whole `resolution`² map.
    pub fn full(resolution: u32) -> Self {
        Self { x: 0, y: 0, width: resolution, height: resolution }
    }

    /// The window of the `resolution`² map of `clip_from_world` holding the projections of
    /// `points`, widened by `margin` texels on every side and clamped to the map; `None` without
    /// points or where they project beside the map; the whole map if one is NaN.
    pub fn around(
        clip_from_world: &DMat4,
        resolution: u32,
        points: impl IntoIterator<Item = DVec3>,
        margin: f64,
    ) -> Option<Self> {
        let n = resolution as f64;
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for p in points {
            let c = clip_from_world.project_point3(p);
            // Clip y up, texel rows down.
            let t = DVec2::new((c.x + 1.0) * 0.5 * n, (1.0 - c.y) * 0.5 * n);
            if t.is_nan() {
                // `min` and `max` would pass over it.
                return Some(Self::full(resolution));
            }
            lo = lo.min(t);
            hi = hi.max(t);
        }
        let lo = ((lo - margin).floor()).max(DVec2::ZERO);
        let hi = ((hi + margin).ceil()).min(DVec2::splat(n));
        (hi.x > lo.x && hi.y > lo.y).then_some(Self {
            x: lo.x as u32,
            y: lo.y as u32,
            width: (hi.x - lo.x) as u32,
            height: (hi.y - lo.y) as u32,
        })
    }

    /// This window grown by `texels` on every side, within the `resolution`² map.
    pub fn widened(&self, texels: u32, resolution: u32) -> Self {
        let (x, y) = (self.x.saturating_sub(texels), self.y.saturating_sub(texels));
        let x1 = (self.x + self.width).saturating_add(texels).min(resolution);
        let y1 = (self.y + self.height).saturating_add(texels).min(resolution);
        Self { x, y, width: x1 - x, height: y1 - y }
    }

    pub fn contains(&self, other: &Self) -> bool {
        other.x >= self.x
            && other.y >= self.y
            && other.x + other.width <= self.x + self.width
            && other.y + other.height <= self.y + self.height
    }

    /// The affine map from the full `resolution`² map's clip space to the clip space of a
    /// `layer` (width, height) texels large holding this window at its top-left corner: texel
    /// (i, j) of the window is texel (i, j) of the layer, on the same grid. Depth is untouched.
    pub fn clip_to_layer(&self, resolution: u32, layer: (u32, u32)) -> DMat4 {
        let n = resolution as f64;
        let (w, h) = (layer.0 as f64, layer.1 as f64);
        // Across: texel u = (x + 1)·n/2 − window.x, and x' = 2u/w − 1.
        // Down: texel v = (1 − y)·n/2 − window.y, and y' = 1 − 2v/h.
        DMat4::from_cols(
            DVec4::new(n / w, 0.0, 0.0, 0.0),
            DVec4::new(0.0, n / h, 0.0, 0.0),
            DVec4::Z,
            DVec4::new((n - 2.0 * self.x as f64) / w - 1.0, 1.0 - (n - 2.0 * self.y as f64) / h, 0.0, 1.0),
        )
    }

    /// The map from the full map's clip space to this window's alone (the window filling clip
    /// space): what its casters are tested against.
    pub fn clip_to_window(&self, resolution: u32) -> DMat4 {
        self.clip_to_layer(resolution, (self.width, self.height))
    }
}

/// The vertices of the intersection of a slice of the view (its eight `corners`, in
/// [`super::cascades::slice_corners`]' order, and its inward `planes`,
/// [`super::cascades::slice_planes`]) with the box `min..max`: the receivers that may read the
/// slice's cascade lie in their convex hull. A vertex of the intersection of two convex
/// polyhedra is a vertex of one inside the other or where an edge of one crosses a face of the
/// other; candidates within `tolerance` (metres) of both count, so rounding never drops one.
/// Empty where the two do not meet.
pub fn slice_box_vertices(
    corners: &[DVec3; 8],
    planes: &[DVec4],
    min: DVec3,
    max: DVec3,
    tolerance: f64,
) -> Vec<DVec3> {
    let in_slice = |p: DVec3| planes.iter().all(|q| q.truncate().dot(p) + q.w >= -tolerance);
    let in_box = |p: DVec3| p.cmpge(min - tolerance).all() && p.cmple(max + tolerance).all();
    let box_corners: [DVec3; 8] =
        std::array::from_fn(|i| DVec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), max, min));
    let box_planes = [
        DVec4::new(1.0, 0.0, 0.0, -min.x),
        DVec4::new(-1.0, 0.0, 0.0, max.x),
        DVec4::new(0.0, 1.0, 0.0, -min.y),
        DVec4::new(0.0, -1.0, 0.0, max.y),
        DVec4::new(0.0, 0.0, 1.0, -min.z),
        DVec4::new(0.0, 0.0, -1.0, max.z),
    ];
    // Both corner sets index x, y and z (depth for the slice) by bits 0, 1 and 2: an edge joins
    // corners one bit apart.
    let edges = |c: &[DVec3; 8]| {
        let c = *c;
        (0..8usize).flat_map(move |i| [1, 2, 4].into_iter().filter(move |b| i & b == 0).map(move |b| (c[i], c[i | b])))
    };
    let crossings = |edges: &mut dyn Iterator<Item = (DVec3, DVec3)>, faces: &[DVec4], out: &mut Vec<DVec3>| {
        for (a, b) in edges {
            for f in faces {
                let (da, db) = (f.truncate().dot(a) + f.w, f.truncate().dot(b) + f.w);
                if (da < 0.0) != (db < 0.0) {
                    out.push(a + (b - a) * (da / (da - db)));
                }
            }
        }
    };
    let mut candidates: Vec<DVec3> = corners.iter().chain(&box_corners).copied().collect();
    crossings(&mut edges(corners), &box_planes, &mut candidates);
    crossings(&mut edges(&box_corners), planes, &mut candidates);
    candidates.retain(|p| p.is_nan() || in_slice(*p) && in_box(*p));
    candidates
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map 8 m across centred on the origin, looking down −Z (world x across, world y up).
    fn ortho() -> DMat4 {
        DMat4::from_scale(DVec3::new(0.25, 0.25, 0.05)) * DMat4::from_translation(DVec3::Z * 10.0)
    }

    #[test]
    fn the_window_holds_the_points_projections_widened() {
        let n = 800;
        let m = ortho();
        // Texels are 1 cm; the points span x 1..2 m and y −1..2 m.
        let points = [DVec3::new(1.0, -1.0, 0.0), DVec3::new(2.0, 2.0, 1.0), DVec3::new(1.5, 0.0, 3.0)];
        // x 1..2 m is texels 500..600, y −1..2 m is rows 200..500 (rows count down from y = 4).
        let w = TexelWindow::around(&m, n, points, 2.0).unwrap();
        assert_eq!(w, TexelWindow { x: 498, y: 198, width: 104, height: 304 });
        // Beyond the map: clamped to it; wholly beside it or no points: nothing.
        let huge = [DVec3::new(-100.0, -1.0, 0.0), DVec3::new(100.0, 2.0, 0.0)];
        assert_eq!(TexelWindow::around(&m, n, huge, 2.0), Some(TexelWindow { x: 0, y: 198, width: 800, height: 304 }));
        assert_eq!(TexelWindow::around(&m, n, [DVec3::new(9.0, 0.0, 0.0)], 2.0), None);
        assert_eq!(TexelWindow::around(&m, n, [], 2.0), None);
        // A NaN: the whole map, not less.
        assert_eq!(TexelWindow::around(&m, n, [DVec3::ONE, DVec3::NAN], 2.0), Some(TexelWindow::full(n)));
    }

    /// Every point both in a slice of the view (1e6 m from the origin) and in a box lies within
    /// the hull of the vertices found: in every direction tried, no point reaches further than
    /// the furthest vertex. Every vertex lies in both; a box beside the slice gives none.
    #[test]
    fn the_slice_box_vertices_bound_their_intersection() {
        use crate::features::shadows::cascades::{CascadeCamera, slice_corners, slice_planes};
        use glam::{DAffine3, DQuat};
        use penumbra_engine::components::Projection;
        let eye = DVec3::new(1e6, 30.0, -2e5);
        let camera = CascadeCamera {
            world_from_view: DAffine3::from_rotation_translation(
                DQuat::from_rotation_y(0.7) * DQuat::from_rotation_x(-0.4),
                eye,
            ),
            projection: Projection::Perspective { yfov: 50f32.to_radians(), znear: 0.1, aspect_ratio: None },
            aspect: 16.0 / 9.0,
        };
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut random = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for (start, far) in [(-1.0, 8.0), (6.0, 40.0)] {
            let corners = slice_corners(&camera, start, far);
            let planes = slice_planes(&camera, start, far);
            // A box around the ground below the camera, reaching into the slice from below.
            let (min, max) = (eye + DVec3::new(-60.0, -40.0, -60.0), eye + DVec3::new(60.0, -3.0, 60.0));
            let vertices = slice_box_vertices(&corners, &planes, min, max, 1e-6);
            assert!(!vertices.is_empty(), "slice {start}..{far}");
            for v in &vertices {
                assert!(planes.iter().all(|q| q.truncate().dot(*v) + q.w >= -1e-6), "{v} outside the slice");
                assert!(v.cmpge(min - 1e-6).all() && v.cmple(max + 1e-6).all(), "{v} outside the box");
            }
            let directions: Vec<DVec3> = (0..32)
                .map(|_| DVec3::new(random() - 0.5, random() - 0.5, random() - 0.5).normalize())
                .chain([DVec3::X, DVec3::Y, DVec3::Z, -DVec3::X, -DVec3::Y, -DVec3::Z])
                .collect();
            let support = |d: DVec3| vertices.iter().map(|v| v.dot(d)).fold(f64::MIN, f64::max);
            let mut inside = 0;
            for _ in 0..20_000 {
                // A point of the slice: depth, then across.
                let (a, b, t) = (random(), random(), random());
                let lerp = |i: usize, j: usize, f: f64| corners[i].lerp(corners[j], f);
                let near = lerp(0, 1, a).lerp(lerp(2, 3, a), b);
                let farther = lerp(4, 5, a).lerp(lerp(6, 7, a), b);
                let p = near.lerp(farther, t);
                if !(p.cmpge(min).all() && p.cmple(max).all()) {
                    continue;
                }
                inside += 1;
                for d in &directions {
                    assert!(p.dot(*d) <= support(*d) + 1e-6, "{p} beyond the vertices along {d}");
                }
            }
            assert!(inside > 100, "{inside} points in both");
            let beside = slice_box_vertices(&corners, &planes, min + DVec3::Y * 1000.0, max + DVec3::Y * 1000.0, 1e-6);
            assert!(beside.is_empty(), "{beside:?}");
        }
    }

    /// A point's texel in the layer is its texel in the full map less the window's corner, for
    /// points far apart on the map and a layer larger than the window.
    #[test]
    fn the_layer_keeps_the_full_maps_texel_grid() {
        let n = 4096;
        let window = TexelWindow { x: 1000, y: 3000, width: 700, height: 300 };
        let to_layer = window.clip_to_layer(n, (768, 512));
        for (x, y) in [(1000.5, 3000.5), (1699.25, 3299.75), (1234.0, 3100.125)] {
            let clip = DVec3::new(x / n as f64 * 2.0 - 1.0, 1.0 - y / n as f64 * 2.0, 0.25);
            let l = to_layer.transform_point3(clip);
            let (u, v) = ((l.x + 1.0) * 0.5 * 768.0, (1.0 - l.y) * 0.5 * 512.0);
            assert!((u - (x - 1000.0)).abs() < 1e-9 && (v - (y - 3000.0)).abs() < 1e-9, "({x}, {y}) -> ({u}, {v})");
            assert_eq!(l.z, 0.25);
        }
        // The window alone fills the clip square.
        let alone = window.clip_to_window(n);
        let corner = alone.transform_point3(DVec3::new(1000.0 / 2048.0 - 1.0, 1.0 - 3000.0 / 2048.0, 0.0));
        assert!((corner - DVec3::new(-1.0, 1.0, 0.0)).length() < 1e-12, "{corner}");
    }

    #[test]
    fn widening_stays_on_the_map_and_contains() {
        let w = TexelWindow { x: 2, y: 10, width: 5, height: 5 };
        let wide = w.widened(4, 16);
        assert_eq!(wide, TexelWindow { x: 0, y: 6, width: 11, height: 10 });
        assert!(wide.contains(&w) && !w.contains(&wide));
    }
}
