// KHR_materials_iridescence's thin-film Fresnel (Belcour and Barla 2017, "A Practical
// Extension to Microfacet Theory for the Modeling of Varying Iridescence", as the extension
// specifies it): light reflected by the film's top and by the surface beneath interferes; the
// reflectance is summed over the first orders of the Airy series, each order's spectrum
// integrated against the CIE sensitivities (the paper's Gaussian fit in Fourier space) and
// brought to linear Rec. 709. brdf.wgsl mixes it with Schlick's Fresnel by the film's strength
// (MATERIAL_IRIDESCENCE).
#define_import_path penumbra::iridescence

#import penumbra::common::PI

// CIE XYZ to linear Rec. 709 (sRGB primaries, D65), columns.
const XYZ_TO_REC709: mat3x3<f32> = mat3x3<f32>(
    vec3<f32>(3.2404542, -0.9692660, 0.0556434),
    vec3<f32>(-1.5371385, 1.8760108, -0.2040259),
    vec3<f32>(-0.4985314, 0.0415560, 1.0572252)
);

fn schlick_scalar(f0: f32, cos_theta: f32) -> f32 {
    let x = 1.0 - cos_theta;
    let x2 = x * x;
    return f0 + (1.0 - f0) * x2 * x2 * x;
}

fn schlick_color(f0: vec3<f32>, cos_theta: f32) -> vec3<f32> {
    let x = 1.0 - cos_theta;
    let x2 = x * x;
    return f0 + (vec3<f32>(1.0) - f0) * x2 * x2 * x;
}

// The reflectance at normal incidence between media of IOR `a` and `b`.
fn ior_to_f0(a: vec3<f32>, b: f32) -> vec3<f32> {
    let r = (a - vec3<f32>(b)) / (a + vec3<f32>(b));
    return r * r;
}

// The IOR (against air) whose reflectance at normal incidence is `f0`.
fn f0_to_ior(f0: vec3<f32>) -> vec3<f32> {
    let s = sqrt(clamp(f0, vec3<f32>(0.0), vec3<f32>(0.9999)));
    return (vec3<f32>(1.0) + s) / (vec3<f32>(1.0) - s);
}

// The CIE sensitivities' response, in Rec. 709, to an order of optical path difference `opd`
// (nanometres) with phase `shift`.
fn sensitivity(opd: f32, shift: vec3<f32>) -> vec3<f32> {
    let phase = 2.0 * PI * opd * 1.0e-9;
    let value = vec3<f32>(5.4856e-13, 4.4201e-13, 5.2481e-13);
    let position = vec3<f32>(1.6810e+06, 1.7953e+06, 2.2084e+06);
    let variance = vec3<f32>(4.3278e+09, 9.3046e+09, 6.6121e+09);
    var xyz = value * sqrt(2.0 * PI * variance) * cos(position * phase + shift) * exp(-phase * phase * variance);
    xyz.x += 9.7470e-14 * sqrt(2.0 * PI * 4.5282e+09) * cos(2.2399e+06 * phase + shift.x)
        * exp(-4.5282e+09 * phase * phase);
    return XYZ_TO_REC709 * (xyz / 1.0685e-7);
}

// The reflectance of a film of IOR `film_ior`, `thickness` nanometres thick, over a surface
// whose reflectance at normal incidence is `base_f0`, seen from air at cos θ = `cos_theta`.
fn iridescent_fresnel(film_ior_in: f32, cos_theta: f32, thickness: f32, base_f0: vec3<f32>) -> vec3<f32> {
    // A vanishing film fades to the bare surface.
    let film_ior = mix(1.0, film_ior_in, smoothstep(0.0, 0.03, thickness));
    let sin2_film = (1.0 / (film_ior * film_ior)) * (1.0 - cos_theta * cos_theta);
    let cos2_film = 1.0 - sin2_film;
    if cos2_film < 0.0 {
        // Total internal reflection.
        return vec3<f32>(1.0);
    }
    let cos_film = sqrt(cos2_film);
    // Air to film.
    let r12 = schlick_scalar(ior_to_f0(vec3<f32>(film_ior), 1.0).x, cos_theta);
    let t121 = 1.0 - r12;
    let phi12 = select(0.0, PI, film_ior < 1.0);
    let phi21 = PI - phi12;
    // Film to the surface beneath.
    let base_ior = f0_to_ior(base_f0);
    let r23 = schlick_color(ior_to_f0(base_ior, film_ior), cos_film);
    let phi23 = select(vec3<f32>(0.0), vec3<f32>(PI), base_ior < vec3<f32>(film_ior));
    let opd = 2.0 * film_ior * thickness * cos_film;
    let phi = vec3<f32>(phi21) + phi23;
    let r123 = clamp(r12 * r23, vec3<f32>(1e-5), vec3<f32>(0.9999));
    let amplitude = sqrt(r123);
    let rs = t121 * t121 * r23 / (vec3<f32>(1.0) - r123);
    var reflectance = vec3<f32>(r12) + rs;
    var cm = rs - vec3<f32>(t121);
    for (var m = 1; m <= 2; m++) {
        cm *= amplitude;
        reflectance += cm * 2.0 * sensitivity(f32(m) * opd, f32(m) * phi);
    }
    // Out-of-gamut colours can come out negative.
    return max(reflectance, vec3<f32>(0.0));
}
