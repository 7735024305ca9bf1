// glTF 2.0's BRDF (spec appendix B): GGX microfacets with height-correlated Smith visibility and
// Schlick Fresnel, Lambert diffuse, and the metal/dielectric mix; plus the response to uniform
// ambient light with multiple scattering.
//
// Every lobe weight that depends on the whole lobe (multiple scattering, what the dielectric's
// specular layer leaves to its diffuse base, the response to ambient light) comes from the
// surface's directional albedo `Surface::dfg`, read once per fragment from the split-sum table
// (brdf_lut.wgsl, `split_sum.wgsl`), never from a fit: Karis's analytic fit, used before, puts
// a white lobe of roughness 1 seen head-on at 0.45 where the integral is 0.307, and rough metals
// lit directly came out 15 % darker than the Cycles references (`penumbra report`).
#define_import_path penumbra::brdf

#import penumbra::common::{PI, safe_normalize}
#ifdef MATERIAL_IRIDESCENCE
#import penumbra::iridescence::iridescent_fresnel
#endif
#ifdef MATERIAL_SHEEN
#import penumbra::sheen::sheen_cos_white
#import penumbra::split_sum::sheen_albedo
#endif

// Filament's clamp: below 0.045 perceptual roughness, GGX's D overflows f16 and aliases badly.
const MIN_PERCEPTUAL_ROUGHNESS: f32 = 0.045;
// Dielectric reflectance at normal incidence, glTF 2.0 (IOR 1.5) without KHR_materials_ior or
// KHR_materials_specular.
const DIELECTRIC_F0: vec3<f32> = vec3<f32>(0.04);

struct Surface {
    base_color: vec3<f32>,
    metallic: f32,
    // base_color · (1 − metallic): the Lambertian lobe of the dielectric half of glTF's mix.
    diffuse_color: vec3<f32>,
    // Specular reflectance at normal incidence, mixed: the dielectric's (0.04, or with
    // MATERIAL_SPECULAR its own times its specular strength) to base_color (metal).
    f0_color: vec3<f32>,
#ifdef MATERIAL_SPECULAR
    // KHR_materials_ior / KHR_materials_specular (set by `with_reflectance`): the reflectance at
    // grazing incidence, the dielectric's specular strength to 1 (metal); and the dielectric
    // lobe's directional albedo (the light it takes from the diffuse base). Without the
    // feature both are glTF's constants (`surface_f90`, `dielectric_albedo`), so default
    // materials compile the core shading unchanged.
    f90_weight: f32,
    dielectric_specular: vec3<f32>,
#endif
#ifdef MATERIAL_CLEARCOAT
    // KHR_materials_clearcoat (set by `with_coat`): a clear dielectric layer (F0 0.04) of
    // strength `coat` over the material, with its own roughness and normal. `coat_albedo` is
    // strength times its lobe's directional albedo seen from the eye: what the coat reflects of
    // light arriving evenly, and what it takes from the light the material beneath receives.
    coat: f32,
    coat_perceptual_roughness: f32,
    coat_alpha: f32,
    coat_n: vec3<f32>,
    coat_n_dot_v: f32,
    coat_albedo: f32,
    // Multiple scattering of the coat's lobe (`specular_multiscatter` for F0 0.04).
    coat_multiscatter: f32,
#endif
#ifdef MATERIAL_IRIDESCENCE
    // KHR_materials_iridescence (set by `with_iridescence`): the film's strength, its
    // reflectance seen from the eye (the dielectric's and the metal's, mixed by metalness; it
    // replaces Schlick's Fresnel by that strength), and the directional albedos it gives the
    // dielectric's and the metal's lobes.
    iridescence: f32,
    iridescence_fresnel: vec3<f32>,
    iridescence_dielectric_albedo: vec3<f32>,
    iridescence_metal_albedo: vec3<f32>,
#endif
#ifdef MATERIAL_ANISOTROPY
    // KHR_materials_anisotropy (set by `with_anisotropy`): the strength, the direction of
    // stretching (`anisotropic_t`, perpendicular to n) and the one across it, and GGX's α
    // along each: mix(α, 1, strength²) along, α across, as the extension specifies.
    anisotropy: f32,
    anisotropic_t: vec3<f32>,
    anisotropic_b: vec3<f32>,
    alpha_t: f32,
    alpha_b: f32,
#endif
#ifdef MATERIAL_TRANSMISSION
    // KHR_materials_transmission (set by the caller): the share of light passing through
    // (transmission × (1 − metallic)), its tint (base colour × the volume's attenuation), and
    // the GGX α of the transmitted lobe (the surface's, scaled by the IOR's refraction as the
    // Khronos sample viewer does).
    transmission: f32,
    transmission_tint: vec3<f32>,
    transmission_alpha: f32,
#endif
#ifdef MATERIAL_SHEEN
    // KHR_materials_sheen (set by `with_sheen`): a layer of fibres of colour `sheen_color` over
    // the material (beneath a coat). `sheen_scale_v` is the albedo scaling seen from the eye,
    // 1 − max(sheen colour) · E(n·v), E being the white sheen lobe's directional albedo; light
    // from direction l scales the material beneath by the lesser of it and 1 − max · E(n·l),
    // as the extension specifies.
    sheen_color: vec3<f32>,
    sheen_perceptual_roughness: f32,
    sheen_alpha: f32,
    sheen_albedo_v: f32,
    sheen_scale_v: f32,
#endif
    perceptual_roughness: f32,
    alpha: f32,
    n: vec3<f32>,
    v: vec3<f32>,
    n_dot_v: f32,
    occlusion: f32,
    // The specular lobe's directional albedo as scale A and bias B on f0 (∫ f_spec·cosθ =
    // f0·A + B) at (n_dot_v, perceptual_roughness): single scattering, from the split-sum table.
    dfg: vec2<f32>,
};

