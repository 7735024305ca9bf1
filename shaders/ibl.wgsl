// Image-based lighting: light from the environment (environment/mod.rs prefilters it), for
// the forward shader (IBL variant) and the background pass.
//
// - Diffuse: nine spherical-harmonic coefficients of the cosine-convolved environment, over π
//   (env_filter.wgsl), so a Lambertian surface of albedo 1 returns Σ c_i·Y_i(n).
// - Specular: the split sum (Karis 2013): the GGX-prefiltered cube at the surface's roughness
//   (mip = perceptual roughness × max_lod) times the directional albedo from the table of
//   brdf_lut.wgsl (`Surface::dfg`), with multiple-scattering compensation, combined as glTF's
//   metal/dielectric mix exactly as the uniform ambient light is (brdf.wgsl's lobe_weights): a
//   white surface under a uniform environment returns exactly its radiance (the furnace test).
#define_import_path penumbra::ibl

#import penumbra::brdf::{Surface, coat_base, lobe_weights}
#import penumbra::split_sum::linear_sampler
#ifdef MATERIAL_ANISOTROPY
#import penumbra::common::safe_normalize
#endif

struct EnvironmentParams {
    // cos and sin of the environment's turn about +Y.
    rotation: vec2<f32>,
    // Radiance scale: the user's intensity times the scale the maps are stored at.
    intensity: f32,
    // Mip of the specular cube that holds perceptual roughness 1.
    max_lod: f32,
    // The specular mip the background shows (0: sharp).
    background_lod: f32,
    _pad_a: f32,
    _pad_b: f32,
    _pad_c: f32,
};

@group(0) @binding(17) var<uniform> environment: EnvironmentParams;
@group(0) @binding(18) var<storage, read> irradiance_sh: array<vec4<f32>, 9>;
@group(0) @binding(19) var specular_cube: texture_cube<f32>;

// A world direction in the environment's own frame (turned back by its rotation).
fn to_environment(d: vec3<f32>) -> vec3<f32> {
    let c = environment.rotation.x;
    let s = environment.rotation.y;
    return vec3<f32>(c * d.x - s * d.z, d.y, s * d.x + c * d.z);
}

// Outgoing radiance of a white Lambertian surface facing `n`, scaled.
fn diffuse_irradiance(n_world: vec3<f32>) -> vec3<f32> {
    let n = to_environment(n_world);
    let c = irradiance_sh;
    let sum = c[0].rgb * 0.282095
        + c[1].rgb * (0.488603 * n.y) + c[2].rgb * (0.488603 * n.z) + c[3].rgb * (0.488603 * n.x)
        + c[4].rgb * (1.092548 * n.x * n.y) + c[5].rgb * (1.092548 * n.y * n.z)
        + c[6].rgb * (0.315392 * (3.0 * n.z * n.z - 1.0)) + c[7].rgb * (1.092548 * n.x * n.z)
        + c[8].rgb * (0.546274 * (n.x * n.x - n.y * n.y));
    // Three bands ring below zero opposite a small bright source.
    return max(sum, vec3<f32>(0.0)) * environment.intensity;
}

// Prefiltered radiance along `dir` at perceptual roughness `roughness`, scaled.
//
// Trilinear by hand: two bilinear reads of the neighbouring mips (the sampler's mip filter is
// nearest) blended by the fractional level, which is what a trilinear sampler computes. A CPU
// rasteriser (llvmpipe) compiles a seamless cube read at a per-pixel level into a large body of
// code, once per distinct read; the two reads here share one body of a single level, which
// shortens the lit shader's compile on every hot reload (docs/shaders.md).
// The last mip's neighbour clamps to itself.
fn prefiltered_radiance(dir: vec3<f32>, roughness: f32) -> vec3<f32> {
    // A NaN roughness reads the sharpest mip rather than blending NaN into the pixel.
    let lod = select(0.0, roughness * environment.max_lod, roughness == roughness);
    let d = to_environment(dir);
    let level = floor(lod);
    let lower = textureSampleLevel(specular_cube, linear_sampler, d, level).rgb;
    let upper = textureSampleLevel(specular_cube, linear_sampler, d, level + 1.0).rgb;
    return mix(lower, upper, lod - level) * environment.intensity;
}

// Light the environment sends towards the eye from surface `s`.
fn environment_light(s: Surface) -> vec3<f32> {
    var r = reflect(-s.v, s.n);
#ifdef MATERIAL_ANISOTROPY
    // An anisotropic lobe reflects about a normal bent towards the plane across its direction,
    // the more the stronger and smoother it is (the Khronos sample viewer's bent normal).
    if s.anisotropy > 0.0 {
        let across = cross(s.anisotropic_t, s.v);
        let anisotropic_n = cross(across, s.anisotropic_t);
        let bend = 1.0 - s.anisotropy * (1.0 - s.perceptual_roughness);
        let bend4 = bend * bend * bend * bend;
        r = reflect(-s.v, safe_normalize(mix(anisotropic_n, s.n, bend4), s.n));
    }
#endif
    // Rough lobes lean towards the normal (Lagarde and de Rousiers 2014, "Moving Frostbite to
    // PBR", §4.9.3): the prefiltered cube was made with n = v = r.
    let a = s.alpha;
    let dir = normalize(mix(s.n, r, (1.0 - a) * (sqrt(1.0 - a) + a)));
    let w = lobe_weights(s);
    var light = w.specular * prefiltered_radiance(dir, s.perceptual_roughness) + w.diffuse * diffuse_irradiance(s.n);
#ifdef MATERIAL_SHEEN
    // The sheen reflects its directional albedo's share of the environment prefiltered at its
    // roughness about the reflected direction (leaning as above, as Filament does); the
    // material beneath keeps the albedo scaling.
    let sa = s.sheen_alpha;
    let sheen_dir = normalize(mix(s.n, r, (1.0 - sa) * (sqrt(1.0 - sa) + sa)));
    let sheen = s.sheen_color * s.sheen_albedo_v * prefiltered_radiance(sheen_dir, s.sheen_perceptual_roughness);
    light = light * s.sheen_scale_v + sheen;
#endif
#ifdef MATERIAL_CLEARCOAT
    // The coat reflects its share along its own normal, at its own roughness (leaning as above);
    // the material beneath keeps the rest.
    let rc = reflect(-s.v, s.coat_n);
    let ac = s.coat_alpha;
    let coat_dir = normalize(mix(s.coat_n, rc, (1.0 - ac) * (sqrt(1.0 - ac) + ac)));
    let coat = s.coat_albedo * prefiltered_radiance(coat_dir, s.coat_perceptual_roughness);
    return (light * coat_base(s) + coat) * s.occlusion;
#else
    return light * s.occlusion;
#endif
}
