//! Built-in meshes with exact normals, UVs and tangents: UV and ico spheres, cuboid, plane,
//! cylinder, cone, capsule, torus. UVs follow glTF (origin top-left, v down); tangents point
//! along +u with w = +1 (checked against MikkTSpace). Round shapes stand on the Y axis, centred
//! on the origin; `u` runs once around it (from +X toward −Z) and `v` down their profile, with a
//! seam of duplicated vertices at u = 0/1.

use std::collections::HashMap;
use std::f32::consts::{FRAC_PI_2, PI, TAU};

use glam::{Vec2, Vec3, Vec4};

use crate::mesh::{Mesh, Topology};

/// One ring of a shape of revolution: its radius and height, the (radial, vertical) components
/// of its normal, and its `v`.
#[derive(Clone, Copy)]
struct Ring {
    radius: f32,
    y: f32,
    normal: Vec2,
    v: f32,
}

/// Where azimuth `a` points, around +Y from +X toward −Z.
fn around(a: f32) -> (f32, f32) {
    (a.cos(), -a.sin())
}

impl Mesh {
    /// A surface of revolution through `rings` (top to bottom), `sectors` around, added to `m`.
    /// Triangles with an edge on a ring of radius 0 (a pole or an apex) are left out.
    fn add_revolution(m: &mut Mesh, rings: &[Ring], sectors: u32) {
        let base = m.positions.len() as u32;
        for ring in rings {
            for i in 0..=sectors {
                let u = i as f32 / sectors as f32;
                let a = u * TAU;
                let (c, s) = around(a);
                m.positions.push(Vec3::new(ring.radius * c, ring.y, ring.radius * s));
                m.normals.push(Vec3::new(ring.normal.x * c, ring.normal.y, ring.normal.x * s).normalize());
                m.uv0.push(Vec2::new(u, ring.v));
                // d(position)/du, normalised; defined on the axis too.
                m.tangents.push(Vec4::new(-a.sin(), 0.0, -a.cos(), 1.0));
            }
        }
        let row = sectors + 1;
        let idx = m.indices.get_or_insert_with(Vec::new);
        for j in 0..rings.len() as u32 - 1 {
            for i in 0..sectors {
                let a = base + j * row + i;
                let b = a + row;
                if rings[j as usize].radius > 0.0 {
                    idx.extend_from_slice(&[a, b, a + 1]);
                }
                if rings[j as usize + 1].radius > 0.0 {
                    idx.extend_from_slice(&[a + 1, b, b + 1]);
                }
            }
        }
    }

    /// A flat disk of `radius` at height `y`, facing +Y (`up`) or −Y, UVs mapped from above (or
    /// below, unmirrored).
    fn add_disk(m: &mut Mesh, radius: f32, y: f32, up: bool, sectors: u32) {
        let base = m.positions.len() as u32;
        let (n, flip) = if up { (Vec3::Y, 1.0) } else { (Vec3::NEG_Y, -1.0) };
        let mut push = |p: Vec3| {
            m.positions.push(p);
            m.normals.push(n);
            m.uv0.push(Vec2::new(0.5 + 0.5 * p.x / radius, 0.5 + 0.5 * flip * p.z / radius));
            m.tangents.push(Vec4::new(1.0, 0.0, 0.0, 1.0));
        };
        push(Vec3::new(0.0, y, 0.0));
        for i in 0..=sectors {
            let (c, s) = around(i as f32 / sectors as f32 * TAU);
            push(Vec3::new(radius * c, y, radius * s));
        }
        let idx = m.indices.get_or_insert_with(Vec::new);
        for i in 0..sectors {
            let (a, b) = (base + 1 + i, base + 2 + i);
            // Counter-clockwise seen from the side the disk faces.
            if up {
                idx.extend_from_slice(&[base, a, b]);
            } else {
                idx.extend_from_slice(&[base, b, a]);
            }
        }
    }

