//! `Mesh`: geometry as parallel attribute arrays, the form importers and primitive builders hand
//! over. The render crate's mesh pool decides the GPU layout; nothing here knows about it.
//!
//! Topology is normalised at import to lists (strips, fans and loops are expanded), so the GPU
//! side deals with three topologies and winding is always explicit per triangle.

use glam::{Vec2, Vec3, Vec4};

use crate::bounds::Aabb;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Topology {
    #[default]
    TriangleList,
    LineList,
    PointList,
}

impl Topology {
    pub fn vertices_per_primitive(self) -> usize {
        match self {
            Topology::TriangleList => 3,
            Topology::LineList => 2,
            Topology::PointList => 1,
        }
    }
}

/// Geometry of one drawable primitive. An empty attribute vector means "absent".
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    pub topology: Topology,
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// xyz tangent, w the bitangent sign (±1), as glTF.
    pub tangents: Vec<Vec4>,
    pub uv0: Vec<Vec2>,
    pub uv1: Vec<Vec2>,
    /// Linear RGBA.
    pub colors: Vec<Vec4>,
    pub indices: Option<Vec<u32>>,
    /// Up to four joints per vertex (glTF's JOINTS_0), indices into the skin's joint list.
    pub joints: Vec<[u16; 4]>,
    /// Weights of `joints` (WEIGHTS_0). Importers normalise them to sum to 1; a vertex whose
    /// weights are all 0 is not skinned (it keeps its bind-space position).
    pub weights: Vec<Vec4>,
    /// Displacements added to the attributes, each scaled by its weight in `MorphWeights`.
    pub morph_targets: Vec<MorphTarget>,
}

