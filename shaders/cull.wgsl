// GPU frustum culling of the opaque and masked draw list (see crates/render/src/passes/culling.rs).
//
// One thread per entry of the opaque draw list: its instance's world bounds (the mesh's local
// box, transformed) are tested against the view frustum; a visible entry appends its instance
// slot to its batch's region of `visible_slots` and counts itself into the batch's indirect
// draw arguments, whose instance count starts each frame at 0. The forward pass then draws
// each batch indirectly, reading instance slots from `visible_slots`.
//
// The test is conservative: a box is culled only when it lies wholly outside one plane by more
// than a margin relative to the magnitudes involved (so rounding cannot remove a visible
// object), and NaN anywhere fails every comparison and keeps the object.

#import penumbra::view::View
#import penumbra::draw_data::Instance

struct CullBatch {
    // The mesh's local bounding box: centre (xyz) and half extent (xyz). `first` is where the
    // batch's region starts in the draw list and in `visible_slots`.
    center: vec3<f32>,
    first: u32,
    half_extent: vec3<f32>,
    _pad: u32,
};

struct CullParams {
    item_count: u32,
    _pad_a: u32,
    _pad_b: u32,
    _pad_c: u32,
};

@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<storage, read> instances: array<Instance>;
@group(0) @binding(2) var<storage, read> draw_slots: array<u32>;
@group(0) @binding(3) var<storage, read> item_batch: array<u32>;
@group(0) @binding(4) var<storage, read> batches: array<CullBatch>;
// Five words per batch (DrawIndexedIndirectArgs; a non-indexed batch uses the first four as
// DrawIndirectArgs); word 1 is the instance count in both layouts.
@group(0) @binding(5) var<storage, read_write> args: array<atomic<u32>>;
@group(0) @binding(6) var<storage, read_write> visible_slots: array<u32>;
@group(0) @binding(7) var<uniform> params: CullParams;

// Relative size of the margin a box must clear a plane by to be culled: some hundred f32 ulps.
const MARGIN: f32 = 1e-5;

fn clip_row(r: u32) -> vec4<f32> {
    let m = view.clip_from_rel;
    return vec4<f32>(m[0][r], m[1][r], m[2][r], m[3][r]);
}

// Whether a box (camera-relative centre, half extent along the world axes) may be in view.
fn box_in_view(center: vec3<f32>, half_extent: vec3<f32>) -> bool {
    // Gribb-Hartmann: the clip-space half-spaces -w <= x <= w, -w <= y <= w and z <= w (near;
    // reverse-Z), z >= 0 (far; never binding for the infinite perspective), as planes.
    let w = clip_row(3u);
    let x = clip_row(0u);
    let y = clip_row(1u);
    let z = clip_row(2u);
    var planes = array<vec4<f32>, 6>(w + x, w - x, w + y, w - y, w - z, z);
    for (var p = 0u; p < 6u; p++) {
        let plane = planes[p];
        let distance = dot(plane.xyz, center) + plane.w;
        let reach = dot(abs(plane.xyz), half_extent);
        let scale = abs(plane.w) + dot(abs(plane.xyz), abs(center) + half_extent);
        if distance + reach < -MARGIN * scale {
            return false;
        }
    }
    return true;
}

@compute @workgroup_size(64)
fn cull_instances(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
) {
    // Dispatched as a 2D grid when one dimension's workgroup limit is too small.
    let i = (group.y * groups.x + group.x) * 64u + lane;
    if i >= params.item_count {
        return;
    }
    let slot = draw_slots[i];
    let b = item_batch[i];
    let batch = batches[b];
    let inst = instances[slot];
    let m0 = inst.row_x.xyz;
    let m1 = inst.row_y.xyz;
    let m2 = inst.row_z.xyz;
    let c = batch.center;
    let h = batch.half_extent;
    // Camera-relative as place_vertex computes it, so the box is where the vertices will be.
    let t_rel = vec3<f32>(inst.row_x.w, inst.row_y.w, inst.row_z.w) - view.camera_position;
    let rel_center = vec3<f32>(dot(m0, c), dot(m1, c), dot(m2, c)) + t_rel;
    let world_half = vec3<f32>(dot(abs(m0), h), dot(abs(m1), h), dot(abs(m2), h));
    if !box_in_view(rel_center, world_half) {
        return;
    }
    let k = atomicAdd(&args[b * 5u + 1u], 1u);
    visible_slots[batch.first + k] = slot;
}