    /// A closed cylinder of `radius` and `height` along Y.
    pub fn cylinder(radius: f32, height: f32, sectors: u32) -> Mesh {
        let sectors = sectors.max(3);
        let h = 0.5 * height;
        let mut m = Mesh { topology: Topology::TriangleList, ..Default::default() };
        let side = Vec2::X;
        let rings = [Ring { radius, y: h, normal: side, v: 0.0 }, Ring { radius, y: -h, normal: side, v: 1.0 }];
        Self::add_revolution(&mut m, &rings, sectors);
        Self::add_disk(&mut m, radius, h, true, sectors);
        Self::add_disk(&mut m, radius, -h, false, sectors);
        m
    }

    /// A closed cone with its apex at +`height`/2 and its base of `radius` at −`height`/2.
    pub fn cone(radius: f32, height: f32, sectors: u32) -> Mesh {
        let sectors = sectors.max(3);
        let h = 0.5 * height;
        let mut m = Mesh { topology: Topology::TriangleList, ..Default::default() };
        // The slant's outward normal.
        let slant = Vec2::new(height, radius).normalize_or(Vec2::Y);
        let rings = [Ring { radius: 0.0, y: h, normal: slant, v: 0.0 }, Ring { radius, y: -h, normal: slant, v: 1.0 }];
        Self::add_revolution(&mut m, &rings, sectors);
        Self::add_disk(&mut m, radius, -h, false, sectors);
        m
    }

    /// A capsule: a cylinder of `radius` and `length` along Y capped by hemispheres (total
    /// height `length + 2·radius`), with `rings` latitudes per hemisphere.
    pub fn capsule(radius: f32, length: f32, sectors: u32, rings: u32) -> Mesh {
        let sectors = sectors.max(3);
        let rings = rings.max(1);
        let h = 0.5 * length;
        // v runs along the profile's arc length.
        let total = PI * radius + length;
        let mut profile = Vec::new();
        for (centre, from, arc_start) in [(h, 0.0, 0.0), (-h, FRAC_PI_2, FRAC_PI_2 * radius + length)] {
            for j in 0..=rings {
                let polar = from + FRAC_PI_2 * j as f32 / rings as f32;
                let normal = Vec2::new(polar.sin(), polar.cos());
                let arc = arc_start + (polar - from) * radius;
                profile.push(Ring {
                    radius: radius * normal.x,
                    y: centre + radius * normal.y,
                    normal,
                    v: if total > 0.0 { arc / total } else { 0.0 },
                });
            }
        }
        // The poles' radii are exactly 0, so the revolution leaves their slivers out.
        profile[0].radius = 0.0;
        let last = profile.len() - 1;
        profile[last].radius = 0.0;
        let mut m = Mesh { topology: Topology::TriangleList, ..Default::default() };
        Self::add_revolution(&mut m, &profile, sectors);
        m
    }

    /// A torus around Y: a tube of radius `minor` whose centre circles at radius `major`.
    pub fn torus(major: f32, minor: f32, sectors: u32, rings: u32) -> Mesh {
        let sectors = sectors.max(3);
        let rings = rings.max(3);
        // Around the tube from its top, outside first: the same way the sphere's profile runs.
        let profile: Vec<Ring> = (0..=rings)
            .map(|j| {
                let phi = FRAC_PI_2 - TAU * j as f32 / rings as f32;
                let normal = Vec2::new(phi.cos(), phi.sin());
                Ring { radius: major + minor * normal.x, y: minor * normal.y, normal, v: j as f32 / rings as f32 }
            })
            .collect();
        let mut m = Mesh { topology: Topology::TriangleList, ..Default::default() };
        Self::add_revolution(&mut m, &profile, sectors);
        m
    }

