// The opaque colour's copy that transmissive surfaces see through (features/transmission):
// level 0 is the resolved HDR colour after the opaque draws and the background, each further
// level the 2×2 mean of the one above (DOWNSAMPLE: one bilinear read at the block's centre).
// forward.wgsl's MATERIAL_TRANSMISSION reads it along the refracted ray, at a level chosen
// from the surface's roughness.

#import penumbra::common::fullscreen_position

@group(0) @binding(0) var source: texture_2d<f32>;
#ifdef DOWNSAMPLE
@group(0) @binding(1) var source_sampler: sampler;
#endif

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    return fullscreen_position(i);
}

@fragment
fn fs_main(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
#ifdef DOWNSAMPLE
    let uv = 2.0 * position.xy / vec2<f32>(textureDimensions(source));
    return vec4<f32>(textureSampleLevel(source, source_sampler, uv, 0.0).rgb, 1.0);
#else
    return vec4<f32>(textureLoad(source, vec2<i32>(position.xy), 0).rgb, 1.0);
#endif
}
