//! One glTF mesh primitive to one `Mesh`: attributes decoded, topology expanded to lists,
//! missing normals made flat, missing tangents generated (MikkTSpace) when a normal map needs them.

use glam::{Vec2, Vec3, Vec4};
use gltf::mesh::{Mode, Semantic};

use super::accessor::{AccessorError, AccessorResult, Buffers, read_f32, read_indices};
use super::draco::{self, DracoPrimitive};
use crate::import::ImportErrorKind;
use crate::mesh::{Mesh, MorphTarget, Topology};

/// What the primitive's material asks of its geometry.
pub(crate) struct GeometryNeeds {
    /// UV set of the normal map, if the material has one: tangents are needed in that set.
    pub normal_map_uv_set: Option<u32>,
}

pub(crate) enum Built {
    /// The mesh, and what was repaired or is suspect in it (for the scene's warnings).
    Mesh(Box<Mesh>, Vec<String>),
    /// No POSITION: the spec says to skip rendering the primitive.
    Skipped(String),
}

/// An attribute's values: from the primitive's Draco stream where it carries the attribute,
/// else from the accessor.
fn read_attribute<const N: usize>(
    draco: Option<&DracoPrimitive>,
    semantic: &Semantic,
    accessor: &gltf::Accessor,
    buffers: &Buffers,
) -> AccessorResult<Vec<[f32; N]>> {
    match draco.and_then(|d| d.read::<N>(semantic, accessor, buffers)) {
        Some(values) => values,
        None => read_f32::<N>(accessor, buffers),
    }
}

