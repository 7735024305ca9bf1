// GPU frustum culling of the opaque and masked draw list (see crates/render/src/features/culling/).
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
//
// Triangle culling (shader def TRIANGLE_CULLING, in any phase): batches of small meshes
// that the renderer marked (`triangles_first`) do not draw instances. A visible instance of
// such a batch tests each of its mesh's triangles here and keeps only those that can cover a
// sample of the frame: not facing away, not outside the target, and not so small that they
// fall between sample positions. The kept triangles' indices go to the batch's region of
// `triangle_indices`, each naming its instance and vertex (`slot << 8 | vertex`), and the batch
// draws them as one indexed draw whose vertex shader fetches its vertices (PULLED_VERTICES in
// forward.wgsl). Graphics units set up and rasterise only what can show; on GPUs with few of
// them (the H100 and H200 rasterise on 2 of their 66 TPCs) a million small objects are bound
// by exactly that work. Every test leaves a margin for the rasteriser's snapping (`params.snap`:
// half its sub-pixel step, as the driver reports it, plus rounding), so a triangle that could
// cover a sample is never dropped; the image is the one the instances would draw.

#import penumbra::view::View
#import penumbra::draw_data::Instance
#import penumbra::cull_bounds::{CullBatch, box_in_clip, world_box}
#ifdef TRIANGLE_CULLING
#import penumbra::draw_data::place_vertex
#import penumbra::common::STANDARD_SAMPLES_4
#endif

struct CullParams {
    item_count: u32,
    // Where the late draws' region of `visible_slots` starts.
    late_base: u32,
    // Mip levels of the hierarchical depth buffer.
    hzb_levels: u32,
    // The word of `args` after the late draws' arguments, where the late phase counts the
    // entries in view that the depth pyramid hid.
    hidden_word: u32,
    // The frame's size in pixels and samples per pixel, and how far (in pixels, on each axis)
    // the rasteriser may move a vertex from where this pass computes it: half its sub-pixel
    // step plus rounding (triangle culling).
    target_size: vec2<f32>,
    samples: u32,
    snap: f32,
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
#ifdef TRIANGLE_CULLING
// The mesh pool's indices and vertices (GpuVertex, 16 words each, position first).
@group(0) @binding(10) var<storage, read> pool_indices: array<u32>;
@group(0) @binding(11) var<storage, read> pool_vertices: array<f32>;
@group(0) @binding(12) var<storage, read_write> triangle_indices: array<u32>;
#endif

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
#ifdef TRIANGLE_CULLING
    // Kept triangles of the lanes in lane 0's batch take one reservation for the workgroup;
    // a lane in another batch reserves its own.
    let kept = cull_entry_triangles(i);
    if lane == 0u {
        group_batch = kept.batch;
        atomicStore(&group_indices, 0u);
        atomicStore(&group_visible, 0u);
    }
    workgroupBarrier();
    let shared_batch = group_batch;
    let same = kept.batch != NO_TRIANGLES && kept.batch == shared_batch;
    let pooled = kept.count > 0u && same;
    var at = 0u;
    if pooled {
        at = atomicAdd(&group_indices, kept.count * 3u);
    } else if kept.count > 0u {
        at = atomicAdd(&args[kept.batch * 5u], kept.count * 3u);
    }
    // Visible instances of triangle-culled batches, counted after the hidden-count word
    // (`read_visible_counts`).
    if kept.visible && same {
        atomicAdd(&group_visible, 1u);
    } else if kept.visible {
        atomicAdd(&args[params.hidden_word + 1u + kept.batch], 1u);
    }
    workgroupBarrier();
    if lane == 0u {
        let total = atomicLoad(&group_indices);
        if total > 0u {
            group_start = atomicAdd(&args[shared_batch * 5u], total);
        }
        let visible = atomicLoad(&group_visible);
        if visible > 0u {
            atomicAdd(&args[params.hidden_word + 1u + shared_batch], visible);
        }
    }
    workgroupBarrier();
    if pooled {
        at += group_start;
    }
    if kept.count > 0u {
        write_triangles(kept, at);
    }
    let hidden = kept.hidden;
#else
    let hidden = cull_entry(i);
#endif
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
    let e = test_entry(i);
    if e.draw {
        append_instance(e);
    }
    return e.hidden;
}

// What this phase does with a draw-list entry.
struct EntryTest {
    slot: u32,
    batch: u32,
    // Draw it in this phase's draws.
    draw: bool,
    // In view but hidden by the depth pyramid (late phase).
    hidden: bool,
};

// Tests entry `i` (< params.item_count) against the frustum and, with occlusion culling, last
// frame's visibility (early) or the depth pyramid (late, which records the answer).
fn test_entry(i: u32) -> EntryTest {
    let slot = draw_slots[i];
    let b = item_batch[i];
    let bounds = world_box(instances[slot], batches[b], view.camera_position);
    let rel_center = bounds.center;
    let world_half = bounds.half_extent;
    var visible = box_in_clip(view.clip_from_rel, rel_center, world_half);
    var hidden = false;
#ifdef OCCLUSION_EARLY
    visible = visible && was_visible[i] != 0u;
#endif
#ifdef OCCLUSION_LATE
    let drawn_early = visible && was_visible[i] != 0u;
    hidden = visible && box_occluded(rel_center, world_half);
    visible = visible && !hidden;
    was_visible[i] = u32(visible);
    visible = visible && !drawn_early;
#endif
    return EntryTest(slot, b, visible, hidden);
}

