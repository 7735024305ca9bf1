// Directional-light shadows, read from the cascaded shadow maps the shadow orchestrator renders
// (crates/render/src/features/shadows/): each cascade is one layer of an array atlas of depths,
// reverse-Z (1 nearest the light), holding the depth of the nearest caster over the window of the
// cascade's map that receivers read (features/shadows/window.rs), at the layer's top-left; the
// cascade's matrix maps straight into the layer, and filters step by the layer's texels. The atlas
// is a Depth32Float target where the hardware draws the casters and R32Float where they are
// rasterised in compute (copied in from a buffer: a depth texture can be neither written by
// compute nor copied into); this binding reads either as plain floats. So the comparisons are made
// here: each bilinear comparison gathers the four texels around its point and weighs their
// results, as a comparison sampler would.
//
// A fragment picks its cascade by view depth and blends into the next one over the last
// `blend` of the cascade's depth range, so no seam shows where cascades meet; past the last
// cascade (the maximum shadow distance) shadows fade out the same way. Acne is kept away by two
// biases that scale with the map, never a fixed depth offset: the casters' slope-scaled depth
// bias (raster state), and here a receiver offset along the geometric normal of `normal_bias`
// texels of the cascade, scaled by the sine of the angle to the light (a surface facing the
// light has no depth slope to hide). Filtering: PCF (3×3 bilinear comparisons spanning 4×4
// texels) or PCSS (a blocker search, then a comparison kernel as wide as the penumbra the
// light's angular size casts from the blockers' distance; Fernando 2005).
//
// Local lights (LOCAL_SHADOWS): spot lights read one perspective map, point lights (and wide
// spots) the cube face their direction falls on, from layers of a second atlas (see
// features/shadows/local.rs); reverse-Z with an infinite far plane, filtered by 3×3 bilinear
// comparisons. Their receiver offset scales with the texel's size at the receiver's distance.
// Punctual lights cast hard-edged shadows, so PCSS does not apply to them.
#define_import_path penumbra::shadows

#import penumbra::light_data::Light

struct ShadowCascade {
    // The layer's clip space (x, y in −1..1 across the layer; depth 1 at the light's side) from
    // camera-relative positions, for receivers: their depth is raised by the casters' f32 precision (see orchestrator.rs,
    // DEPTH_PRECISION_ULPS).
    clip_from_rel: mat4x4<f32>,
    // View depth where the cascade ends.
    far: f32,
    // World size of one texel of the cascade's layer.
    texel_size: f32,
    // World distance along the light from depth 1 to depth 0.
    depth_range: f32,
    // 1 when the layer was rendered this frame; 0 when no caster reaches the cascade (lit).
    rendered: u32,
    // The part of the layer holding the stored window (uv from the top-left).
    window: vec2<f32>,
    _pad: vec2<u32>,
};

struct DirectionalShadow {
    // The light's slot in `lights`.
    light_slot: u32,
    first_cascade: u32,
    // Tangent of the light's angular radius (PCSS).
    angular_tan: f32,
    _pad: u32,
};

const MAX_SHADOW_CASCADES: u32 = 16u;
const MAX_SHADOWED_DIRECTIONAL: u32 = 4u;
const FILTER_PCF: u32 = 0u;
const FILTER_PCSS: u32 = 1u;

struct Shadows {
    cascades: array<ShadowCascade, MAX_SHADOW_CASCADES>,
    lights: array<DirectionalShadow, MAX_SHADOWED_DIRECTIONAL>,
    light_count: u32,
    cascade_count: u32,
    normal_bias: f32,
    blend: f32,
    filter_mode: u32,
    // PCSS: the widest kernel, in texels.
    max_kernel: f32,
    // Added to a receiver's depth before comparing: 0, or a few steps where the backend rounds
    // depth coarsely (GL; `Capabilities::exact_depth`).
    depth_tolerance: f32,
    _pad: u32,
};

