// Rect and disk lights by linearly transformed cosines (Heitz, Dupuy, Hill and Neubelt,
// "Real-Time Polygonal-Light Shading with Linearly Transformed Cosines", SIGGRAPH 2016).
//
// The GGX lobe times N·L, for a given roughness and view angle, is approximated by a clamped
// cosine distribution transformed by a 3×3 matrix M. Integrating it over a polygon is then
// integrating a cosine over the polygon transformed by M⁻¹, which has a closed form: the sum
// over its edges of θ·(n · unit normal of the edge's plane), after clipping to the upper
// hemisphere. Diffuse light is the same integral with M = I (exact up to the Lambertian BRDF).
//
// The fitted M⁻¹ (4 entries per cell) and the lobe's magnitude and Fresnel terms (2 per cell)
// come from the authors' published fit (github.com/selfshadow/ltc_code, fit/results), as
// distributed with three.js r111; see assets/ltc/README.md. 64 × 64 cells over
// (perceptual roughness, √(1 − N·V)), bilinearly interpolated here.
//
// Disks are integrated as the regular 16-gon of the same area (the polygon's error against the
// exact disk on the axis is in the tests, well under 1%).
#define_import_path penumbra::ltc

#import penumbra::common::{PI, safe_normalize}
#import penumbra::brdf::{Surface, coat_base, diffuse_share, multiscatter_scale, surface_f90}
#ifdef MATERIAL_CLEARCOAT
#import penumbra::brdf::DIELECTRIC_F0
#endif
#import penumbra::light_data::{Light, LIGHT_DISK, range_window}

const LTC_SIZE: u32 = 64u;
const DISK_SIDES: u32 = 16u;

struct LtcTable {
    // (m00, m02, m20, m22) of M⁻¹, normalised so that m11 = 1.
    inverse_m: array<vec4<f32>, 4096>,
    // (magnitude, Fresnel weight) of the GGX lobe.
    magnitude: array<vec2<f32>, 4096>,
};

@group(0) @binding(6) var<storage, read> ltc_table: LtcTable;

struct LtcCell {
    inverse_m: vec4<f32>,
    magnitude: vec2<f32>,
};

// Bilinear lookup; `uv` in [0, 1]² spans the table's cell centres.
fn ltc_lookup(uv: vec2<f32>) -> LtcCell {
    let p = clamp(uv, vec2<f32>(0.0), vec2<f32>(1.0)) * f32(LTC_SIZE - 1u);
    let lo = min(vec2<u32>(floor(p)), vec2<u32>(LTC_SIZE - 2u));
    let f = p - vec2<f32>(lo);
    let i = lo.y * LTC_SIZE + lo.x;
    let j = i + LTC_SIZE;
    var c: LtcCell;
    c.inverse_m = mix(
        mix(ltc_table.inverse_m[i], ltc_table.inverse_m[i + 1u], f.x),
        mix(ltc_table.inverse_m[j], ltc_table.inverse_m[j + 1u], f.x),
        f.y
    );
    c.magnitude = mix(
        mix(ltc_table.magnitude[i], ltc_table.magnitude[i + 1u], f.x),
        mix(ltc_table.magnitude[j], ltc_table.magnitude[j + 1u], f.x),
        f.y
    );
    return c;
}

// θ · (n · unit normal of the plane through a and b), n = +z: one edge's share of the cosine
// integral. The cross product of a with the edge b − a (rather than of the two unit vectors)
// keeps small or distant lights precise, and atan2 keeps θ accurate for nearly parallel
// vertices, where acos loses it.
fn edge_integral(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let norms = length(a) * length(b);
    let c = cross(a, b - a) / norms;
    let sin_theta = length(c);
    let theta = atan2(sin_theta, dot(a, b) / norms);
    return c.z * select(theta / sin_theta, 1.0, sin_theta < 1e-7);
}

// Cuts the convex polygon `src[0..count]` to the upper hemisphere z ≥ 0 (Sutherland–Hodgman
// against one plane through the origin) into `dst`; returns its vertex count (≤ count + 1).
fn clip_to_horizon(src: ptr<function, array<vec3<f32>, 17>>, count: u32, dst: ptr<function, array<vec3<f32>, 17>>) -> u32 {
    var n = 0u;
    var a = (*src)[count - 1u];
    for (var i = 0u; i < count; i++) {
        let b = (*src)[i];
        if (a.z > 0.0) != (b.z > 0.0) {
            var c = a + (b - a) * (a.z / (a.z - b.z));
            c.z = 0.0;
            (*dst)[n] = c;
            n += 1u;
        }
        if b.z > 0.0 {
            (*dst)[n] = b;
            n += 1u;
        }
        a = b;
    }
    return n;
}