pub(crate) fn build(
    document: &gltf::Document,
    prim: &gltf::Primitive,
    buffers: &Buffers,
    needs: &GeometryNeeds,
    mesh_index: usize,
) -> Result<Built, ImportErrorKind> {
    let primitive = prim.index();
    let acc_err = |a: &gltf::Accessor, e: AccessorError| e.into_kind(a.index());
    let draco = draco::decode(document, prim, buffers)
        .map_err(|e| e.into_kind_with(|reason| ImportErrorKind::Primitive { mesh: mesh_index, primitive, reason }))?;
    let draco = draco.as_ref();
    let read = |s: Semantic| prim.get(&s).map(|a| (s, a));
    let read3 = |s: Semantic| -> Result<Option<Vec<Vec3>>, ImportErrorKind> {
        read(s)
            .map(|(s, a)| {
                read_attribute::<3>(draco, &s, &a, buffers)
                    .map(|v| v.into_iter().map(Vec3::from).collect())
                    .map_err(|e| acc_err(&a, e))
            })
            .transpose()
    };
    let Some(positions) = read3(Semantic::Positions)? else {
        return Ok(Built::Skipped(format!(
            "mesh {mesh_index} primitive {primitive} has no POSITION; skipped as the glTF spec asks"
        )));
    };
    let n = positions.len();
    let mut mesh = Mesh { positions, ..Default::default() };
    mesh.normals = read3(Semantic::Normals)?.unwrap_or_default();
    if let Some((s, a)) = read(Semantic::Tangents) {
        mesh.tangents = read_attribute::<4>(draco, &s, &a, buffers)
            .map_err(|e| acc_err(&a, e))?
            .into_iter()
            .map(Vec4::from)
            .collect();
    }
    for (set, dst) in [(0, &mut mesh.uv0), (1, &mut mesh.uv1)] {
        if let Some((s, a)) = read(Semantic::TexCoords(set)) {
            *dst = read_attribute::<2>(draco, &s, &a, buffers)
                .map_err(|e| acc_err(&a, e))?
                .into_iter()
                .map(Vec2::from)
                .collect();
        }
    }
    if let Some((s, a)) = read(Semantic::Colors(0)) {
        mesh.colors = match a.dimensions() {
            gltf::accessor::Dimensions::Vec3 => read_attribute::<3>(draco, &s, &a, buffers)
                .map_err(|e| acc_err(&a, e))?
                .into_iter()
                .map(|c| Vec3::from(c).extend(1.0))
                .collect(),
            _ => read_attribute::<4>(draco, &s, &a, buffers)
                .map_err(|e| acc_err(&a, e))?
                .into_iter()
                .map(Vec4::from)
                .collect(),
        };
    }

    if let Some((s, a)) = read(Semantic::Joints(0)) {
        if a.normalized() || !matches!(a.data_type(), gltf::accessor::DataType::U8 | gltf::accessor::DataType::U16) {
            return Err(acc_err(&a, String::from("JOINTS_0 must be unsigned bytes or shorts, not normalized").into()));
        }
        mesh.joints = read_attribute::<4>(draco, &s, &a, buffers)
            .map_err(|e| acc_err(&a, e))?
            .into_iter()
            .map(|j| j.map(|x| x as u16))
            .collect();
    }
    if let Some((s, a)) = read(Semantic::Weights(0)) {
        mesh.weights = read_attribute::<4>(draco, &s, &a, buffers)
            .map_err(|e| acc_err(&a, e))?
            .into_iter()
            .map(Vec4::from)
            .collect();
    }
    for (target_index, target) in prim.morph_targets().enumerate() {
        let mut t = MorphTarget::default();
        for (acc, dst) in [
            (target.positions(), &mut t.positions),
            (target.normals(), &mut t.normals),
            (target.tangents(), &mut t.tangents),
        ] {
            if let Some(a) = acc {
                *dst = read_f32::<3>(&a, buffers)
                    .map_err(|e| acc_err(&a, e.context(format!("morph target {target_index}"))))?
                    .into_iter()
                    .map(Vec3::from)
                    .collect();
            }
        }
        mesh.morph_targets.push(t);
    }

    let (mode, elements) = match (draco, prim.indices()) {
        // Draco's triangles are a list whatever the primitive's mode (4 or 5) says.
        (Some(d), _) => (Mode::Triangles, Some(d.indices())),
        (None, Some(a)) => (prim.mode(), Some(read_indices(&a, buffers).map_err(|e| acc_err(&a, e))?)),
        (None, None) => (prim.mode(), None),
    };
    let (topology, indices) = expand_topology(mode, elements, n);
    mesh.topology = topology;
    mesh.indices = indices;
    // Dangling indices must be caught before anything below indexes attribute arrays by them.
    mesh.validate().map_err(|source| ImportErrorKind::Mesh { mesh: mesh_index, primitive, source })?;

    let mut notes = Vec::new();
    if mesh.is_skinned() {
        let off = mesh.normalize_weights();
        if off > 0 {
            notes.push(format!(
                "mesh {mesh_index} primitive {primitive}: {off} vertices' WEIGHTS_0 did not sum to 1; normalised"
            ));
        }
    }
    let replaced = mesh.sanitize();
    if replaced > 0 {
        notes.push(format!(
            "mesh {mesh_index} primitive {primitive}: replaced {replaced} non-finite or zero-length attribute values \
             (NaN or infinite positions, UVs, colours; zero-length normals and tangents)"
        ));
    }
    let degenerate = mesh.degenerate_triangles();
    if degenerate > 0 {
        notes.push(format!(
            "mesh {mesh_index} primitive {primitive}: {degenerate} degenerate triangles (zero area: \
             the rasteriser draws nothing for them)"
        ));
    }
    if topology == Topology::TriangleList {
        if mesh.normals.is_empty() {
            mesh.compute_flat_normals();
        }
        if let Some(set) = needs.normal_map_uv_set {
            let has_uvs = if set == 0 { !mesh.uv0.is_empty() } else { !mesh.uv1.is_empty() };
            let from_file = !mesh.tangents.is_empty();
            if !from_file && has_uvs {
                mesh.generate_tangents(set).map_err(|source| ImportErrorKind::Mesh {
                    mesh: mesh_index,
                    primitive,
                    source,
                })?;
            }
            // A few zero-area UV triangles are common and harmless (MikkTSpace takes their
            // neighbours' direction); UVs that are all one point leave the map no direction at all.
            let triangles = mesh.indices.as_ref().map_or(mesh.positions.len(), Vec::len) / 3;
            if has_uvs && triangles > 0 && mesh.degenerate_uv_triangles(set) == triangles {
                notes.push(format!(
                    "mesh {mesh_index} primitive {primitive}: the normal map's TEXCOORD_{set} has zero area on \
                     every triangle (all UVs equal or in a line), so the map has no direction on this mesh"
                ));
            }
            // Generated tangents can be degenerate too (MikkTSpace's fallback where UVs give no
            // direction): repaired the same way, but only the file's own are news to its author.
            let repaired = mesh.repair_tangent_frames(set);
            if repaired > 0 && from_file {
                notes.push(format!(
                    "mesh {mesh_index} primitive {primitive}: {repaired} vertices had tangents parallel to their \
                     normals; rebuilt (MikkTSpace where the UVs allow, else any perpendicular direction)"
                ));
            }
        }
    }
    Ok(Built::Mesh(Box::new(mesh), notes))
}

