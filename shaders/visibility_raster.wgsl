// Rasterisation in compute (see crates/render/src/features/visibility/): the visibility buffer.
//
// Every opaque batch's visible instances (the cull pass's `visible_slots` and instance counts)
// are numbered triangle by triangle, batch after batch: `raster_prepare` turns this frame's
// instance counts into each batch's first number (`counters`). The batches are rasterised in
// bins (`bin`: a range of the batch table, whose numbers are contiguous): the unmasked ones,
// then the alpha-masked ones by variant and texture. Each bin's start (`raster_prepare` for the
// first, `raster_begin` for each later one) sizes its raster dispatch and empties the job list.
// One thread per number of the bin (`raster_triangles`) places the triangle's vertices as the
// vertex shader does (draw_data::place_vertex), clips it against the depth range, and writes
// `depth << 32 | number` with a 64-bit atomicMax into each sample it covers. Reverse-Z: the
// nearest surface has the largest depth, and a tie goes to the larger number, so the result
// does not depend on the order the threads run in. An empty sample stays 0 (depth 0 is the
// infinitely far plane, which no triangle reaches). Masked variants (ALPHA_MASK, with
// BASE_COLOR_TEXTURE, TRANSFORMED_UVS and VERTEX_COLORS as the forward variant has them) cover
// a sample only where glTF's alpha test passes there (`alpha_passes`).
//
// A triangle whose box spans at most small_box() pixels each way is rasterised by its thread. A
// larger one leaves a record (`big`); `raster_scan` gives each record its first job, and
// `raster_tiles` runs one job per TILE×TILE-pixel tile of each record's box (each thread group
// takes a run of consecutive jobs, sets each record's triangle up again from its number once,
// and covers the tiles), so a triangle filling the view is spread over the GPU instead of one
// thread. A triangle whose record does
// not fit is not lost: its own thread rasterises the whole box (slower, same samples).
//
// Coverage, as fixed-function rasterisers decide it: the triangle is clipped to the depth
// range and a guard band, its vertices snapped to a grid of 1/256 pixel, and each sample tested
// against exact edge functions (64-bit; 32-bit relative to the box for small outlines, the
// same values), with the top-left rule for samples exactly on an edge: two triangles sharing
// an edge get exactly opposite edge values there, so each such sample goes to exactly one of
// them; clipping computes each new vertex from the edge's inside end, so neighbours clipped
// by the same plane meet at the same point. The result does not depend on the order threads
// run in. The shading pass (forward.wgsl, VISIBILITY_SHADE) decodes the
// number the same way and recomputes the triangle from it.
//
// SHADOW_DEPTH: the same steps draw one shadow map's casters (features/shadows/raster.rs): the
// map's culled lists and instance counts (at `view.slot_base` and `view.args_base` of the
// caster cull's), its clip space, both faces, one sample a texel, and into each texel only the
// depth (f32 bits, which order as the floats do) with a 32-bit atomicMax, pushed away from the
// light by the casters' slope-scaled bias as the hardware's raster state pushes it.

#ifndef SHADOW_DEPTH
#import penumbra::view::View
#endif
#import penumbra::draw_data::{Instance, Material, TexCoord, UvSets, place_vertex, slot_coord}
#import penumbra::common::STANDARD_SAMPLES_4
#import penumbra::visibility::{RasterBatch, CULL_BACK, FRONT_CW, NON_INDEXED, pixel_weights}

struct RasterParams {
    target_size: vec2<u32>,
    samples: u32,
    batch_count: u32,
    // Records `big` can hold.
    job_capacity: u32,
    // Thread groups `raster_tiles` runs (each loops over jobs).
    tile_groups: u32,
    // Pixels from one row of `vis` to the next (at least the target's width).
    row_pitch: u32,
    _pad: u32,
};

#ifdef SHADOW_DEPTH
// One shadow map's casters as the caster pass sees them (shadow_caster.wgsl's CasterView).
struct CasterRasterView {
    clip_from_rel: mat4x4<f32>,
    camera_position: vec3<f32>,
    // Where the map's culled lists start in `visible_slots`, and its batches' instance counts
    // in `cull_args`.
    slot_base: u32,
    args_base: u32,
    // ShadowSettings::slope_bias.
    slope_bias: f32,
    _pad_a: u32,
    _pad_b: u32,
};
#endif

// The batches one raster bin draws: first_batch..end_batch of the table, whose numbers are
// contiguous (end_batch may be the batch count: its word holds the total).
struct RasterBin {
    first_batch: u32,
    end_batch: u32,
    _pad_a: u32,
    _pad_b: u32,
};

// Largest box (pixels each way) a triangle's own thread rasterises: 16×16 pixels of one sample
// (shadow maps), 8×8 of four, the same number of sample tests. Larger boxes, a mix of sizes
// holding each warp to its largest, measured slower on real models at four samples; mid-sized
// triangles are what tile jobs do worst (one lane sets the triangle up again per tile while the
// group waits, most of the tile outside it), as in a shadow map of many mid-sized casters.
fn small_box() -> u32 {
    return select(8u, 16u, params.samples == 1u);
}
// Side of a job's tile in pixels.
const TILE: u32 = 16u;
const WORKGROUP: u32 = 64u;
// Dispatches wider than this many groups go 2D.
const MAX_GROUPS_X: u32 = 32768u;