// ∫ cos θ dω over the polygon `v[0..count]` (seen from the origin, clipped to z ≥ 0), which is
// π times its form factor. Vertices need not be normalised.
fn clipped_cos_integral(v: ptr<function, array<vec3<f32>, 17>>, count: u32) -> f32 {
    if count < 3u {
        return 0.0;
    }
    var sum = 0.0;
    var exit_point = vec3<f32>(0.0);
    var entry_point = vec3<f32>(0.0);
    var crossings = 0u;
    var a = (*v)[count - 1u];
    for (var i = 0u; i < count; i++) {
        let b = (*v)[i];
        let a_up = a.z > 0.0;
        let b_up = b.z > 0.0;
        if a_up && b_up {
            sum += edge_integral(a, b);
        } else if a_up != b_up {
            var c = a + (b - a) * (a.z / (a.z - b.z));
            c.z = 0.0;
            if a_up {
                sum += edge_integral(a, c);
                exit_point = c;
            } else {
                sum += edge_integral(c, b);
                entry_point = c;
            }
            crossings += 1u;
        }
        a = b;
    }
    // The clipped polygon closes along the horizon from where it left to where it came back.
    if crossings == 2u {
        sum += edge_integral(exit_point, entry_point);
    }
    // Winding depends on which side the polygon is seen from; the caller has already kept only
    // the lit side.
    return 0.5 * abs(sum);
}

// A rectangle's or disk's unit width axis (in its plane) and, for a rectangle, half height:
// a rectangle's shape.xyz is its width axis scaled by its half height (shape.w holds the
// shadow layer, as for every local light), a disk's is the unit axis.
fn plane_axes(light: Light) -> vec4<f32> {
    if light.kind == LIGHT_DISK {
        return vec4<f32>(light.shape.xyz, 0.0);
    }
    let half_height = length(light.shape.xyz);
    return vec4<f32>(light.shape.xyz / max(half_height, 1e-30), half_height);
}

// The light's outline, relative to the surface, as `count` corners.
fn outline(light: Light, to_light: vec3<f32>, v: ptr<function, array<vec3<f32>, 17>>) -> u32 {
    let axes = plane_axes(light);
    let across = axes.xyz;
    let up = cross(light.direction, across);
    if light.kind == LIGHT_DISK {
        // The regular 16-gon of the disk's area: circumradius r·√(2π / (n·sin(2π/n))).
        let r = light.size * 1.0130016;
        for (var i = 0u; i < DISK_SIDES; i++) {
            let angle = f32(i) * (2.0 * PI / f32(DISK_SIDES));
            (*v)[i] = to_light + r * (cos(angle) * across + sin(angle) * up);
        }
        return DISK_SIDES;
    }
    let x = across * light.size;
    let y = up * axes.w;
    (*v)[0] = to_light + x + y;
    (*v)[1] = to_light - x + y;
    (*v)[2] = to_light - x - y;
    (*v)[3] = to_light + x - y;
    return 4u;
}

// Squared distance from the surface to the nearest point of the light (`to_light` points from
// the surface to the light's centre).
fn nearest_dist2(light: Light, to_light: vec3<f32>) -> f32 {
    let q = -to_light;
    let axes = plane_axes(light);
    let across = axes.xyz;
    let up = cross(light.direction, across);
    var in_plane: vec3<f32>;
    if light.kind == LIGHT_DISK {
        let planar = q - light.direction * dot(q, light.direction);
        let len = length(planar);
        in_plane = planar * min(1.0, light.size / max(len, 1e-30));
    } else {
        in_plane = across * clamp(dot(q, across), -light.size, light.size)
            + up * clamp(dot(q, up), -axes.w, axes.w);
    }
    let off = q - in_plane;
    return dot(off, off);
}