    /// A geodesic sphere: an icosahedron subdivided `subdivisions` times (20·4ⁿ triangles of
    /// nearly equal size), with spherical UVs like [`Mesh::uv_sphere`]'s.
    pub fn ico_sphere(radius: f32, subdivisions: u32) -> Mesh {
        let subdivisions = subdivisions.min(8);
        let t = (1.0 + 5f32.sqrt()) / 2.0;
        let mut dirs: Vec<Vec3> = [
            (-1.0, t, 0.0),
            (1.0, t, 0.0),
            (-1.0, -t, 0.0),
            (1.0, -t, 0.0),
            (0.0, -1.0, t),
            (0.0, 1.0, t),
            (0.0, -1.0, -t),
            (0.0, 1.0, -t),
            (t, 0.0, -1.0),
            (t, 0.0, 1.0),
            (-t, 0.0, -1.0),
            (-t, 0.0, 1.0),
        ]
        .iter()
        .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
        .collect();
        let mut faces: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..subdivisions {
            let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
            let mut mid = |a: u32, b: u32, dirs: &mut Vec<Vec3>| {
                *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    dirs.push((dirs[a as usize] + dirs[b as usize]).normalize());
                    dirs.len() as u32 - 1
                })
            };
            faces = faces
                .iter()
                .flat_map(|&[a, b, c]| {
                    let (ab, bc, ca) = (mid(a, b, &mut dirs), mid(b, c, &mut dirs), mid(c, a, &mut dirs));
                    [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
                })
                .collect();
        }
        let mut m = Mesh { topology: Topology::TriangleList, ..Default::default() };
        let u_of = |d: Vec3| (-d.z).atan2(d.x).rem_euclid(TAU) / TAU;
        for &d in &dirs {
            let a = u_of(d) * TAU;
            m.positions.push(d * radius);
            m.normals.push(d);
            m.uv0.push(Vec2::new(u_of(d), d.y.clamp(-1.0, 1.0).acos() / PI));
            m.tangents.push(Vec4::new(-a.sin(), 0.0, -a.cos(), 1.0));
        }
        // Triangles straddling the seam get copies of their small-u vertices at u + 1 (so u runs
        // past 1 there, which the default repeating sampler wraps). A vertex on a pole has no
        // azimuth of its own: each triangle gets a copy at the mean u of its other two.
        let on_pole = |p: Vec3| p.x * p.x + p.z * p.z < 1e-10 * radius * radius.max(1e-30);
        let mut copies: HashMap<u32, u32> = HashMap::new();
        let mut idx = Vec::with_capacity(faces.len() * 3);
        for face in &faces {
            let pole = face.map(|i| on_pole(m.positions[i as usize]));
            let mut us = face.map(|i| m.uv0[i as usize].x);
            let off_pole = || (0..3).filter(|&k| !pole[k]);
            let hi = off_pole().map(|k| us[k]).fold(f32::MIN, f32::max);
            let lo = off_pole().map(|k| us[k]).fold(f32::MAX, f32::min);
            let wraps = hi - lo > 0.5;
            let mut out = *face;
            for k in off_pole() {
                if wraps && us[k] < 0.5 {
                    us[k] += 1.0;
                    let i = face[k];
                    out[k] = *copies.entry(i).or_insert_with(|| {
                        let j = i as usize;
                        let (p, n, t, uv) = (m.positions[j], m.normals[j], m.tangents[j], m.uv0[j]);
                        m.positions.push(p);
                        m.normals.push(n);
                        m.tangents.push(t);
                        m.uv0.push(Vec2::new(uv.x + 1.0, uv.y));
                        m.positions.len() as u32 - 1
                    });
                }
            }
            let others = off_pole().count().max(1) as f32;
            let mean_u = off_pole().map(|k| us[k]).sum::<f32>() / others;
            for k in (0..3).filter(|&k| pole[k]) {
                let j = face[k] as usize;
                let (p, n, uv) = (m.positions[j], m.normals[j], m.uv0[j]);
                let a = mean_u * TAU;
                m.positions.push(p);
                m.normals.push(n);
                m.tangents.push(Vec4::new(-a.sin(), 0.0, -a.cos(), 1.0));
                m.uv0.push(Vec2::new(mean_u, uv.y));
                out[k] = m.positions.len() as u32 - 1;
            }
            idx.extend_from_slice(&out);
        }
        m.indices = Some(idx);
        m
    }
}