// The surface's reflectance from its dielectric's F0 (before the specular strength) and
// specular strength (KHR_materials_specular): the dielectric lobe is `weight` times the lobe of
// F0 `dielectric_f0_color`, Schlick's F being linear in (F0, F90); metals keep F90 = 1. Needs
// `dfg`. Without MATERIAL_SPECULAR the arguments are glTF's (DIELECTRIC_F0, 1) and only
// `f0_color` is set.
fn with_reflectance(surface: Surface, dielectric_f0_color: vec3<f32>, weight: f32) -> Surface {
    var s = surface;
#ifdef MATERIAL_SPECULAR
    let dielectric = dielectric_f0_color * weight;
    s.f0_color = mix(dielectric, s.base_color, s.metallic);
    s.f90_weight = weight + (1.0 - weight) * s.metallic;
    s.dielectric_specular = specular_albedo(dielectric, weight, s.dfg);
#else
    s.f0_color = mix(dielectric_f0_color, s.base_color, s.metallic);
#endif
    return s;
}

#ifdef MATERIAL_CLEARCOAT
// Puts a coat of `strength` and `perceptual_roughness` with normal `n` over the surface; `dfg`
// is the split-sum table at the coat's N·V and roughness.
fn with_coat(surface: Surface, strength: f32, perceptual_roughness: f32, n: vec3<f32>, dfg: vec2<f32>) -> Surface {
    var s = surface;
    s.coat = strength;
    s.coat_perceptual_roughness = perceptual_roughness;
    s.coat_alpha = perceptual_roughness * perceptual_roughness;
    s.coat_n = n;
    s.coat_n_dot_v = max(dot(n, s.v), 1e-4);
    s.coat_albedo = strength * specular_albedo(DIELECTRIC_F0, 1.0, dfg).x;
    s.coat_multiscatter = multiscatter_scale(DIELECTRIC_F0, 1.0, dfg.x + dfg.y).x;
    return s;
}

// The coat's lobe times its N·L towards `l` (its strength and Fresnel included).
fn coat_cos(s: Surface, l: vec3<f32>) -> f32 {
    let n_dot_l = dot(s.coat_n, l);
    if n_dot_l <= 0.0 || s.coat <= 0.0 {
        return 0.0;
    }
    let h = safe_normalize(l + s.v, s.coat_n);
    let n_dot_h = clamp(dot(s.coat_n, h), 0.0, 1.0);
    let f = f_schlick(DIELECTRIC_F0, 1.0, clamp(dot(s.v, h), 0.0, 1.0)).x;
    let d_v = d_ggx(s.coat_n, h, n_dot_h, s.coat_alpha) * v_smith_ggx_correlated(s.coat_n_dot_v, n_dot_l, s.coat_alpha);
    return s.coat * f * s.coat_multiscatter * d_v * n_dot_l;
}
#endif