/// One morph target: per-vertex displacements (an empty vector means the target does not move
/// that attribute).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MorphTarget {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// Displacements of the tangents' xyz (the handedness sign does not morph).
    pub tangents: Vec<Vec3>,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshError {
    #[error("attribute {name} has {len} values but there are {vertices} positions")]
    AttributeLength { name: &'static str, len: usize, vertices: usize },
    #[error("index {index} at position {at} is out of range for {vertices} vertices")]
    IndexOutOfRange { index: u32, at: usize, vertices: usize },
    #[error("{count} indices is not a whole number of {topology:?} primitives")]
    PartialPrimitive { count: usize, topology: Topology },
    #[error("JOINTS_0 and WEIGHTS_0 must come together ({joints} joint and {weights} weight values)")]
    SkinAttributes { joints: usize, weights: usize },
    #[error("morph target {target}: {name} has {len} values but there are {vertices} positions")]
    MorphTargetLength { target: usize, name: &'static str, len: usize, vertices: usize },
    #[error("tangent generation needs triangles with normals and texture coordinates")]
    TangentInputsMissing,
    #[error("tangent generation failed: {0}")]
    Tangents(String),
}

impl Mesh {
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of vertices the draw consumes (index count, or vertex count when non-indexed).
    pub fn element_count(&self) -> usize {
        self.indices.as_ref().map_or(self.positions.len(), Vec::len)
    }

    pub fn aabb(&self) -> Aabb {
        Aabb::from_points(&self.positions)
    }

    /// Checks the invariants the GPU side relies on: equal attribute lengths, indices in range,
    /// whole primitives.
    pub fn validate(&self) -> Result<(), MeshError> {
        let n = self.positions.len();
        let check = |name, len: usize| {
            if len != 0 && len != n { Err(MeshError::AttributeLength { name, len, vertices: n }) } else { Ok(()) }
        };
        check("NORMAL", self.normals.len())?;
        check("TANGENT", self.tangents.len())?;
        check("TEXCOORD_0", self.uv0.len())?;
        check("TEXCOORD_1", self.uv1.len())?;
        check("COLOR_0", self.colors.len())?;
        check("JOINTS_0", self.joints.len())?;
        check("WEIGHTS_0", self.weights.len())?;
        if self.joints.len() != self.weights.len() {
            return Err(MeshError::SkinAttributes { joints: self.joints.len(), weights: self.weights.len() });
        }
        for (target, t) in self.morph_targets.iter().enumerate() {
            for (name, len) in
                [("POSITION", t.positions.len()), ("NORMAL", t.normals.len()), ("TANGENT", t.tangents.len())]
            {
                if len != 0 && len != n {
                    return Err(MeshError::MorphTargetLength { target, name, len, vertices: n });
                }
            }
        }
        if let Some(indices) = &self.indices
            && let Some((at, &index)) = indices.iter().enumerate().find(|(_, i)| **i as usize >= n)
        {
            return Err(MeshError::IndexOutOfRange { index, at, vertices: n });
        }
        let count = self.element_count();
        if !count.is_multiple_of(self.topology.vertices_per_primitive()) {
            return Err(MeshError::PartialPrimitive { count, topology: self.topology });
        }
        Ok(())
    }

    /// Replaces non-finite attribute values so that no NaN can flow from input into shading:
    /// positions become the origin (the triangle degenerates and is not rasterised), normals and
    /// tangents a fixed unit vector, UVs and colours zero / white. Returns how many were replaced.
    pub fn sanitize(&mut self) -> usize {
        fn fix<T: Copy>(v: &mut [T], finite: impl Fn(&T) -> bool, fallback: T) -> usize {
            let mut n = 0;
            for x in v.iter_mut().filter(|x| !finite(x)) {
                *x = fallback;
                n += 1;
            }
            n
        }
        fix(&mut self.positions, |p| p.is_finite(), Vec3::ZERO)
            + fix(&mut self.normals, |p| p.is_finite() && p.length_squared() > 0.0, Vec3::Z)
            + fix(
                &mut self.tangents,
                |p| p.is_finite() && p.truncate().length_squared() > 0.0,
                Vec4::new(1.0, 0.0, 0.0, 1.0),
            )
            + fix(&mut self.uv0, |p| p.is_finite(), Vec2::ZERO)
            + fix(&mut self.uv1, |p| p.is_finite(), Vec2::ZERO)
            + fix(&mut self.colors, |p| p.is_finite(), Vec4::ONE)
            + fix(&mut self.weights, |w| w.is_finite(), Vec4::ZERO)
            + self
                .morph_targets
                .iter_mut()
                .map(|t| {
                    fix(&mut t.positions, |p| p.is_finite(), Vec3::ZERO)
                        + fix(&mut t.normals, |p| p.is_finite(), Vec3::ZERO)
                        + fix(&mut t.tangents, |p| p.is_finite(), Vec3::ZERO)
                })
                .sum::<usize>()
    }

    /// Triangles of a triangle list with zero area (repeated or collinear corners); 0 for
    /// other topologies.
    pub fn degenerate_triangles(&self) -> usize {
        if self.topology != Topology::TriangleList {
            return 0;
        }
        let corner = |i: u32| self.positions.get(i as usize).copied().unwrap_or(Vec3::ZERO);
        let area_zero = |t: &[u32]| (corner(t[1]) - corner(t[0])).cross(corner(t[2]) - corner(t[0])) == Vec3::ZERO;
        match &self.indices {
            Some(idx) => idx.chunks_exact(3).filter(|t| area_zero(t)).count(),
            None => {
                (0..self.positions.len() as u32).collect::<Vec<_>>().chunks_exact(3).filter(|t| area_zero(t)).count()
            }
        }
    }

    /// Triangles of a triangle list whose UVs (in `uv_set`) have zero area: all three corners at
    /// one UV, or on one line. A normal map has no direction on them (MikkTSpace cannot derive a
    /// tangent there).
    pub fn degenerate_uv_triangles(&self, uv_set: u32) -> usize {
        let uvs = if uv_set == 0 { &self.uv0 } else { &self.uv1 };
        if self.topology != Topology::TriangleList || uvs.len() != self.positions.len() {
            return 0;
        }
        let uv = |i: u32| uvs.get(i as usize).copied().unwrap_or(Vec2::ZERO);
        let flat = |t: &[u32]| (uv(t[1]) - uv(t[0])).perp_dot(uv(t[2]) - uv(t[0])) == 0.0;
        match &self.indices {
            Some(idx) => idx.chunks_exact(3).filter(|t| flat(t)).count(),
            None => (0..self.positions.len() as u32).collect::<Vec<_>>().chunks_exact(3).filter(|t| flat(t)).count(),
        }
    }

    /// Makes every tangent frame usable: a tangent (nearly) parallel to its vertex's normal
    /// gives no direction to a normal map (the shader's Gram-Schmidt step divides by zero: black
    /// and white noise). Such tangents are replaced by MikkTSpace's from `uv_set` where those
    /// are usable, else by any direction perpendicular to the normal (the map then has an
    /// arbitrary but stable orientation there, as a surface without UV direction must).
    /// Returns how many vertices were repaired.
    pub fn repair_tangent_frames(&mut self, uv_set: u32) -> usize {
        if self.tangents.len() != self.positions.len() || self.normals.len() != self.positions.len() {
            return 0;
        }
        // A sine of 1e-3 between the two: beyond that the frame is noise in f16 normal maps.
        let usable = |t: Vec4, n: Vec3| {
            let t = t.truncate();
            t.is_finite() && t.cross(n).length_squared() > 1e-6 * t.length_squared() * n.length_squared()
        };
        let broken: Vec<usize> =
            (0..self.tangents.len()).filter(|&i| !usable(self.tangents[i], self.normals[i])).collect();
        if broken.is_empty() {
            return 0;
        }
        let mut generated = self.clone();
        let mikk = generated.generate_tangents(uv_set).is_ok();
        for &i in &broken {
            let n = self.normals[i];
            self.tangents[i] = match mikk.then(|| generated.tangents[i]) {
                Some(t) if usable(t, n) => t,
                _ => n.normalize_or(Vec3::Z).any_orthonormal_vector().extend(1.0),
            };
        }
        broken.len()
    }

    /// Expands indices so every triangle owns its three vertices (needed for flat normals).
    pub fn unindex(&mut self) {
        let Some(indices) = self.indices.take() else {
            return;
        };
        fn gather<T: Copy>(v: &mut Vec<T>, idx: &[u32]) {
            if !v.is_empty() {
                *v = idx.iter().map(|&i| v[i as usize]).collect();
            }
        }
        gather(&mut self.positions, &indices);
        gather(&mut self.normals, &indices);
        gather(&mut self.tangents, &indices);
        gather(&mut self.uv0, &indices);
        gather(&mut self.uv1, &indices);
        gather(&mut self.colors, &indices);
        gather(&mut self.joints, &indices);
        gather(&mut self.weights, &indices);
        for t in &mut self.morph_targets {
            gather(&mut t.positions, &indices);
            gather(&mut t.normals, &indices);
            gather(&mut t.tangents, &indices);
        }
    }

    /// Scales every vertex's weights to sum to 1, as glTF requires of skinned meshes (exporters
    /// often write sums a few ULPs off, some far off). All-zero weights stay zero. Returns the
    /// number of vertices whose sum was off by more than 1e-3, for a warning.
    pub fn normalize_weights(&mut self) -> usize {
        let mut off = 0;
        for w in &mut self.weights {
            let w_clamped = w.max(Vec4::ZERO);
            let sum = w_clamped.element_sum();
            if (sum - 1.0).abs() > 1e-3 {
                off += 1;
            }
            *w = if sum > 0.0 { w_clamped / sum } else { Vec4::ZERO };
        }
        off
    }

    /// Positions after morph targets (`weights`, missing ones 0) and skinning (`joints`:
    /// mesh_from_bind per joint, missing ones the identity), computed on the CPU exactly as the
    /// GPU deformation pass does. For framing and tests; frames deform on the GPU.
    pub fn deformed_positions(&self, joints: &[glam::Mat4], weights: &[f32]) -> Vec<Vec3> {
        (0..self.positions.len())
            .map(|v| {
                let mut p = self.positions[v];
                for (t, target) in self.morph_targets.iter().enumerate() {
                    if let (Some(w), Some(d)) = (weights.get(t), target.positions.get(v)) {
                        p += *w * *d;
                    }
                }
                self.skin_matrix(v, joints).map_or(p, |m| m.transform_point3(p))
            })
            .collect()
    }

    /// Vertex `v`'s blended joint matrix (`joints` missing ones count as the identity), or `None`
    /// when the vertex is not skinned (no skin, or all weights 0).
    fn skin_matrix(&self, v: usize, joints: &[glam::Mat4]) -> Option<glam::Mat4> {
        let (j, w) = (self.joints.get(v)?, self.weights.get(v)?);
        (w.element_sum() > 0.0).then(|| {
            (0..4).fold(glam::Mat4::ZERO, |m, i| {
                m + joints.get(j[i] as usize).copied().unwrap_or(glam::Mat4::IDENTITY) * w[i]
            })
        })
    }

    /// Normals after morph targets and skinning, as the GPU deformation pass computes them:
    /// displaced, then turned by the cofactor of the blended joint matrix (signed by its
    /// determinant), then normalised (a zero normal stays zero). For tests and tools.
    pub fn deformed_normals(&self, joints: &[glam::Mat4], weights: &[f32]) -> Vec<Vec3> {
        (0..self.normals.len())
            .map(|v| {
                let mut n = self.normals[v];
                for (t, target) in self.morph_targets.iter().enumerate() {
                    if let (Some(w), Some(d)) = (weights.get(t), target.normals.get(v)) {
                        n += *w * *d;
                    }
                }
                if let Some(m) = self.skin_matrix(v, joints) {
                    let (c0, c1, c2) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
                    let cofactor = glam::Mat3::from_cols(c1.cross(c2), c2.cross(c0), c0.cross(c1));
                    let sign = if c0.dot(c1.cross(c2)) < 0.0 { -1.0 } else { 1.0 };
                    n = cofactor * n * sign;
                }
                n.try_normalize().unwrap_or(Vec3::ZERO)
            })
            .collect()
    }

    pub fn is_skinned(&self) -> bool {
        !self.joints.is_empty()
    }

    /// The largest joint index a vertex with non-zero weight refers to.
    pub fn max_joint(&self) -> Option<u16> {
        self.joints
            .iter()
            .zip(&self.weights)
            .flat_map(|(j, w)| j.iter().zip(w.to_array()).filter(|(_, w)| *w > 0.0).map(|(j, _)| *j))
            .max()
    }

    /// Face normals, as the glTF spec asks for when NORMAL is absent. Unindexes the mesh.
    pub fn compute_flat_normals(&mut self) {
        if self.topology != Topology::TriangleList {
            return;
        }
        self.unindex();
        self.normals = self
            .positions
            .chunks_exact(3)
            .flat_map(|t| {
                let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or(Vec3::Z);
                [n; 3]
            })
            .collect();
    }

    /// Smooth normals: each vertex gets the area-weighted sum of the normals of every triangle
    /// touching its position (vertices split only by UV or colour are welded for this), the
    /// shading a missing-normals OBJ most often intends. Triangle lists only.
    pub fn compute_smooth_normals(&mut self) {
        if self.topology != Topology::TriangleList {
            return;
        }
        let indices = self.indices.clone().unwrap_or_else(|| (0..self.positions.len() as u32).collect());
        let key = |p: Vec3| p.to_array().map(f32::to_bits);
        let mut sums: std::collections::HashMap<[u32; 3], Vec3> = std::collections::HashMap::new();
        for t in indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| self.positions[i as usize]);
            // The cross product's length is twice the area: the weighting.
            let n = (b - a).cross(c - a);
            for p in [a, b, c] {
                *sums.entry(key(p)).or_default() += n;
            }
        }
        self.normals =
            self.positions.iter().map(|p| sums.get(&key(*p)).map_or(Vec3::Z, |n| n.normalize_or(Vec3::Z))).collect();
    }

    /// MikkTSpace tangents (the space glTF normal maps are baked in), from `NORMAL` and the given
    /// UV set. Vertices MikkTSpace leaves undefined (degenerate faces) get +X with sign +1.
    pub fn generate_tangents(&mut self, uv_set: u32) -> Result<(), MeshError> {
        let uv_len = if uv_set == 0 { self.uv0.len() } else { self.uv1.len() };
        if self.topology != Topology::TriangleList
            || self.normals.len() != self.positions.len()
            || uv_len != self.positions.len()
        {
            return Err(MeshError::TangentInputsMissing);
        }
        let vertex_count = self.positions.len();
        let indices = self.indices.clone().unwrap_or_else(|| (0..vertex_count as u32).collect());
        let mut geometry = TangentGeometry {
            mesh: self,
            indices: &indices,
            uv_set,
            out: vec![Vec4::new(1.0, 0.0, 0.0, 1.0); vertex_count],
        };
        bevy_mikktspace::generate_tangents(&mut geometry).map_err(|e| MeshError::Tangents(format!("{e:?}")))?;
        let out = geometry.out;
        self.tangents = out;
        Ok(())
    }
}

