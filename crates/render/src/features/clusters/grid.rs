//! The froxel grid on the CPU: built from the view each frame, packed for the GPU
//! (`GpuClusterGrid`, mirrored by `struct ClusterGrid` in `shaders/clusters.wgsl`), and the CPU
//! twin of the binning walk in `shaders/cluster_bin.wgsl` (a light's bounds, its candidate box,
//! the per-cluster test). The twin serves the reference binner the tests compare against and
//! the upper bound that sizes the index buffer.

use bytemuck::{Pod, Zeroable};
use glam::{Mat3, UVec3, Vec2, Vec3};
use penumbra_engine::components::Projection;

use crate::resources::light_store::{GpuLight, KIND_DISK, KIND_RECT, KIND_SPOT, LightBounds};
use crate::scene::world::ExtractedView;

/// Froxel grid resolution: tiles across and down the screen, and depth slices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClusterConfig {
    pub tiles_x: u32,
    pub tiles_y: u32,
    pub slices: u32,
}

impl Default for ClusterConfig {
    /// 16 × 16 tiles × 32 slices = 8192 clusters.
    fn default() -> Self {
        Self { tiles_x: 16, tiles_y: 16, slices: 32 }
    }
}

/// The most clusters a grid may have. Up to 2²² (cluster, block) runs (see [`LightBlocks`]: 4
/// blocks at this many clusters), each of the scan's at most 4096 workgroups sums up to 4095
/// block totals before its own; past 262 144 lights on such a grid, blocks stop growing at
/// 65 536 lights, the runs pass 2²², and that part of the scan grows with the square of the
/// block count.
pub const MAX_CLUSTERS: u32 = 1 << 20;

impl ClusterConfig {
    pub fn count(&self) -> u32 {
        self.tiles_x * self.tiles_y * self.slices
    }

    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [("tiles across", self.tiles_x), ("tiles down", self.tiles_y), ("depth slices", self.slices)] {
            if !(1..=1024).contains(&v) {
                return Err(format!("cluster {name} {v} is out of range (1 to 1024)"));
            }
        }
        if self.count() > MAX_CLUSTERS {
            return Err(format!("{} clusters is more than the {MAX_CLUSTERS} supported", self.count()));
        }
        Ok(())
    }
}

/// How the binner splits the local lights into blocks of consecutive lights: each cluster's
/// list is counted and filled per block, so that its list comes out as one run per block, in
/// block order, and only the runs need sorting (see cluster_bin.wgsl).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LightBlocks {
    pub count: u32,
    /// Lights per block.
    pub lights: u32,
}

impl LightBlocks {
    /// Lights per block at most scenes' light counts: runs stay a few lights long up to
    /// hundreds of thousands of lights (on the many-lights scene at 100 000 lights, 5 on average
    /// and 15 in the longest list's runs).
    pub const LIGHTS: u32 = 1024;
    /// The most (cluster, block) runs: past it blocks grow instead, to keep the run counters
    /// (a word each) within 16 MiB, up to [`Self::MAX_LIGHTS`].
    pub const MAX_RUNS: u32 = 1 << 22;
    /// The largest block: the long-run sort holds a bit per light of a block in its workgroup
    /// memory (`MASK_WORDS` in cluster_bin.wgsl).
    pub const MAX_LIGHTS: u32 = 2048 * 32;

    pub fn new(light_count: u32, clusters: u32) -> Self {
        let max_blocks = (Self::MAX_RUNS / clusters.max(1)).max(1);
        let lights = Self::LIGHTS.max(light_count.div_ceil(max_blocks)).min(Self::MAX_LIGHTS);
        Self { count: light_count.div_ceil(lights).max(1), lights }
    }

    /// The (cluster, block) runs of a grid of `clusters`.
    pub fn runs(&self, clusters: u32) -> u64 {
        self.count as u64 * clusters as u64
    }
}

/// Mirrors `struct ClusterGrid` in `shaders/clusters.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuClusterGrid {
    pub view_x: [f32; 4],
    pub view_y: [f32; 4],
    pub view_z: [f32; 4],
    pub camera_position: [f32; 3],
    pub near: f32,
    pub dims: [u32; 3],
    pub is_orthographic: u32,
    pub proj_scale: [f32; 2],
    pub far: f32,
    pub slice_scale: f32,
    pub viewport: [f32; 2],
    pub light_first: u32,
    pub light_count: u32,
    pub light_blocks: u32,
    pub block_lights: u32,
    pub _pad: [u32; 2],
}