#ifdef MATERIAL_SHEEN
// Puts a sheen of `color` and `perceptual_roughness` (clamped as the specular lobe's) over the
// surface.
fn with_sheen(surface: Surface, color: vec3<f32>, perceptual_roughness: f32) -> Surface {
    var s = surface;
    let r = clamp(perceptual_roughness, MIN_PERCEPTUAL_ROUGHNESS, 1.0);
    s.sheen_color = color;
    s.sheen_perceptual_roughness = r;
    s.sheen_alpha = r * r;
    s.sheen_albedo_v = sheen_albedo(s.n_dot_v, r);
    s.sheen_scale_v = 1.0 - max(color.r, max(color.g, color.b)) * s.sheen_albedo_v;
    return s;
}

// The sheen lobe times N·L towards `l`.
fn sheen_cos(s: Surface, l: vec3<f32>) -> vec3<f32> {
    let n_dot_l = dot(s.n, l);
    if n_dot_l <= 0.0 {
        return vec3<f32>(0.0);
    }
    let h = safe_normalize(l + s.v, s.n);
    return s.sheen_color * sheen_cos_white(s.n, h, s.n_dot_v, n_dot_l, s.sheen_alpha);
}

// What the material beneath the sheen keeps of light from `l` and seen from the eye.
fn sheen_scale(s: Surface, l: vec3<f32>) -> f32 {
    let n_dot_l = clamp(dot(s.n, l), 0.0, 1.0);
    let max_color = max(s.sheen_color.r, max(s.sheen_color.g, s.sheen_color.b));
    return min(s.sheen_scale_v, 1.0 - max_color * sheen_albedo(n_dot_l, s.sheen_perceptual_roughness));
}
#endif

// What the material beneath a sheen keeps of light seen from the eye, for light whose direction
// the caller does not resolve (the environment, area lights' diffuse part): 1 without a sheen.
fn sheen_base(s: Surface) -> f32 {
#ifdef MATERIAL_SHEEN
    return s.sheen_scale_v;
#else
    return 1.0;
#endif
}

#ifdef MATERIAL_IRIDESCENCE
// Puts a thin film of `strength`, IOR `film_ior` and `thickness` nanometres over the surface;
// the dielectric's reflectance beneath it is `dielectric_f0_color` at `weight`, as
// `with_reflectance` was given. The film's reflectance is evaluated once, at n·v (as the
// Khronos sample viewer does), and used for every light.
fn with_iridescence(
    surface: Surface,
    strength: f32,
    film_ior: f32,
    thickness: f32,
    dielectric_f0_color: vec3<f32>,
    weight: f32,
) -> Surface {
    var s = surface;
    let dielectric = iridescent_fresnel(film_ior, s.n_dot_v, thickness, dielectric_f0_color) * weight;
    let metal = iridescent_fresnel(film_ior, s.n_dot_v, thickness, s.base_color);
    s.iridescence = strength;
    s.iridescence_fresnel = mix(dielectric, metal, s.metallic);
    s.iridescence_dielectric_albedo = dielectric * (s.dfg.x + s.dfg.y);
    s.iridescence_metal_albedo = metal * (s.dfg.x + s.dfg.y);
    return s;
}
#endif

// The specular lobe's Fresnel at v·h: Schlick's, or with MATERIAL_IRIDESCENCE mixed with the
// thin film's by its strength.
fn surface_fresnel(s: Surface, v_dot_h: f32) -> vec3<f32> {
    let schlick = f_schlick(s.f0_color, surface_f90(s), v_dot_h);
#ifdef MATERIAL_IRIDESCENCE
    return mix(schlick, s.iridescence_fresnel, s.iridescence);
#else
    return schlick;
#endif
}

#ifdef MATERIAL_ANISOTROPY
// Stretches the surface's specular lobe by `strength` along `t` (made perpendicular to n).
fn with_anisotropy(surface: Surface, strength: f32, t: vec3<f32>) -> Surface {
    var s = surface;
    s.anisotropy = strength;
    s.anisotropic_t = safe_normalize(t - s.n * dot(s.n, t), t);
    s.anisotropic_b = cross(s.n, s.anisotropic_t);
    s.alpha_t = mix(s.alpha, 1.0, strength * strength);
    s.alpha_b = s.alpha;
    return s;
}
#endif