struct TangentGeometry<'a> {
    mesh: &'a Mesh,
    indices: &'a [u32],
    uv_set: u32,
    out: Vec<Vec4>,
}

impl TangentGeometry<'_> {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.indices[face * 3 + vert] as usize
    }
}

impl bevy_mikktspace::Geometry for TangentGeometry<'_> {
    fn num_faces(&self) -> usize {
        self.indices.len() / 3
    }
    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }
    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.mesh.positions[self.vertex(face, vert)].into()
    }
    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.mesh.normals[self.vertex(face, vert)].into()
    }
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        let uvs = if self.uv_set == 0 { &self.mesh.uv0 } else { &self.mesh.uv1 };
        let uv = uvs[self.vertex(face, vert)];
        // glTF's v grows downwards, but its normal maps store +Y as "up in the image", which is
        // MikkTSpace's +v when v grows upwards (how Blender and other bakers compute it before
        // export flips v). Feeding 1 − v yields the bitangent sign glTF expects.
        [uv.x, 1.0 - uv.y]
    }
    fn set_tangent(&mut self, tangent_space: Option<bevy_mikktspace::TangentSpace>, face: usize, vert: usize) {
        if let Some(ts) = tangent_space {
            let i = self.vertex(face, vert);
            // A vertex shared by faces gets the last face's tangent; MikkTSpace gives shared
            // vertices the same tangent unless they should be split, which glTF meshes already are.
            self.out[i] = Vec4::from_array(ts.tangent_encoded());
        }
    }
}

