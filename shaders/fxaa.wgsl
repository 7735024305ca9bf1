// FXAA (after Lottes 2011, "FXAA 3.11", the PC quality path): anti-aliasing of the tonemapped,
// display-encoded image, a cheap alternative to MSAA. Per pixel: local contrast in luma (below
// a threshold nothing changes); the edge's orientation from the 3 × 3 neighbourhood; a search
// along the edge in both directions for its ends; the pixel moved across the edge by how near
// it lies to the nearer end, or by the sub-pixel blend where that is larger.
//
// Variants: DECODE_SRGB when the output format is sRGB (the hardware encodes again on store).

#import penumbra::common::fullscreen_position

@group(0) @binding(0) var ldr: texture_2d<f32>;
@group(0) @binding(1) var linear_clamp: sampler;

struct VertexOut {
    @builtin(position) position: vec4<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> VertexOut {
    var out: VertexOut;
    out.position = fullscreen_position(i);
    return out;
}

const EDGE_THRESHOLD: f32 = 0.125;
const EDGE_THRESHOLD_MIN: f32 = 0.0312;
const SUBPIXEL: f32 = 0.75;
const SEARCH_STEPS: u32 = 10u;

fn luma(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.299, 0.587, 0.114));
}

fn luma_at(uv: vec2<f32>) -> f32 {
    return luma(textureSampleLevel(ldr, linear_clamp, uv, 0.0).rgb);
}

fn luma_off(p: vec2<i32>, dx: i32, dy: i32) -> f32 {
    let size = vec2<i32>(textureDimensions(ldr));
    return luma(textureLoad(ldr, clamp(p + vec2<i32>(dx, dy), vec2<i32>(0), size - 1), 0).rgb);
}

fn srgb_decode(c: vec3<f32>) -> vec3<f32> {
    let lo = c / 12.92;
    let hi = pow((c + 0.055) / 1.055, vec3<f32>(2.4));
    return select(hi, lo, c <= vec3<f32>(0.04045));
}

fn fxaa(p: vec2<i32>) -> vec3<f32> {
    let size = vec2<f32>(textureDimensions(ldr));
    let texel = 1.0 / size;
    let uv = (vec2<f32>(p) + 0.5) * texel;
    let center = textureLoad(ldr, p, 0).rgb;
    let m = luma(center);
    let n = luma_off(p, 0, -1);
    let s = luma_off(p, 0, 1);
    let e = luma_off(p, 1, 0);
    let w = luma_off(p, -1, 0);
    let hi = max(max(max(n, s), max(e, w)), m);
    let lo = min(min(min(n, s), min(e, w)), m);
    let range = hi - lo;
    if range < max(EDGE_THRESHOLD_MIN, hi * EDGE_THRESHOLD) {
        return center;
    }
    let nw = luma_off(p, -1, -1);
    let ne = luma_off(p, 1, -1);
    let sw = luma_off(p, -1, 1);
    let se = luma_off(p, 1, 1);

    // Sub-pixel aliasing: how far the centre stands out from its neighbourhood's average.
    let average = (2.0 * (n + s + e + w) + (nw + ne + sw + se)) / 12.0;
    let sub = clamp(abs(average - m) / range, 0.0, 1.0);
    let sub_blend = smoothstep(0.0, 1.0, sub) * smoothstep(0.0, 1.0, sub) * SUBPIXEL;

    // A horizontal edge changes along y.
    let horizontal = abs(nw + sw - 2.0 * w) + 2.0 * abs(n + s - 2.0 * m) + abs(ne + se - 2.0 * e)
        >= abs(nw + ne - 2.0 * n) + 2.0 * abs(w + e - 2.0 * m) + abs(sw + se - 2.0 * s);
    let l_neg = select(w, n, horizontal);
    let l_pos = select(e, s, horizontal);
    let grad_neg = abs(l_neg - m);
    let grad_pos = abs(l_pos - m);
    var step_len = select(texel.x, texel.y, horizontal);
    var edge_luma: f32;
    var gradient: f32;
    if grad_neg >= grad_pos {
        step_len = -step_len;
        edge_luma = 0.5 * (l_neg + m);
        gradient = grad_neg;
    } else {
        edge_luma = 0.5 * (l_pos + m);
        gradient = grad_pos;
    }
    // Walk along the edge, half a pixel across it.
    var edge_uv = uv;
    let along = select(vec2<f32>(0.0, texel.y), vec2<f32>(texel.x, 0.0), horizontal);
    if horizontal {
        edge_uv.y += 0.5 * step_len;
    } else {
        edge_uv.x += 0.5 * step_len;
    }
    let threshold = 0.25 * gradient;
    var uv_neg = edge_uv - along;
    var uv_pos = edge_uv + along;
    var d_neg = luma_at(uv_neg) - edge_luma;
    var d_pos = luma_at(uv_pos) - edge_luma;
    var done_neg = abs(d_neg) >= threshold;
    var done_pos = abs(d_pos) >= threshold;
    let steps = array<f32, 10>(1.0, 1.0, 1.0, 1.0, 1.5, 2.0, 2.0, 2.0, 4.0, 8.0);
    for (var i = 1u; i < SEARCH_STEPS && !(done_neg && done_pos); i++) {
        if !done_neg {
            uv_neg -= along * steps[i];
            d_neg = luma_at(uv_neg) - edge_luma;
            done_neg = abs(d_neg) >= threshold;
        }
        if !done_pos {
            uv_pos += along * steps[i];
            d_pos = luma_at(uv_pos) - edge_luma;
            done_pos = abs(d_pos) >= threshold;
        }
    }
    let dist_neg = select(uv.y - uv_neg.y, uv.x - uv_neg.x, horizontal);
    let dist_pos = select(uv_pos.y - uv.y, uv_pos.x - uv.x, horizontal);
    let nearer_neg = dist_neg < dist_pos;
    let dist = min(dist_neg, dist_pos);
    let span = dist_neg + dist_pos;
    // Move only if the centre lies on the side whose end it is nearer to.
    let centre_below = m - edge_luma < 0.0;
    let end_below = select(d_pos, d_neg, nearer_neg) < 0.0;
    let edge_blend = select(0.0, 0.5 - dist / span, centre_below != end_below);
    let blend = max(edge_blend, sub_blend);
    var final_uv = uv;
    if horizontal {
        final_uv.y += blend * step_len;
    } else {
        final_uv.x += blend * step_len;
    }
    return textureSampleLevel(ldr, linear_clamp, final_uv, 0.0).rgb;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    var c = fxaa(vec2<i32>(in.position.xy));
#ifdef DECODE_SRGB
    c = srgb_decode(c);
#endif
    return vec4<f32>(c, 1.0);
}