// The specular lobe's D · V towards `l` with half vector `h`: GGX with height-correlated
// Smith visibility, or with MATERIAL_ANISOTROPY their anisotropic forms (Burley 2012; Heitz
// 2014), with α along and across the anisotropy's direction.
fn specular_d_v(s: Surface, l: vec3<f32>, h: vec3<f32>, n_dot_h: f32, n_dot_l: f32) -> f32 {
#ifdef MATERIAL_ANISOTROPY
    if s.anisotropy > 0.0 {
        let t = s.anisotropic_t;
        let b = s.anisotropic_b;
        let at = s.alpha_t;
        let ab = s.alpha_b;
        let a2 = at * ab;
        let f = vec3<f32>(ab * dot(t, h), at * dot(b, h), a2 * n_dot_h);
        let w2 = a2 / max(dot(f, f), 1e-30);
        let d = a2 * w2 * w2 / PI;
        let view_term = n_dot_l * length(vec3<f32>(at * dot(t, s.v), ab * dot(b, s.v), s.n_dot_v));
        let light_term = s.n_dot_v * length(vec3<f32>(at * dot(t, l), ab * dot(b, l), n_dot_l));
        return d * 0.5 / max(view_term + light_term, 1e-7);
    }
#endif
    return d_ggx(s.n, h, n_dot_h, s.alpha) * v_smith_ggx_correlated(s.n_dot_v, n_dot_l, s.alpha);
}

// What the material beneath the coat keeps of the light it receives (1 without a coat).
fn coat_base(s: Surface) -> f32 {
#ifdef MATERIAL_CLEARCOAT
    return 1.0 - s.coat_albedo;
#else
    return 1.0;
#endif
}

// The surface's reflectance at grazing incidence.
fn surface_f90(s: Surface) -> f32 {
#ifdef MATERIAL_SPECULAR
    return s.f90_weight;
#else
    return 1.0;
#endif
}

// The directional albedo of the surface's dielectric specular lobe (single and multiple
// scattering).
fn dielectric_albedo(s: Surface) -> vec3<f32> {
#ifdef MATERIAL_SPECULAR
    let albedo = s.dielectric_specular;
#else
    let albedo = specular_albedo(DIELECTRIC_F0, 1.0, s.dfg);
#endif
#ifdef MATERIAL_IRIDESCENCE
    return mix(albedo, s.iridescence_dielectric_albedo, s.iridescence);
#else
    return albedo;
#endif
}

// The directional albedo of the surface's metal lobe.
fn metal_albedo(s: Surface) -> vec3<f32> {
    let albedo = specular_albedo(s.base_color, 1.0, s.dfg);
#ifdef MATERIAL_IRIDESCENCE
    return mix(albedo, s.iridescence_metal_albedo, s.iridescence);
#else
    return albedo;
#endif
}

// GGX / Trowbridge-Reitz normal distribution, α² / (π ((N·H)²(α² − 1) + 1)²) written as
// (α / (|N × H|² + (N·H α)²))² / π: near the peak of a sharp lobe N·H is within a few f32 steps
// of 1, and 1 − (N·H)² computed from it keeps none of the digits that shape the highlight
// (drivers' rounding then decides it; the H100 and lavapipe differed there). |N × H|² keeps them
// (as Filament computes it).
fn d_ggx(n: vec3<f32>, h: vec3<f32>, n_dot_h: f32, alpha: f32) -> f32 {
    let n_cross_h = cross(n, h);
    let a = n_dot_h * alpha;
    let k = alpha / max(dot(n_cross_h, n_cross_h) + a * a, 1e-30);
    return k * k * (1.0 / PI);
}

// Height-correlated Smith visibility, V = G / (4 N·L N·V) (Heitz 2014).
fn v_smith_ggx_correlated(n_dot_v: f32, n_dot_l: f32, alpha: f32) -> f32 {
    let alpha_sq = alpha * alpha;
    let gv = n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - alpha_sq) + alpha_sq);
    let gl = n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - alpha_sq) + alpha_sq);
    return 0.5 / max(gv + gl, 1e-7);
}

fn f_schlick(f0_color: vec3<f32>, f90_weight: f32, v_dot_h: f32) -> vec3<f32> {
    let x = 1.0 - v_dot_h;
    let x_sq = x * x;
    return f0_color + (vec3<f32>(f90_weight) - f0_color) * (x_sq * x_sq * x);
}

// Directional albedo of the specular lobe, single plus multiple scattering: E = FssEss + Fms·Ems
// (Fdez-Agüera 2019, "A Multiple-Scattering Microfacet Model for Real-Time Image-based
// Lighting"), with (A, B) = `Surface::dfg`. For f0_color = f90_weight = 1 it is exactly 1.
fn specular_albedo(f0_color: vec3<f32>, f90_weight: f32, ab: vec2<f32>) -> vec3<f32> {
    let fss_ess = f0_color * ab.x + f90_weight * ab.y;
    let ems = 1.0 - (ab.x + ab.y);
    let f_avg = f0_color + (vec3<f32>(f90_weight) - f0_color) / 21.0;
    return fss_ess + ems * fss_ess * f_avg / (vec3<f32>(1.0) - ems * f_avg);
}

