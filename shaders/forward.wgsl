// Forward PBR: glTF metallic-roughness shading of every draw, lit by every light in the light
// buffer (a plain loop until clustering lands, issue #3).
//
// Spaces: `world` is scene space; `rel` is world translated so the camera sits at the origin
// (positions far from the origin keep their precision, see vs_main); `clip` is reverse-Z.
// Lighting happens in `rel` space. Output is linear HDR radiance times exposure, clamped to f16.

// Pipeline-overridable switches, fixed per pipeline (see pipeline_cache.rs).
override ALPHA_MODE: u32 = 0u; // 0 opaque, 1 mask, 2 blend
override UNLIT: bool = false;

const PI: f32 = 3.141592653589793;
// Filament's clamp: below 0.045 perceptual roughness, GGX's D overflows f16 and aliases badly.
const MIN_PERCEPTUAL_ROUGHNESS: f32 = 0.045;
// Largest finite f16: anything brighter written to the Rgba16Float target would become +Inf.
const F16_MAX: f32 = 65504.0;

struct View {
    clip_from_rel: mat4x4<f32>,
    camera_position: vec3<f32>,
    exposure: f32,
    // Direction the camera looks, for orthographic views (all view rays parallel).
    camera_forward: vec3<f32>,
    is_orthographic: u32,
    light_count: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
};

struct Instance {
    // Rows of world_from_local (3×4 affine, translation in .w).
    row0: vec4<f32>,
    row1: vec4<f32>,
    row2: vec4<f32>,
    material: u32,
    flags: u32,
    _pad0: u32,
    _pad1: u32,
};

const MATERIAL_HAS_NORMAL_MAP: u32 = 1u;
const MATERIAL_DOUBLE_SIDED: u32 = 2u;

struct Material {
    base_color: vec4<f32>,
    emissive: vec3<f32>,
    alpha_cutoff: f32,
    metallic: f32,
    roughness: f32,
    normal_scale: f32,
    occlusion_strength: f32,
    flags: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    // Per texture slot two rows of the 2×3 UV transform; row 0's .w is the UV set.
    uv: array<vec4<f32>, 10>,
};

const LIGHT_DIRECTIONAL: u32 = 0u;
const LIGHT_POINT: u32 = 1u;
const LIGHT_SPOT: u32 = 2u;
const LIGHT_AMBIENT: u32 = 3u;

struct Light {
    position: vec3<f32>,
    kind: u32,
    // Direction the light shines (spot, directional), world space, unit length.
    direction: vec3<f32>,
    // Influence radius; 0 means unbounded.
    range: f32,
    // Linear colour times intensity (cd, lux, or cd/m² for ambient).
    color: vec3<f32>,
    spot_scale: f32,
    spot_offset: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
};

@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<storage, read> instances: array<Instance>;
@group(0) @binding(2) var<storage, read> draw_slots: array<u32>;
@group(0) @binding(3) var<storage, read> materials: array<Material>;
@group(0) @binding(4) var<storage, read> lights: array<Light>;

@group(1) @binding(0) var base_color_texture: texture_2d<f32>;
@group(1) @binding(1) var base_color_sampler: sampler;
@group(1) @binding(2) var metallic_roughness_texture: texture_2d<f32>;
@group(1) @binding(3) var metallic_roughness_sampler: sampler;
@group(1) @binding(4) var normal_texture: texture_2d<f32>;
@group(1) @binding(5) var normal_sampler: sampler;
@group(1) @binding(6) var occlusion_texture: texture_2d<f32>;
@group(1) @binding(7) var occlusion_sampler: sampler;
@group(1) @binding(8) var emissive_texture: texture_2d<f32>;
@group(1) @binding(9) var emissive_sampler: sampler;

struct VertexIn {
    @builtin(instance_index) instance_index: u32,
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) tangent: vec4<f32>,
    @location(3) uv0: vec2<f32>,
    @location(4) uv1: vec2<f32>,
    @location(5) color: vec4<f32>,
};

