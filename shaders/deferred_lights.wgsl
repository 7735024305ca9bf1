// Deferred local lights: a compute pass that shades every local light (all kinds but
// directional and ambient) for the opaque surfaces the forward pass drew, reading the surface
// each fragment wrote (gbuffer.wgsl) and walking its cluster's list, and writes the exposed
// radiance per pixel for deferred_composite.wgsl to add into the frame before blended draws.
//
// Why compute: on GPUs with few graphics-capable units (NVIDIA's H100 runs fragment shaders on
// 2 of its 66 TPCs) the light loop runs many times faster in compute than in fragment shaders;
// fragments then only write the surface.
//
// Multisampling (MULTISAMPLED): where all samples of a pixel hold the same surface, it is
// shaded once, at the mean of the samples' positions (the pixel centre on that surface, as the
// forward shader would shade it); elsewhere each sample is shaded and the mean written, which
// is what resolving the samples would give. Variants follow the forward shader's light kinds:
// SPHERE_TUBE_LIGHTS, LTC_LIGHTS, IES_LIGHTS.

#import penumbra::common::{F16_MAX, STANDARD_SAMPLES_4}
#import penumbra::view::{View, eye_direction}
#import penumbra::light_data::Light
#import penumbra::lights::{shade_light, within_reach}
#import penumbra::clusters::{ClusterGrid, fragment_cluster}
#import penumbra::gbuffer::{decode_surface, oct_decode}
#import penumbra::brdf::Surface

struct DeferredParams {
    // Inverse of view.clip_from_rel: clip-space sample positions back to camera-relative ones.
    rel_from_clip: mat4x4<f32>,
    viewport: vec2<f32>,
    _pad: vec2<f32>,
};

@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(4) var<storage, read> lights: array<Light>;
@group(0) @binding(8) var<uniform> grid: ClusterGrid;
@group(0) @binding(9) var<storage, read> cluster_ranges: array<vec2<u32>>;
@group(0) @binding(10) var<storage, read> cluster_lights: array<u32>;

// The forward pass's colour, whose alpha holds the surface's roughness (see gbuffer.wgsl).
#ifdef MULTISAMPLED
@group(1) @binding(0) var surface_color: texture_multisampled_2d<f32>;
@group(1) @binding(1) var surface_shape: texture_multisampled_2d<u32>;
@group(1) @binding(2) var depth: texture_depth_multisampled_2d;
const SAMPLES: u32 = 4u;
#else
@group(1) @binding(0) var surface_color: texture_2d<f32>;
@group(1) @binding(1) var surface_shape: texture_2d<u32>;
@group(1) @binding(2) var depth: texture_depth_2d;
const SAMPLES: u32 = 1u;
#endif
@group(1) @binding(3) var local_light: texture_storage_2d<rgba16float, write>;
@group(1) @binding(4) var<uniform> params: DeferredParams;

// Where sample i sits in its pixel: the standard 4× pattern, or the centre.
fn sample_offset(i: u32) -> vec2<f32> {
#ifdef MULTISAMPLED
    return STANDARD_SAMPLES_4[i];
#else
    return vec2<f32>(0.5);
#endif
}

// The camera-relative position seen at framebuffer position `xy` with depth `d`.
fn position_at(xy: vec2<f32>, d: f32) -> vec3<f32> {
    let ndc = vec2<f32>(xy.x / params.viewport.x * 2.0 - 1.0, 1.0 - xy.y / params.viewport.y * 2.0);
    let h = params.rel_from_clip * vec4<f32>(ndc, d, 1.0);
    return h.xyz / h.w;
}

// Local light leaving the surface at `rel` toward the eye; `frag_xy` picks the cluster.
fn shade_at(rel: vec3<f32>, frag_xy: vec2<f32>, roughness: f32, shape: vec4<u32>) -> vec3<f32> {
    let s = decode_surface(roughness, shape, eye_direction(view, rel));
    let range = cluster_ranges[fragment_cluster(grid, frag_xy, dot(rel, view.camera_forward))];
    var total = vec3<f32>(0.0);
    for (var i = 0u; i < range.y; i++) {
        let slot = cluster_lights[range.x + i];
        let reach = lights[slot].range;
        if within_reach(lights[slot].position - view.camera_position, reach * reach, rel) {
            total += shade_light(s, lights[slot], rel, view.camera_position);
        }
    }
    return total;
}

// Each covered sample shaded where it lies, and the mean: what resolving the samples gives.
fn shade_samples(px: vec2<i32>, corner: vec2<f32>, centre: vec2<f32>) -> vec3<f32> {
    var total = vec3<f32>(0.0);
    for (var i = 0u; i < SAMPLES; i++) {
        let sample_roughness = textureLoad(surface_color, px, i).a;
        if sample_roughness > 0.0 {
            let rel = position_at(corner + sample_offset(i), textureLoad(depth, px, i));
            total += shade_at(rel, centre, sample_roughness, textureLoad(surface_shape, px, i));
        }
    }
    return total / f32(SAMPLES);
}

