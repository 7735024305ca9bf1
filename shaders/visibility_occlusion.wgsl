// What the forward pass's draws in a hybrid frame test their samples against (see
// crates/render/src/features/visibility/overlay.rs): the visibility buffer, which holds each
// sample's nearest opaque depth, in place of a depth target that no opaque draw filled. A
// fragment keeps the samples where it is nearer than what the buffer holds there, as the
// depth test would have kept them, and writes that as its sample mask. The entry shaders bind
// the buffer (`occluders`, an array of vec2<u32>: number, depth bits) and its parameters, in the
// group their pipeline layouts give it.
#define_import_path penumbra::visibility_occlusion

#import penumbra::common::STANDARD_SAMPLES_4

// The visibility buffer's size and samples, and the overlay's rectangle: its target's pixel
// (0, 0) is the frame's pixel `origin` (mirrors `GpuOcclusionParams` in overlay.rs).
struct OcclusionParams {
    target_size: vec2<u32>,
    samples: u32,
    _pad: u32,
    origin: vec2<u32>,
    _pad_b: vec2<u32>,
    // Clip positions cropped to the rectangle: xy · crop_scale + crop_offset · w.
    crop_scale: vec2<f32>,
    crop_offset: vec2<f32>,
};

// A draw's clip position cropped to the overlay's target: the same pixel scale, shifted.
fn overlay_clip(clip: vec4<f32>, params: OcclusionParams) -> vec4<f32> {
    return vec4<f32>(clip.xy * params.crop_scale + params.crop_offset * clip.w, clip.zw);
}

// Where the samples of the overlay pixel at `position` (a fragment's `@builtin(position)`)
// start in the buffer, or none outside the frame.
fn first_sample(position: vec4<f32>, params: OcclusionParams) -> u32 {
    let pixel = vec2<u32>(position.xy) + params.origin;
    if pixel.x >= params.target_size.x || pixel.y >= params.target_size.y {
        return 0xffffffffu;
    }
    return (pixel.y * params.target_size.x + pixel.x) * params.samples;
}

// The samples of the fragment at `position` (the pixel's centre and the depth there) nearer than
// `held` (the buffer's depth at each of its `n` samples; 0, the far plane, where none is), `dz`
// being the depth's screen-space derivatives: depth is planar in screen space, so extrapolating
// it to each of the 4 standard sample positions gives what the rasteriser interpolates there.
// `or_equal` keeps samples at equal depth too (the gizmos' GreaterEqual test; reverse-Z: nearer
// is greater).
fn unoccluded_mask(position: vec4<f32>, dz: vec2<f32>, or_equal: bool, held: vec4<f32>, n: u32) -> u32 {
    var mask = 0u;
    for (var k = 0u; k < min(n, 4u); k++) {
        var z = position.z;
        if n == 4u {
            z += dot(dz, STANDARD_SAMPLES_4[k] - vec2<f32>(0.5));
        }
        if z > held[k] || (or_equal && z == held[k]) {
            mask |= 1u << k;
        }
    }
    return mask;
}