struct LocalShadow {
    // Light clip space (reverse-Z, infinite far) from camera-relative positions.
    clip_from_rel: mat4x4<f32>,
    // World size of a texel per metre from the light.
    texel_scale: f32,
    // 1 once rendered for the light as it is (0: not yet, read as lit).
    valid: u32,
    // 1: a spot light's map; 6: cube faces +X, −X, +Y, −Y, +Z, −Z from this layer on.
    faces: u32,
    _pad: u32,
};

@group(0) @binding(11) var<uniform> shadows: Shadows;
@group(0) @binding(12) var shadow_atlas: texture_2d_array<f32>;
// The local atlas's comparisons.
@group(0) @binding(13) var shadow_sampler: sampler_comparison;
@group(0) @binding(14) var<storage, read> local_shadows: array<LocalShadow>;
@group(0) @binding(15) var local_atlas: texture_depth_2d_array;
// Nearest, clamped to the edge: the directional atlas's gathers.
@group(0) @binding(16) var shadow_gather: sampler;

// Taps of a Vogel (golden-angle spiral) disk of unit radius, turned by `angle`.
fn vogel_tap(i: u32, count: u32, angle: f32) -> vec2<f32> {
    let r = sqrt((f32(i) + 0.5) / f32(count));
    let theta = f32(i) * 2.399963 + angle;
    return r * vec2<f32>(cos(theta), sin(theta));
}

// 1 where a receiver at `depth` is lit by the texel (at least as near the light as its caster).
fn lit(depth: f32, texels: vec4<f32>) -> vec4<f32> {
    return select(vec4<f32>(0.0), vec4<f32>(1.0), vec4<f32>(depth) >= texels);
}

// Comparisons of `depth` with the 2×2 texels whose shared corner is `corner` (texel units):
// x (left, lower), y (right, lower), z (right, upper), w (left, upper), as textureGather orders
// them ("upper" is the smaller row).
fn lit_quad(layer: u32, corner: vec2<f32>, size: vec2<f32>, depth: f32) -> vec4<f32> {
    return lit(depth, textureGather(0, shadow_atlas, shadow_gather, corner / size, layer));
}

// The bilinear comparison at `uv`: the four texels around it compared, their results weighed by
// the point's place between their centres.
fn compare_bilinear(layer: u32, uv: vec2<f32>, size: vec2<f32>, depth: f32) -> f32 {
    let t = uv * size - 0.5;
    let base = floor(t);
    let f = t - base;
    let q = lit_quad(layer, base + 1.0, size, depth);
    return mix(mix(q.w, q.z, f.x), mix(q.x, q.y, f.x), f.y);
}

// Fraction of the layer's texels around `uv` nearer the light than `depth`, sampled over a disk
// of `radius` texels (at least the 4×4 texels of 3×3 bilinear comparisons).
fn pcf(layer: u32, uv: vec2<f32>, depth: f32, radius: f32, angle: f32) -> f32 {
    let size = vec2<f32>(textureDimensions(shadow_atlas));
    if radius <= 1.5 {
        // The 3×3 bilinear comparisons one texel apart, from four gathers: over the 4×4 texels
        // they span, they weigh the columns (1 − f.x, 1, 1, f.x) and the rows likewise.
        let t = uv * size - 0.5;
        let base = floor(t);
        let f = t - base;
        let near = vec2<f32>(1.0) - f;
        let upper_left = lit_quad(layer, base, size, depth);
        let upper_right = lit_quad(layer, base + vec2<f32>(2.0, 0.0), size, depth);
        let lower_left = lit_quad(layer, base + vec2<f32>(0.0, 2.0), size, depth);
        let lower_right = lit_quad(layer, base + 2.0, size, depth);
        // Per quad: (left, right) column weights a, b and (upper, lower) row weights r, s give
        // (a·s, b·s, b·r, a·r) in gather order.
        let sum = dot(upper_left, vec4<f32>(near.x, 1.0, near.y, near.x * near.y))
            + dot(upper_right, vec4<f32>(1.0, f.x, f.x * near.y, near.y))
            + dot(lower_left, vec4<f32>(near.x * f.y, f.y, 1.0, near.x))
            + dot(lower_right, vec4<f32>(f.y, f.x * f.y, f.x, 1.0));
        return sum / 9.0;
    }
    var sum = 0.0;
    let taps = 16u;
    for (var i = 0u; i < taps; i++) {
        let at = uv + vogel_tap(i, taps, angle) * (radius / size);
        sum += compare_bilinear(layer, at, size, depth);
    }
    return sum / f32(taps);
}

