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
// integral, as sin θ · (n · that normal) times θ / sin θ. The cross product of a with the edge
// b − a (rather than of the two unit vectors) keeps small or distant lights precise, and its
// length is sin θ. θ / sin θ comes from cos θ by Hill and Heitz's rational fit over cos θ in
// [0, 1] ("Real-Time Area Lighting: a Journey from Research to Production", SIGGRAPH 2016
// course; relative error below 2e-6 there), and for obtuse angles as π / sin θ − θ' / sin θ'
// with θ' = π − θ, sin θ from the cross product (from cos θ it would cancel near θ = π, as for
// a horizon edge seen from beside the light): no inverse trigonometric function, and smooth
// where the vertices are nearly parallel, where acos loses θ.
fn edge_integral(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let norms = length(a) * length(b);
    let c = cross(a, b - a) / norms;
    let x = dot(a, b) / norms;
    let y = abs(x);
    // θ / (2π sin θ) for cos θ = y.
    let fit = (0.8543985 + (0.4965155 + 0.0145206 * y) * y) / (3.417594 + (4.1616724 + y) * y);
    let scaled = select(0.5 * inverseSqrt(max(dot(c, c), 1e-30)) - fit, fit, x > 0.0);
    return c.z * (2.0 * PI) * scaled;
}

// What is left of one edge of a convex polygon cut to the upper hemisphere z ≥ 0, and where
// its outline crossed the horizon: summing `edge_integral` over the kept parts, plus the edge
// along the horizon from where the polygon left to where it came back, gives the cut polygon's
// integral (a convex polygon crosses the horizon at most twice).
struct HorizonCut {
    exit_point: vec3<f32>,
    entry_point: vec3<f32>,
    crossings: u32,
}

struct Segment {
    head: vec3<f32>,
    tail: vec3<f32>,
    kept: bool,
}

fn cut_edge(cut: ptr<function, HorizonCut>, a: vec3<f32>, b: vec3<f32>) -> Segment {
    let a_up = a.z > 0.0;
    let b_up = b.z > 0.0;
    if a_up == b_up {
        return Segment(a, b, a_up);
    }
    var c = a + (b - a) * (a.z / (a.z - b.z));
    c.z = 0.0;
    (*cut).crossings += 1u;
    if a_up {
        (*cut).exit_point = c;
        return Segment(a, c, true);
    }
    (*cut).entry_point = c;
    return Segment(c, b, true);
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

// The light's outline in the shading frame: corner i is centre + d.x·across + d.y·up, where d
// starts at `first` and turns by `turn` (cos, sin) from corner to corner. A rectangle's d runs
// (1, 1), (−1, 1), (−1, −1), (1, −1) (quarter turns); a disk is the regular 16-gon of its area
// (circumradius r·√(2π / (n·sin(2π/n)))). Corners are made one at a time as the edges are
// walked, by a rotation rather than a sine and cosine each: an array indexed at run time lives
// in slow per-thread memory on GPUs.
struct Outline {
    centre: vec3<f32>,
    across: vec3<f32>,
    up: vec3<f32>,
    first: vec2<f32>,
    turn: vec2<f32>,
    sides: u32,
}

const DISK_TURN: vec2<f32> = vec2<f32>(0.9238795, 0.38268343);

fn outline(light: Light, to_light: vec3<f32>, to_frame: mat3x3<f32>) -> Outline {
    let axes = plane_axes(light);
    let up = cross(light.direction, axes.xyz);
    if light.kind == LIGHT_DISK {
        let r = light.size * 1.0130016;
        return Outline(to_frame * to_light, to_frame * (axes.xyz * r), to_frame * (up * r), vec2<f32>(1.0, 0.0), DISK_TURN, DISK_SIDES);
    }
    return Outline(to_frame * to_light, to_frame * (axes.xyz * light.size), to_frame * (up * axes.w), vec2<f32>(1.0, 1.0), vec2<f32>(0.0, 1.0), 4u);
}

fn outline_corner(o: Outline, d: vec2<f32>) -> vec3<f32> {
    return o.centre + d.x * o.across + d.y * o.up;
}

// `d` turned by `turn` (forward = false: back).
fn turned(d: vec2<f32>, turn: vec2<f32>, forward: bool) -> vec2<f32> {
    let t = select(vec2<f32>(turn.x, -turn.y), turn, forward);
    return vec2<f32>(d.x * t.x - d.y * t.y, d.x * t.y + d.y * t.x);
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

    let cell = ltc_lookup(vec2<f32>(perceptual_roughness, sqrt(1.0 - clamp(n_dot_v, 0.0, 1.0))));
    let m = cell.inverse_m;
    let inverse_m = mat3x3<f32>(vec3<f32>(m.x, 0.0, m.y), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(m.z, 0.0, m.w));

    // One walk over the outline's edges: each is cut at the surface's horizon first (the
    // transformed cosine of a grazing view reaches below it, and what lies below must not be
    // reflected), its kept part adds to the diffuse (clipped cosine) integral, and that part
    // transformed by M⁻¹, cut again, to the specular one.
    var horizon = HorizonCut();
    var lobe_cut = HorizonCut();
    var diffuse = 0.0;
    var specular = 0.0;
    let o = outline(light, to_light, to_frame);
    var d = o.first;
    var a = outline_corner(o, turned(d, o.turn, false));
    for (var i = 0u; i < o.sides; i++) {
        let b = outline_corner(o, d);
        d = turned(d, o.turn, true);
        let kept = cut_edge(&horizon, a, b);
        if kept.kept {
            diffuse += edge_integral(kept.head, kept.tail);
            let t = cut_edge(&lobe_cut, inverse_m * kept.head, inverse_m * kept.tail);
            if t.kept {
                specular += edge_integral(t.head, t.tail);
            }
        }
        a = b;
    }
    // The cut polygon closes along the horizon from where it left to where it came back; so
    // does its transformed copy, along the transformed horizon.
    if horizon.crossings == 2u {
        diffuse += edge_integral(horizon.exit_point, horizon.entry_point);
        let t = cut_edge(&lobe_cut, inverse_m * horizon.exit_point, inverse_m * horizon.entry_point);
        if t.kept {
            specular += edge_integral(t.head, t.tail);
        }
    }
    if lobe_cut.crossings == 2u {
        specular += edge_integral(lobe_cut.exit_point, lobe_cut.entry_point);
    }
    // Winding depends on which side the polygon is seen from; the caller has already kept only
    // the lit side. The transformed cosine is normalised (it integrates to π over the
    // hemisphere); the fit's magnitude restores the lobe's albedo, split into F0 and 1 − F0
    // shares (Schlick).
    return vec4<f32>(0.5 * abs(diffuse), 0.5 * abs(specular) / PI, cell.magnitude.x, cell.magnitude.y);
}