#ifdef SHADOW_DEPTH
@group(0) @binding(0) var<uniform> view: CasterRasterView;
#else
@group(0) @binding(0) var<uniform> view: View;
#endif
@group(0) @binding(1) var<storage, read> instances: array<Instance>;
@group(0) @binding(2) var<storage, read> visible_slots: array<u32>;
@group(0) @binding(3) var<storage, read> batches: array<RasterBatch>;
@group(0) @binding(4) var<storage, read> cull_args: array<u32>;
@group(0) @binding(5) var<storage, read> pool_indices: array<u32>;
@group(0) @binding(6) var<storage, read> pool_vertices: array<f32>;
@group(0) @binding(7) var<uniform> params: RasterParams;
// Per batch its first number, then the total, then the job count.
@group(0) @binding(8) var<storage, read_write> counters: array<atomic<u32>>;
#ifdef SHADOW_DEPTH
@group(0) @binding(9) var<storage, read_write> vis: array<atomic<u32>>;
#else
@group(0) @binding(9) var<storage, read_write> vis: array<atomic<u64>>;
#endif
// Large triangles: (number, first tile y << 16 | x, tiles high << 16 | wide, first job).
@group(0) @binding(10) var<storage, read_write> big: array<vec4<u32>>;
// This dispatch's bin (a dynamic offset into the bins' uniforms).
@group(0) @binding(11) var<uniform> bin: RasterBin;
// The raster dispatch's arguments, written by raster_prepare and raster_begin (their own group:
// the dispatch they drive cannot also bind them for writing).
// Masked variants (ALPHA_MASK) make pipelines only of raster_triangles and raster_tiles, whose
// group 1 is the bin's material.
#ifndef ALPHA_MASK
@group(1) @binding(0) var<storage, read_write> dispatch: array<u32>;
#endif
#ifdef ALPHA_MASK
@group(0) @binding(12) var<storage, read> materials: array<Material>;
#ifdef BASE_COLOR_TEXTURE
// The bin's material group (forward.wgsl's group 1): only the base colour is read.
@group(1) @binding(0) var base_color_texture: texture_2d<f32>;
@group(1) @binding(1) var base_color_sampler: sampler;
#endif
#endif

// Where this draw's lists start in `visible_slots` and its counts in `cull_args`.
fn slot_base() -> u32 {
#ifdef SHADOW_DEPTH
    return view.slot_base;
#else
    return 0u;
#endif
}

fn args_base() -> u32 {
#ifdef SHADOW_DEPTH
    return view.args_base;
#else
    return 0u;
#endif
}

// Whether a batch's back faces are left out (never for shadow casters: a single-sided wall
// still blocks light coming from behind it).
fn culls_back(flags: u32) -> bool {
#ifdef SHADOW_DEPTH
    return false;
#else
    return (flags & CULL_BACK) != 0u;
#endif
}

