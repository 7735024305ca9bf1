//! Built-in meshes with exact normals, UVs and tangents: UV sphere, cuboid, plane.
//! UVs follow glTF (origin top-left, v down); tangents point along +u with w = +1.

use std::f32::consts::{PI, TAU};

use glam::{Vec2, Vec3, Vec4};

use crate::mesh::{Mesh, Topology};

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