impl Mesh {
    /// A sphere of `sectors` longitudes and `stacks` latitudes, with a seam at u = 0/1.
    pub fn uv_sphere(radius: f32, sectors: u32, stacks: u32) -> Mesh {
        let sectors = sectors.max(3);
        let stacks = stacks.max(2);
        let mut m = Mesh { topology: Topology::TriangleList, ..Default::default() };
        for j in 0..=stacks {
            let v = j as f32 / stacks as f32;
            let polar = v * PI; // 0 at +Y
            for i in 0..=sectors {
                let u = i as f32 / sectors as f32;
                let azimuth = u * TAU;
                let n = Vec3::new(polar.sin() * azimuth.cos(), polar.cos(), -polar.sin() * azimuth.sin());
                m.positions.push(n * radius);
                m.normals.push(n);
                m.uv0.push(Vec2::new(u, v));
                // d(position)/du, normalised; well defined even at the poles.
                let t = Vec3::new(-azimuth.sin(), 0.0, -azimuth.cos());
                m.tangents.push(t.extend(1.0));
            }
        }
        let row = sectors + 1;
        let mut idx = Vec::with_capacity((sectors * stacks * 6) as usize);
        for j in 0..stacks {
            for i in 0..sectors {
                let a = j * row + i;
                let b = a + row;
                if j != 0 {
                    idx.extend_from_slice(&[a, b, a + 1]);
                }
                if j != stacks - 1 {
                    idx.extend_from_slice(&[a + 1, b, b + 1]);
                }
            }
        }
        m.indices = Some(idx);
        m
    }