/// One frame's grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClusterGrid {
    /// Rotation from camera-relative world space to view space.
    pub view_from_rel: Mat3,
    pub camera_position: Vec3,
    pub dims: UVec3,
    pub orthographic: bool,
    pub proj_scale: Vec2,
    /// Depths where the first slice begins and the last one ends (see `ClusterGrid::new`).
    pub near: f32,
    pub far: f32,
    pub slice_scale: f32,
    pub viewport: Vec2,
}

/// How far past a light's exact projected bounds, in tiles or slices, its candidate box
/// reaches: `CANDIDATE_MARGIN` in cluster_bin.wgsl, whose comment says why.
pub const CANDIDATE_MARGIN: f32 = 0.01;

/// How many pixels further across the screen candidate boxes reach: `LOOKUP_SLACK` in
/// cluster_bin.wgsl, whose comment says why.
pub const LOOKUP_SLACK: f32 = 1.0;

/// How far past a light's exact bounds, in tiles or slices, the CPU's bound on its list entries
/// reaches. Whole tiles and slices each side would make the bound, and the cluster buffers it
/// sizes, many times the lists' real length on scenes of many small lights (the many-lights
/// scene).
pub const BOUND_MARGIN: f32 = 0.5;

/// A sphere this close to the eye plane (depth within this factor of its radius) covers a whole
/// screen axis: `NEAR_SIDE_GUARD` in cluster_bin.wgsl, whose comment says why.
pub const NEAR_SIDE_GUARD: f32 = 1.05;

/// A whole number of slices as an index (the GPU clamps to ±2³⁰, see `slice_of` in
/// clusters.wgsl; both are far past any grid).
fn slice_index(s: f32) -> i32 {
    s.clamp(i32::MIN as f32, i32::MAX as f32) as i32
}

/// A light's influence in (x, y, d) view coordinates, d = −z_view (in front is positive).
#[derive(Debug, Clone, Copy)]
pub struct Bounds {
    pub center: Vec3,
    pub radius: f32,
    /// The cone the light reaches into, as (axis, cos, sin of its half-angle).
    pub spot: Option<(Vec3, f32, f32)>,
}

/// Inclusive cluster box; empty when any `hi < lo`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClusterBox {
    pub lo: [i32; 3],
    pub hi: [i32; 3],
}

