// Cluster binning: every frame, on the GPU, each local light is assigned to every froxel its
// influence volume touches. Compute passes, in this order:
//
//   count_lights  8 lights per workgroup: atomically count each light in each cluster it touches
//   scan_blocks,  exclusive scan of the counts into (offset, count) ranges, and the counts turned
//   scan_apply    into write cursors: each block of 256 clusters scanned by a workgroup, then
//                 the totals of the blocks before it added
//   fill_lists    the same walk, writing each light's index at its cluster's cursor
//   sort_short    one invocation per cluster: sort its list (insertion sort) if it holds at most
//                 SHORT_LIST lights, else queue the cluster for sort_long; sorted lists make
//                 lighting sum in a fixed order, so frames are deterministic whatever order the
//                 atomics ran in
//   sort_long     one workgroup per queued cluster (an indirect dispatch the queue sizes): a
//                 bitonic sort of its long list
//
// (One 256-thread workgroup per cluster sorted every list before: 8192 workgroups that mostly
// returned at once cost lavapipe 30 ms a frame, its workgroup barriers being coroutines.)
//
// The index buffer is sized on the CPU by an upper bound of the total (the sum of each light's
// candidate box, see passes/clusters/grid.rs), so lists never overflow, on the first frame too.
// The walk is mirrored exactly by the CPU reference binner (passes/clusters/reference.rs).

#import penumbra::light_data::{Light, LIGHT_SPOT, LIGHT_RECT, LIGHT_DISK}
#import penumbra::clusters::{ClusterGrid, slice_depth, slice_of, cluster_id}

@group(0) @binding(0) var<uniform> grid: ClusterGrid;
@group(0) @binding(1) var<storage, read> lights: array<Light>;
@group(0) @binding(2) var<storage, read_write> counts: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> ranges: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read_write> indices: array<u32>;

// The clusters sort_short leaves to sort_long. The first three words are sort_long's indirect
// dispatch (x = queued clusters, at most MAX_DISPATCH; sort_long strides over the rest). Past one
// slot per cluster, the scan parks its block totals.
struct LongLists {
    x: atomic<u32>,
    y: u32,
    z: u32,
    count: atomic<u32>,
    clusters: array<u32>,
};
@group(0) @binding(5) var<storage, read_write> long_lists: LongLists;
const MAX_DISPATCH: u32 = 65535u;
// Longest list sort_short sorts itself (at most SHORT_LIST² / 2 steps in one invocation). At
// 64, lists of 20 to 60 lights (1 000 lights on the many-lights scene) kept one invocation each
// sorting in memory for 0.128 ms on an H200; a workgroup sorts them in parallel.
const SHORT_LIST: u32 = 16u;

// A light's sphere (and cone) of influence in (x, y, d) view coordinates.
struct Bounds {
    center: vec3<f32>,
    radius: f32,
    is_spot: bool,
    axis: vec3<f32>,
    cos_outer: f32,
    sin_outer: f32,
};

fn light_bounds(light: Light) -> Bounds {
    let rel = light.position - grid.camera_position;
    let v = vec3<f32>(dot(grid.view_x.xyz, rel), dot(grid.view_y.xyz, rel), -dot(grid.view_z.xyz, rel));
    var b: Bounds;
    b.center = v;
    // Padding covers rounding between the fragment's cluster lookup and these bounds. A light
    // of range 0 lights nothing and is not binned (its box comes out empty).
    b.radius = select(light.range + 1e-5 * (length(v) + light.range), 0.0, !(light.range > 0.0));
    // A spot reaches only into its cone; a one-sided rect or disk only in front of its plane:
    // the cone of half-angle π/2 from its centre.
    b.is_spot = light.kind == LIGHT_SPOT || light.kind == LIGHT_RECT || light.kind == LIGHT_DISK;
    let a = light.direction;
    b.axis = vec3<f32>(dot(grid.view_x.xyz, a), dot(grid.view_y.xyz, a), -dot(grid.view_z.xyz, a));
    b.cos_outer = select(0.0, clamp(-light.shape.x / light.size, 0.0, 1.0), light.kind == LIGHT_SPOT);
    b.sin_outer = sqrt(max(1.0 - b.cos_outer * b.cos_outer, 0.0));
    return b;
}

