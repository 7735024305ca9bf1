// GPU frustum culling of the opaque and masked draw list (see crates/render/src/passes/culling.rs).
//
// One thread per entry of the opaque draw list: its instance's world bounds (the mesh's local
// box, transformed) are tested against the view frustum; a visible entry appends its instance
// slot to its batch's region of `visible_slots` and counts itself into the batch's indirect
// draw arguments, whose instance count starts each frame at 0. The forward pass then draws
// each batch indirectly, reading instance slots from `visible_slots`.
//
// With occlusion culling the pass runs twice a frame (shader defs OCCLUSION_EARLY and
// OCCLUSION_LATE). Early: only entries that were visible last frame (`was_visible`) and are in
// the frustum go to the early draws. The early draws' depth is reduced into a hierarchical
// depth buffer (`hzb.wgsl`). Late: every entry in the frustum is tested against that buffer;
// its `was_visible` bit is rewritten for the next frame, and the visible ones the early pass did
// not draw go to the late draws (their own arguments, and their own region of `visible_slots`
// starting at `params.late_base`). An object is only ever hidden by what this frame drew in
// front of it, so nothing visible is lost, and an object uncovered by a moving occluder is
// drawn in the late pass of the same frame.
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
    // Where the late draws' region of `visible_slots` starts.
    late_base: u32,
    // Mip levels of the hierarchical depth buffer.
    hzb_levels: u32,
    // The word of `args` after the late draws' arguments, where the late phase counts the
    // entries in view that the depth pyramid hid.
    hidden_word: u32,
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
#ifdef OCCLUSION_EARLY
@group(0) @binding(8) var<storage, read> was_visible: array<u32>;
#endif
#ifdef OCCLUSION_LATE
@group(0) @binding(8) var<storage, read_write> was_visible: array<u32>;
// Farthest depth (reverse-Z: smallest value) under each texel, mip by mip.
@group(0) @binding(9) var hzb: texture_2d<f32>;
#endif

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

#ifdef OCCLUSION_LATE
// Entries of this workgroup in view that the depth pyramid hid. Counted here and added once per
// workgroup to `args[params.hidden_word]`: the renderer reads the total back, a few frames late,
// to judge whether occlusion culling pays (`OcclusionCulling::Auto`).
var<workgroup> hidden_in_group: atomic<u32>;
#endif

@compute @workgroup_size(64)
fn cull_instances(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
) {
    // Dispatched as a 2D grid when one dimension's workgroup limit is too small.
    let i = (group.y * groups.x + group.x) * 64u + lane;
    let hidden = cull_entry(i);
#ifdef OCCLUSION_LATE
    if hidden {
        atomicAdd(&hidden_in_group, 1u);
    }
    workgroupBarrier();
    if lane == 0u {
        let n = atomicLoad(&hidden_in_group);
        if n > 0u {
            atomicAdd(&args[params.hidden_word], n);
        }
    }
#endif
}

// Culls draw-list entry `i`; returns whether it was in view but hidden by the depth pyramid
// (late phase only).
fn cull_entry(i: u32) -> bool {
    if i >= params.item_count {
        return false;
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
    var visible = box_in_view(rel_center, world_half);
    var hidden = false;
#ifdef OCCLUSION_EARLY
    visible = visible && was_visible[i] != 0u;
#endif
    var base = 0u;
#ifdef OCCLUSION_LATE
    let drawn_early = visible && was_visible[i] != 0u;
    hidden = visible && box_occluded(rel_center, world_half);
    visible = visible && !hidden;
    was_visible[i] = u32(visible);
    visible = visible && !drawn_early;
    base = params.late_base;
#endif
    if !visible {
        return hidden;
    }
    let k = atomicAdd(&args[b * 5u + 1u], 1u);
    visible_slots[base + batch.first + k] = slot;
    return false;
}

#ifdef OCCLUSION_LATE
// Whether the box lies wholly behind what the hierarchical depth buffer holds over its screen
// rectangle. A box reaching behind the camera plane is never occluded.
fn box_occluded(center: vec3<f32>, half_extent: vec3<f32>) -> bool {
    var lo = vec2<f32>(1e30);
    var hi = vec2<f32>(-1e30);
    var nearest = 0.0;
    for (var c = 0u; c < 8u; c++) {
        let corner = center + half_extent * vec3<f32>(
            select(-1.0, 1.0, (c & 1u) != 0u),
            select(-1.0, 1.0, (c & 2u) != 0u),
            select(-1.0, 1.0, (c & 4u) != 0u),
        );
        let clip = view.clip_from_rel * vec4<f32>(corner, 1.0);
        // Written so that NaN (or an infinite box) keeps the object too.
        if !(clip.w > 1e-6) {
            return false;
        }
        let ndc = clip.xyz / clip.w;
        // min and max may drop NaN: a corner that is NaN or infinite keeps the object.
        if !all(abs(ndc) < vec3<f32>(1e30)) {
            return false;
        }
        lo = min(lo, ndc.xy);
        hi = max(hi, ndc.xy);
        // Reverse-Z: the largest depth is the nearest point.
        nearest = max(nearest, ndc.z);
    }
    // Normalised device coordinates to texture coordinates (y down), clamped to the screen.
    let uv_lo = clamp(vec2<f32>(lo.x * 0.5 + 0.5, 0.5 - hi.y * 0.5), vec2<f32>(0.0), vec2<f32>(1.0));
    let uv_hi = clamp(vec2<f32>(hi.x * 0.5 + 0.5, 0.5 - lo.y * 0.5), vec2<f32>(0.0), vec2<f32>(1.0));
    let size0 = vec2<f32>(textureDimensions(hzb, 0));
    let extent = (uv_hi - uv_lo) * size0;
    // The level at which the rectangle spans at most two texels each way.
    let level = min(u32(ceil(log2(max(max(extent.x, extent.y), 1.0)))), params.hzb_levels - 1u);
    // Each level halves the one below (at least 1). Derived rather than asked for: lavapipe's
    // textureDimensions(hzb, level) answered wrongly for some levels (measured: an 8×8 level
    // read out of bounds, so hidden boxes counted as visible).
    let size = max(vec2<i32>(size0) >> vec2<u32>(level), vec2<i32>(1));
    let t_lo = clamp(vec2<i32>(floor(uv_lo * vec2<f32>(size))), vec2<i32>(0), size - 1);
    let t_hi = clamp(vec2<i32>(floor(uv_hi * vec2<f32>(size))), vec2<i32>(0), size - 1);
    var farthest = 1.0;
    for (var y = t_lo.y; y <= t_hi.y; y++) {
        for (var x = t_lo.x; x <= t_hi.x; x++) {
            farthest = min(farthest, textureLoad(hzb, vec2<i32>(x, y), i32(level)).x);
        }
    }
    // Occluded only when clearly behind: a relative margin for rounding in both depths.
    return nearest * (1.0 + 1e-5) < farthest;
}
#endif