// The slope-scaled depth bias of a triangle whose projected vertices are `a`, `b`, `c`
// (framebuffer x, y and depth): the bias times its steepest depth change across one pixel
// (as Vulkan's depth bias takes it, the larger of the two axes' slopes), toward 0, away from
// the light. 0 outside shadow maps.
fn depth_bias(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> f32 {
#ifdef SHADOW_DEPTH
    let e1 = b - a;
    let e2 = c - a;
    let det = e1.x * e2.y - e1.y * e2.x;
    if !(abs(det) > 0.0) {
        return 0.0;
    }
    let dzdx = (e1.z * e2.y - e2.z * e1.y) / det;
    let dzdy = (e1.x * e2.z - e2.x * e1.z) / det;
    let slope = max(abs(dzdx), abs(dzdy));
    // A sliver's slope can overflow: clamp the bias to the depth range.
    return min(view.slope_bias * slope, 1.0);
#else
    return 0.0;
#endif
}

// The number of large triangles recorded in `big`.
fn big_count_word() -> u32 {
    return params.batch_count + 1u;
}

// The number of tile jobs their records add up to (raster_scan).
fn job_total_word() -> u32 {
    return params.batch_count + 2u;
}

// This frame's numbering: each batch's first triangle number and the total; then the first
// bin's start (raster_begin). One thread: batches are few next to their triangles, and this
// runs once.
@compute @workgroup_size(1)
fn raster_prepare() {
    var total = 0u;
    for (var b = 0u; b < params.batch_count; b++) {
        atomicStore(&counters[b], total);
        let batch = batches[b];
        let instances_visible = cull_args[args_base() + batch.count_word];
        // Numbers are u32: a frame with more visible triangles than that draws what fits
        // (the renderer does not choose this path for such a scene).
        let n = u64(instances_visible) * u64(batch.triangle_count);
        total = u32(min(u64(total) + n, u64(0xffffffffu)));
    }
    atomicStore(&counters[params.batch_count], total);
    begin_bin();
}

// A later bin's start: its raster dispatch's size and an empty job list.
@compute @workgroup_size(1)
fn raster_begin() {
    begin_bin();
}

fn begin_bin() {
#ifndef ALPHA_MASK
    let range = bin_range();
    let count = range.y - range.x;
    let groups = (count + WORKGROUP - 1u) / WORKGROUP;
    let x = min(groups, MAX_GROUPS_X);
    let y = select(1u, (groups + x - 1u) / x, x > 0u);
    dispatch[0] = x;
    dispatch[1] = y;
    dispatch[2] = 1u;
    atomicStore(&counters[big_count_word()], 0u);
    atomicStore(&counters[job_total_word()], 0u);
#endif
}

// The bin's first triangle number, and the number after its last.
fn bin_range() -> vec2<u32> {
    let start = atomicLoad(&counters[min(bin.first_batch, params.batch_count)]);
    return vec2<u32>(start, max(atomicLoad(&counters[min(bin.end_batch, params.batch_count)]), start));
}

// The triangle a number names: its batch, instance slot and vertices.
struct TriangleRef {
    batch: u32,
    slot: u32,
    vertices: vec3<u32>,
    valid: bool,
};

fn find_triangle(number: u32) -> TriangleRef {
    var r: TriangleRef;
    r.valid = false;
    if number >= atomicLoad(&counters[params.batch_count]) {
        return r;
    }
    // The last batch whose first number is at most `number`.
    var lo = 0u;
    var hi = params.batch_count;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if atomicLoad(&counters[mid]) <= number {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // Past this bin's batches: the next bin's (the dispatch is rounded up to whole groups).
    if lo >= bin.end_batch {
        return r;
    }
    let batch = batches[lo];
    if batch.triangle_count == 0u {
        return r;
    }
    let local = number - atomicLoad(&counters[lo]);
    let instance = local / batch.triangle_count;
    let triangle = local % batch.triangle_count;
    r.batch = lo;
    r.slot = visible_slots[slot_base() + batch.first + instance];
    if (batch.flags & NON_INDEXED) != 0u {
        let v = batch.index_start + 3u * triangle;
        r.vertices = vec3<u32>(v, v + 1u, v + 2u);
    } else {
        let at = batch.index_start + 3u * triangle;
        r.vertices = batch.vertex_start + vec3<u32>(pool_indices[at], pool_indices[at + 1u], pool_indices[at + 2u]);
    }
    r.valid = true;
    return r;
}

fn vertex_clip(inst: Instance, vertex: u32) -> vec4<f32> {
    let at = vertex * 16u;
    let p = vec3<f32>(pool_vertices[at], pool_vertices[at + 1u], pool_vertices[at + 2u]);
    // As the vertex shader places it (forward.wgsl), so shading finds the same triangle.
    return view.clip_from_rel * vec4<f32>(place_vertex(inst, p, view.camera_position).rel, 1.0);
}

// Sub-pixel bits of the fixed-point grid vertices snap to (as hardware rasterisers do; Vulkan
// requires at least 4, GPUs use 8).
const SUBPIXEL: f32 = 256.0;
// The guard band: triangles are clipped to |x|, |y| ≤ GUARD·w (normalised device coordinates
// within ±GUARD), so snapped coordinates stay within f32's exact integers (2^24, for targets
// up to 14 000 pixels across) and i32, and edge functions within i64.
const GUARD: f32 = 8.0;
// Clip planes: the depth range's near (z ≤ w) and far (z ≥ 0) planes, then the guard band.
const PLANES: u32 = 6u;
// The most vertices clipping a triangle against PLANES planes leaves.
const MAX_VERTICES: u32 = 9u;

// A triangle ready to rasterise: its clipped outline as a fan of `count` vertices, snapped to
// the sub-pixel grid in framebuffer coordinates (y down; `xy`) with depth (`z`), and the box of
// pixels whose samples it may cover.
struct Setup {
    xy: array<vec2<i32>, 9>,
    z: array<f32, 9>,
    count: u32,
    lo: vec2<i32>,
    hi: vec2<i32>,
    // The outline lies within COMPACT pixels each way (before clamping to the target): its
    // edge functions fit 32 bits relative to `lo`.
    compact: bool,
};

const COMPACT: f32 = 16.0;

fn plane_distance(c: vec4<f32>, plane: u32) -> f32 {
    switch plane {
        case 0u: { return c.w - c.z; }
        case 1u: { return c.z; }
        case 2u: { return GUARD * c.w - c.x; }
        case 3u: { return GUARD * c.w + c.x; }
        case 4u: { return GUARD * c.w - c.y; }
        default: { return GUARD * c.w + c.y; }
    }
}

// A clip-space position in framebuffer coordinates (pixels, y down) with its depth.
fn project(c: vec4<f32>) -> vec3<f32> {
    let size = vec2<f32>(params.target_size);
    let ndc = c.xyz / c.w;
    return vec3<f32>((ndc.x * 0.5 + 0.5) * size.x, (0.5 - ndc.y * 0.5) * size.y, ndc.z);
}

// A framebuffer position on the sub-pixel grid.
fn snap(f: vec2<f32>) -> vec2<i32> {
    return vec2<i32>(round(f * SUBPIXEL));
}

// Whether a clip-space position lies inside every clip plane (a triangle of three such is not
// clipped at all).
fn unclipped(c: vec4<f32>) -> bool {
    let g = GUARD * c.w;
    return c.z <= c.w && c.z >= 0.0 && c.x <= g && c.x >= -g && c.y <= g && c.y >= -g && c.w > 0.0;
}

fn setup_triangle(number: u32) -> Setup {
    var s: Setup;
    s.count = 0u;
    let t = find_triangle(number);
    if !t.valid {
        return s;
    }
    let inst = instances[t.slot];
    let batch = batches[t.batch];
    let zero = vec4<f32>(0.0);
    var poly = array<vec4<f32>, 9>(
        vertex_clip(inst, t.vertices.x),
        vertex_clip(inst, t.vertices.y),
        vertex_clip(inst, t.vertices.z),
        zero, zero, zero, zero, zero, zero,
    );
    var n = 3u;
#ifdef ALPHA_MASK
    load_alpha_source(t, poly[0], poly[1], poly[2]);
#endif
    // From the whole triangle (shadow maps are orthographic: the projection keeps its plane),
    // before clipping can leave slivers.
    var bias = 0.0;
#ifdef SHADOW_DEPTH
    if poly[0].w > 0.0 && poly[1].w > 0.0 && poly[2].w > 0.0 {
        bias = depth_bias(project(poly[0]), project(poly[1]), project(poly[2]));
    }
#endif
    // NaN anywhere: nothing to draw (the hardware's result is undefined; ours is nothing).
    for (var i = 0u; i < 3u; i++) {
        if any(poly[i] != poly[i]) {
            return s;
        }
    }
    // Sutherland-Hodgman; most triangles lie inside every plane and skip each at once.
    for (var plane = 0u; plane < PLANES; plane++) {
        var inside = 0u;
        for (var i = 0u; i < n; i++) {
            if plane_distance(poly[i], plane) >= 0.0 {
                inside++;
            }
        }
        if inside == n {
            continue;
        }
        if inside == 0u {
            return s;
        }
        var out = array<vec4<f32>, 9>(zero, zero, zero, zero, zero, zero, zero, zero, zero);
        var m = 0u;
        for (var i = 0u; i < n; i++) {
            let a = poly[i];
            let b = poly[(i + 1u) % n];
            let da = plane_distance(a, plane);
            let db = plane_distance(b, plane);
            if da >= 0.0 && m < MAX_VERTICES {
                out[m] = a;
                m++;
            }
            if (da >= 0.0) != (db >= 0.0) && m < MAX_VERTICES {
                // From the inside end, whichever way the outline runs: the neighbour sharing
                // this edge walks it the other way and must get the same point to the bit, or
                // a sample could fall between the two after snapping.
                let inside_a = da >= 0.0;
                let p_in = select(b, a, inside_a);
                let p_out = select(a, b, inside_a);
                let d_in = select(db, da, inside_a);
                let d_out = select(da, db, inside_a);
                out[m] = p_in + (p_out - p_in) * (d_in / (d_in - d_out));
                m++;
            }
        }
        poly = out;
        n = m;
    }
    let size = vec2<f32>(params.target_size);
    var lo = vec2<f32>(3.4e38);
    var hi = vec2<f32>(-3.4e38);
    for (var i = 0u; i < n; i++) {
        let c = poly[i];
        // Positive: the near plane (perspective) or the depth range (orthographic, w = 1).
        if !(c.w > 0.0) {
            return s;
        }
        let f = project(c);
        s.xy[i] = snap(f.xy);
        s.z[i] = f.z - bias;
        lo = min(lo, f.xy);
        hi = max(hi, f.xy);
    }
    // Orientation from the snapped fan's area (framebuffer y down: negative is counter-
    // clockwise as normalised device coordinates see it, the front unless FRONT_CW).
    var area = i64(0);
    for (var i = 1u; i + 1u < n; i++) {
        area += edge(s.xy[0], s.xy[i], s.xy[i + 1u]);
    }
    if area == i64(0) {
        return s;
    }
    let front = (area < i64(0)) != ((batch.flags & FRONT_CW) != 0u);
    if culls_back(batch.flags) && !front {
        return s;
    }
    if hi.x < 0.0 || hi.y < 0.0 || lo.x > size.x || lo.y > size.y {
        return s;
    }
    // Pixels whose samples may lie inside (every sample of a pixel lies within it); the guard
    // band keeps these finite and within i32.
    s.compact = all(hi - lo <= vec2<f32>(COMPACT));
    s.lo = vec2<i32>(max(floor(lo), vec2<f32>(0.0)));
    s.hi = vec2<i32>(min(floor(hi), size - 1.0));
    if any(s.hi < s.lo) {
        return s;
    }
    s.count = n;
    return s;
}

// Sample `i`'s position within its pixel on the sub-pixel grid (Vulkan's standard locations
// are multiples of 1/16).
fn sample_offset(i: u32) -> vec2<i32> {
    if params.samples == 4u {
        return vec2<i32>(STANDARD_SAMPLES_4[i] * SUBPIXEL);
    }
    return vec2<i32>(i32(SUBPIXEL) / 2);
}

// The edge function of (a, b) at p on the sub-pixel grid: twice the signed area of (a, b, p),
// exact in 64 bits, so two triangles sharing an edge get exactly opposite values there and the
// result is the same on every GPU.
fn edge(a: vec2<i32>, b: vec2<i32>, p: vec2<i32>) -> i64 {
    return i64(b.x - a.x) * i64(p.y - a.y) - i64(b.y - a.y) * i64(p.x - a.x);
}

// Whether the edge from `a` to `b`, of a triangle whose edge functions times `sign` are positive
// inside, is a top or a left edge (framebuffer y down): the interior lies to its right, or it
// is horizontal with the interior below. A sample exactly on an edge is covered only by such
// an edge's triangle: the rule fixed-function rasterisers follow, so of two triangles sharing
// an edge exactly one covers it (their edge functions there are exactly opposite).
fn top_left(a: vec2<i32>, b: vec2<i32>, sign: i32) -> bool {
    let gx = -sign * (b.y - a.y);
    let gy = sign * (b.x - a.x);
    return gx > 0 || (gx == 0 && gy > 0);
}

// Sample `k` of pixel `pixel` (its index `at` in the buffer) lies inside triangle `number` at
// `depth`: the nearest triangle keeps it. A masked triangle (ALPHA_MASK) covers it only where
// its alpha passes there, and tests only samples it would win.
fn cover(at: u32, depth: f32, number: u32, pixel: vec2<i32>, k: u32) {
    if depth > 0.0 {
#ifdef SHADOW_DEPTH
        let value = bitcast<u32>(depth);
#else
        let value = (u64(bitcast<u32>(depth)) << 32u) | u64(number);
#endif
#ifdef ALPHA_MASK
        if atomicLoad(&vis[at]) >= value || !alpha_passes(pixel, k) {
            return;
        }
#endif
        atomicMax(&vis[at], value);
    }
}

#ifdef ALPHA_MASK
// What the alpha test reads of the triangle being rasterised: its clip positions' cross products
// (for perspective_weights), its vertices' UV sets and colour alpha, and its material.
struct AlphaSource {
    r_a: vec3<f32>,
    r_b: vec3<f32>,
    r_c: vec3<f32>,
    first_a: vec2<f32>,
    first_b: vec2<f32>,
    first_c: vec2<f32>,
    second_a: vec2<f32>,
    second_b: vec2<f32>,
    second_c: vec2<f32>,
    vertex_alpha: vec3<f32>,
    material: u32,
};

// The triangle this invocation rasterises (set by setup_triangle and raster_unclipped_small; a
// tile job's group shares its first lane's through `tile_alpha`).
var<private> alpha_source: AlphaSource;
var<workgroup> tile_alpha: AlphaSource;

fn pool_uv(vertex: u32, word: u32) -> vec2<f32> {
    let at = vertex * 16u + word;
    return vec2<f32>(pool_vertices[at], pool_vertices[at + 1u]);
}

fn load_alpha_source(t: TriangleRef, ca: vec4<f32>, cb: vec4<f32>, cc: vec4<f32>) {
    var a: AlphaSource;
    a.r_a = cross(cb.xyw, cc.xyw);
    a.r_b = cross(cc.xyw, ca.xyw);
    a.r_c = cross(ca.xyw, cb.xyw);
    let v = t.vertices;
    a.first_a = pool_uv(v.x, 10u);
    a.first_b = pool_uv(v.y, 10u);
    a.first_c = pool_uv(v.z, 10u);
    a.second_a = pool_uv(v.x, 12u);
    a.second_b = pool_uv(v.y, 12u);
    a.second_c = pool_uv(v.z, 12u);
    // Colours are two words of unorm16 pairs (r, g) and (b, a).
    a.vertex_alpha = vec3<f32>(
        unpack2x16unorm(bitcast<u32>(pool_vertices[v.x * 16u + 15u])).y,
        unpack2x16unorm(bitcast<u32>(pool_vertices[v.y * 16u + 15u])).y,
        unpack2x16unorm(bitcast<u32>(pool_vertices[v.z * 16u + 15u])).y,
    );
    a.material = instances[t.slot].material;
    alpha_source = a;
}

fn mix_uv(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, w: vec3<f32>) -> vec2<f32> {
    return a * w.x + b * w.y + c * w.z;
}

// glTF's alpha test of the triangle at sample `k` of `pixel`, as the forward pass makes it
// (forward.wgsl: the per-pixel test at one sample, alpha_coverage at four): the alpha (factor ×
// vertex colour × base colour texel) at the sample, the texel fetched with the pixel's fine
// gradients, the colour extrapolated from the pixel's centre along its gradient. NaN alpha
// covers nothing.
fn alpha_passes(pixel: vec2<i32>, k: u32) -> bool {
    let a = alpha_source;
    let r = array<vec3<f32>, 3>(a.r_a, a.r_b, a.r_c);
    let pw = pixel_weights(r, vec2<f32>(pixel) + 0.5, params.target_size);
    var o = vec2<f32>(0.0);
    if params.samples == 4u {
        o = STANDARD_SAMPLES_4[k] - vec2<f32>(0.5);
    }
    let mat = materials[a.material];
    var alpha = mat.base_color.a;
#ifdef VERTEX_COLORS
    let va = a.vertex_alpha;
    let gradient = vec2<f32>(dot(va, pw.right) - dot(va, pw.left), dot(va, pw.bottom) - dot(va, pw.top));
    alpha *= dot(va, pw.centre) + dot(gradient, o);
#endif
#ifdef BASE_COLOR_TEXTURE
    let sets = UvSets(
        mix_uv(a.first_a, a.first_b, a.first_c, pw.centre),
        mix_uv(a.second_a, a.second_b, a.second_c, pw.centre),
        mix_uv(a.first_a, a.first_b, a.first_c, pw.right) - mix_uv(a.first_a, a.first_b, a.first_c, pw.left),
        mix_uv(a.first_a, a.first_b, a.first_c, pw.bottom) - mix_uv(a.first_a, a.first_b, a.first_c, pw.top),
        mix_uv(a.second_a, a.second_b, a.second_c, pw.right) - mix_uv(a.second_a, a.second_b, a.second_c, pw.left),
        mix_uv(a.second_a, a.second_b, a.second_c, pw.bottom) - mix_uv(a.second_a, a.second_b, a.second_c, pw.top),
    );
#ifdef TRANSFORMED_UVS
    let c = slot_coord(mat, 0u, sets);
#else
    let c = TexCoord(sets.first, sets.first_ddx, sets.first_ddy);
#endif
    let uv = c.uv + c.ddx * o.x + c.ddy * o.y;
    alpha *= textureSampleGrad(base_color_texture, base_color_sampler, uv, c.ddx, c.ddy).a;
#endif
    return alpha >= mat.alpha_cutoff;
}
#endif

// Writes fan triangle (0, i, i + 1) of `s` into the samples of pixels lo..=hi it covers.
fn raster_fan_triangle(s: Setup, i: u32, lo: vec2<i32>, hi: vec2<i32>, number: u32) {
    let a = s.xy[0];
    let b = s.xy[i];
    let c = s.xy[i + 1u];
    let area = edge(a, b, c);
    if area == i64(0) {
        return;
    }
    let flip = area < i64(0);
    let inv_area = 1.0 / f32(area);
    let sign = select(1, -1, flip);
    let ta = top_left(b, c, sign);
    let tb = top_left(c, a, sign);
    let tc = top_left(a, b, sign);
    let grid = i32(SUBPIXEL);
    let tlo = max(lo, min(a, min(b, c)) / grid - 1);
    let thi = min(hi, max(a, max(b, c)) / grid + 1);
    let width = params.row_pitch;
    let samples = params.samples;
    for (var y = tlo.y; y <= thi.y; y++) {
        for (var x = tlo.x; x <= thi.x; x++) {
            let pixel = (u32(y) * width + u32(x)) * samples;
            for (var k = 0u; k < samples; k++) {
                let p = vec2<i32>(x, y) * grid + sample_offset(k);
                var wa = edge(b, c, p);
                var wb = edge(c, a, p);
                var wc = edge(a, b, p);
                if flip {
                    wa = -wa;
                    wb = -wb;
                    wc = -wc;
                }
                if (wa > i64(0) || (wa == i64(0) && ta)) && (wb > i64(0) || (wb == i64(0) && tb))
                    && (wc > i64(0) || (wc == i64(0) && tc)) {
                    let depth = clamp((f32(wa) * s.z[0] + f32(wb) * s.z[i] + f32(wc) * s.z[i + 1u]) * abs(inv_area), 0.0, 1.0);
                    cover(pixel + k, depth, number, vec2<i32>(x, y), k);
                }
            }
        }
    }
}

fn edge32(a: vec2<i32>, b: vec2<i32>, p: vec2<i32>) -> i32 {
    return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
}

// raster_fan_triangle for a compact outline: the same edge functions (they do not change when
// every point moves by the same offset) in 32 bits, relative to the corner of the box lo..=hi.
fn raster_small_triangle(pa: vec2<i32>, pb: vec2<i32>, pc: vec2<i32>, z: vec3<f32>, lo: vec2<i32>, hi: vec2<i32>, number: u32) {
    let grid = i32(SUBPIXEL);
    let origin = lo * grid;
    let a = pa - origin;
    let b = pb - origin;
    let c = pc - origin;
    let area = edge32(a, b, c);
    if area == 0 {
        return;
    }
    let sign = select(1, -1, area < 0);
    let inv_area = 1.0 / f32(abs(area));
    let ta = top_left(b, c, sign);
    let tb = top_left(c, a, sign);
    let tc = top_left(a, b, sign);
    let width = params.row_pitch;
    let samples = params.samples;
    for (var y = lo.y; y <= hi.y; y++) {
        for (var x = lo.x; x <= hi.x; x++) {
            let pixel = (u32(y) * width + u32(x)) * samples;
            for (var k = 0u; k < samples; k++) {
                let p = (vec2<i32>(x, y) - lo) * grid + sample_offset(k);
                let wa = edge32(b, c, p) * sign;
                let wb = edge32(c, a, p) * sign;
                let wc = edge32(a, b, p) * sign;
                if (wa > 0 || (wa == 0 && ta)) && (wb > 0 || (wb == 0 && tb)) && (wc > 0 || (wc == 0 && tc)) {
                    let depth = clamp((f32(wa) * z.x + f32(wb) * z.y + f32(wc) * z.z) * inv_area, 0.0, 1.0);
                    cover(pixel + k, depth, number, vec2<i32>(x, y), k);
                }
            }
        }
    }
}

fn raster_small(s: Setup, number: u32) {
    for (var i = 1u; i + 1u < s.count; i++) {
        raster_small_triangle(s.xy[0], s.xy[i], s.xy[i + 1u], vec3<f32>(s.z[0], s.z[i], s.z[i + 1u]), s.lo, s.hi, number);
    }
}

// The common case without the general set-up's arrays (which live in slow local memory on
// GPUs): a triangle no plane clips, small and compact, exactly as setup_triangle and
// raster_small would draw it. Returns whether it was handled.
fn raster_unclipped_small(number: u32) -> bool {
    let t = find_triangle(number);
    if !t.valid {
        return true;
    }
    let inst = instances[t.slot];
    let ca = vertex_clip(inst, t.vertices.x);
    let cb = vertex_clip(inst, t.vertices.y);
    let cc = vertex_clip(inst, t.vertices.z);
    if !(unclipped(ca) && unclipped(cb) && unclipped(cc)) {
        return false;
    }
    let fa = project(ca);
    let fb = project(cb);
    let fc = project(cc);
    let lo_f = min(fa.xy, min(fb.xy, fc.xy));
    let hi_f = max(fa.xy, max(fb.xy, fc.xy));
    let size = vec2<f32>(params.target_size);
    let lo = vec2<i32>(max(floor(lo_f), vec2<f32>(0.0)));
    let hi = vec2<i32>(min(floor(hi_f), size - 1.0));
    let compact = all(hi_f - lo_f <= vec2<f32>(COMPACT));
    if !compact || any(vec2<u32>(max(hi - lo, vec2<i32>(0))) + 1u > vec2<u32>(small_box())) {
        return false;
    }
    let a = snap(fa.xy);
    let b = snap(fb.xy);
    let c = snap(fc.xy);
    let area = edge(a, b, c);
    if area == i64(0) {
        return true;
    }
    let batch = batches[t.batch];
    let front = (area < i64(0)) != ((batch.flags & FRONT_CW) != 0u);
    if culls_back(batch.flags) && !front {
        return true;
    }
    if hi_f.x < 0.0 || hi_f.y < 0.0 || lo_f.x > size.x || lo_f.y > size.y || any(hi < lo) {
        return true;
    }
#ifdef ALPHA_MASK
    load_alpha_source(t, ca, cb, cc);
#endif
    raster_small_triangle(a, b, c, vec3<f32>(fa.z, fb.z, fc.z) - depth_bias(fa, fb, fc), lo, hi, number);
    return true;
}

fn raster_setup(s: Setup, lo: vec2<i32>, hi: vec2<i32>, number: u32) {
    for (var i = 1u; i + 1u < s.count; i++) {
        raster_fan_triangle(s, i, lo, hi, number);
    }
}

@compute @workgroup_size(64)
fn raster_triangles(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
) {
    // The bin's numbers start at its first batch's (0 for the first bin, which holds most
    // triangles: no load); a number past the bin's last batch is refused by find_triangle.
    var number = (group.y * groups.x + group.x) * WORKGROUP + lane;
    if bin.first_batch != 0u {
        number += atomicLoad(&counters[min(bin.first_batch, params.batch_count)]);
    }
    if raster_unclipped_small(number) {
        return;
    }
    let s = setup_triangle(number);
    if s.count == 0u {
        return;
    }
    let extent = vec2<u32>(s.hi - s.lo) + 1u;
    if extent.x <= small_box() && extent.y <= small_box() {
        if s.compact {
            raster_small(s, number);
        } else {
            // A small visible part of a triangle reaching far outside the target.
            raster_setup(s, s.lo, s.hi, number);
        }
        return;
    }
    // A large triangle: one record, which raster_scan turns into TILE×TILE-pixel jobs.
    let t0 = vec2<u32>(s.lo) / TILE;
    let tiles = (vec2<u32>(s.hi) / TILE - t0) + 1u;
    let at = atomicAdd(&counters[big_count_word()], 1u);
    if at < params.job_capacity {
        big[at] = vec4<u32>(number, (t0.y << 16u) | t0.x, (tiles.y << 16u) | tiles.x, 0u);
    } else {
        // No room for its record: cover the whole box here.
        raster_setup(s, s.lo, s.hi, number);
    }
}

var<workgroup> scan_sums: array<u32, 256>;

// Each large triangle's first job: an exclusive prefix sum of their tile counts (one group of
// 256; each lane sums a run of records), and the total.
@compute @workgroup_size(256)
fn raster_scan(@builtin(local_invocation_index) lane: u32) {
    if lane == 0u {
        tile_jobs = min(atomicLoad(&counters[big_count_word()]), params.job_capacity);
    }
    let count = workgroupUniformLoad(&tile_jobs);
    let per = (count + 255u) / 256u;
    let begin = min(lane * per, count);
    let end = min(begin + per, count);
    var sum = 0u;
    for (var i = begin; i < end; i++) {
        let t = big[i].z;
        sum += (t & 0xffffu) * (t >> 16u);
    }
    scan_sums[lane] = sum;
    workgroupBarrier();
    for (var offset = 1u; offset < 256u; offset *= 2u) {
        let other = select(0u, scan_sums[lane - offset], lane >= offset);
        workgroupBarrier();
        scan_sums[lane] += other;
        workgroupBarrier();
    }
    var first = scan_sums[lane] - sum;
    for (var i = begin; i < end; i++) {
        big[i].w = first;
        let t = big[i].z;
        first += (t & 0xffffu) * (t >> 16u);
    }
    if lane == 255u {
        atomicStore(&counters[job_total_word()], scan_sums[255]);
    }
}

// A job's triangle, set up by the group's first lane once per record, the record and the job.
var<workgroup> tile_setup: Setup;
var<workgroup> tile_record: u32;
var<workgroup> tile_job: vec2<u32>;
var<workgroup> tile_jobs: u32;

// The record whose jobs hold job `j`.
fn find_record(j: u32) -> u32 {
    var lo = 0u;
    var hi = min(atomicLoad(&counters[big_count_word()]), params.job_capacity);
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if big[mid].w <= j {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// Job `j` of record `r`: its triangle's number and tile (y << 16 | x).
fn record_job(r: u32, j: u32) -> vec2<u32> {
    let record = big[r];
    let local = j - record.w;
    let wide = record.z & 0xffffu;
    let t = vec2<u32>(record.y & 0xffffu, record.y >> 16u) + vec2<u32>(local % wide, local / wide);
    return vec2<u32>(record.x, (t.y << 16u) | t.x);
}

// Writes fan triangle (0, i, i + 1) of `s` into the samples of this lane's pixels of a tile:
// column `column`, rows `row0 + 4k`. The edge functions are evaluated once per sample at the
// first row and stepped down the column (exact: integers).
fn raster_tile_column(s: Setup, i: u32, column: i32, row0: i32, number: u32) {
    let a = s.xy[0];
    let b = s.xy[i];
    let c = s.xy[i + 1u];
    let area = edge(a, b, c);
    if area == i64(0) {
        return;
    }
    let grid = i32(SUBPIXEL);
    let lo = max(s.lo, min(a, min(b, c)) / grid - 1);
    let hi = min(s.hi, max(a, max(b, c)) / grid + 1);
    if column < lo.x || column > hi.x {
        return;
    }
    let sign = select(i64(1), i64(-1), area < i64(0));
    let inv_area = 1.0 / f32(abs(area));
    let ta = top_left(b, c, i32(sign));
    let tb = top_left(c, a, i32(sign));
    let tc = top_left(a, b, i32(sign));
    // Four rows down: p.y grows by 4 pixels, each edge function by (its dx) · 4 pixels.
    let step = i64(4 * grid) * sign;
    let da = i64(c.x - b.x) * step;
    let db = i64(a.x - c.x) * step;
    let dc = i64(b.x - a.x) * step;
    let width = params.row_pitch;
    let samples = params.samples;
    for (var k = 0u; k < samples; k++) {
        let p = vec2<i32>(column, row0) * grid + sample_offset(k);
        var wa = edge(b, c, p) * sign;
        var wb = edge(c, a, p) * sign;
        var wc = edge(a, b, p) * sign;
        for (var r = 0; r < i32(TILE / 4u); r++) {
            let row = row0 + 4 * r;
            let inside = (wa > i64(0) || (wa == i64(0) && ta)) && (wb > i64(0) || (wb == i64(0) && tb))
                && (wc > i64(0) || (wc == i64(0) && tc));
            if row >= lo.y && row <= hi.y && inside {
                let depth = clamp((f32(wa) * s.z[0] + f32(wb) * s.z[i] + f32(wc) * s.z[i + 1u]) * inv_area, 0.0, 1.0);
                cover((u32(row) * width + u32(column)) * samples + k, depth, number, vec2<i32>(column, row), k);
            }
            wa += da;
            wb += db;
            wc += dc;
        }
    }
}

@compute @workgroup_size(64)
fn raster_tiles(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    if lane == 0u {
        tile_jobs = atomicLoad(&counters[job_total_word()]);
    }
    let count = workgroupUniformLoad(&tile_jobs);
    // Each group takes a run of consecutive jobs: a record's jobs are consecutive, so its
    // triangle is found and set up once per group rather than once per job.
    let per = (count + params.tile_groups - 1u) / params.tile_groups;
    let begin = min(group.x * per, count);
    let end = min(begin + per, count);
    for (var j = begin; j < end; j++) {
        // One lane finds the job and, for a new record, sets its triangle up for all 64.
        if lane == 0u {
            var r = tile_record;
            var fresh = j == begin;
            if fresh {
                r = find_record(j);
            } else {
                let records = min(atomicLoad(&counters[big_count_word()]), params.job_capacity);
                while r + 1u < records && big[r + 1u].w <= j {
                    r++;
                    fresh = true;
                }
            }
            if fresh {
                tile_setup = setup_triangle(big[r].x);
#ifdef ALPHA_MASK
                tile_alpha = alpha_source;
#endif
            }
            tile_record = r;
            tile_job = record_job(r, j);
        }
        workgroupBarrier();
        let s = tile_setup;
#ifdef ALPHA_MASK
        alpha_source = tile_alpha;
#endif
        let job = tile_job;
        // This lane's pixels: column lane % 16, rows lane / 16 + 4k.
        let tile = vec2<i32>(vec2<u32>(job.y & 0xffffu, job.y >> 16u) * TILE);
        let column = tile.x + i32(lane % TILE);
        let row0 = tile.y + i32(lane / TILE);
        for (var i = 1u; i + 1u < s.count; i++) {
            raster_tile_column(s, i, column, row0, job.x);
        }
        // The next job's record and setup overwrite these.
        workgroupBarrier();
    }
}
