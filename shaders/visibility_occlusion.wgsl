// What the forward pass's draws in a hybrid frame test their samples against (see
// crates/render/src/features/visibility/overlay.rs): the visibility buffer, which holds each
// sample's nearest opaque depth, in place of a depth target that no opaque draw filled. A
// fragment keeps the samples where it is nearer than what the buffer holds there, as the
// depth test would have kept them, and writes that as its sample mask.
#define_import_path penumbra::visibility_occlusion

#import penumbra::common::STANDARD_SAMPLES_4

// The prefix of visibility_raster.wgsl's RasterParams this reads.
struct OcclusionParams {
    target_size: vec2<u32>,
    samples: u32,
};

@group(2) @binding(0) var<storage, read> occluders: array<vec2<u32>>;
@group(2) @binding(1) var<uniform> occlusion: OcclusionParams;

// The samples of the fragment at `position` (its `@builtin(position)`: the pixel's centre and
// the depth there) nearer than the visibility buffer's, `dz` being the depth's screen-space
// derivatives: the depth is planar in screen space, so extrapolating it to each sample gives what
// the rasteriser interpolates there. `or_equal` keeps samples at equal depth too (the gizmos'
// GreaterEqual test; reverse-Z: nearer is greater). An empty sample holds 0, the far plane.
fn unoccluded_samples(position: vec4<f32>, dz: vec2<f32>, or_equal: bool) -> u32 {
    let pixel = vec2<u32>(position.xy);
    let size = occlusion.target_size;
    if pixel.x >= size.x || pixel.y >= size.y {
        return 0u;
    }
    let n = occlusion.samples;
    var mask = 0u;
    for (var k = 0u; k < n; k++) {
        var o = vec2<f32>(0.0);
        if n == 4u {
            o = STANDARD_SAMPLES_4[k] - vec2<f32>(0.5);
        }
        let z = position.z + dot(dz, o);
        let held = bitcast<f32>(occluders[(pixel.y * size.x + pixel.x) * n + k].y);
        if z > held || (or_equal && z == held) {
            mask |= 1u << k;
        }
    }
    return mask;
}