// Multiple scattering for light from one direction: the single-scattering GGX lobe loses
// Ems = 1 − Ess of its energy (more the rougher it is). The lobe is scaled by the ratio of the
// total directional albedo to the single-scattering one in the model `specular_albedo` uses
// (Fdez-Agüera 2019): 1 + Ems·Favg / (1 − Ems·Favg), which is 1/Ess for a white metal (as
// Kulla & Conty 2017) and saturates coloured metals as repeated bounces do. Path tracers'
// multiple-scattering GGX (Cycles' Principled BSDF) keeps that energy too: without it, rough
// metals lit directly were up to half as bright as the Cycles references of `penumbra report`
// (tests/reference, spheres scene).
fn specular_multiscatter(s: Surface) -> vec3<f32> {
    return multiscatter_scale(s.f0_color, surface_f90(s), s.dfg.x + s.dfg.y);
}

// `specular_multiscatter` for a given single-scattering albedo of a white lobe.
fn multiscatter_scale(f0_color: vec3<f32>, f90_weight: f32, ess: f32) -> vec3<f32> {
    let ems_f_avg = (1.0 - clamp(ess, 0.0, 1.0)) * (f0_color + (vec3<f32>(f90_weight) - f0_color) / 21.0);
    return vec3<f32>(1.0) + ems_f_avg / (vec3<f32>(1.0) - ems_f_avg);
}

// Light from a uniform environment of radiance `l`. As glTF defines the material, this is
// mix(dielectric, metal, metallic): the dielectric's diffuse lobe gets what its specular lobe
// leaves, so a white surface returns exactly `l` whatever its roughness or metalness, which the
// white-furnace test checks.
fn ambient(s: Surface, l: vec3<f32>) -> vec3<f32> {
    let w = lobe_weights(s);
    var beneath = w.specular + w.diffuse;
#ifdef MATERIAL_SHEEN
    beneath = beneath * s.sheen_scale_v + s.sheen_color * s.sheen_albedo_v;
#endif
#ifdef MATERIAL_CLEARCOAT
    return (beneath * coat_base(s) + s.coat_albedo) * l * s.occlusion;
#else
    return beneath * l * s.occlusion;
#endif
}

// What each lobe returns of light arriving evenly from the whole hemisphere (before
// occlusion): the specular lobe's directional albedo, and the diffuse albedo scaled by what the
// dielectric's specular layer leaves. `ambient` weights one radiance by both; the environment
// (ibl.wgsl) weights its prefiltered and irradiance terms by each.
struct LobeWeights {
    specular: vec3<f32>,
    diffuse: vec3<f32>,
};

fn lobe_weights(s: Surface) -> LobeWeights {
    let dielectric_specular = dielectric_albedo(s);
    let metal_specular = metal_albedo(s);
    return LobeWeights(
        mix(dielectric_specular, metal_specular, s.metallic),
        s.diffuse_color * (vec3<f32>(1.0) - dielectric_specular)
    );
}

// Radiance reflected towards the eye from light arriving along `l` with illuminance `e`
// (measured perpendicular to the light): BRDF · E · N·L, where the dielectric's diffuse lobe is
// weighted by `diffuse_share`. Schlick's F is linear in f0_color, so the specular lobes of
// glTF's mix combine into F(f0_color mixed).
fn direct(s: Surface, l: vec3<f32>, e: vec3<f32>) -> vec3<f32> {
    var beneath = direct_beneath(s, l, e);
#ifdef MATERIAL_TRANSMISSION
    beneath += transmission_cos(s, l) * sheen_base(s) * e;
#endif
#ifdef MATERIAL_CLEARCOAT
    return beneath * coat_base(s) + coat_cos(s, l) * e;
#else
    return beneath;
#endif
}