struct VertexOut {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) rel_position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) tangent: vec4<f32>,
    @location(3) uv0: vec2<f32>,
    @location(4) uv1: vec2<f32>,
    @location(5) color: vec4<f32>,
    @location(6) @interpolate(flat) material: u32,
};

@vertex
fn vs_main(in: VertexIn) -> VertexOut {
    let inst = instances[draw_slots[in.instance_index]];
    let m0 = inst.row0.xyz;
    let m1 = inst.row1.xyz;
    let m2 = inst.row2.xyz;
    // Camera-relative translation: both terms are f32 values; for geometry near the camera they
    // are within a factor of two of each other, so the subtraction is exact (Sterbenz lemma) and
    // nearby geometry keeps full precision however far from the origin the scene sits.
    let t_rel = vec3<f32>(inst.row0.w, inst.row1.w, inst.row2.w) - view.camera_position;
    let p = in.position;
    let rel = vec3<f32>(dot(m0, p), dot(m1, p), dot(m2, p)) + t_rel;

    // Normals transform by the cofactor matrix (inverse transpose times det): correct under
    // non-uniform scale and shear; the sign of det keeps them outward under mirroring.
    let c0 = vec3<f32>(m0.x, m1.x, m2.x);
    let c1 = vec3<f32>(m0.y, m1.y, m2.y);
    let c2 = vec3<f32>(m0.z, m1.z, m2.z);
    let det = dot(c0, cross(c1, c2));
    let s = select(1.0, -1.0, det < 0.0);
    let cof = mat3x3<f32>(cross(c1, c2), cross(c2, c0), cross(c0, c1)) * s;
    let linear = mat3x3<f32>(c0, c1, c2);

    var out: VertexOut;
    out.clip_position = view.clip_from_rel * vec4<f32>(rel, 1.0);
    out.rel_position = rel;
    // Normalised here: the cofactor scales normals by the square of the object's scale, which for
    // a 1e-4 scale model would be 1e-8 before interpolation.
    out.normal = safe_normalize(cof * in.normal, vec3<f32>(0.0));
    out.tangent = vec4<f32>(safe_normalize(linear * in.tangent.xyz, vec3<f32>(0.0)), in.tangent.w * s);
    out.uv0 = in.uv0;
    out.uv1 = in.uv1;
    out.color = in.color;
    out.material = inst.material;
    return out;
}

// A texture coordinate with its screen-space gradients.
struct TexCoord {
    uv: vec2<f32>,
    ddx: vec2<f32>,
    ddy: vec2<f32>,
};

// Raw UV sets and their gradients, taken once in uniform control flow.
struct UvSets {
    uv0: vec2<f32>,
    uv1: vec2<f32>,
    uv0_ddx: vec2<f32>,
    uv0_ddy: vec2<f32>,
    uv1_ddx: vec2<f32>,
    uv1_ddy: vec2<f32>,
};

// The texture coordinate of material texture `slot` (KHR_texture_transform applied). Gradients
// are transformed from the raw UV gradients rather than taken from the transformed UVs, because
// the transform is read from a storage buffer and some drivers (llvmpipe) do not execute loads in
// helper invocations: derivatives of loaded values are garbage at triangle edges there.
fn slot_coord(mat: Material, slot: u32, sets: UvSets) -> TexCoord {
    let r0 = mat.uv[slot * 2u];
    let r1 = mat.uv[slot * 2u + 1u];
    let second = r0.w > 0.5;
    let uv = select(sets.uv0, sets.uv1, second);
    let dx = select(sets.uv0_ddx, sets.uv1_ddx, second);
    let dy = select(sets.uv0_ddy, sets.uv1_ddy, second);
    let linear = mat2x2<f32>(vec2<f32>(r0.x, r1.x), vec2<f32>(r0.y, r1.y));
    return TexCoord(linear * uv + vec2<f32>(r0.z, r1.z), linear * dx, linear * dy);
}

