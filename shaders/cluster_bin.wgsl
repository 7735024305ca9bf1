// Cluster binning: every frame, on the GPU, each local light is assigned to every froxel its
// influence volume touches. Each cluster's list is built as one run per block of
// grid.block_lights consecutive lights, in block order: a counter per (cluster, block) run
// (`runs`, run r = cluster · light_blocks + block). Dispatches of one compute pass, in this
// order:
//
//   count_lights  BIN_LIGHTS lights per workgroup: atomically count each light in each run it falls in
//   scan_blocks,  exclusive scan of the run counts into write cursors: each block of SCAN_ITEMS
//   scan_apply    runs scanned by a workgroup, then the totals of the blocks before it added
//   fill_lists    the same walk, writing each light's index at its run's cursor
//   sort_short    one invocation per run: sort it (a sorting network) if it holds at most
//                 SHORT_LIST lights, else queue it for sort_long; the last run of each
//                 cluster writes the cluster's (offset, count). Runs sorted in block order make
//                 each list sorted, so lighting sums in a fixed order and frames are
//                 deterministic whatever order the atomics ran in
//   sort_long     one workgroup per queued run (an indirect dispatch the queue sizes): a rank
//                 sort of its long run, or a bitmask of its block's lights for the longest
//
// Lists used to be counted per cluster and sorted whole: with many lights that meant bitonic
// sorts of lists hundreds of lights long, where runs of 1 024-light blocks hold only a few
// (figures in docs/performance.md, "Many lights"). (One 256-thread workgroup per cluster sorted
// every list before that: 8192 workgroups that mostly returned at once made lavapipe slow, its
// workgroup barriers being coroutines.)
//
// The index buffer is sized on the CPU by an upper bound of the total (the sum of each light's
// candidate box, see features/clusters/grid.rs), so lists never overflow, on the first frame too.
// The walk is mirrored exactly by the CPU reference binner (features/clusters/reference.rs).

#import penumbra::light_data::{Light, LIGHT_SPOT, LIGHT_RECT, LIGHT_DISK}
#import penumbra::clusters::{ClusterGrid, slice_depth, slice_coordinate, slice_index, cluster_id}

@group(0) @binding(0) var<uniform> grid: ClusterGrid;
@group(0) @binding(1) var<storage, read> lights: array<Light>;
// Per run: its count, then (after the scan) its write cursor, which the fill leaves at the run's
// end (the next run's start).
@group(0) @binding(2) var<storage, read_write> runs: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> ranges: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read_write> indices: array<u32>;

// The runs sort_short leaves to sort_long: how many, then the scan's block totals in the first
// slots (scan_block_count of them), then the queue.
struct LongLists {
    count: atomic<u32>,
    slots: array<u32>,
};
@group(0) @binding(5) var<storage, read_write> long_lists: LongLists;
// sort_long's indirect dispatch (x = queued runs, at most MAX_DISPATCH; sort_long strides over
// the rest), in a buffer of its own: the dispatch that reads it as arguments binds a stand-in
// there, so that sort_long runs in the same compute pass, with no copy of the arguments.
struct DispatchArgs {
    x: atomic<u32>,
    y: u32,
    z: u32,
};
@group(0) @binding(6) var<storage, read_write> long_dispatch: DispatchArgs;
const MAX_DISPATCH: u32 = 65535u;
// Longest run sort_short sorts itself (a 16-key sorting network). When SHORT_LIST was 64, lists
// of 20 to 60 lights each kept a single invocation sorting in memory, one step after another; a
// workgroup sorts them in parallel.
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
// lines from the eye bound the projected circle exactly. `scale` maps view slope to NDC. A
// sphere whose near side is within NEAR_SIDE_GUARD of its radius from the eye plane covers the
// whole axis: there d² − r² cancels, and its rounding (about 1e-7 / (d/r − 1) of the bounds,
// relative) could pass the candidate margin on fine grids.
const NEAR_SIDE_GUARD: f32 = 1.05;
fn tile_span(c: f32, d: f32, r: f32, scale: f32, tiles: u32, pixels: f32) -> vec2<i32> {
    var lo = -1.0;
    var hi = 1.0;
    if grid.is_orthographic != 0u {
        lo = (c - r) * scale;
        hi = (c + r) * scale;
    } else if d > r * NEAR_SIDE_GUARD {
        let root = r * sqrt(c * c + d * d - r * r);
        let den = d * d - r * r;
        lo = (c * d - root) / den * scale;
        hi = (c * d + root) / den * scale;
    }
    let t = f32(tiles);
    // NaN (a light so far off that c² or d² overflows) covers the whole screen: conservative.
    lo = select(-2.0, min(lo, 2.0), lo >= -2.0);
    hi = select(2.0, max(hi, -2.0), hi <= 2.0);
    // The tangent bounds are exact, so the margin covers their rounding and where the cluster is
    // looked up (see CANDIDATE_MARGIN).
    let margin = CANDIDATE_MARGIN + LOOKUP_SLACK * t / pixels;
    let first = i32(floor((lo + 1.0) * 0.5 * t - margin));
    let last = i32(floor((hi + 1.0) * 0.5 * t + margin));
    return vec2<i32>(max(first, 0), min(last, i32(tiles) - 1));
}

