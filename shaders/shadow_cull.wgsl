// Shadow casters culled per shadow map (see crates/render/src/features/shadows/caster_cull.rs).
//
// One thread per entry of the opaque and masked draw list, for a chunk of the shadow maps drawn
// this frame (cascade layers, spot maps, cube faces): the instance's box (the view's cull reads
// the same bounds, cull_bounds.wgsl) is tested against each map's clip volume and, for a
// cascade, against the planes its receivers give (`ShadowCullParams::planes`); where it may
// reach in, its slot is appended to the batch's region of that map's list and counted into the
// map's indirect arguments for the batch (instance count reset to 0 from a template before the
// pass). The caster pass then draws each batch indirectly from its map's list. A map's clip
// volume is all it can hold (the hardware clips whatever lies outside it), and a caster outside
// a cascade's planes changes only texels that no receiver reads: the shadows are the ones the
// full list casts.
//
// The lanes of a workgroup mostly share a batch (the list is batch by batch): they count into
// workgroup memory and one lane reserves their places with one global atomic, rather than every
// visible instance contending for its batch's counter.

#import penumbra::draw_data::Instance
#import penumbra::cull_bounds::{CullBatch, box_in_clip, box_outside, world_box}

// Shadow maps one pass culls for at most; more are culled in further passes.
const MAX_MAPS: u32 = 16u;
const MAX_PLANES: u32 = 6u;
const MAX_PLANE_SLOTS: u32 = 96u;

struct ShadowCullParams {
    item_count: u32,
    batch_count: u32,
    // Maps culled for in this pass, and the distance between their lists in `visible_slots`.
    map_count: u32,
    slot_stride: u32,
    camera_position: vec3<f32>,
    _pad: u32,
    // Each map's clip from camera-relative position (the caster pass's own matrix).
    clip_from_rel: array<mat4x4<f32>, MAX_MAPS>,
    // A cascade's receivers' planes (camera-relative): those of the slice of the view that reads
    // it which face the light, widened by the lookups' reach, so that the slice swept toward the
    // light lies inside them. A caster outside one cannot shadow anything that reads the map.
    // MAX_PLANES per map, `plane_counts[m / 4][m % 4]` of them used.
    planes: array<vec4<f32>, MAX_PLANE_SLOTS>,
    plane_counts: array<vec4<u32>, 4>,
};

@group(0) @binding(0) var<uniform> params: ShadowCullParams;
@group(0) @binding(1) var<storage, read> instances: array<Instance>;
@group(0) @binding(2) var<storage, read> draw_slots: array<u32>;
@group(0) @binding(3) var<storage, read> item_batch: array<u32>;
@group(0) @binding(4) var<storage, read> batches: array<CullBatch>;
// Per map, five words per batch (DrawIndexedIndirectArgs, or DrawIndirectArgs in the first
// four); word 1 is the instance count in both.
@group(0) @binding(5) var<storage, read_write> args: array<atomic<u32>>;
// Per map (`slot_stride` apart), each batch's visible instances from its region's start.
@group(0) @binding(6) var<storage, read_write> visible_slots: array<u32>;

var<workgroup> group_batch: u32;
var<workgroup> group_count: atomic<u32>;
var<workgroup> group_start: u32;

@compute @workgroup_size(64)
fn cull_casters(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
) {
    // Dispatched as a 2D grid when one dimension's workgroup limit is too small.
    let i = (group.y * groups.x + group.x) * 64u + lane;
    // Lanes past the list take part in the barriers and keep nothing.
    let valid = i < params.item_count;
    let item = min(i, max(params.item_count, 1u) - 1u);
    let slot = draw_slots[item];
    let b = item_batch[item];
    let batch = batches[b];
    let bounds = world_box(instances[slot], batch, params.camera_position);
    for (var m = 0u; m < min(params.map_count, MAX_MAPS); m++) {
        var kept = valid && box_in_clip(params.clip_from_rel[m], bounds.center, bounds.half_extent);
        let planes = min(params.plane_counts[m / 4u][m % 4u], MAX_PLANES);
        for (var p = 0u; p < planes; p++) {
            kept = kept && !box_outside(params.planes[m * MAX_PLANES + p], bounds.center, bounds.half_extent);
        }
        if lane == 0u {
            group_batch = b;
            atomicStore(&group_count, 0u);
        }
        workgroupBarrier();
        let pooled = kept && b == group_batch;
        let counter = (m * params.batch_count + b) * 5u + 1u;
        var at = 0u;
        if pooled {
            at = atomicAdd(&group_count, 1u);
        } else if kept {
            at = atomicAdd(&args[counter], 1u);
        }
        workgroupBarrier();
        if lane == 0u {
            let total = atomicLoad(&group_count);
            if total > 0u {
                group_start = atomicAdd(&args[(m * params.batch_count + group_batch) * 5u + 1u], total);
            }
        }
        workgroupBarrier();
        if pooled {
            at += group_start;
        }
        if kept {
            visible_slots[m * params.slot_stride + batch.first + at] = slot;
        }
    }
}