    /// An axis-aligned box centred on the origin, four vertices per face.
    pub fn cuboid(size: Vec3) -> Mesh {
        let h = size * 0.5;
        let mut m = Mesh::default();
        // (normal, tangent (+u), bitangent (−v, image up))
        let faces = [
            (Vec3::X, Vec3::NEG_Z, Vec3::Y),
            (Vec3::NEG_X, Vec3::Z, Vec3::Y),
            (Vec3::Y, Vec3::X, Vec3::NEG_Z),
            (Vec3::NEG_Y, Vec3::X, Vec3::Z),
            (Vec3::Z, Vec3::X, Vec3::Y),
            (Vec3::NEG_Z, Vec3::NEG_X, Vec3::Y),
        ];
        let mut idx = Vec::new();
        for (n, t, b) in faces {
            let base = m.positions.len() as u32;
            for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                m.positions.push((n + t * su + b * sv) * h);
                m.normals.push(n);
                m.tangents.push(Vec4::from((t, 1.0)));
                m.uv0.push(Vec2::new(0.5 + 0.5 * su, 0.5 - 0.5 * sv));
            }
            idx.extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
        }
        m.indices = Some(idx);
        m
    }

    /// A square in the XZ plane facing +Y.
    pub fn plane(size: f32) -> Mesh {
        let h = size * 0.5;
        Mesh {
            positions: vec![Vec3::new(-h, 0.0, h), Vec3::new(h, 0.0, h), Vec3::new(h, 0.0, -h), Vec3::new(-h, 0.0, -h)],
            normals: vec![Vec3::Y; 4],
            tangents: vec![Vec4::new(1.0, 0.0, 0.0, 1.0); 4],
            uv0: vec![Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.0)],
            indices: Some(vec![0, 1, 2, 0, 2, 3]),
            ..Default::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every triangle's geometric normal agrees with its vertex normals: the winding is
    /// counter-clockwise seen from outside.
    fn assert_outward_ccw(m: &Mesh) {
        m.validate().unwrap();
        let idx = m.indices.as_ref().unwrap();
        for t in idx.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| m.positions[i as usize]);
            let g = (b - a).cross(c - a);
            if g.length() < 1e-9 {
                continue;
            }
            let n = m.normals[t[0] as usize] + m.normals[t[1] as usize] + m.normals[t[2] as usize];
            assert!(g.dot(n) > 0.0, "triangle {t:?} winds inwards");
        }
    }

    #[test]
    fn primitives_wind_outwards() {
        assert_outward_ccw(&Mesh::uv_sphere(1.0, 16, 8));
        assert_outward_ccw(&Mesh::cuboid(Vec3::new(1.0, 2.0, 3.0)));
        assert_outward_ccw(&Mesh::plane(2.0));
        for (name, m) in round_shapes() {
            assert_outward_ccw(&m);
            let _ = name;
        }
    }

    fn round_shapes() -> Vec<(&'static str, Mesh)> {
        vec![
            ("cylinder", Mesh::cylinder(0.5, 2.0, 24)),
            ("cone", Mesh::cone(0.5, 1.5, 24)),
            ("capsule", Mesh::capsule(0.4, 1.2, 24, 8)),
            ("torus", Mesh::torus(1.0, 0.25, 32, 16)),
            ("ico sphere", Mesh::ico_sphere(1.5, 3)),
        ]
    }

    /// Size, unit normals, tangents perpendicular to them, UVs in range, and every triangle
    /// with area; for shapes without poles, tangents as MikkTSpace computes them.
    #[test]
    fn round_shapes_have_their_size_and_a_sound_tangent_frame() {
        let sizes = [
            Vec3::new(1.0, 2.0, 1.0),
            Vec3::new(1.0, 1.5, 1.0),
            Vec3::new(0.8, 2.0, 0.8),
            Vec3::new(2.5, 0.5, 2.5),
            Vec3::new(3.0, 3.0, 3.0),
        ];
        for ((name, m), size) in round_shapes().into_iter().zip(sizes) {
            m.validate().unwrap();
            let aabb = m.aabb();
            let got = aabb.max - aabb.min;
            // Polygons are inscribed in their circles: up to 1 − cos(π/sectors) narrower.
            assert!((got - size).abs().max_element() < 0.02 * size.max_element(), "{name}: {got} vs {size}");
            assert!(aabb.min.abs_diff_eq(-aabb.max, 0.02), "{name} is not centred: {aabb:?}");
            for (i, (n, t)) in m.normals.iter().zip(&m.tangents).enumerate() {
                assert!((n.length() - 1.0).abs() < 1e-5, "{name}: normal {i} is {n}");
                assert!(t.truncate().dot(*n).abs() < 1e-4, "{name}: tangent {i} {t} not perpendicular to {n}");
                let uv = m.uv0[i];
                // The ico sphere's seam copies run u past 1 (a repeating sampler wraps them).
                let u_max = if name == "ico sphere" { 2.0 } else { 1.0 + 1e-6 };
                assert!((0.0..=1.0 + 1e-6).contains(&uv.y) && (0.0..=u_max).contains(&uv.x), "{name}: uv {uv}");
            }
            let idx = m.indices.as_ref().unwrap();
            for tri in idx.chunks_exact(3) {
                let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| m.positions[i as usize]);
                assert!((b - a).cross(c - a).length() > 1e-8, "{name}: degenerate triangle {tri:?}");
            }
        }
        for (name, mut m) in [("cylinder", Mesh::cylinder(0.5, 2.0, 24)), ("torus", Mesh::torus(1.0, 0.25, 32, 16))] {
            let given = m.tangents.clone();
            m.generate_tangents(0).unwrap();
            for (a, b) in given.iter().zip(&m.tangents) {
                assert!(a.truncate().dot(b.truncate()) > 0.95 && a.w == b.w, "{name}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn ico_sphere_triangles_are_nearly_equal_and_uvs_do_not_wrap_across_the_seam() {
        let m = Mesh::ico_sphere(1.0, 2);
        let idx = m.indices.as_ref().unwrap();
        assert_eq!(idx.len() / 3, 20 * 16);
        let areas: Vec<f32> = idx
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| m.positions[i as usize]);
                (b - a).cross(c - a).length()
            })
            .collect();
        let (lo, hi) = areas.iter().fold((f32::MAX, 0.0f32), |(lo, hi), &a| (lo.min(a), hi.max(a)));
        assert!(hi / lo < 1.5, "areas from {lo} to {hi}");
        for t in idx.chunks_exact(3) {
            let us = [t[0], t[1], t[2]].map(|i| m.uv0[i as usize].x);
            let span = us.iter().fold(f32::MIN, |a, &b| a.max(b)) - us.iter().fold(f32::MAX, |a, &b| a.min(b));
            assert!(span < 0.5, "triangle {t:?} spans u {us:?}");
        }
    }

    #[test]
    fn primitive_tangents_match_mikktspace_direction() {
        for mut m in [Mesh::cuboid(Vec3::ONE), Mesh::plane(1.0)] {
            let given = m.tangents.clone();
            m.generate_tangents(0).unwrap();
            for (a, b) in given.iter().zip(&m.tangents) {
                assert!(a.truncate().dot(b.truncate()) > 0.99 && a.w == b.w, "{a} vs {b}");
            }
        }
    }
}