// Normalises, or returns `fallback` for a zero, denormal or NaN vector. The threshold is just above
// f32's smallest normal number so that vectors of tiny scenes (1e-12 m²) still normalise.
fn safe_normalize(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let l2 = dot(v, v);
    if !(l2 > 1e-36) {
        return fallback;
    }
    return v * inverseSqrt(l2);
}

// GGX / Trowbridge-Reitz normal distribution (glTF 2.0 spec, appendix B.3.2).
fn d_ggx(n_dot_h: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let f = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
    return a2 / (PI * f * f);
}

// Height-correlated Smith visibility, V = G / (4 N·L N·V) (Heitz 2014; glTF appendix B.3.2).
fn v_smith_ggx_correlated(n_dot_v: f32, n_dot_l: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let gv = n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2);
    let gl = n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2);
    return 0.5 / max(gv + gl, 1e-7);
}

fn f_schlick(f0: vec3<f32>, v_dot_h: f32) -> vec3<f32> {
    let x = 1.0 - v_dot_h;
    let x2 = x * x;
    return f0 + (vec3<f32>(1.0) - f0) * (x2 * x2 * x);
}

// Split-sum scale and bias (A, B) for ∫ f_spec cosθ under uniform light, by Karis's analytic fit
// ("Physically Based Shading on Mobile", 2014). Used for the ambient term; issue #10 replaces it
// with a GPU-computed lookup table for image-based lighting.
fn env_brdf_approx(n_dot_v: f32, perceptual_roughness: f32) -> vec2<f32> {
    let c0 = vec4<f32>(-1.0, -0.0275, -0.572, 0.022);
    let c1 = vec4<f32>(1.0, 0.0425, 1.04, -0.04);
    let r = perceptual_roughness * c0 + c1;
    let a004 = min(r.x * r.x, exp2(-9.28 * n_dot_v)) * r.x + r.y;
    return vec2<f32>(-1.04, 1.04) * a004 + r.zw;
}

struct Surface {
    base_color: vec3<f32>,
    metallic: f32,
    // base_color · (1 − metallic): the Lambertian lobe of the dielectric half of glTF's mix.
    diffuse_color: vec3<f32>,
    // Specular reflectance at normal incidence, mixed: 0.04 (dielectric) to base_color (metal).
    f0: vec3<f32>,
    perceptual_roughness: f32,
    alpha: f32,
    n: vec3<f32>,
    v: vec3<f32>,
    n_dot_v: f32,
    occlusion: f32,
};

// Dielectric reflectance at normal incidence, glTF 2.0 (IOR 1.5).
const DIELECTRIC_F0: vec3<f32> = vec3<f32>(0.04);

// Directional albedo of the specular lobe, single plus multiple scattering: E = FssEss + Fms·Ems
// (Fdez-Agüera 2019, "A Multiple-Scattering Microfacet Model for Real-Time Image-based
// Lighting"), with (A, B) = `env_brdf_approx`. For f0 = 1 it is exactly 1.
fn specular_albedo(f0: vec3<f32>, ab: vec2<f32>) -> vec3<f32> {
    let fss_ess = f0 * ab.x + ab.y;
    let ems = 1.0 - (ab.x + ab.y);
    let f_avg = f0 + (vec3<f32>(1.0) - f0) / 21.0;
    return fss_ess + ems * fss_ess * f_avg / (vec3<f32>(1.0) - ems * f_avg);
}