fn ltc_light(s: Surface, light: Light, to_light: vec3<f32>) -> vec3<f32> {
    // One-sided: only what lies in front of the emitting face is lit.
    if dot(light.direction, to_light) >= 0.0 {
        return vec3<f32>(0.0);
    }
    let extent = select(length(vec2<f32>(light.size, plane_axes(light).w)), light.size, light.kind == LIGHT_DISK);
    let window = range_window(nearest_dist2(light, to_light), light.range - extent);
    if window <= 0.0 {
        return vec3<f32>(0.0);
    }
    let lobe = ltc_lobe(light, to_light, s.n, s.v, s.n_dot_v, s.perceptual_roughness);
    // lobe: the diffuse (clipped cosine) integral, the specular integral, the fit's magnitude.
    // Multiple scattering as in `brdf::specular_multiscatter`, with the fit's own albedo for
    // F0 = 1 (magnitude.x + magnitude.y) as Ess.
    let f90 = surface_f90(s);
    let ms = multiscatter_scale(s.f0_color, f90, lobe.z + lobe.w);
    let specular = (s.f0_color * lobe.z + (vec3<f32>(f90) - s.f0_color) * lobe.w) * lobe.y * ms;
    // The dielectric's diffuse lobe gets what its specular lobe leaves, as in `direct`.
    let diffuse = diffuse_share(s) * s.diffuse_color / PI * lobe.x;
    var beneath = diffuse + specular;
#ifdef MATERIAL_SHEEN
    // The sheen's lobe is nearly as wide as the hemisphere: its response is taken as that of a
    // diffuse lobe of its directional albedo (the light's clipped-cosine integral, lobe.x), and
    // the material beneath keeps the albedo scaling seen from the eye.
    beneath = beneath * s.sheen_scale_v + s.sheen_color * (s.sheen_albedo_v / PI * lobe.x);
#endif
#ifdef MATERIAL_CLEARCOAT
    // Under a coat the material keeps what the coat leaves; the coat reflects the light with
    // its own lobe (F0 0.04), about its own normal.
    var coat = 0.0;
    if s.coat > 0.0 {
        let c = ltc_lobe(light, to_light, s.coat_n, s.v, s.coat_n_dot_v, s.coat_perceptual_roughness);
        let f0 = DIELECTRIC_F0.x;
        coat = s.coat * (f0 * c.z + (1.0 - f0) * c.w) * c.y * s.coat_multiscatter;
    }
    return (beneath * coat_base(s) + coat) * light.color * window;
#else
    return beneath * light.color * window;
#endif
}

// The light's polygon seen by a lobe of `perceptual_roughness` about normal `n` from `v`:
// (the clipped cosine integral, the specular integral (normalised), the fit's magnitude for F0
// and for 1 − F0).
fn ltc_lobe(light: Light, to_light: vec3<f32>, n: vec3<f32>, v: vec3<f32>, n_dot_v: f32, perceptual_roughness: f32) -> vec4<f32> {
    // Shading frame: z along the normal, x in the plane of normal and view (the fit's frame);
    // any x when the view is along the normal (the lobe is isotropic there).
    let along_view = v - n * dot(v, n);
    var tan_x: vec3<f32>;
    if dot(along_view, along_view) < 1e-8 {
        tan_x = normalize(cross(n, select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9)));
    } else {
        tan_x = normalize(along_view - n * dot(along_view, n));
    }
    let tan_y = cross(n, tan_x);
    let to_frame = transpose(mat3x3<f32>(tan_x, tan_y, n));

    var corners: array<vec3<f32>, 17>;
    let outline_count = outline(light, to_light, &corners);
    for (var i = 0u; i < outline_count; i++) {
        corners[i] = to_frame * corners[i];
    }
    // Cut at the surface's horizon first: the transformed cosine of a grazing view reaches
    // below it, and what lies below must not be reflected.
    var in_frame: array<vec3<f32>, 17>;
    let count = clip_to_horizon(&corners, outline_count, &in_frame);
    if count < 3u {
        return vec4<f32>(0.0);
    }
    let diffuse_integral = clipped_cos_integral(&in_frame, count);

    let cell = ltc_lookup(vec2<f32>(perceptual_roughness, sqrt(1.0 - clamp(n_dot_v, 0.0, 1.0))));
    let m = cell.inverse_m;
    let inverse_m = mat3x3<f32>(vec3<f32>(m.x, 0.0, m.y), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(m.z, 0.0, m.w));
    for (var i = 0u; i < count; i++) {
        in_frame[i] = inverse_m * in_frame[i];
    }
    // The transformed cosine is normalised (it integrates to π over the hemisphere); the fit's
    // magnitude restores the lobe's albedo, split into F0 and 1 − F0 shares (Schlick).
    let specular_integral = clipped_cos_integral(&in_frame, count) / PI;
    return vec4<f32>(diffuse_integral, specular_integral, cell.magnitude.x, cell.magnitude.y);
}
