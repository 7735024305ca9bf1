//! Line segments as quads: the form in which the renderer holds and draws `LineList` meshes.
//!
//! Hardware lines are rasterised by rules each driver picks for itself: with multisampling,
//! Vulkan lets a line cover the samples of a rectangle or of a parallelogram, and lavapipe and
//! NVIDIA's driver light different pixels for the same segment (the MeshPrimitiveModes golden
//! differed by a pixel column at MSAA 4, and by nothing at MSAA 1). Triangles are covered by
//! one rule everywhere. So each segment becomes a quad one pixel wide, made of two triangles
//! that the forward vertex shader (`LINE_QUADS`) widens in screen space: the same rectangle a
//! strict hardware line covers, drawn the same on every driver.
//!
//! Layout, which the vertex shader relies on: segment `s` (endpoints `a`, `b`) becomes the
//! vertices `4s + c` for corners `c` = 0, 1 (copies of `a`) and 2, 3 (copies of `b`); bit 0 of
//! `c` picks the side of the line, bit 1 the end. A corner's opposite endpoint is therefore
//! vertex `c ^ 2` of the same segment, which the shader reads from the vertex pool as
//! `vertex_index ^ 2`: the mesh pool places line entries (and their deformed copies) at vertex
//! offsets that are multiples of [`VERTEX_ALIGNMENT`], so that XOR stays inside the segment.
//! Every per-vertex array (skin and morph data too) is expanded alike, so deformation moves
//! both copies of an endpoint the same way.

use penumbra_engine::mesh::{Mesh, MorphTarget, Topology};

/// Vertices per segment, and the alignment of a line entry's first vertex in the pool.
pub const VERTEX_ALIGNMENT: u32 = 4;

/// The two triangles of a segment's quad, as corners (see the module doc).
const QUAD: [u32; 6] = [0, 1, 2, 2, 1, 3];

/// `mesh` in the form the renderer draws, when that differs from the mesh itself: a
/// `LineList` mesh's segments as quads. Other topologies are drawn as they are (`None`).
pub fn expand(mesh: &Mesh) -> Option<Mesh> {
    if mesh.topology != Topology::LineList {
        return None;
    }
    // The endpoints of every segment, in order (a non-indexed list pairs its vertices).
    let ends: Vec<usize> = match &mesh.indices {
        Some(indices) => indices.iter().map(|&i| i as usize).collect(),
        None => (0..mesh.positions.len()).collect(),
    };
    let segments = ends.len() / 2;
    // Corner k of segment s copies endpoint ends[2s + (k >> 1)].
    let sources: Vec<usize> = (0..segments * 4).map(|v| ends[2 * (v / 4) + (v % 4) / 2]).collect();
    // An index out of range (a mesh built in code and never validated) reads zeros rather than
    // panicking; deformation validates the mesh before expanding it.
    fn pick<T: Copy + Default>(values: &[T], sources: &[usize]) -> Vec<T> {
        if values.is_empty() {
            Vec::new()
        } else {
            sources.iter().map(|&i| values.get(i).copied().unwrap_or_default()).collect()
        }
    }
    let indices = (0..segments as u32).flat_map(|s| QUAD.map(|c| 4 * s + c)).collect();
    Some(Mesh {
        topology: Topology::LineList,
        positions: pick(&mesh.positions, &sources),
        normals: pick(&mesh.normals, &sources),
        tangents: pick(&mesh.tangents, &sources),
        uv0: pick(&mesh.uv0, &sources),
        uv1: pick(&mesh.uv1, &sources),
        colors: pick(&mesh.colors, &sources),
        indices: Some(indices),
        joints: pick(&mesh.joints, &sources),
        weights: pick(&mesh.weights, &sources),
        morph_targets: mesh
            .morph_targets
            .iter()
            .map(|t| MorphTarget {
                positions: pick(&t.positions, &sources),
                normals: pick(&t.normals, &sources),
                tangents: pick(&t.tangents, &sources),
            })
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use glam::{Vec2, Vec3, Vec4};

    use super::*;

    fn two_segments() -> Mesh {
        Mesh {
            topology: Topology::LineList,
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            uv0: vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)],
            joints: vec![[0, 0, 0, 0], [1, 0, 0, 0], [2, 0, 0, 0]],
            weights: vec![Vec4::X; 3],
            morph_targets: vec![MorphTarget {
                positions: vec![Vec3::Z, 2.0 * Vec3::Z, 3.0 * Vec3::Z],
                ..Default::default()
            }],
            indices: Some(vec![0, 1, 1, 2]),
            ..Default::default()
        }
    }

    #[test]
    fn each_segment_becomes_four_corners_whose_opposite_endpoint_is_the_index_xor_2() {
        let m = expand(&two_segments()).expect("a line list");
        assert_eq!(m.positions, [Vec3::ZERO, Vec3::ZERO, Vec3::X, Vec3::X, Vec3::X, Vec3::X, Vec3::Y, Vec3::Y]);
        assert_eq!(m.indices.as_deref(), Some(&[0, 1, 2, 2, 1, 3, 4, 5, 6, 6, 5, 7][..]));
        for v in 0..8usize {
            let other = v ^ 2;
            assert_eq!(v / 4, other / 4, "the opposite corner stays in its segment");
            assert_ne!((v >> 1) & 1, (other >> 1) & 1, "and lies at the other end");
        }
        // Every per-vertex array follows the positions, so a pose moves both copies alike.
        assert_eq!(m.uv0[2], Vec2::new(1.0, 0.0));
        assert_eq!(m.joints[6], [2, 0, 0, 0]);
        assert_eq!(m.weights.len(), 8);
        assert_eq!(m.morph_targets[0].positions[4], 2.0 * Vec3::Z);
        assert!(m.normals.is_empty() && m.colors.is_empty(), "absent attributes stay absent");
        m.validate().expect("a valid mesh");
    }

    #[test]
    fn a_non_indexed_list_pairs_its_vertices() {
        let indexed = two_segments();
        let order = [0usize, 1, 1, 2];
        let plain = Mesh {
            positions: order.map(|i| indexed.positions[i]).to_vec(),
            uv0: order.map(|i| indexed.uv0[i]).to_vec(),
            indices: None,
            joints: Vec::new(),
            weights: Vec::new(),
            morph_targets: Vec::new(),
            ..indexed.clone()
        };
        let (a, b) = (expand(&indexed).unwrap(), expand(&plain).unwrap());
        assert_eq!((a.positions, a.uv0, a.indices), (b.positions, b.uv0, b.indices));
    }

    #[test]
    fn other_topologies_are_drawn_as_they_are() {
        assert_eq!(expand(&Mesh::uv_sphere(1.0, 4, 3)), None);
    }
}
