// KHR_materials_sheen's BRDF: a layer of fibres over the material, with the "Charlie"
// distribution (Estevez and Kulla 2017, "Production Friendly Microfacet Sheen BRDF") and its
// height-correlated visibility, as the extension's specification gives them. brdf.wgsl layers
// it over the material (MATERIAL_SHEEN); brdf_lut.wgsl integrates its directional albedo into
// the split-sum table's third channel, which the albedo scaling of the material beneath reads.
#define_import_path penumbra::sheen

#import penumbra::common::PI

// The Charlie distribution of α = perceptual roughness², (2 + 1/α) sin(θh)^(1/α) / 2π, with
// sin²θh computed as |N × H|² (exact near N·H = 1, as brdf.wgsl's d_ggx).
fn d_charlie(n: vec3<f32>, h: vec3<f32>, alpha: f32) -> f32 {
    let inv_alpha = 1.0 / alpha;
    let n_cross_h = cross(n, h);
    let sin2 = dot(n_cross_h, n_cross_h);
    return (2.0 + inv_alpha) * pow(sin2, 0.5 * inv_alpha) / (2.0 * PI);
}

// The paper's fit of ln Λ at cos θ = x for roughness α: its five coefficients interpolated
// between α = 0 and α = 1 by (1 − α)².
fn sheen_l(x: f32, alpha: f32) -> f32 {
    let t = (1.0 - alpha) * (1.0 - alpha);
    let a = mix(21.5473, 25.3245, t);
    let b = mix(3.82987, 3.32435, t);
    let c = mix(0.19823, 0.16801, t);
    let d = mix(-1.97760, -1.27393, t);
    let e = mix(-4.32054, -4.85967, t);
    return a / (1.0 + b * pow(x, c)) + d * x + e;
}

// Λ(cos θ), mirrored above 0.5 so that the fit's tail is not used where it is least accurate.
fn sheen_lambda(cos_theta: f32, alpha: f32) -> f32 {
    if cos_theta < 0.5 {
        return exp(sheen_l(cos_theta, alpha));
    }
    return exp(2.0 * sheen_l(0.5, alpha) - sheen_l(1.0 - cos_theta, alpha));
}

// The sheen BRDF for a white sheen times N·L: D · G / (4 N·V), with the height-correlated
// G = 1 / (1 + Λ(V) + Λ(L)). `n_dot_v` must be above 0.
fn sheen_cos_white(n: vec3<f32>, h: vec3<f32>, n_dot_v: f32, n_dot_l: f32, alpha: f32) -> f32 {
    let g = 1.0 / (1.0 + sheen_lambda(n_dot_v, alpha) + sheen_lambda(n_dot_l, alpha));
    return d_charlie(n, h, alpha) * g / (4.0 * n_dot_v);
}
