// Output: linear HDR scene colour (already exposed) -> tonemapped display colour (the curves and
// the sRGB encode live in display.wgsl).

// Variants: display.wgsl's (TONEMAP_NEUTRAL, TONEMAP_ACES, ENCODE_SRGB); BLOOM mixes in the
// bloom chain (bloom.wgsl) by its strength, AUTO_EXPOSURE applies automatic exposure's
// correction (exposure.wgsl), both before the curve.

#import penumbra::common::fullscreen_position
#import penumbra::post_params::PostParams
#import penumbra::display::display_rgb

@group(0) @binding(0) var hdr: texture_2d<f32>;
@group(0) @binding(1) var bloom: texture_2d<f32>;
@group(0) @binding(2) var linear_clamp: sampler;
@group(0) @binding(3) var<storage, read> post: PostParams;

struct VertexOut {
    @builtin(position) position: vec4<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> VertexOut {
    var out: VertexOut;
    out.position = fullscreen_position(i);
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    var c = max(textureLoad(hdr, vec2<i32>(in.position.xy), 0).rgb, vec3<f32>(0.0));
#ifdef BLOOM
    // Level 0 is half the frame's size: sampled at the pixel's centre, bilinearly.
    let uv = in.position.xy / vec2<f32>(textureDimensions(hdr));
    let blurred = textureSampleLevel(bloom, linear_clamp, uv, 0.0).rgb * post.bloom_norm;
    c = mix(c, blurred, post.bloom_strength);
#endif
#ifdef AUTO_EXPOSURE
    c *= post.exposure_scale;
#endif
    return vec4<f32>(display_rgb(c), 1.0);
}
