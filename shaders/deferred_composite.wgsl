// Adds the deferred local lights (deferred_lights.wgsl) into the HDR frame: one full-screen
// triangle, blended additively into every sample, before blended draws are drawn over it.

#import penumbra::common::fullscreen_position

@group(0) @binding(0) var local_light: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    return fullscreen_position(i);
}

@fragment
fn fs_main(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(textureLoad(local_light, vec2<i32>(position.xy), 0).rgb, 0.0);
}