// Light from a uniform environment of radiance `l`. As glTF defines the material, this is
// mix(dielectric, metal, metallic): the dielectric's diffuse lobe gets what its specular lobe
// leaves, so a white surface returns exactly `l` whatever its roughness or metalness, which the
// white-furnace test checks.
fn ambient(s: Surface, l: vec3<f32>) -> vec3<f32> {
    let ab = env_brdf_approx(s.n_dot_v, s.perceptual_roughness);
    let dielectric_specular = specular_albedo(DIELECTRIC_F0, ab);
    let metal_specular = specular_albedo(s.base_color, ab);
    let specular = mix(dielectric_specular, metal_specular, s.metallic);
    let diffuse = s.diffuse_color * (vec3<f32>(1.0) - dielectric_specular);
    return (specular + diffuse) * l * s.occlusion;
}

// Radiance reflected towards the eye from light arriving along `l` with illuminance `e`
// (measured perpendicular to the light): BRDF · E · N·L, with glTF's BRDF (spec appendix B):
// mix(dielectric, metal, metallic), where the dielectric's diffuse lobe is weighted by
// 1 − F(0.04). Schlick's F is linear in f0, so the specular lobes combine into F(f0 mixed).
fn direct(s: Surface, l: vec3<f32>, e: vec3<f32>) -> vec3<f32> {
    let n_dot_l = dot(s.n, l);
    if n_dot_l <= 0.0 {
        return vec3<f32>(0.0);
    }
    let h = safe_normalize(l + s.v, s.n);
    let n_dot_h = clamp(dot(s.n, h), 0.0, 1.0);
    let v_dot_h = clamp(dot(s.v, h), 0.0, 1.0);
    let f = f_schlick(s.f0, v_dot_h);
    let spec = f * (d_ggx(n_dot_h, s.alpha) * v_smith_ggx_correlated(s.n_dot_v, n_dot_l, s.alpha));
    let diffuse = (vec3<f32>(1.0) - f_schlick(DIELECTRIC_F0, v_dot_h)) * s.diffuse_color / PI;
    return (diffuse + spec) * e * n_dot_l;
}

// glTF KHR_lights_punctual range window: (1 − (d/r)⁴)² clamped; 1 when unbounded.
fn range_window(dist2: f32, range: f32) -> f32 {
    if range <= 0.0 {
        return 1.0;
    }
    let x = dist2 / (range * range);
    let w = clamp(1.0 - x * x, 0.0, 1.0);
    return w * w;
}

