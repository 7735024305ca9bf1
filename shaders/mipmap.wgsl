// Mip generation: each texel of level N+1 is a bilinear tap at the centre of the 2×2 block of
// level N it covers, which is exactly the 2×2 box average for even sizes. For sRGB textures the
// views are sRGB, so the hardware decodes before filtering and encodes after: averaging happens
// in linear light.

#import penumbra::common::fullscreen_position

@group(0) @binding(0) var source: texture_2d<f32>;
@group(0) @binding(1) var linear_clamp: sampler;

struct VertexOut {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> VertexOut {
    var out: VertexOut;
    out.position = fullscreen_position(i);
    // Clip-space y is up, texture v is down.
    out.uv = vec2<f32>(0.5 * out.position.x + 0.5, 0.5 - 0.5 * out.position.y);
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    return textureSampleLevel(source, linear_clamp, in.uv, 0.0);
}