/// Whether the front faces of a mesh can cover one pixel twice (see
/// [`Mesh::self_overlap`]); where they cannot, a frame that draws only this mesh, once, needs
/// no depth buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum SelfOverlap {
    /// Never, from any viewpoint: a single triangle.
    Never,
    /// Never while back faces are culled: a convex surface wound outwards (every vertex on or
    /// behind every triangle's plane), flat ones included, with no two triangles overlapping.
    WhenBackFacesCulled,
    /// Possibly (or not worth proving: see [`OVERLAP_TEST_BUDGET`]).
    #[default]
    Possible,
}

/// Most triangle × vertex plane tests [`Mesh::self_overlap`] spends before answering
/// `Possible` (a few milliseconds of one core).
pub const OVERLAP_TEST_BUDGET: usize = 1 << 22;

impl Mesh {
    /// Whether this mesh's front faces can overlap on screen. Skinned and morphed meshes change
    /// shape, and lines and points have no faces: `Possible`. Triangles of zero area cover no
    /// pixel and are ignored.
    pub fn self_overlap(&self) -> SelfOverlap {
        if self.topology != Topology::TriangleList
            || !self.joints.is_empty()
            || !self.morph_targets.is_empty()
            || self.positions.iter().any(|p| !p.is_finite())
        {
            return SelfOverlap::Possible;
        }
        let corners: Vec<[Vec3; 3]> = match &self.indices {
            Some(idx) => idx
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]].map(|i| self.positions.get(i as usize).copied().unwrap_or(Vec3::ZERO)))
                .collect(),
            None => self.positions.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        };
        let faces: Vec<([Vec3; 3], Vec3)> = corners
            .into_iter()
            .map(|c| (c, (c[1] - c[0]).cross(c[2] - c[0])))
            .filter(|(_, n)| *n != Vec3::ZERO)
            .collect();
        match faces.len() {
            0 | 1 => return SelfOverlap::Never,
            n if n.saturating_mul(self.positions.len()) > OVERLAP_TEST_BUDGET => return SelfOverlap::Possible,
            _ => {}
        }
        let aabb = self.aabb();
        // 1e-4 of the mesh's size (a dent shallower than that counts as flat: it could only
        // show at grazing angles, as slivers under a pixel), plus what f32 positions this far
        // out are rounded by (a mesh too small for its distance from its origin answers
        // `Possible`).
        let far = aabb.min.abs().max(aabb.max.abs()).max_element() as f64;
        let size = (aabb.max - aabb.min).max_element() as f64;
        let rounding = 16.0 * f32::EPSILON as f64 * far;
        if rounding > 1e-3 * size {
            return SelfOverlap::Possible;
        }
        let tolerance = 1e-4 * size + rounding;
        // Convex, wound outwards: nothing in front of any face's plane. In f64 about the
        // bounds' centre, so that distance from the origin costs no precision here.
        let centre = (0.5 * (aabb.min + aabb.max)).as_dvec3();
        let local: Vec<glam::DVec3> = self.positions.iter().map(|p| p.as_dvec3() - centre).collect();
        for (c, _) in &faces {
            let [a, b, d] = c.map(|p| p.as_dvec3() - centre);
            let n = (b - a).cross(d - a).normalize();
            if local.iter().any(|p| n.dot(*p - a) > tolerance) {
                return SelfOverlap::Possible;
            }
        }
        // On a convex surface, faces with one outward normal share one supporting plane; there
        // they must tile, not overlap: their areas add up to at most their hull's.
        let mut planes: std::collections::HashMap<[i64; 3], (glam::DVec3, f64, Vec<glam::DVec3>)> = Default::default();
        for (c, _) in &faces {
            let [a, b, d] = c.map(|p| p.as_dvec3() - centre);
            let n = (b - a).cross(d - a);
            let unit = n.normalize();
            let key = (unit * 1e4).round().as_i64vec3().to_array();
            let plane = planes.entry(key).or_insert((unit, 0.0, Vec::new()));
            plane.1 += 0.5 * n.length();
            plane.2.extend_from_slice(&[a, b, d]);
        }
        for (normal, area, points) in planes.values() {
            if *area > hull_area(*normal, points) * (1.0 + 1e-4) + tolerance * tolerance {
                return SelfOverlap::Possible;
            }
        }
        SelfOverlap::WhenBackFacesCulled
    }
}