// How far past a light's projected bounds, in tiles or slices, its candidate box reaches: far
// more than the bounds' rounding (about 1e-6 of a tile), so a point the light reaches always
// finds the light in its tile and slice. Across the screen the box reaches LOOKUP_SLACK pixels
// further: a point may be shaded up to a pixel from where its cluster is looked up (the
// deferred pass shades each sample where it lies, and looks up the pixel centre's cluster;
// line quads shade half a pixel off their fragment). The box used to take a whole tile and
// slice of slack each side, for the per-cluster test to decide: a light of the many-lights
// scene (1 to 2 tiles and slices) then had about 46 candidates for 4 clusters it touches, and
// the count and fill walks spent their time testing them.
const CANDIDATE_MARGIN: f32 = 0.01;
const LOOKUP_SLACK: f32 = 1.0;

// Candidate box of clusters, inclusive: lo.xyz .. hi.xyz; empty when any hi < lo.
struct ClusterBox {
    lo: vec3<i32>,
    hi: vec3<i32>,
};

fn candidate_box(b: Bounds) -> ClusterBox {
    var box: ClusterBox;
    let d = b.center.z;
    let r = b.radius;
    let sx = tile_span(b.center.x, d, r, grid.proj_scale.x, grid.dims.x, grid.viewport.x);
    // Tile rows count down from the top of the screen, NDC y counts up.
    let sy = tile_span(b.center.y, d, r, grid.proj_scale.y, grid.dims.y, grid.viewport.y);
    let rows = i32(grid.dims.y) - 1;
    let k_first = slice_index(floor(slice_coordinate(grid, max(d - r, grid.near)) - CANDIDATE_MARGIN));
    let k_last = slice_index(floor(slice_coordinate(grid, d + r) + CANDIDATE_MARGIN));
    box.lo = vec3<i32>(sx.x, rows - sy.y, max(k_first, 0));
    box.hi = vec3<i32>(sx.y, rows - sy.x, min(k_last, i32(grid.dims.z) - 1));
    if d + r < grid.near || !(b.radius > 0.0) {
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

// Walks the candidate clusters of lights BIN_LIGHTS·w to BIN_LIGHTS·(w + 1) − 1 with the 64
// threads of workgroup w (or, split into `slices` workgroups, the cells of slice `slice`: cell n
// belongs to slice (n / 64) mod slices):
// their boxes' cells are numbered one after another (a scan of the cell counts in workgroup
// memory) and thread `t` takes every 64th cell, finding its light by binary search. A light is
// counted into each cluster it touches, or (`fill`) writes its slot at each one's cursor; both
// passes visit exactly the same (light, cluster) pairs. One thread per light walked a light
// covering the whole view (a bright lamp in a room: its range reaches past the walls) through
// all 8192 clusters serially, an atomic each: a long serial chain for one light. A workgroup
// per light fixed that but left 60 of its 64 threads idle for the small lights that most scenes
// are made of; sharing the workgroup's cells among a few lights keeps its threads busy, while
// enough workgroups remain to fill the GPU at a thousand lights (at 64 lights a workgroup there
// were too few). 16 lights (8 before the candidate boxes were tightened) suit small boxes: see
// BIN_LIGHTS in features/clusters/mod.rs, and docs/performance.md for what binning costs.
const BIN_THREADS: u32 = 64u;
const BIN_LIGHTS: u32 = 16u;
var<workgroup> bin_bounds: array<Bounds, BIN_LIGHTS>;
var<workgroup> bin_lo: array<vec3<u32>, BIN_LIGHTS>;
var<workgroup> bin_size: array<vec3<u32>, BIN_LIGHTS>;
// Inclusive scan of the lights' cell counts.
var<workgroup> bin_end: array<u32, BIN_LIGHTS>;

fn bin_lights(group: u32, t: u32, fill: bool, slice: u32, slices: u32) {
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
    for (var n = slice * BIN_THREADS + t; n < total; n += BIN_THREADS * slices) {
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
            let light = group * BIN_LIGHTS + lo;
            let at = atomicAdd(&runs[cluster_id(grid, c) * grid.light_blocks + light / grid.block_lights], 1u);
            if fill {
                indices[at] = grid.light_first + light;
            }
        }
    }
}

// BIN_LIGHTS lights per workgroup; large dispatches spill into y (a dimension holds at most 65 535
// workgroups). With few lights, z splits each group's cells into slices, a workgroup each (see
// `bin_slices` in features/clusters/mod.rs): the same (light, cluster) pairs, in more hands.
@compute @workgroup_size(64)
fn count_lights(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) t: u32,
) {
    bin_lights(wg.x + wg.y * groups.x, t, false, wg.z, groups.z);
}