// Tiles covered along one screen axis by a sphere at lateral offset c and depth d: the tangent
// lines from the eye bound the projected circle exactly. `scale` maps view slope to NDC.
fn tile_span(c: f32, d: f32, r: f32, scale: f32, tiles: u32) -> vec2<i32> {
    var lo = -1.0;
    var hi = 1.0;
    if grid.is_orthographic != 0u {
        lo = (c - r) * scale;
        hi = (c + r) * scale;
    } else if d > r {
        let root = r * sqrt(c * c + d * d - r * r);
        let den = d * d - r * r;
        lo = (c * d - root) / den * scale;
        hi = (c * d + root) / den * scale;
    }
    let t = f32(tiles);
    // NaN (a light so far off that c² or d² overflows) covers the whole screen: conservative.
    lo = select(-2.0, min(lo, 2.0), lo >= -2.0);
    hi = select(2.0, max(hi, -2.0), hi <= 2.0);
    // One tile of slack each side: the per-cluster test below decides.
    let first = i32(floor((lo + 1.0) * 0.5 * t)) - 1;
    let last = i32(floor((hi + 1.0) * 0.5 * t)) + 1;
    return vec2<i32>(max(first, 0), min(last, i32(tiles) - 1));
}

// Candidate box of clusters, inclusive: lo.xyz .. hi.xyz; empty when any hi < lo.
struct ClusterBox {
    lo: vec3<i32>,
    hi: vec3<i32>,
};

fn candidate_box(b: Bounds) -> ClusterBox {
    var box: ClusterBox;
    let d = b.center.z;
    let r = b.radius;
    let sx = tile_span(b.center.x, d, r, grid.proj_scale.x, grid.dims.x);
    // Tile rows count down from the top of the screen, NDC y counts up.
    let sy = tile_span(b.center.y, d, r, grid.proj_scale.y, grid.dims.y);
    let rows = i32(grid.dims.y) - 1;
    let k_first = slice_of(grid, max(d - r, grid.near)) - 1;
    // Clamped before adding so that a huge range cannot wrap past i32's maximum.
    let k_last = min(slice_of(grid, d + r), i32(grid.dims.z)) + 1;
    box.lo = vec3<i32>(sx.x, rows - sy.y, max(k_first, 0));
    box.hi = vec3<i32>(sx.y, rows - sy.x, min(k_last, i32(grid.dims.z) - 1));
    if d + r < grid.near || b.radius <= 0.0 {
        box.hi.z = -1;
    }
    return box;
}

// Whether the light's influence touches cluster (i, j, k): its sphere against the froxel's
// bounding box, and for cones (spots; rects and disks, π/2) the cone against the froxel's
// bounding sphere (Wronski 2017).
fn touches(b: Bounds, c: vec3<u32>) -> bool {
    let d_near = slice_depth(grid, c.z);
    let d_far = slice_depth(grid, c.z + 1u);
    let t = vec2<f32>(grid.dims.xy);
    let ndc_x = vec2<f32>(-1.0 + 2.0 * f32(c.x) / t.x, -1.0 + 2.0 * f32(c.x + 1u) / t.x);
    let ndc_y = vec2<f32>(1.0 - 2.0 * f32(c.y + 1u) / t.y, 1.0 - 2.0 * f32(c.y) / t.y);
    var lo: vec3<f32>;
    var hi: vec3<f32>;
    if grid.is_orthographic != 0u {
        lo = vec3<f32>(ndc_x.x / grid.proj_scale.x, ndc_y.x / grid.proj_scale.y, d_near);
        hi = vec3<f32>(ndc_x.y / grid.proj_scale.x, ndc_y.y / grid.proj_scale.y, d_far);
    } else {
        let sx = ndc_x / grid.proj_scale.x;
        let sy = ndc_y / grid.proj_scale.y;
        lo = vec3<f32>(min(sx.x * d_near, sx.x * d_far), min(sy.x * d_near, sy.x * d_far), d_near);
        hi = vec3<f32>(max(sx.y * d_near, sx.y * d_far), max(sy.y * d_near, sy.y * d_far), d_far);
    }
    let nearest = clamp(b.center, lo, hi);
    let off = b.center - nearest;
    if dot(off, off) > b.radius * b.radius {
        return false;
    }
    if b.is_spot {
        let sphere_center = 0.5 * (lo + hi);
        let sphere_radius = 0.5 * length(hi - lo);
        let v = sphere_center - b.center;
        let along = dot(v, b.axis);
        let across = sqrt(max(dot(v, v) - along * along, 0.0));
        let gap = b.cos_outer * across - along * b.sin_outer;
        if gap > sphere_radius || along > sphere_radius + b.radius || along < -sphere_radius {
            return false;
        }
    }
    return true;
}