#ifdef MATERIAL_TRANSMISSION
// Light from behind the surface passing through it towards the eye: the transmitted GGX lobe
// about the light's direction mirrored to the front (the thin-surface model of the Khronos
// sample viewer), times what the surface's reflection leaves (1 − F), its tint and its share,
// times |N·L|. Zero for light in front.
fn transmission_cos(s: Surface, l: vec3<f32>) -> vec3<f32> {
    let n_dot_l = dot(s.n, l);
    if n_dot_l >= 0.0 || s.transmission <= 0.0 {
        return vec3<f32>(0.0);
    }
    let mirrored = reflect(l, s.n);
    let h = safe_normalize(mirrored + s.v, s.n);
    let n_dot_h = clamp(dot(s.n, h), 0.0, 1.0);
    let f = surface_fresnel(s, clamp(dot(s.v, h), 0.0, 1.0));
    let d_v = d_ggx(s.n, h, n_dot_h, s.transmission_alpha)
        * v_smith_ggx_correlated(s.n_dot_v, -n_dot_l, s.transmission_alpha);
    return (vec3<f32>(1.0) - f) * s.transmission_tint * (s.transmission * d_v * -n_dot_l);
}
#endif

// `direct` for the material beneath its coat, if it has one: with its sheen over it.
fn direct_beneath(s: Surface, l: vec3<f32>, e: vec3<f32>) -> vec3<f32> {
#ifdef MATERIAL_SHEEN
    return direct_base(s, l, e) * sheen_scale(s, l) + sheen_cos(s, l) * e;
#else
    return direct_base(s, l, e);
#endif
}

// `direct` for glTF's core material alone.
fn direct_base(s: Surface, l: vec3<f32>, e: vec3<f32>) -> vec3<f32> {
    let n_dot_l = dot(s.n, l);
    if n_dot_l <= 0.0 {
        return vec3<f32>(0.0);
    }
    let h = safe_normalize(l + s.v, s.n);
    let n_dot_h = clamp(dot(s.n, h), 0.0, 1.0);
    let v_dot_h = clamp(dot(s.v, h), 0.0, 1.0);
    let f = surface_fresnel(s, v_dot_h) * specular_multiscatter(s);
    let spec = f * specular_d_v(s, l, h, n_dot_h, n_dot_l);
    let diffuse = diffuse_share(s) * s.diffuse_color / PI;
    return (diffuse + spec) * e * n_dot_l;
}

// What the dielectric's specular layer leaves to its diffuse base, seen from the eye:
// 1 − its directional albedo (single and multiple scattering, as `ambient` uses), the layering
// of Cycles' Principled BSDF and OpenPBR. The per-light 1 − F(V·H) of glTF's sample
// implementation darkened rough surfaces seen at grazing angles by up to 8 % against the
// Cycles references (tests/reference, sun_csm's distant ground).
fn diffuse_share(s: Surface) -> vec3<f32> {
    return vec3<f32>(1.0) - dielectric_albedo(s);
}

// The two lobes of `direct` apart, for lights whose diffuse and specular parts are seen in
// different directions (sphere and tube lights). The diffuse BRDF without N·L (the caller's
// irradiance includes it; it does not depend on the light's direction, only on the view's):
fn diffuse_brdf(s: Surface) -> vec3<f32> {
    return diffuse_share(s) * s.diffuse_color / PI * sheen_base(s) * coat_base(s);
}

// The specular BRDF times N·L, towards `l`.
fn specular_cos(s: Surface, l: vec3<f32>) -> vec3<f32> {
#ifdef MATERIAL_CLEARCOAT
    return specular_cos_beneath(s, l) * coat_base(s) + vec3<f32>(coat_cos(s, l));
#else
    return specular_cos_beneath(s, l);
#endif
}

// `specular_cos` for the material beneath its coat, if it has one: with its sheen over it.
fn specular_cos_beneath(s: Surface, l: vec3<f32>) -> vec3<f32> {
#ifdef MATERIAL_SHEEN
    return specular_cos_base(s, l) * sheen_scale(s, l) + sheen_cos(s, l);
#else
    return specular_cos_base(s, l);
#endif
}

// `specular_cos` for glTF's core material alone.
fn specular_cos_base(s: Surface, l: vec3<f32>) -> vec3<f32> {
    let n_dot_l = dot(s.n, l);
    if n_dot_l <= 0.0 {
        return vec3<f32>(0.0);
    }
    let h = safe_normalize(l + s.v, s.n);
    let n_dot_h = clamp(dot(s.n, h), 0.0, 1.0);
    let v_dot_h = clamp(dot(s.v, h), 0.0, 1.0);
    let d_v = specular_d_v(s, l, h, n_dot_h, n_dot_l);
    let ms = specular_multiscatter(s);
    return surface_fresnel(s, v_dot_h) * ms * (d_v * n_dot_l);
}