// The exclusive scan of the run counts, in two passes over blocks of SCAN_THREADS · SCAN_ITEMS
// runs: scan_blocks scans each block (each thread its SCAN_ITEMS consecutive runs, then the
// threads' sums in workgroup memory) and parks its total; scan_apply adds the totals of the
// blocks before it. (One workgroup scanning every cluster serially, its loads one after
// another, took longer the finer the grid, so fine grids such as 64×36×32 paid most for it.)
const SCAN_THREADS: u32 = 256u;
const SCAN_ITEMS: u32 = 4u;
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

fn run_total() -> u32 {
    return cluster_total() * grid.light_blocks;
}

fn scan_block_count() -> u32 {
    return (run_total() + SCAN_THREADS * SCAN_ITEMS - 1u) / (SCAN_THREADS * SCAN_ITEMS);
}

// The block of runs workgroup `wg` scans, or NO_BLOCK for the surplus of a dispatch spilled
// into y.
const NO_BLOCK: u32 = 0xffffffffu;
fn scan_block(wg: vec3<u32>, groups: vec3<u32>) -> u32 {
    let b = wg.x + wg.y * groups.x;
    return select(NO_BLOCK, b, b < scan_block_count());
}

// Block `b`: each run's count becomes its offset within the block.
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
    let total = run_total();
    let first = (b * SCAN_THREADS + t) * SCAN_ITEMS;
    var n: array<u32, SCAN_ITEMS>;
    var sum = 0u;
    for (var i = 0u; i < SCAN_ITEMS; i++) {
        n[i] = select(0u, atomicLoad(&runs[first + i]), first + i < total);
        sum += n[i];
    }
    var offset = workgroup_scan(t, sum) - sum;
    for (var i = 0u; i < SCAN_ITEMS; i++) {
        if first + i < total {
            atomicStore(&runs[first + i], offset);
        }
        offset += n[i];
    }
    if t == SCAN_THREADS - 1u {
        long_lists.slots[b] = offset;
    }
}