// Walks the candidate clusters of lights 8·w to 8·w + 7 with the 64 threads of workgroup w:
// their boxes' cells are numbered one after another (a scan of the cell counts in workgroup
// memory) and thread `t` takes every 64th cell, finding its light by binary search. A light is
// counted into each cluster it touches, or (`fill`) writes its slot at each one's cursor; both
// passes visit exactly the same (light, cluster) pairs. One thread per light walked a light
// covering the whole view (a bright lamp in a room: its range reaches past the walls) through
// all 8192 clusters serially, an atomic each: 5.5 ms on an H100 for one light. A workgroup per
// light fixed that but left 60 of its 64 threads idle for the small lights that most scenes
// are made of (100 000 lights took 0.113 ms to count on an H200); sharing the workgroup's
// cells among a few lights keeps its threads busy, while enough workgroups remain to fill the
// GPU at a thousand lights (64 lights a workgroup took 0.030 ms to count 1 000 there).
const BIN_THREADS: u32 = 64u;
const BIN_LIGHTS: u32 = 8u;
var<workgroup> bin_bounds: array<Bounds, BIN_LIGHTS>;
var<workgroup> bin_lo: array<vec3<u32>, BIN_LIGHTS>;
var<workgroup> bin_size: array<vec3<u32>, BIN_LIGHTS>;
// Inclusive scan of the lights' cell counts.
var<workgroup> bin_end: array<u32, BIN_LIGHTS>;

fn bin_lights(group: u32, t: u32, fill: bool) {
    let id = group * BIN_LIGHTS + t;
    var cells = 0u;
    if t < BIN_LIGHTS && id < grid.light_count {
        let b = light_bounds(lights[grid.light_first + id]);
        let box = candidate_box(b);
        if all(box.hi >= box.lo) {
            let size = vec3<u32>(box.hi - box.lo) + vec3<u32>(1u);
            cells = size.x * size.y * size.z;
            bin_bounds[t] = b;
            bin_lo[t] = vec3<u32>(box.lo);
            bin_size[t] = size;
        }
    }
    if t < BIN_LIGHTS {
        bin_end[t] = cells;
    }
    workgroupBarrier();
    for (var step = 1u; step < BIN_LIGHTS; step <<= 1u) {
        var add = 0u;
        if t < BIN_LIGHTS && t >= step {
            add = bin_end[t - step];
        }
        workgroupBarrier();
        if t < BIN_LIGHTS {
            bin_end[t] += add;
        }
        workgroupBarrier();
    }
    let total = workgroupUniformLoad(&bin_end[BIN_LIGHTS - 1u]);
    for (var n = t; n < total; n += BIN_THREADS) {
        // The light whose cells hold cell n: the first with bin_end > n.
        var lo = 0u;
        var hi = BIN_LIGHTS - 1u;
        while lo < hi {
            let mid = (lo + hi) / 2u;
            if bin_end[mid] > n {
                hi = mid;
            } else {
                lo = mid + 1u;
            }
        }
        let first = select(0u, bin_end[lo - 1u], lo > 0u);
        let k = n - first;
        let size = bin_size[lo];
        let c = bin_lo[lo] + vec3<u32>(k % size.x, (k / size.x) % size.y, k / (size.x * size.y));
        if touches(bin_bounds[lo], c) {
            let at = atomicAdd(&counts[cluster_id(grid, c)], 1u);
            if fill {
                indices[at] = grid.light_first + group * BIN_LIGHTS + lo;
            }
        }
    }
}