// PCSS kernel radius in texels: blockers (texels nearer the light than the receiver) within the
// widest penumbra the light could cast are averaged; the penumbra spans 2·tan(radius)·distance
// from them. No blocker: 0 (lit, nothing to filter).
fn pcss_radius(layer: u32, uv: vec2<f32>, depth: f32, cascade: ShadowCascade, angular_tan: f32, angle: f32) -> f32 {
    let size = vec2<f32>(textureDimensions(shadow_atlas));
    let search = shadows.max_kernel;
    var blockers = 0.0;
    var blocker_depth = 0.0;
    let taps = 16u;
    for (var i = 0u; i < taps; i++) {
        let at = uv + vogel_tap(i, taps, angle) * search / size;
        let texel = vec2<i32>(clamp(at * size, vec2<f32>(0.0), size - 1.0));
        let d = textureLoad(shadow_atlas, texel, layer, 0).x;
        if d > depth {
            blockers += 1.0;
            blocker_depth += d;
        }
    }
    if blockers == 0.0 {
        return 0.0;
    }
    let distance = (blocker_depth / blockers - depth) * cascade.depth_range;
    // Half the penumbra's width, in texels.
    return clamp(distance * angular_tan / cascade.texel_size, 1.0, search);
}

// How much of the light reaches a receiver through cascade `c` (1 lit, 0 shadowed).
fn cascade_visibility(c: u32, rel: vec3<f32>, normal: vec3<f32>, n_dot_l: f32, angular_tan: f32, angle: f32) -> f32 {
    let cascade = shadows.cascades[c];
    if cascade.rendered == 0u {
        return 1.0;
    }
    let sin_l = sqrt(max(1.0 - n_dot_l * n_dot_l, 0.0));
    let offset = normal * (cascade.texel_size * shadows.normal_bias * sin_l);
    let clip = cascade.clip_from_rel * vec4<f32>(rel + offset, 1.0);
    // Above the map's top: casters clamped there never shadow what lies above them.
    if clip.z > 1.0 {
        return 1.0;
    }
    // The layer stores the window of the cascade's map that receivers read, widened by more than
    // the filters reach, so a receiver's own lookups stay inside it. Only a position
    // extrapolated past a surface's edge (a pixel's centre outside the triangle its MSAA samples
    // cover) can land outside: it reads the window's nearest texels, not texels never drawn.
    let texel = 1.0 / vec2<f32>(textureDimensions(shadow_atlas));
    let uv = clamp(clip.xy * vec2<f32>(0.5, -0.5) + 0.5, 2.0 * texel, max(cascade.window - 2.0 * texel, 2.0 * texel));
    let depth = clip.z + shadows.depth_tolerance;
    var radius = 1.0;
    if shadows.filter_mode == FILTER_PCSS {
        radius = pcss_radius(c, uv, depth, cascade, angular_tan, angle);
        if radius == 0.0 {
            return 1.0;
        }
    }
    return pcf(c, uv, depth, radius, angle);
}

