// MSAA resolve as a pass of Penumbra's own (`Capabilities::shader_msaa_resolve`): each pixel the
// mean of its samples, what the render pass's resolve computes. Used where the driver's resolve
// costs more than the pass: lavapipe resolves through a blit shader that Mesa builds anew in
// every process, outside its shader cache. Reading an sRGB target decodes each sample, and the
// sRGB output encodes the mean: the average is in linear light, as the driver's.

#import penumbra::common::fullscreen_position

@group(0) @binding(0) var samples: texture_multisampled_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    return fullscreen_position(i);
}

@fragment
fn fs_main(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let at = vec2<i32>(position.xy);
    let n = textureNumSamples(samples);
    var sum = vec4<f32>(0.0);
    for (var s = 0u; s < n; s++) {
        sum += textureLoad(samples, at, i32(s));
    }
    return sum / f32(n);
}
