// Bloom: a physically based, energy-preserving blur chain (Jimenez 2014, "Next Generation Post
// Processing in Call of Duty: Advanced Warfare"). `downsample` makes each level of a half-size
// mip chain from the level above with a 13-tap filter (five overlapping 2 × 2 boxes); the first
// level (FIRST) weighs each box by 1 / (1 + luma), Karis's average, so one very bright pixel does
// not flicker as it moves. `upsample` adds each level, tent-filtered, onto the level above
// (additive blending), so level 0 ends as the sum of every level's blur; the tonemap pass divides
// by the level count and mixes it with the image by the bloom strength, which keeps the total
// light unchanged.

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
    out.uv = vec2<f32>(0.5 * out.position.x + 0.5, 0.5 - 0.5 * out.position.y);
    return out;
}

fn tap(uv: vec2<f32>, texel: vec2<f32>, x: f32, y: f32) -> vec3<f32> {
    return textureSampleLevel(source, linear_clamp, uv + texel * vec2<f32>(x, y), 0.0).rgb;
}

fn box_weight(c: vec3<f32>) -> f32 {
#ifdef FIRST
    return 1.0 / (1.0 + dot(c, vec3<f32>(0.2126, 0.7152, 0.0722)));
#else
    return 1.0;
#endif
}

@fragment
fn downsample(in: VertexOut) -> @location(0) vec4<f32> {
    let texel = 1.0 / vec2<f32>(textureDimensions(source, 0));
    let a = tap(in.uv, texel, -2.0, -2.0);
    let b = tap(in.uv, texel, 0.0, -2.0);
    let c = tap(in.uv, texel, 2.0, -2.0);
    let d = tap(in.uv, texel, -2.0, 0.0);
    let e = tap(in.uv, texel, 0.0, 0.0);
    let f = tap(in.uv, texel, 2.0, 0.0);
    let g = tap(in.uv, texel, -2.0, 2.0);
    let h = tap(in.uv, texel, 0.0, 2.0);
    let i = tap(in.uv, texel, 2.0, 2.0);
    let j = tap(in.uv, texel, -1.0, -1.0);
    let k = tap(in.uv, texel, 1.0, -1.0);
    let l = tap(in.uv, texel, -1.0, 1.0);
    let m = tap(in.uv, texel, 1.0, 1.0);
    // The centre box weighs 1/2, the four corner boxes 1/8 each.
    let boxes = array<vec3<f32>, 5>(
        (j + k + l + m) * 0.25,
        (a + b + d + e) * 0.25,
        (b + c + e + f) * 0.25,
        (d + e + g + h) * 0.25,
        (e + f + h + i) * 0.25
    );
    let share = array<f32, 5>(0.5, 0.125, 0.125, 0.125, 0.125);
    var sum = vec3<f32>(0.0);
    var weight = 0.0;
    for (var n = 0u; n < 5u; n++) {
        let w = share[n] * box_weight(boxes[n]);
        sum += boxes[n] * w;
        weight += w;
    }
    let out = sum / weight;
    // NaN never enters the chain (it would spread over the whole level).
    return vec4<f32>(select(vec3<f32>(0.0), max(out, vec3<f32>(0.0)), out == out), 1.0);
}

@fragment
fn upsample(in: VertexOut) -> @location(0) vec4<f32> {
    let texel = 1.0 / vec2<f32>(textureDimensions(source, 0));
    let sum = tap(in.uv, texel, 0.0, 0.0) * 4.0
        + (tap(in.uv, texel, 0.0, -1.0) + tap(in.uv, texel, -1.0, 0.0) + tap(in.uv, texel, 1.0, 0.0) + tap(in.uv, texel, 0.0, 1.0)) * 2.0
        + tap(in.uv, texel, -1.0, -1.0) + tap(in.uv, texel, 1.0, -1.0) + tap(in.uv, texel, -1.0, 1.0) + tap(in.uv, texel, 1.0, 1.0);
    return vec4<f32>(sum / 16.0, 1.0);
}