// Visibility of directional light `slot` at `rel` (camera-relative) with geometric normal
// `normal`, `view_depth` along the camera's view direction. Lights without a shadow map: 1.
// `frag_xy` turns the PCSS sampling disk from pixel to pixel (interleaved gradient noise), which
// trades banding for fine, stable noise.
fn directional_shadow(slot: u32, rel: vec3<f32>, normal: vec3<f32>, n_dot_l: f32, view_depth: f32, frag_xy: vec2<f32>) -> f32 {
    var entry = shadows.light_count;
    for (var i = 0u; i < shadows.light_count; i++) {
        if shadows.lights[i].light_slot == slot {
            entry = i;
        }
    }
    if entry == shadows.light_count {
        return 1.0;
    }
    let light = shadows.lights[entry];
    let count = shadows.cascade_count;
    var c = 0u;
    while c < count && view_depth >= shadows.cascades[light.first_cascade + c].far {
        c++;
    }
    if c == count {
        return 1.0;
    }
    let angle = 6.2831853 * fract(52.982919 * fract(dot(frag_xy, vec2<f32>(0.06711056, 0.00583715))));
    let first = light.first_cascade;
    var visibility = cascade_visibility(first + c, rel, normal, n_dot_l, light.angular_tan, angle);
    let near = select(0.0, shadows.cascades[first + c - 1u].far, c > 0u);
    let far = shadows.cascades[first + c].far;
    let t = (far - view_depth) / max((far - near) * shadows.blend, 1e-30);
    if t < 1.0 {
        var next = 1.0;
        if c + 1u < count {
            next = cascade_visibility(first + c + 1u, rel, normal, n_dot_l, light.angular_tan, angle);
        }
        visibility = mix(next, visibility, t);
    }
    return visibility;
}

// Visibility of local light `light` (point or spot with a map) at `rel`, with surface normal
// `normal` and `to_light` from the surface to the light.
fn local_shadow(light: Light, rel: vec3<f32>, normal: vec3<f32>, to_light: vec3<f32>) -> f32 {
    var layer = u32(light.shape.w) - 1u;
    if local_shadows[layer].faces == 6u {
        let d = -to_light;
        let a = abs(d);
        var face = 4u + select(1u, 0u, d.z > 0.0);
        if a.x >= a.y && a.x >= a.z {
            face = select(1u, 0u, d.x > 0.0);
        } else if a.y >= a.z {
            face = 2u + select(1u, 0u, d.y > 0.0);
        }
        layer += face;
    }
    let info = local_shadows[layer];
    if info.valid == 0u {
        return 1.0;
    }
    let dist = length(to_light);
    let n_dot_l = dot(normal, to_light) / max(dist, 1e-30);
    let sin_l = sqrt(max(1.0 - n_dot_l * n_dot_l, 0.0));
    let offset = normal * (dist * info.texel_scale * shadows.normal_bias * sin_l);
    let clip = info.clip_from_rel * vec4<f32>(rel + offset, 1.0);
    if clip.w <= 0.0 {
        return 1.0;
    }
    let ndc = clip.xyz / clip.w;
    let uv = ndc.xy * vec2<f32>(0.5, -0.5) + 0.5;
    if any(uv < vec2<f32>(0.0)) || any(uv > vec2<f32>(1.0)) {
        return 1.0;
    }
    let texel = 1.0 / vec2<f32>(textureDimensions(local_atlas));
    let depth = ndc.z + shadows.depth_tolerance;
    var sum = 0.0;
    for (var y = -1; y <= 1; y++) {
        for (var x = -1; x <= 1; x++) {
            let at = uv + vec2<f32>(f32(x), f32(y)) * texel;
            sum += textureSampleCompareLevel(local_atlas, shadow_sampler, at, layer, depth);
        }
    }
    return sum / 9.0;
}

// Debug view: a colour for the cascade of the first shadowed directional light holding view
// depth `view_depth` (red, green, blue, yellow from near to far); grey beyond the last, or when
// no directional light casts this frame.
fn cascade_tint(view_depth: f32) -> vec3<f32> {
    let tints = array<vec3<f32>, 4>(
        vec3<f32>(1.0, 0.2, 0.2),
        vec3<f32>(0.2, 1.0, 0.2),
        vec3<f32>(0.25, 0.4, 1.0),
        vec3<f32>(1.0, 0.9, 0.15)
    );
    if shadows.light_count == 0u {
        return vec3<f32>(0.5);
    }
    let first = shadows.lights[0].first_cascade;
    for (var c = 0u; c < shadows.cascade_count; c++) {
        if view_depth < shadows.cascades[first + c].far {
            return tints[c];
        }
    }
    return vec3<f32>(0.5);
}