fn shade_light(s: Surface, light: Light, rel_pos: vec3<f32>) -> vec3<f32> {
    switch light.kind {
        case LIGHT_DIRECTIONAL: {
            return direct(s, -light.direction, light.color);
        }
        case LIGHT_AMBIENT: {
            return ambient(s, light.color);
        }
        default: {
            let to_light = (light.position - view.camera_position) - rel_pos;
            // Only guards the division: any fixed physical floor (1 mm, 1 cm as some engines use)
            // would break scenes modelled at small scales, so the floor sits just above f32's
            // smallest normal number. A light touching the surface saturates the pixel, and the
            // output clamp keeps it finite.
            let dist2 = max(dot(to_light, to_light), 1e-30);
            let l = to_light * inverseSqrt(dist2);
            var atten = range_window(dist2, light.range) / dist2;
            if light.kind == LIGHT_SPOT {
                let cd = dot(light.direction, -l);
                let a = clamp(cd * light.spot_scale + light.spot_offset, 0.0, 1.0);
                atten *= a * a;
            }
            if atten <= 0.0 {
                return vec3<f32>(0.0);
            }
            return direct(s, l, light.color * atten);
        }
    }
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let mat = materials[in.material];
    let sets = UvSets(in.uv0, in.uv1, dpdx(in.uv0), dpdy(in.uv0), dpdx(in.uv1), dpdy(in.uv1));
    let bc = slot_coord(mat, 0u, sets);
    var base = mat.base_color * in.color;
    base *= textureSampleGrad(base_color_texture, base_color_sampler, bc.uv, bc.ddx, bc.ddy);

    if ALPHA_MODE == 1u {
        if base.a < mat.alpha_cutoff {
            discard;
        }
        base.a = 1.0;
    } else if ALPHA_MODE == 0u {
        base.a = 1.0;
    }

    var color: vec3<f32>;
    if UNLIT {
        color = base.rgb;
    } else {
        let mrc = slot_coord(mat, 1u, sets);
        let nmc = slot_coord(mat, 2u, sets);
        let aoc = slot_coord(mat, 3u, sets);
        let emc = slot_coord(mat, 4u, sets);
        let mr = textureSampleGrad(metallic_roughness_texture, metallic_roughness_sampler, mrc.uv, mrc.ddx, mrc.ddy);
        let nm = textureSampleGrad(normal_texture, normal_sampler, nmc.uv, nmc.ddx, nmc.ddy);
        let ao = textureSampleGrad(occlusion_texture, occlusion_sampler, aoc.uv, aoc.ddx, aoc.ddy);
        let em = textureSampleGrad(emissive_texture, emissive_sampler, emc.uv, emc.ddx, emc.ddy);

        let v = select(safe_normalize(-in.rel_position, vec3<f32>(0.0, 0.0, 1.0)), -view.camera_forward, view.is_orthographic != 0u);
        var n = safe_normalize(in.normal, v);
        let has_normal_map = (mat.flags & MATERIAL_HAS_NORMAL_MAP) != 0u && dot(in.tangent.xyz, in.tangent.xyz) > 1e-12;
        var t = vec3<f32>(0.0);
        var b = vec3<f32>(0.0);
        if has_normal_map {
            // Gram-Schmidt: interpolation leaves T and N slightly non-orthogonal.
            t = safe_normalize(in.tangent.xyz - n * dot(n, in.tangent.xyz), vec3<f32>(1.0, 0.0, 0.0));
            b = cross(n, t) * select(1.0, -1.0, in.tangent.w < 0.0);
        }
        if (mat.flags & MATERIAL_DOUBLE_SIDED) != 0u && !front_facing {
            // The back face's frame is the front's, mirrored: all three axes flip.
            n = -n;
            t = -t;
            b = -b;
        }
        if has_normal_map {
            let tn = (nm.xyz * 2.0 - 1.0) * vec3<f32>(mat.normal_scale, mat.normal_scale, 1.0);
            n = safe_normalize(t * tn.x + b * tn.y + n * tn.z, n);
        }

        let metallic = clamp(mat.metallic * mr.b, 0.0, 1.0);
        let perceptual_roughness = clamp(mat.roughness * mr.g, MIN_PERCEPTUAL_ROUGHNESS, 1.0);
        var s: Surface;
        s.base_color = base.rgb;
        s.metallic = metallic;
        s.diffuse_color = base.rgb * (1.0 - metallic);
        s.f0 = mix(DIELECTRIC_F0, base.rgb, metallic);
        s.perceptual_roughness = perceptual_roughness;
        s.alpha = perceptual_roughness * perceptual_roughness;
        s.n = n;
        s.v = v;
        // 1e-4 floor: at grazing angles N·V → 0 and the visibility term divides by it.
        s.n_dot_v = max(dot(n, v), 1e-4);
        s.occlusion = 1.0 + mat.occlusion_strength * (ao.r - 1.0);

        color = vec3<f32>(0.0);
        for (var i = 0u; i < view.light_count; i++) {
            color += shade_light(s, lights[i], in.rel_position);
        }
        color += mat.emissive * em.rgb;
    }

    var out = color * view.exposure;
    // No NaN or Inf may reach the render target: a NaN fails every comparison, so it becomes 0.
    out = select(vec3<f32>(0.0), clamp(out, vec3<f32>(0.0), vec3<f32>(F16_MAX)), out == out);
    let alpha = clamp(base.a, 0.0, 1.0);
    if ALPHA_MODE == 2u {
        // Premultiplied alpha: the blend state is (ONE, ONE_MINUS_SRC_ALPHA).
        return vec4<f32>(out * alpha, alpha);
    }
    return vec4<f32>(out, 1.0);
}