// Adds the totals of the blocks before block `b` to its offsets, which become the fill pass's
// write cursors.
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
    var before = 0u;
    for (var i = t; i < b; i += SCAN_THREADS) {
        before += long_lists.slots[i];
    }
    // The scan's last step ends in a barrier: its last element, the sum, is there for all.
    workgroup_scan(t, before);
    let block_base = partial[SCAN_THREADS - 1u];
    let total = run_total();
    let first = (b * SCAN_THREADS + t) * SCAN_ITEMS;
    for (var i = 0u; i < SCAN_ITEMS; i++) {
        if first + i < total {
            atomicStore(&runs[first + i], atomicLoad(&runs[first + i]) + block_base);
        }
    }
    if b == 0u && t == 0u {
        // The range fragments in front of the first slice look up (see fragment_cluster).
        ranges[cluster_total()] = vec2<u32>(0u, 0u);
        atomicStore(&long_dispatch.x, 0u);
        long_dispatch.y = 1u;
        long_dispatch.z = 1u;
        atomicStore(&long_lists.count, 0u);
    }
}

@compute @workgroup_size(64)
fn fill_lists(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) t: u32,
) {
    bin_lights(wg.x + wg.y * groups.x, t, true, wg.z, groups.z);
}

// Where run r begins in the index buffer, once filled (each run's cursor then stands at its
// end, where the next run begins).
fn run_start(r: u32) -> u32 {
    return select(0u, atomicLoad(&runs[r - 1u]), r > 0u);
}

// Sorts 16 keys in place: Batcher's odd-even merge sort network, 63 exchanges. (SHORT_LIST
// is 16.)
fn sort_16(k: ptr<function, array<u32, SHORT_LIST>>) {
    exchange(k, 0, 1); exchange(k, 2, 3); exchange(k, 0, 2); exchange(k, 1, 3);
    exchange(k, 1, 2); exchange(k, 4, 5); exchange(k, 6, 7); exchange(k, 4, 6);
    exchange(k, 5, 7); exchange(k, 5, 6); exchange(k, 0, 4); exchange(k, 2, 6);
    exchange(k, 2, 4); exchange(k, 1, 5); exchange(k, 3, 7); exchange(k, 3, 5);
    exchange(k, 1, 2); exchange(k, 3, 4); exchange(k, 5, 6); exchange(k, 8, 9);
    exchange(k, 10, 11); exchange(k, 8, 10); exchange(k, 9, 11); exchange(k, 9, 10);
    exchange(k, 12, 13); exchange(k, 14, 15); exchange(k, 12, 14); exchange(k, 13, 15);
    exchange(k, 13, 14); exchange(k, 8, 12); exchange(k, 10, 14); exchange(k, 10, 12);
    exchange(k, 9, 13); exchange(k, 11, 15); exchange(k, 11, 13); exchange(k, 9, 10);
    exchange(k, 11, 12); exchange(k, 13, 14); exchange(k, 0, 8); exchange(k, 4, 12);
    exchange(k, 4, 8); exchange(k, 2, 10); exchange(k, 6, 14); exchange(k, 6, 10);
    exchange(k, 2, 4); exchange(k, 6, 8); exchange(k, 10, 12); exchange(k, 1, 9);
    exchange(k, 5, 13); exchange(k, 5, 9); exchange(k, 3, 11); exchange(k, 7, 15);
    exchange(k, 7, 11); exchange(k, 3, 5); exchange(k, 7, 9); exchange(k, 11, 13);
    exchange(k, 1, 2); exchange(k, 3, 4); exchange(k, 5, 6); exchange(k, 7, 8);
    exchange(k, 9, 10); exchange(k, 11, 12); exchange(k, 13, 14);
}

fn exchange(k: ptr<function, array<u32, SHORT_LIST>>, i: u32, j: u32) {
    let a = (*k)[i];
    let b = (*k)[j];
    (*k)[i] = min(a, b);
    (*k)[j] = max(a, b);
}