// BIN_LIGHTS lights per workgroup; large dispatches spill into y (a dimension holds at most 65 535
// workgroups).
@compute @workgroup_size(64)
fn count_lights(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) t: u32,
) {
    bin_lights(wg.x + wg.y * groups.x, t, false);
}

// The exclusive scan of the counts, in two passes over blocks of SCAN_THREADS clusters:
// scan_blocks scans each block in workgroup memory and parks its total; scan_apply adds the
// totals of the blocks before it. (One workgroup scanning every cluster serially took 0.035
// ms for 8192 clusters on an H100 and 0.29 ms for 73 728, its loads one after another.)
const SCAN_THREADS: u32 = 256u;
var<workgroup> partial: array<u32, SCAN_THREADS>;

// Hillis-Steele inclusive scan of the workgroup's values; every thread must call it.
fn workgroup_scan(t: u32, value: u32) -> u32 {
    partial[t] = value;
    workgroupBarrier();
    for (var step = 1u; step < SCAN_THREADS; step <<= 1u) {
        var add = 0u;
        if t >= step {
            add = partial[t - step];
        }
        workgroupBarrier();
        partial[t] += add;
        workgroupBarrier();
    }
    return partial[t];
}

fn cluster_total() -> u32 {
    return grid.dims.x * grid.dims.y * grid.dims.z;
}

// Block b's total waits in the long-list queue's slots past one per cluster (the queue fills
// only later, in sort_short, and never past one slot per cluster).
fn block_total_slot(b: u32) -> u32 {
    return cluster_total() + b;
}

// The block of SCAN_THREADS clusters workgroup `wg` scans, or NO_BLOCK for the surplus of a
// dispatch spilled into y.
const NO_BLOCK: u32 = 0xffffffffu;
fn scan_block(wg: vec3<u32>, groups: vec3<u32>) -> u32 {
    let b = wg.x + wg.y * groups.x;
    return select(NO_BLOCK, b, b * SCAN_THREADS < cluster_total());
}

// Block `b` of SCAN_THREADS clusters: ranges get (offset within the block, count).
@compute @workgroup_size(256)
fn scan_blocks(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) t: u32,
) {
    let b = scan_block(wg, groups);
    if b == NO_BLOCK {
        return;
    }
    let total = cluster_total();
    let c = b * SCAN_THREADS + t;
    var n = 0u;
    if c < total {
        n = atomicLoad(&counts[c]);
    }
    let inclusive = workgroup_scan(t, n);
    if c < total {
        ranges[c] = vec2<u32>(inclusive - n, n);
    }
    if t == SCAN_THREADS - 1u {
        long_lists.clusters[block_total_slot(b)] = inclusive;
    }
}

// Adds the totals of the blocks before block `b` to its offsets, which also become the fill
// pass's write cursors.
@compute @workgroup_size(256)
fn scan_apply(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) t: u32,
) {
    let b = scan_block(wg, groups);
    if b == NO_BLOCK {
        return;
    }
    let total = cluster_total();
    var before = 0u;
    for (var i = t; i < b; i += SCAN_THREADS) {
        before += long_lists.clusters[block_total_slot(i)];
    }
    // The scan's last step ends in a barrier: its last element, the sum, is there for all.
    workgroup_scan(t, before);
    let block_base = partial[SCAN_THREADS - 1u];
    let c = b * SCAN_THREADS + t;
    if c < total {
        let offset = block_base + ranges[c].x;
        ranges[c].x = offset;
        atomicStore(&counts[c], offset);
    }
    if b == 0u && t == 0u {
        // The range fragments in front of the first slice look up (see fragment_cluster).
        ranges[total] = vec2<u32>(0u, 0u);
        atomicStore(&long_lists.x, 0u);
        long_lists.y = 1u;
        long_lists.z = 1u;
        atomicStore(&long_lists.count, 0u);
    }
}

@compute @workgroup_size(64)
fn fill_lists(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) t: u32,
) {
    bin_lights(wg.x + wg.y * groups.x, t, true);
}

