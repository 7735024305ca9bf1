// What the cull passes test: a batch's mesh bounds, an instance's box along the world axes
// (camera-relative, where its vertices will be placed) and whether that box may reach into a
// clip volume. Shared by the view's cull (cull.wgsl) and the shadow casters' cull per shadow
// map (shadow_cull.wgsl), so a caster and a visible object are kept by the same test.
#define_import_path penumbra::cull_bounds

#import penumbra::draw_data::Instance

struct CullBatch {
    // The mesh's local bounding box: centre (xyz) and half extent (xyz). `first` is where the
    // batch's region starts in the draw list and in `visible_slots`.
    center: vec3<f32>,
    first: u32,
    half_extent: vec3<f32>,
    // Triangle culling: where the batch's region starts in `triangle_indices` (NO_TRIANGLES:
    // the batch draws instances), its mesh's first index and triangle count in the mesh pool,
    // its first vertex there, and CULL_BACK / FRONT_CW.
    triangles_first: u32,
    index_start: u32,
    triangle_count: u32,
    vertex_start: u32,
    flags: u32,
};

// Relative size of the margin a box must clear a plane by to be culled: some hundred f32 ulps.
const MARGIN: f32 = 1e-5;

// An instance's bounding box along the world axes, camera-relative.
struct WorldBox {
    center: vec3<f32>,
    half_extent: vec3<f32>,
};

fn world_box(inst: Instance, batch: CullBatch, camera_position: vec3<f32>) -> WorldBox {
    let m0 = inst.row_x.xyz;
    let m1 = inst.row_y.xyz;
    let m2 = inst.row_z.xyz;
    let c = batch.center;
    let h = batch.half_extent;
    // Camera-relative as place_vertex computes it, so the box is where the vertices will be.
    let t_rel = vec3<f32>(inst.row_x.w, inst.row_y.w, inst.row_z.w) - camera_position;
    let center = vec3<f32>(dot(m0, c), dot(m1, c), dot(m2, c)) + t_rel;
    return WorldBox(center, vec3<f32>(dot(abs(m0), h), dot(abs(m1), h), dot(abs(m2), h)));
}

// Whether a box (camera-relative centre, half extent along the world axes) may reach into the
// clip volume of `clip_from_rel`.
fn box_in_clip(clip_from_rel: mat4x4<f32>, center: vec3<f32>, half_extent: vec3<f32>) -> bool {
    let m = clip_from_rel;
    let x = vec4<f32>(m[0][0], m[1][0], m[2][0], m[3][0]);
    let y = vec4<f32>(m[0][1], m[1][1], m[2][1], m[3][1]);
    let z = vec4<f32>(m[0][2], m[1][2], m[2][2], m[3][2]);
    let w = vec4<f32>(m[0][3], m[1][3], m[2][3], m[3][3]);
    // Gribb-Hartmann: the clip-space half-spaces -w <= x <= w, -w <= y <= w and z <= w (near;
    // reverse-Z), z >= 0 (far; never binding for the infinite perspective), as planes. The
    // same six bound an orthographic shadow cascade (w = 1) and a local light's perspective map.
    var planes = array<vec4<f32>, 6>(w + x, w - x, w + y, w - y, w - z, z);
    for (var p = 0u; p < 6u; p++) {
        if box_outside(planes[p], center, half_extent) {
            return false;
        }
    }
    return true;
}

// Whether a box lies wholly on the outer side of a plane (xyz · p + w >= 0 inside), by more
// than the rounding margin. Written so that NaN anywhere keeps the box.
fn box_outside(plane: vec4<f32>, center: vec3<f32>, half_extent: vec3<f32>) -> bool {
    let distance = dot(plane.xyz, center) + plane.w;
    let reach = dot(abs(plane.xyz), half_extent);
    let scale = abs(plane.w) + dot(abs(plane.xyz), abs(center) + half_extent);
    return distance + reach < -MARGIN * scale;
}