/// Strips, fans and loops become lists, following the glTF 2.0 spec §3.7.2.1 exactly so the
/// winding of every triangle is preserved.
fn expand_topology(mode: Mode, elements: Option<Vec<u32>>, vertex_count: usize) -> (Topology, Option<Vec<u32>>) {
    let seq = |e: &Option<Vec<u32>>| -> Vec<u32> { e.clone().unwrap_or_else(|| (0..vertex_count as u32).collect()) };
    match mode {
        Mode::Triangles => (Topology::TriangleList, elements),
        Mode::Lines => (Topology::LineList, elements),
        Mode::Points => (Topology::PointList, elements),
        Mode::TriangleStrip => {
            let v = seq(&elements);
            let tris = (0..v.len().saturating_sub(2))
                .flat_map(|i| {
                    // p_i = {v_i, v_{i+(1+i%2)}, v_{i+(2−i%2)}}
                    let odd = i % 2;
                    [v[i], v[i + 1 + odd], v[i + 2 - odd]]
                })
                .collect();
            (Topology::TriangleList, Some(tris))
        }
        Mode::TriangleFan => {
            let v = seq(&elements);
            // p_i = {v_{i+1}, v_{i+2}, v_0}
            let tris = (0..v.len().saturating_sub(2)).flat_map(|i| [v[i + 1], v[i + 2], v[0]]).collect();
            (Topology::TriangleList, Some(tris))
        }
        Mode::LineStrip => {
            let v = seq(&elements);
            let lines = v.windows(2).flat_map(|w| [w[0], w[1]]).collect();
            (Topology::LineList, Some(lines))
        }
        Mode::LineLoop => {
            let v = seq(&elements);
            let mut lines: Vec<u32> = v.windows(2).flat_map(|w| [w[0], w[1]]).collect();
            if v.len() > 1 {
                lines.extend_from_slice(&[v[v.len() - 1], v[0]]);
            }
            (Topology::LineList, Some(lines))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_keep_the_winding_of_their_first_triangle() {
        let (_, s) = expand_topology(Mode::TriangleStrip, None, 5);
        assert_eq!(s.unwrap(), [0, 1, 2, 1, 3, 2, 2, 3, 4]);
        let (_, f) = expand_topology(Mode::TriangleFan, None, 4);
        assert_eq!(f.unwrap(), [1, 2, 0, 2, 3, 0]);
        let (t, l) = expand_topology(Mode::LineLoop, Some(vec![4, 5, 6]), 7);
        assert_eq!((t, l.unwrap()), (Topology::LineList, vec![4, 5, 5, 6, 6, 4]));
    }
}
