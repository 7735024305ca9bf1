// Mip generation: each texel of level N+1 is the average of the 2×2 block of level N it covers
// (clamped at an odd edge), in linear light for sRGB textures. With SRGB, texels are loaded and
// stored through unorm views and the sRGB curve is applied here, not by the texture unit and the
// render target: drivers round those conversions differently (NVIDIA's and lavapipe's a step
// apart here and there), and down a chain the steps compound into frames that differ between
// GPUs. Without unorm views (GL) sRGB textures are read and written through sRGB views and the
// driver converts.

#import penumbra::common::fullscreen_position
#import penumbra::display::srgb_encode

@group(0) @binding(0) var source: texture_2d<f32>;
// The sRGB curve's inverse at the 256 stored values, four to an entry (computed exactly on the
// CPU: a table costs a load where pow costs a software rasteriser dearly).
@group(0) @binding(1) var<uniform> srgb_to_linear: array<vec4<f32>, 64>;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    return fullscreen_position(i);
}

fn decode(stored: f32) -> f32 {
    let i = u32(stored * 255.0 + 0.5);
    return srgb_to_linear[i >> 2u][i & 3u];
}

fn srgb_decode(c: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(decode(c.r), decode(c.g), decode(c.b));
}

fn texel(at: vec2<i32>, last: vec2<i32>) -> vec4<f32> {
    let t = textureLoad(source, min(at, last), 0);
#ifdef SRGB
    return vec4<f32>(srgb_decode(t.rgb), t.a);
#else
    return t;
#endif
}

@fragment
fn fs_main(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let last = vec2<i32>(textureDimensions(source)) - 1;
    let at = 2 * vec2<i32>(position.xy);
    let sum = texel(at, last) + texel(at + vec2<i32>(1, 0), last) + texel(at + vec2<i32>(0, 1), last)
        + texel(at + vec2<i32>(1, 1), last);
    let mean = 0.25 * sum;
#ifdef SRGB
    return vec4<f32>(srgb_encode(mean.rgb), mean.a);
#else
    return mean;
#endif
}