// Appends the entry's instance to its batch's region of `visible_slots` (the late draws' own
// region in the late phase) and counts it.
fn append_instance(e: EntryTest) {
    var base = 0u;
#ifdef OCCLUSION_LATE
    base = params.late_base;
#endif
    let k = atomicAdd(&args[e.batch * 5u + 1u], 1u);
    visible_slots[base + batches[e.batch].first + k] = e.slot;
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

#ifdef TRIANGLE_CULLING
const NO_TRIANGLES: u32 = 0xffffffffu;
const CULL_BACK: u32 = 1u;
const FRONT_CW: u32 = 2u;
// Triangles a batch's mesh may have (the renderer marks only such meshes): one bit each.
const MAX_TRIANGLES: u32 = 64u;
// Sample positions a triangle's box may hold for the exact test; a box holding more keeps
// the triangle untested (it is large enough that it likely covers one).
const MAX_CANDIDATES: u32 = 16u;

var<workgroup> group_batch: u32;
var<workgroup> group_indices: atomic<u32>;
var<workgroup> group_visible: atomic<u32>;
var<workgroup> group_start: u32;

// What a lane keeps of its entry: the triangles of `batch`'s mesh set in `mask`, for the
// instance in `slot`. `batch` is NO_TRIANGLES for entries of instanced batches.
struct KeptTriangles {
    batch: u32,
    slot: u32,
    mask: vec2<u32>,
    count: u32,
    visible: bool,
    // In view but hidden by the depth pyramid (late phase).
    hidden: bool,
};

// Sample `s`'s position within its pixel (framebuffer coordinates, y down): Vulkan's standard
// locations for 1 and 4 samples.
fn sample_offset(s: u32) -> vec2<f32> {
    if params.samples != 4u {
        return vec2<f32>(0.5, 0.5);
    }
    return STANDARD_SAMPLES_4[s];
}

fn vertex_clip(inst: Instance, vertex: u32) -> vec4<f32> {
    let at = vertex * 16u;
    let p = vec3<f32>(pool_vertices[at], pool_vertices[at + 1u], pool_vertices[at + 2u]);
    // As the vertex shader places it (forward.wgsl), so both agree to rounding.
    return view.clip_from_rel * vec4<f32>(place_vertex(inst, p, view.camera_position).rel, 1.0);
}

// Twice the signed area of (a, b, c), positive when counter-clockwise in framebuffer
// coordinates (y down).
fn cross2(u: vec2<f32>, v: vec2<f32>) -> f32 {
    return u.x * v.y - u.y * v.x;
}

// Whether sample position `p` may lie inside the triangle, given its orientation `sign`
// (+1 or −1, the sign of cross2(b − a, c − a)): each edge function, allowed the change that
// moving the vertices by up to `snap` on each axis can make.
fn inside_with_margin(p: vec2<f32>, a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, sign: f32) -> bool {
    let d = params.snap;
    let ab = b - a;
    let bc = c - b;
    let ca = a - c;
    let pa = p - a;
    let pb = p - b;
    let pc = p - c;
    // E = e × (p − v): moving v and the edge's other end by up to d per axis changes it by at
    // most d·(|e.x| + |e.y|) + 2d·(|(p − v).x| + |(p − v).y|) + 4d².
    let slack = 4.0 * d * d;
    let ea = sign * cross2(ab, pa) + d * (abs(ab.x) + abs(ab.y)) + 2.0 * d * (abs(pa.x) + abs(pa.y)) + slack;
    let eb = sign * cross2(bc, pb) + d * (abs(bc.x) + abs(bc.y)) + 2.0 * d * (abs(pb.x) + abs(pb.y)) + slack;
    let ec = sign * cross2(ca, pc) + d * (abs(ca.x) + abs(ca.y)) + 2.0 * d * (abs(pc.x) + abs(pc.y)) + slack;
    return ea >= 0.0 && eb >= 0.0 && ec >= 0.0;
}

// Whether the triangle with these clip positions may cover a sample of the frame. Every test
// keeps a triangle that could cover one once the rasteriser has snapped its vertices.
fn triangle_may_cover(a: vec4<f32>, b: vec4<f32>, c: vec4<f32>, flags: u32) -> bool {
    // A vertex at or behind the eye plane (or NaN): the rasteriser clips; keep.
    if !(a.w > 1e-6 && b.w > 1e-6 && c.w > 1e-6) {
        return true;
    }
    let half = params.target_size * 0.5;
    // Framebuffer coordinates, y down.
    let pa = vec2<f32>(1.0 + a.x / a.w, 1.0 - a.y / a.w) * half;
    let pb = vec2<f32>(1.0 + b.x / b.w, 1.0 - b.y / b.w) * half;
    let pc = vec2<f32>(1.0 + c.x / c.w, 1.0 - c.y / c.w) * half;
    let d = params.snap;
    let lo = min(pa, min(pb, pc)) - d;
    let hi = max(pa, max(pb, pc)) + d;
    // Far off screen f32 no longer resolves the margin (and NaN fails this too): keep.
    if !(all(abs(lo) < vec2<f32>(1e6)) && all(abs(hi) < vec2<f32>(1e6))) {
        return true;
    }
    if hi.x < 0.0 || hi.y < 0.0 || lo.x > params.target_size.x || lo.y > params.target_size.y {
        return false;
    }
    // Orientation, unless snapping could flip it (a nearly degenerate triangle: it is then
    // tested below in both orientations, so as if it had no back).
    let e1 = pb - pa;
    let e2 = pc - pa;
    let area2 = cross2(e1, e2);
    let perimeter_l1 = abs(e1.x) + abs(e1.y) + abs(e2.x) + abs(e2.y) + abs(pc.x - pb.x) + abs(pc.y - pb.y);
    let ambiguous = abs(area2) <= 4.0 * d * perimeter_l1 + 16.0 * d * d;
    // Counter-clockwise in framebuffer coordinates (y down) is clockwise as normalised device
    // coordinates (y up) see it, which front faces are not, unless the batch winds clockwise.
    let front = (area2 < 0.0) != ((flags & FRONT_CW) != 0u);
    if (flags & CULL_BACK) != 0u && !front && !ambiguous {
        return false;
    }
    // The sample positions inside the box (each pattern offset repeats every pixel): the
    // triangle covers nothing unless one of them may lie inside it.
    let sign = select(-1.0, 1.0, area2 > 0.0);
    let samples = max(params.samples, 1u);
    var candidates = 0u;
    for (var s = 0u; s < samples; s++) {
        let o = sample_offset(s);
        let first = ceil(lo - o);
        let last = floor(hi - o);
        if any(last < first) {
            continue;
        }
        let n = (last - first) + 1.0;
        candidates += u32(n.x * n.y);
    }
    if candidates == 0u {
        return false;
    }
    if candidates > MAX_CANDIDATES {
        return true;
    }
    for (var s = 0u; s < samples; s++) {
        let o = sample_offset(s);
        let first = ceil(lo - o);
        let last = floor(hi - o);
        for (var y = first.y; y <= last.y; y += 1.0) {
            for (var x = first.x; x <= last.x; x += 1.0) {
                let p = vec2<f32>(x, y) + o;
                if inside_with_margin(p, pa, pb, pc, sign) || (ambiguous && inside_with_margin(p, pa, pb, pc, -sign)) {
                    return true;
                }
            }
        }
    }
    return false;
}

// Culls draw-list entry `i` (TRIANGLE_CULLING): an entry of an instanced batch as
// `cull_entry` does; an entry of a triangle-culled batch that this phase draws returns the
// triangles it keeps. The late phase writes its triangles over the early phase's region, which
// the early draws have read by then, and counts them in its own arguments.
fn cull_entry_triangles(i: u32) -> KeptTriangles {
    var kept = KeptTriangles(NO_TRIANGLES, 0u, vec2<u32>(0u), 0u, false, false);
    if i >= params.item_count {
        return kept;
    }
    let e = test_entry(i);
    kept.hidden = e.hidden;
    let b = e.batch;
    let batch = batches[b];
    if batch.triangles_first == NO_TRIANGLES {
        if e.draw {
            append_instance(e);
        }
        return kept;
    }
    let slot = e.slot;
    let inst = instances[slot];
    kept.batch = b;
    kept.slot = slot;
    kept.visible = e.draw;
    if !e.draw {
        return kept;
    }
    let n = min(batch.triangle_count, MAX_TRIANGLES);
    for (var t = 0u; t < n; t++) {
        let at = batch.index_start + 3u * t;
        let pa = vertex_clip(inst, batch.vertex_start + pool_indices[at]);
        let pb = vertex_clip(inst, batch.vertex_start + pool_indices[at + 1u]);
        let pc = vertex_clip(inst, batch.vertex_start + pool_indices[at + 2u]);
        if triangle_may_cover(pa, pb, pc, batch.flags) {
            kept.mask[t / 32u] |= 1u << (t % 32u);
            kept.count += 1u;
        }
    }
    return kept;
}

// Writes the kept triangles' indices from index `at` of the batch's region.
fn write_triangles(kept: KeptTriangles, at: u32) {
    let batch = batches[kept.batch];
    var out = batch.triangles_first + at;
    let n = min(batch.triangle_count, MAX_TRIANGLES);
    for (var t = 0u; t < n; t++) {
        if (kept.mask[t / 32u] & (1u << (t % 32u))) == 0u {
            continue;
        }
        let idx = batch.index_start + 3u * t;
        for (var k = 0u; k < 3u; k++) {
            triangle_indices[out + k] = (kept.slot << 8u) | pool_indices[idx + k];
        }
        out += 3u;
    }
}
#endif