@compute @workgroup_size(64)
fn sort_short(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let cluster = id.x + id.y * groups.x * 64u;
    let total = grid.dims.x * grid.dims.y * grid.dims.z;
    if cluster >= total {
        return;
    }
    let base = ranges[cluster].x;
    let n = ranges[cluster].y;
    if n <= 1u {
        return;
    }
    if n > SHORT_LIST {
        let slot = atomicAdd(&long_lists.count, 1u);
        long_lists.clusters[slot] = cluster;
        atomicMax(&long_lists.x, min(slot + 1u, MAX_DISPATCH));
        return;
    }
    for (var i = 1u; i < n; i++) {
        let key = indices[base + i];
        var j = i;
        while j > 0u && indices[base + j - 1u] > key {
            indices[base + j] = indices[base + j - 1u];
            j -= 1u;
        }
        indices[base + j] = key;
    }
}

// One workgroup sorts one cluster's list with a bitonic network in which every comparator
// puts the smaller value at the lower index (each merge begins by comparing mirrored
// positions, i ^ (k − 1)). Positions past the list's end act as +∞ and are never touched, so
// any length sorts in place. Lists up to SORT_CAPACITY are sorted in workgroup memory; longer
// ones (thousands of lights in one cluster) directly in the index buffer, many times slower:
// where the device has the workgroup memory (LARGE_SORTS: 32 KiB), lists up to 8192.
#ifdef LARGE_SORTS
const SORT_CAPACITY: u32 = 8192u;
#else
const SORT_CAPACITY: u32 = 2048u;
#endif
const SORT_THREADS: u32 = 256u;
var<workgroup> sort_keys: array<u32, SORT_CAPACITY>;
var<workgroup> sort_count: u32;

// The partner of position i at merge size k and step j, or an index ≥ n when there is none.
fn sort_partner(i: u32, k: u32, j: u32) -> u32 {
    if j == k >> 1u {
        return i ^ (k - 1u);
    }
    return i ^ j;
}

var<workgroup> long_count: u32;

@compute @workgroup_size(256)
fn sort_long(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) t: u32,
) {
    if t == 0u {
        long_count = atomicLoad(&long_lists.count);
    }
    let queued = workgroupUniformLoad(&long_count);
    for (var q = wg.x; q < queued; q += groups.x) {
        sort_one(long_lists.clusters[q], t);
    }
}

// Bitonic sort of one cluster's list by the 256 threads of a workgroup (sort_long).
fn sort_one(cluster: u32, t: u32) {
    let base = ranges[cluster].x;
    if t == 0u {
        sort_count = ranges[cluster].y;
    }
    // Broadcast so that every barrier below sits in uniform control flow.
    let n = workgroupUniformLoad(&sort_count);
    if n <= 1u {
        return;
    }
    var size = 2u;
    while size < n {
        size <<= 1u;
    }
    if n <= SORT_CAPACITY {
        for (var i = t; i < n; i += SORT_THREADS) {
            sort_keys[i] = indices[base + i];
        }
        workgroupBarrier();
        for (var k = 2u; k <= size; k <<= 1u) {
            for (var j = k >> 1u; j > 0u; j >>= 1u) {
                for (var i = t; i < n; i += SORT_THREADS) {
                    let p = sort_partner(i, k, j);
                    if p > i && p < n {
                        let a = sort_keys[i];
                        let b = sort_keys[p];
                        if a > b {
                            sort_keys[i] = b;
                            sort_keys[p] = a;
                        }
                    }
                }
                workgroupBarrier();
            }
        }
        for (var i = t; i < n; i += SORT_THREADS) {
            indices[base + i] = sort_keys[i];
        }
        return;
    }
    for (var k = 2u; k <= size; k <<= 1u) {
        for (var j = k >> 1u; j > 0u; j >>= 1u) {
            for (var i = t; i < n; i += SORT_THREADS) {
                let p = sort_partner(i, k, j);
                if p > i && p < n {
                    let a = indices[base + i];
                    let b = indices[base + p];
                    if a > b {
                        indices[base + i] = b;
                        indices[base + p] = a;
                    }
                }
            }
            storageBarrier();
        }
    }
}