impl ClusterBox {
    pub fn len(&self) -> u64 {
        (0..3).map(|a| (self.hi[a] - self.lo[a] + 1).max(0) as u64).product()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The nearest and farthest view depths of `bounds`' corners, `forward` being the unit view
/// direction: the range of depths any point of the box can have. The near end is pulled in by
/// the rounding of the camera-relative corners (far from the origin that is centimetres), so
/// that no light in the box starts in front of it.
fn light_depth_range(bounds: LightBounds, camera_position: Vec3, forward: Vec3) -> (f32, f32) {
    let rel_min = bounds.min - camera_position;
    let rel_max = bounds.max - camera_position;
    let nearest = Vec3::select(forward.cmpge(Vec3::ZERO), rel_min, rel_max).dot(forward);
    let farthest = Vec3::select(forward.cmpge(Vec3::ZERO), rel_max, rel_min).dot(forward);
    // Each of the corner's subtraction, the light's own and the bounds' rounds by half an ulp
    // of the largest coordinate; four ulps cover them, and 1e-5 of the depth the GPU's padding.
    let magnitude = bounds.min.abs().max(bounds.max.abs()).max(camera_position.abs()).max_element();
    (nearest - 4.0 * f32::EPSILON * magnitude - 1e-5 * nearest.abs(), farthest)
}

impl ClusterGrid {
    /// The grid for `view` rendered at `viewport` pixels. Perspective slices start at the near
    /// side of the local lights' bounds (or the near plane, if nearer): no light reaches a
    /// fragment in front of it, so such fragments look up no list at all (see
    /// `fragment_cluster` in clusters.wgsl). Slicing from the near plane spent most slices where
    /// no light reaches: on the many-lights bench scene, 154 to 292 m from the eye, 28 of the
    /// 32 slices lay nearer than 154 m. They end at the lights' far side (a fragment beyond
    /// looks up the last slice), unless that would make them much thinner than the lights
    /// (`slice_scale` below). Orthographic slices span the near plane to zfar.
    pub fn new(view: &ExtractedView, viewport: (u32, u32), config: ClusterConfig, bounds: Option<LightBounds>) -> Self {
        let rotation = Mat3::from(view.world_from_view.matrix3);
        let camera_position = Vec3::from(view.world_from_view.translation);
        let forward = (rotation * Vec3::NEG_Z).normalize_or(Vec3::NEG_Z);
        let aspect = viewport.0.max(1) as f32 / viewport.1.max(1) as f32;
        let clip = view.projection.clip_from_view(aspect);
        let znear = view.projection.znear().max(f32::MIN_POSITIVE);
        let (orthographic, near, far) = match view.projection {
            Projection::Orthographic { zfar, .. } => (true, znear, zfar.max(znear * (1.0 + 1e-3))),
            Projection::Perspective { .. } => match bounds.map(|b| light_depth_range(b, camera_position, forward)) {
                Some((first, last)) if first.is_finite() && last.is_finite() => {
                    let near = first.max(znear);
                    // Lights all behind the eye have no depth range: the smallest grid in front.
                    let far = if last > near { last.max(near * (1.0 + 1e-3)) } else { near * 2.0 };
                    (false, near, far)
                }
                Some(_) => (false, znear, f32::MAX / 4.0),
                None => (false, znear, znear * 2.0),
            },
        };
        let slices = config.slices as f32;
        let slice_scale = if orthographic {
            slices / (far - near)
        } else {
            // Slices per octave of depth. Thinner slices shorten each fragment's list only while
            // they are thicker than the lights; past that, every light lands in more clusters
            // for little gain (lights crowded in a thin band of depth would each span most
            // slices). So a slice at the near end is kept at least the lights' mean radius
            // thick, unless the near plane's slicing was finer still.
            let spanning = slices / (far / near).log2();
            let from_near_plane = slices / (far / znear).log2();
            let no_thinner_than_lights = bounds.map_or(spanning, |b| 1.0 / (1.0 + b.mean_range / near).log2());
            spanning.min(from_near_plane.max(no_thinner_than_lights))
        };
        // Where the last slice ends (past the lights' far side when slices were kept thick).
        let far = if orthographic { far } else { near * (slices / slice_scale).exp2() };
        Self {
            view_from_rel: rotation.transpose(),
            camera_position,
            dims: UVec3::new(config.tiles_x, config.tiles_y, config.slices),
            orthographic,
            proj_scale: Vec2::new(clip.x_axis.x, clip.y_axis.y),
            near,
            far,
            slice_scale,
            viewport: Vec2::new(viewport.0.max(1) as f32, viewport.1.max(1) as f32),
        }
    }

    pub fn cluster_count(&self) -> u32 {
        self.dims.x * self.dims.y * self.dims.z
    }

    /// The grid for the GPU, for `light_count` local lights from slot `light_first`, counted
    /// in `blocks`.
    pub fn to_gpu(&self, light_first: u32, light_count: u32, blocks: LightBlocks) -> GpuClusterGrid {
        let r = self.view_from_rel;
        let row = |i: usize| [r.col(0)[i], r.col(1)[i], r.col(2)[i], 0.0];
        GpuClusterGrid {
            view_x: row(0),
            view_y: row(1),
            view_z: row(2),
            camera_position: self.camera_position.to_array(),
            near: self.near,
            dims: self.dims.to_array(),
            is_orthographic: self.orthographic as u32,
            proj_scale: self.proj_scale.to_array(),
            far: self.far,
            slice_scale: self.slice_scale,
            viewport: self.viewport.to_array(),
            light_first,
            light_count,
            light_blocks: blocks.count,
            block_lights: blocks.lights,
            _pad: [0; 2],
        }
    }

    pub fn cluster_id(&self, c: UVec3) -> u32 {
        (c.z * self.dims.y + c.y) * self.dims.x + c.x
    }

    pub fn slice_depth(&self, k: u32) -> f32 {
        if self.orthographic {
            self.near + k as f32 / self.slice_scale
        } else {
            self.near * (k as f32 / self.slice_scale).exp2()
        }
    }

    pub fn slice_of(&self, d: f32) -> i32 {
        slice_index(self.slice_coordinate(d).floor())
    }

    /// Depth `d` in slices from the first slice's start (not rounded down).
    pub fn slice_coordinate(&self, d: f32) -> f32 {
        if self.orthographic {
            (d - self.near) * self.slice_scale
        } else {
            (d.max(1e-30) / self.near).log2() * self.slice_scale
        }
    }

    fn view_coords(&self, v: Vec3) -> Vec3 {
        let r = self.view_from_rel;
        let (x, y, z) = (r.row(0), r.row(1), r.row(2));
        Vec3::new(x.dot(v), y.dot(v), -z.dot(v))
    }

    pub fn light_bounds(&self, light: &GpuLight) -> Bounds {
        let center = self.view_coords(Vec3::from(light.position) - self.camera_position);
        // A light of range 0 lights nothing and is not binned (its box comes out empty).
        let radius = if light.range > 0.0 { light.range + 1e-5 * (center.length() + light.range) } else { 0.0 };
        // A spot reaches only into its cone; a one-sided rect or disk only in front of its
        // plane: the cone of half-angle π/2 from its centre.
        let cos_outer = match light.kind {
            KIND_SPOT => Some((-light.shape[0] / light.size).clamp(0.0, 1.0)),
            KIND_RECT | KIND_DISK => Some(0.0),
            _ => None,
        };
        let spot = cos_outer.map(|cos_outer| {
            let axis = self.view_coords(Vec3::from(light.direction));
            (axis, cos_outer, (1.0 - cos_outer * cos_outer).max(0.0).sqrt())
        });
        Bounds { center, radius, spot }
    }

    /// Tiles covered along one axis, `margin` tiles and [`LOOKUP_SLACK`] pixels wide of the exact
    /// bounds (the GPU walk's margin is [`CANDIDATE_MARGIN`]).
    fn tile_span(&self, axis: usize, c: f32, d: f32, r: f32, margin: f32) -> (i32, i32) {
        let (scale, tiles, pixels) = (self.proj_scale[axis], self.dims[axis], self.viewport[axis]);
        let (mut lo, mut hi) = (-1.0f32, 1.0f32);
        if self.orthographic {
            lo = (c - r) * scale;
            hi = (c + r) * scale;
        } else if d > r * NEAR_SIDE_GUARD {
            let root = r * (c * c + d * d - r * r).sqrt();
            let den = d * d - r * r;
            lo = (c * d - root) / den * scale;
            hi = (c * d + root) / den * scale;
        }
        let t = tiles as f32;
        // NaN (a light so far off that c² or d² overflows) covers the whole screen: conservative.
        let lo = if lo >= -2.0 { lo.min(2.0) } else { -2.0 };
        let hi = if hi <= 2.0 { hi.max(-2.0) } else { 2.0 };
        let margin = margin + LOOKUP_SLACK * t / pixels;
        let first = ((lo + 1.0) * 0.5 * t - margin).floor() as i32;
        let last = ((hi + 1.0) * 0.5 * t + margin).floor() as i32;
        (first.max(0), last.min(tiles as i32 - 1))
    }

    /// The clusters within `margin` tiles and slices of the light's exact projected bounds (the
    /// GPU walk's: [`CANDIDATE_MARGIN`]).
    pub fn candidate_box(&self, b: &Bounds, margin: f32) -> ClusterBox {
        let (d, r) = (b.center.z, b.radius);
        let sx = self.tile_span(0, b.center.x, d, r, margin);
        let sy = self.tile_span(1, b.center.y, d, r, margin);
        let rows = self.dims.y as i32 - 1;
        let k_first = slice_index((self.slice_coordinate((d - r).max(self.near)) - margin).floor());
        let k_last = slice_index((self.slice_coordinate(d + r) + margin).floor());
        let mut hi = [sx.1, rows - sy.0, k_last.min(self.dims.z as i32 - 1)];
        if d + r < self.near || r.is_nan() || b.radius <= 0.0 {
            hi[2] = -1;
        }
        ClusterBox { lo: [sx.0, rows - sy.1, k_first.max(0)], hi }
    }

    /// The per-cluster test of the GPU walk: sphere against the froxel's bounding box, and for
    /// spots, rects and disks the cone against the froxel's bounding sphere.
    pub fn touches(&self, b: &Bounds, c: UVec3) -> bool {
        let d_near = self.slice_depth(c.z);
        let d_far = self.slice_depth(c.z + 1);
        let t = self.dims.truncate().as_vec2();
        let ndc_x = Vec2::new(-1.0 + 2.0 * c.x as f32 / t.x, -1.0 + 2.0 * (c.x + 1) as f32 / t.x);
        let ndc_y = Vec2::new(1.0 - 2.0 * (c.y + 1) as f32 / t.y, 1.0 - 2.0 * c.y as f32 / t.y);
        let (lo, hi) = if self.orthographic {
            (
                Vec3::new(ndc_x.x / self.proj_scale.x, ndc_y.x / self.proj_scale.y, d_near),
                Vec3::new(ndc_x.y / self.proj_scale.x, ndc_y.y / self.proj_scale.y, d_far),
            )
        } else {
            let sx = ndc_x / self.proj_scale.x;
            let sy = ndc_y / self.proj_scale.y;
            (
                Vec3::new((sx.x * d_near).min(sx.x * d_far), (sy.x * d_near).min(sy.x * d_far), d_near),
                Vec3::new((sx.y * d_near).max(sx.y * d_far), (sy.y * d_near).max(sy.y * d_far), d_far),
            )
        };
        let nearest = b.center.clamp(lo, hi);
        let off = b.center - nearest;
        if off.dot(off) > b.radius * b.radius {
            return false;
        }
        if let Some((axis, cos_outer, sin_outer)) = b.spot {
            let sphere_center = 0.5 * (lo + hi);
            let sphere_radius = 0.5 * (hi - lo).length();
            let v = sphere_center - b.center;
            let along = v.dot(axis);
            let across = (v.dot(v) - along * along).max(0.0).sqrt();
            let gap = cos_outer * across - along * sin_outer;
            if gap > sphere_radius || along > sphere_radius + b.radius || along < -sphere_radius {
                return false;
            }
        }
        true
    }

    /// An upper bound of the total list length the GPU can produce for `lights`: each light's
    /// candidate box reaching [`BOUND_MARGIN`] past its bounds, where the GPU's reaches
    /// [`CANDIDATE_MARGIN`], so rounding differences between CPU and GPU (about 1e-6 of a tile,
    /// see `NEAR_SIDE_GUARD`) cannot make the GPU exceed it. (It is also what `auto`'s
    /// light-walk thresholds are measured against; see `LightWalk`.)
    pub fn index_bound(&self, lights: &[GpuLight]) -> u64 {
        let cap = self.cluster_count() as u64;
        let bound = |ls: &[GpuLight]| -> u64 {
            ls.iter()
                .filter(|l| l.range > 0.0)
                .map(|l| self.candidate_box(&self.light_bounds(l), BOUND_MARGIN).len().min(cap))
                .sum()
        };
        if lights.len() < 20_000 {
            return bound(lights);
        }
        let chunks: Vec<&[GpuLight]> = lights.chunks(lights.len().div_ceil(8)).collect();
        penumbra_engine::parallel::parallel_map(&chunks, |c| bound(c)).into_iter().sum()
    }
}

#[cfg(test)]
mod tests {
    use glam::Affine3A;

    use super::*;

    #[test]
    fn gpu_cluster_grid_mirrors_the_shaders_grid() {
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuClusterGrid,
            "forward.wgsl",
            ["LOCAL_LIGHTS", "CLUSTERED_LIGHTS"],
            "ClusterGrid",
            [
                view_x,
                view_y,
                view_z,
                camera_position,
                near,
                dims,
                is_orthographic,
                proj_scale,
                far,
                slice_scale,
                viewport,
                light_first,
                light_count,
                light_blocks,
                block_lights
            ]
        );
    }

    /// A camera at `eye` looking down −Z.
    fn view_at(eye: Vec3) -> ExtractedView {
        ExtractedView {
            world_from_view: Affine3A::from_translation(eye),
            projection: Projection::default(),
            exposure: 1.0,
        }
    }

    /// Lights of 0.1 radius within `min`..`max`.
    fn grid(view: &ExtractedView, min: Vec3, max: Vec3) -> ClusterGrid {
        ClusterGrid::new(view, (1920, 1080), ClusterConfig::default(), Some(LightBounds { min, max, mean_range: 0.1 }))
    }

    /// A point a light reaches is shaded up to 0.375 px (a sample's offset) from where its
    /// cluster is looked up (the deferred pass looks up the pixel centre's): from there it must
    /// find the light's candidate box. Points on each light's sphere, where its projection ends,
    /// looked up from each sample offset, on a grid whose tile edges fall inside pixels (6.75
    /// pixels a tile row).
    #[test]
    fn points_a_light_reaches_find_it_from_a_sample_away() {
        let view = view_at(Vec3::ZERO);
        let viewport = (192u32, 108u32);
        let bounds =
            LightBounds { min: Vec3::new(-30.0, -20.0, -60.0), max: Vec3::new(30.0, 20.0, -5.0), mean_range: 1.0 };
        let g = ClusterGrid::new(&view, viewport, ClusterConfig::default(), Some(bounds));
        let size = Vec2::new(viewport.0 as f32, viewport.1 as f32);
        let mut rng = penumbra_engine::scenes::SplitMix64(7);
        let mut next = || rng.uniform(0.0, 1.0);
        let mut checked = 0;
        for _ in 0..300 {
            let mut light: GpuLight = bytemuck::Zeroable::zeroed();
            let depth = 8.0 + 45.0 * next();
            let center = Vec3::new((next() - 0.5) * depth, (next() - 0.5) * 0.6 * depth, -depth);
            light.position = center.to_array();
            light.range = 0.3 + 2.0 * next();
            light.kind = crate::resources::light_store::KIND_POINT;
            let b = g.light_bounds(&light);
            let bx = g.candidate_box(&b, CANDIDATE_MARGIN);
            for k in 0..64 {
                let (theta, z) = (k as f32 * 2.399_963, 1.0 - 2.0 * (k as f32 + 0.5) / 64.0);
                let dir = Vec3::new((1.0 - z * z).sqrt() * theta.cos(), (1.0 - z * z).sqrt() * theta.sin(), z);
                let v = g.view_coords(center + dir * light.range * 0.9999 - g.camera_position);
                let ndc = Vec2::new(g.proj_scale.x * v.x / v.z, g.proj_scale.y * v.y / v.z);
                let px = Vec2::new((ndc.x + 1.0) * 0.5 * size.x, (1.0 - ndc.y) * 0.5 * size.y);
                for off in [
                    Vec2::new(-0.375, -0.125),
                    Vec2::new(0.125, -0.375),
                    Vec2::new(-0.125, 0.375),
                    Vec2::new(0.375, 0.125),
                ] {
                    let at = px + off;
                    if at.cmplt(Vec2::ZERO).any() || at.cmpge(size).any() || g.slice_of(v.z) < 0 {
                        continue;
                    }
                    let tile = (at / size * g.dims.truncate().as_vec2()).as_ivec2();
                    let slice = g.slice_of(v.z).min(g.dims.z as i32 - 1);
                    let inside = (0..2).all(|a| (bx.lo[a]..=bx.hi[a]).contains(&tile[a]))
                        && (bx.lo[2]..=bx.hi[2]).contains(&slice);
                    assert!(
                        inside,
                        "light at {center} r {}: point at pixel {px} looked up from {at} (tile {tile}, slice {slice}) is outside {bx:?}",
                        light.range
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 10_000, "{checked} lookups");
    }

    #[test]
    fn light_blocks_are_1024_lights_until_the_runs_would_pass_their_cap() {
        let blocks = |lights, clusters| {
            let b = LightBlocks::new(lights, clusters);
            (b.count, b.lights)
        };
        assert_eq!(blocks(0, 8192), (1, 1024));
        assert_eq!(blocks(1000, 8192), (1, 1024));
        assert_eq!(blocks(100_000, 8192), (98, 1024));
        // 512 blocks of 8192 clusters are the cap: a million lights take blocks of 1954.
        assert_eq!(blocks(1_000_000, 8192), (512, 1954));
        assert_eq!(blocks(40_000, MAX_CLUSTERS), (4, 10_000));
        // Blocks stop growing at the long-run sort's mask: the runs pass their cap instead.
        assert_eq!(blocks(1_000_000, MAX_CLUSTERS), (16, 65_536));
        for (lights, clusters) in [(1_000_000, 8192), (262_144, MAX_CLUSTERS), (5000, 1)] {
            let b = LightBlocks::new(lights, clusters);
            assert!(b.runs(clusters) <= LightBlocks::MAX_RUNS.max(clusters) as u64);
            assert!(b.count as u64 * b.lights as u64 >= lights as u64);
        }
    }

    #[test]
    fn slices_span_the_depths_the_lights_reach() {
        let view = view_at(Vec3::ZERO);
        let g = grid(&view, Vec3::new(-5.0, -1.0, -110.0), Vec3::new(5.0, 1.0, -100.0));
        assert!(g.near <= 100.0 && g.near > 99.99, "near {}", g.near);
        assert!((g.far - 110.0).abs() < 1e-3, "far {}", g.far);
        // Every depth in the lights' range has a slice of its own; nearer and farther ones clamp.
        assert_eq!(g.slice_of(100.0), 0);
        assert_eq!(g.slice_of(109.99), 31);
        assert!(g.slice_of(50.0) < 0 && g.slice_of(200.0) >= 32);
    }

    #[test]
    fn slices_start_at_the_near_plane_when_a_light_reaches_the_eye() {
        let view = view_at(Vec3::ZERO);
        let g = grid(&view, Vec3::new(-3.0, -3.0, -20.0), Vec3::splat(3.0));
        assert_eq!(g.near, 0.1);
        assert!((g.far - 20.0).abs() < 1e-3, "far {}", g.far);
        // Lights all behind the eye: the smallest grid in front of it.
        let g = grid(&view, Vec3::new(-1.0, -1.0, 5.0), Vec3::new(1.0, 1.0, 9.0));
        assert_eq!((g.near, g.far), (0.1, 0.2));
    }

    #[test]
    fn slices_stay_as_thick_as_the_lights_in_a_thin_band_of_depth() {
        // Lights of 0.6 m radius between 3.4 and 5.1 m: 32 slices over that band would be 5 cm
        // thick, and each light would span most of them.
        let view = view_at(Vec3::ZERO);
        let bounds = LightBounds { min: Vec3::new(-1.0, -1.0, -5.1), max: Vec3::new(1.0, 1.0, -3.4), mean_range: 0.6 };
        let g = ClusterGrid::new(&view, (1920, 1080), ClusterConfig::default(), Some(bounds));
        assert!(g.near > 3.39 && g.near <= 3.4, "near {}", g.near);
        // As thick as slicing from the near plane made them (thicker than 0.6 m would be
        // coarser than before): 32 slices from 0.1 to 5.1 m.
        let before = 32.0 / (5.1f32 / 0.1).log2();
        assert!((g.slice_scale - before).abs() < 1e-3 * before, "{} slices per octave", g.slice_scale);
        assert!(g.slice_depth(1) - g.slice_depth(0) > 0.4, "first slice {} m", g.slice_depth(1) - g.slice_depth(0));
        assert!(g.far > 5.1 && (g.slice_depth(32) - g.far).abs() < 1e-3 * g.far);
    }

    #[test]
    fn far_from_the_origin_the_first_slice_starts_in_front_of_every_light() {
        // A million units out, f32 rounds camera-relative corners to about 6 cm.
        let eye = Vec3::new(1e6, 0.0, 1e6);
        let view = view_at(eye);
        let near_side = eye.z - 30.0;
        let g = grid(&view, Vec3::new(eye.x - 1.0, -1.0, eye.z - 40.0), Vec3::new(eye.x + 1.0, 1.0, near_side));
        assert!(g.near < 30.0 - 0.06 && g.near > 29.0, "near {}", g.near);
    }
}