@compute @workgroup_size(64)
fn sort_short(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let r = id.x + id.y * groups.x * 64u;
    if r >= run_total() {
        return;
    }
    let base = run_start(r);
    let end = atomicLoad(&runs[r]);
    if r % grid.light_blocks == grid.light_blocks - 1u {
        // The cluster's last run: its list spans from its first run's start to here.
        let list = run_start(r + 1u - grid.light_blocks);
        ranges[r / grid.light_blocks] = vec2<u32>(list, end - list);
    }
    let n = end - base;
    if n <= 1u {
        return;
    }
    if n > SHORT_LIST {
        let slot = atomicAdd(&long_lists.count, 1u);
        long_lists.slots[scan_block_count() + slot] = r;
        atomicMax(&long_dispatch.x, min(slot + 1u, MAX_DISPATCH));
        return;
    }
    // Loaded at once (unrolled), sorted by a fixed network, stored: every index is a constant,
    // so the run stays in registers. An insertion sort in the index buffer, its loads one after
    // another, made the longest runs' invocations the pass's critical path, and one in a
    // private array indexed at run time spilled to local memory (figures in
    // docs/performance.md, "Many lights").
    var k: array<u32, SHORT_LIST>;
    for (var i = 0u; i < SHORT_LIST; i++) {
        k[i] = 0xffffffffu;
        if i < n {
            k[i] = indices[base + i];
        }
    }
    sort_16(&k);
    for (var i = 0u; i < SHORT_LIST; i++) {
        if i < n {
            indices[base + i] = k[i];
        }
    }
}

// One workgroup sorts one run. A run holds distinct lights of one block, so up to SORT_THREADS
// lights each thread places its light at its rank among them (one barrier); longer runs (a
// crowd of lights in one cluster) set each light's bit in a mask of the block's lights and
// write the set bits out in order (MASK_WORDS words: blocks of up to 65 536 lights, see
// LightBlocks in features/clusters/grid.rs). A bitonic network did this before, a barrier per
// step, in the index buffer for runs past its workgroup memory; sorting whole lists of hundreds
// of lights that way cost far more than sorting runs does (docs/performance.md, "Many lights").
const SORT_THREADS: u32 = 256u;
const MASK_WORDS: u32 = 2048u;
var<workgroup> sort_keys: array<u32, SORT_THREADS>;
var<workgroup> sort_mask: array<atomic<u32>, MASK_WORDS>;
var<workgroup> sort_count: u32;
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
    let queue = scan_block_count();
    for (var q = wg.x; q < queued; q += groups.x) {
        sort_one(long_lists.slots[queue + q], t);
    }
}

// Sorts run r with the 256 threads of a workgroup (sort_long).
fn sort_one(r: u32, t: u32) {
    let base = run_start(r);
    if t == 0u {
        sort_count = atomicLoad(&runs[r]) - base;
    }
    // Broadcast so that every barrier below sits in uniform control flow.
    let n = workgroupUniformLoad(&sort_count);
    if n <= 1u {
        return;
    }
    if n <= SORT_THREADS {
        if t < n {
            sort_keys[t] = indices[base + t];
        }
        workgroupBarrier();
        if t < n {
            let key = sort_keys[t];
            var rank = 0u;
            for (var i = 0u; i < n; i++) {
                rank += u32(sort_keys[i] < key);
            }
            indices[base + rank] = key;
        }
        // The next run reuses sort_keys.
        workgroupBarrier();
        return;
    }
    let first_light = grid.light_first + (r % grid.light_blocks) * grid.block_lights;
    let words = (grid.block_lights + 31u) / 32u;
    for (var w = t; w < words; w += SORT_THREADS) {
        atomicStore(&sort_mask[w], 0u);
    }
    workgroupBarrier();
    for (var i = t; i < n; i += SORT_THREADS) {
        let bit = indices[base + i] - first_light;
        atomicOr(&sort_mask[bit / 32u], 1u << (bit % 32u));
    }
    workgroupBarrier();
    // Each thread writes out a span of words, after the lights of the spans before it.
    let span = (words + SORT_THREADS - 1u) / SORT_THREADS;
    let w_first = min(t * span, words);
    let w_end = min(w_first + span, words);
    var count = 0u;
    for (var w = w_first; w < w_end; w++) {
        count += countOneBits(atomicLoad(&sort_mask[w]));
    }
    var at = base + workgroup_scan(t, count) - count;
    for (var w = w_first; w < w_end; w++) {
        var bits = atomicLoad(&sort_mask[w]);
        while bits != 0u {
            indices[at] = first_light + w * 32u + firstTrailingBit(bits);
            at += 1u;
            bits &= bits - 1u;
        }
    }
    // The next run clears sort_mask.
    workgroupBarrier();
}