// A workgroup's 8×8 pixels mostly share one cluster. When every pixel it shades once does, the
// workgroup walks that list together: each round its 64 threads load 64 lights' bounding
// spheres into workgroup memory, and each pixel tests them from there, instead of waiting on
// two dependent loads per light (the slot, then the light), mostly for lights that miss it.
// With long lists, most of what remains is shading the lights that do reach each pixel (figures
// in docs/performance.md, "Many lights"). The sums run in list order either way, so the image
// is the same.
const GROUP_PIXELS: u32 = 64u;
const NO_CLUSTER: u32 = 0xffffffffu;
var<workgroup> group_first: atomic<u32>;
var<workgroup> group_last: atomic<u32>;
var<workgroup> group_cluster: u32;
var<workgroup> candidate_slot: array<u32, GROUP_PIXELS>;
// Camera-relative centre and squared range of each candidate.
var<workgroup> candidate_sphere: array<vec4<f32>, GROUP_PIXELS>;

@compute @workgroup_size(8, 8)
fn shade_local_lights(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) t: u32,
) {
    if t == 0u {
        atomicStore(&group_first, NO_CLUSTER);
        atomicStore(&group_last, 0u);
    }
    workgroupBarrier();
    let inside = id.x < u32(params.viewport.x) && id.y < u32(params.viewport.y);
    let px = vec2<i32>(id.xy);
    let corner = vec2<f32>(id.xy);
    let centre = corner + 0.5;
    var roughness = 0.0;
    var shape = vec4<u32>(0u);
    var one_surface = true;
    if inside {
        roughness = textureLoad(surface_color, px, 0).a;
        shape = textureLoad(surface_shape, px, 0);
        for (var i = 1u; i < SAMPLES; i++) {
            one_surface = one_surface && textureLoad(surface_color, px, i).a == roughness
                && all(textureLoad(surface_shape, px, i) == shape);
        }
    }
    // What this pixel needs: nothing, one shading at `rel` (planar), or one per sample.
    var shade_once = false;
    var per_sample = inside && !one_surface;
    var rel = vec3<f32>(0.0);
    // Roughness is never below 0.045 on a lit surface; 0 marks unlit ones and the background.
    if inside && one_surface && roughness > 0.0 {
        var positions: array<vec3<f32>, 4>;
        for (var i = 0u; i < SAMPLES; i++) {
            positions[i] = position_at(corner + sample_offset(i), textureLoad(depth, px, i));
            rel += positions[i];
        }
        rel /= f32(SAMPLES);
        // Equal values may still be two surfaces (parallel faces of one material at different
        // depths, a step): the samples must also lie in the surface's plane, within a thousandth
        // of their distance. A curved or normal-mapped surface that fails this is shaded per
        // sample, which is exact, only slower.
        let n = oct_decode(vec2<f32>(shape.xy) / 65535.0);
        var off_plane = 0.0;
        for (var i = 0u; i < SAMPLES; i++) {
            off_plane = max(off_plane, abs(dot(n, positions[i] - rel)));
        }
        shade_once = off_plane <= 1e-3 * length(rel);
        per_sample = !shade_once;
    }
    var cluster = NO_CLUSTER;
    if shade_once {
        cluster = fragment_cluster(grid, centre, dot(rel, view.camera_forward));
        atomicMin(&group_first, cluster);
        atomicMax(&group_last, cluster);
    }
    workgroupBarrier();
    if t == 0u {
        let first = atomicLoad(&group_first);
        group_cluster = select(NO_CLUSTER, first, first == atomicLoad(&group_last));
    }
    let shared_cluster = workgroupUniformLoad(&group_cluster);

    var total = vec3<f32>(0.0);
    if shared_cluster != NO_CLUSTER {
        let range = cluster_ranges[shared_cluster];
        var s: Surface;
        if shade_once {
            s = decode_surface(roughness, shape, eye_direction(view, rel));
        }
        for (var round = 0u; round < range.y; round += GROUP_PIXELS) {
            if round + t < range.y {
                let slot = cluster_lights[range.x + round + t];
                let reach = lights[slot].range;
                candidate_slot[t] = slot;
                candidate_sphere[t] = vec4<f32>(lights[slot].position - view.camera_position, reach * reach);
            }
            workgroupBarrier();
            if shade_once {
                let count = min(GROUP_PIXELS, range.y - round);
                for (var k = 0u; k < count; k++) {
                    let sphere = candidate_sphere[k];
                    if within_reach(sphere.xyz, sphere.w, rel) {
                        total += shade_light(s, lights[candidate_slot[k]], rel, view.camera_position);
                    }
                }
            }
            workgroupBarrier();
        }
    } else if shade_once {
        total = shade_at(rel, centre, roughness, shape);
    }
    if per_sample {
        total = shade_samples(px, corner, centre);
    }
    if !inside {
        return;
    }
    var out = total * view.exposure;
    // As in forward.wgsl: no NaN, and half of f16's range, so the sum with the forward pass's
    // half stays finite.
    out = select(vec3<f32>(0.0), clamp(out, vec3<f32>(0.0), vec3<f32>(0.5 * F16_MAX)), out == out);
    textureStore(local_light, px, vec4<f32>(out, 0.0));
}
