// The froxel grid: screen tiles × depth slices (logarithmic for perspective views, linear for
// orthographic ones), as the cluster binner builds it and the forward shader looks it up.
// Mirrors `GpuClusterGrid` in features/clusters/grid.rs, whose CPU twin computes the same bounds
// for the reference binner and the index-capacity bound.
//
// Depth `d` is distance along the view direction (−z in view space), so froxel boxes live in
// (x, y, d) with d > 0 in front of the camera.
#define_import_path penumbra::clusters

struct ClusterGrid {
    // Rows of view_from_rel (rotation only); .w unused.
    view_x: vec4<f32>,
    view_y: vec4<f32>,
    view_z: vec4<f32>,
    camera_position: vec3<f32>,
    // Where the first slice begins: the local lights' near side, or the near plane if nearer.
    near: f32,
    // Tiles across, tiles down, depth slices.
    dims: vec3<u32>,
    is_orthographic: u32,
    // clip_from_view[0][0] and [1][1]: ndc = scale · x / d (perspective) or scale · x (orthographic).
    proj_scale: vec2<f32>,
    far: f32,
    // Slices per unit of log2(d / near) (perspective) or of d − near (orthographic).
    slice_scale: f32,
    viewport: vec2<f32>,
    // Local lights occupy slots light_first .. light_first + light_count of the light buffer.
    light_first: u32,
    light_count: u32,
    // The binner counts each cluster's lights per block of block_lights consecutive lights
    // (light_blocks blocks; see cluster_bin.wgsl).
    light_blocks: u32,
    block_lights: u32,
    _pad: vec2<u32>,
};

// Depth of the near boundary of slice k (k = slices gives the far end).
fn slice_depth(grid: ClusterGrid, k: u32) -> f32 {
    if grid.is_orthographic != 0u {
        return grid.near + f32(k) / grid.slice_scale;
    }
    return grid.near * exp2(f32(k) / grid.slice_scale);
}

// The slice holding depth d (negative in front of the first slice, grid.near), clamped to ±2³⁰
// so that a huge depth converts to a huge slice on every backend: WGSL's float-to-int conversion
// saturates, but the GLSL that naga writes for wgpu's GL backend converts out-of-range values to
// i32's minimum.
fn slice_of(grid: ClusterGrid, d: f32) -> i32 {
    return slice_index(floor(slice_coordinate(grid, d)));
}

// Depth d in slices from the first slice's start (not rounded down).
fn slice_coordinate(grid: ClusterGrid, d: f32) -> f32 {
    if grid.is_orthographic != 0u {
        return (d - grid.near) * grid.slice_scale;
    }
    return log2(max(d, 1e-30) / grid.near) * grid.slice_scale;
}

// A whole number of slices as an index, clamped as slice_of says.
fn slice_index(s: f32) -> i32 {
    return i32(clamp(s, -1073741824.0, 1073741824.0));
}

fn cluster_id(grid: ClusterGrid, c: vec3<u32>) -> u32 {
    return (c.z * grid.dims.y + c.y) * grid.dims.x + c.x;
}

// The cluster of a fragment at framebuffer position `frag_xy` and view depth `d`. In front of
// the first slice no light reaches (slices start at the lights' near side, see grid.rs): such
// a fragment gets the entry past the last cluster, whose range is always empty.
fn fragment_cluster(grid: ClusterGrid, frag_xy: vec2<f32>, d: f32) -> u32 {
    let s = slice_of(grid, d);
    if s < 0 {
        return grid.dims.x * grid.dims.y * grid.dims.z;
    }
    let tile = min(vec2<u32>(max(frag_xy / grid.viewport * vec2<f32>(grid.dims.xy), vec2<f32>(0.0))), grid.dims.xy - 1u);
    let slice = u32(min(s, i32(grid.dims.z) - 1));
    return cluster_id(grid, vec3<u32>(tile, slice));
}