/// Area of the convex hull of `points` (all in one plane of this normal), by Andrew's monotone
/// chain in the plane's own 2D coordinates.
fn hull_area(normal: glam::DVec3, points: &[glam::DVec3]) -> f64 {
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    let mut p: Vec<(f64, f64)> = points.iter().map(|q| (q.dot(u), q.dot(v))).collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    p.dedup();
    if p.len() < 3 {
        return 0.0;
    }
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0);
    let mut hull: Vec<(f64, f64)> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = hull.len();
        let mut points = p.clone();
        if pass == 1 {
            points.reverse();
        }
        for q in points {
            while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0 {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    let n = hull.len();
    0.5 * (0..n).map(|i| hull[i].0 * hull[(i + 1) % n].1 - hull[(i + 1) % n].0 * hull[i].1).sum::<f64>().abs()
}

/// Editing derives nothing else from the asset.
impl crate::assets::AssetEdit for Mesh {}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Mesh {
        Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            normals: vec![Vec3::Z; 4],
            uv0: vec![Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::ZERO],
            indices: Some(vec![0, 1, 2, 0, 2, 3]),
            ..Default::default()
        }
    }

    #[test]
    fn tangents_follow_increasing_u() {
        let mut m = quad();
        m.generate_tangents(0).unwrap();
        for t in &m.tangents {
            assert!((t.truncate() - Vec3::X).length() < 1e-4, "{t}");
            // Standard, unmirrored mapping: the bitangent cross(N, T) · w is image-up, +Y, so w = +1,
            // as exporters write it.
            assert_eq!(t.w, 1.0);
        }
    }

    #[test]
    fn validation_catches_bad_indices_and_lengths() {
        let mut m = quad();
        m.indices = Some(vec![0, 1, 9]);
        assert!(matches!(m.validate(), Err(MeshError::IndexOutOfRange { index: 9, .. })));
        let mut m = quad();
        m.uv1 = vec![Vec2::ZERO];
        assert!(matches!(m.validate(), Err(MeshError::AttributeLength { name: "TEXCOORD_1", .. })));
    }

    #[test]
    fn flat_normals_face_the_winding() {
        let mut m = quad();
        m.normals.clear();
        m.compute_flat_normals();
        assert_eq!(m.positions.len(), 6);
        assert!(m.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
    }

    #[test]
    fn smooth_normals_weld_split_vertices_and_weight_by_area() {
        // Two triangles folded along the x axis, the shared edge duplicated (as a UV seam would).
        let mut m = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ZERO, Vec3::Z, Vec3::X],
            indices: Some(vec![0, 1, 2, 3, 4, 5]),
            ..Default::default()
        };
        m.compute_smooth_normals();
        let fold = Vec3::new(0.0, 1.0, 1.0).normalize();
        for v in [0, 1, 3, 5] {
            assert!((m.normals[v] - fold).length() < 1e-6, "shared edge vertex {v}: {}", m.normals[v]);
        }
        assert!((m.normals[2] - Vec3::Z).length() < 1e-6 && (m.normals[4] - Vec3::Y).length() < 1e-6);
    }

    #[test]
    fn sanitize_replaces_nan() {
        let mut m = quad();
        m.normals[1] = Vec3::NAN;
        m.positions[2].x = f32::INFINITY;
        assert_eq!(m.sanitize(), 2);
        assert!(m.normals.iter().all(|n| n.is_finite()));
    }

    #[test]
    fn self_overlap_is_proved_only_for_convex_outward_surfaces_and_single_triangles() {
        let triangle = Mesh { positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y], ..Default::default() };
        assert_eq!(triangle.self_overlap(), SelfOverlap::Never);
        assert_eq!(Mesh::cuboid(Vec3::new(1.0, 2.0, 3.0)).self_overlap(), SelfOverlap::WhenBackFacesCulled);
        assert_eq!(Mesh::uv_sphere(0.5, 24, 12).self_overlap(), SelfOverlap::WhenBackFacesCulled);
        assert_eq!(Mesh::plane(2.0).self_overlap(), SelfOverlap::WhenBackFacesCulled, "flat counts");
        // Tiny, and away from its origin: the tolerance follows the mesh's size and distance.
        let mut tiny = Mesh::uv_sphere(1e-3, 16, 8);
        tiny.positions.iter_mut().for_each(|p| *p += Vec3::splat(0.5));
        assert_eq!(tiny.self_overlap(), SelfOverlap::WhenBackFacesCulled);
        let mut away = Mesh::uv_sphere(1.0, 16, 8);
        away.positions.iter_mut().for_each(|p| *p += Vec3::splat(100.0));
        assert_eq!(away.self_overlap(), SelfOverlap::WhenBackFacesCulled);
        // So small for its distance that f32 rounding bends it: not proved, depth stays.
        let mut rounded = Mesh::uv_sphere(1e-3, 16, 8);
        rounded.positions.iter_mut().for_each(|p| *p += Vec3::splat(1e3));
        assert_eq!(rounded.self_overlap(), SelfOverlap::Possible);
        assert_eq!(Mesh::torus(1.0, 0.3, 16, 8).self_overlap(), SelfOverlap::Possible, "not convex");
        let mut inside_out = Mesh::cuboid(Vec3::ONE);
        inside_out.indices.as_mut().unwrap().chunks_exact_mut(3).for_each(|t| t.swap(1, 2));
        assert_eq!(inside_out.self_overlap(), SelfOverlap::Possible, "wound inwards");
        // Two quads in one plane, one over the other: convex by the plane test, but overlapping.
        let mut doubled = Mesh::plane(2.0);
        let mut second = Mesh::plane(1.0);
        let base = doubled.positions.len() as u32;
        doubled.positions.append(&mut second.positions);
        let extra: Vec<u32> = second.indices.unwrap().iter().map(|i| i + base).collect();
        doubled.indices.as_mut().unwrap().extend(extra);
        assert_eq!(doubled.self_overlap(), SelfOverlap::Possible, "coplanar overlap");
        let mut lines = Mesh::cuboid(Vec3::ONE);
        lines.topology = Topology::LineList;
        assert_eq!(lines.self_overlap(), SelfOverlap::Possible);
        let mut nan = Mesh::cuboid(Vec3::ONE);
        nan.positions[0].x = f32::NAN;
        assert_eq!(nan.self_overlap(), SelfOverlap::Possible);
        let mut morphed = Mesh::cuboid(Vec3::ONE);
        morphed.morph_targets.push(MorphTarget::default());
        assert_eq!(morphed.self_overlap(), SelfOverlap::Possible);
    }
}
