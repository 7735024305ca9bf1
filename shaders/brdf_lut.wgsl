// The split-sum table (Karis 2013): for n·v (u) and perceptual roughness (v), the directional
// albedo of glTF's specular lobe as scale A and bias B on f0, ∫ f_spec·cosθ = f0·A + B, by
// importance sampling GGX with the same height-correlated Smith visibility as brdf.wgsl's
// direct light. Computed once, on first use, into a 64² table. Its third channel is the
// directional albedo of KHR_materials_sheen's lobe for a white sheen at (n·v, the sheen's
// perceptual roughness), ∫ f_sheen·cosθ (sheen.wgsl), by cosine-weighted sampling (the Charlie
// distribution has no convenient importance sampling and its lobe is wide).

#import penumbra::brdf::v_smith_ggx_correlated
#import penumbra::cubemap::{hammersley, importance_sample_ggx}
#import penumbra::common::PI
#import penumbra::sheen::sheen_cos_white

@group(0) @binding(0) var table: texture_storage_2d<rgba16float, write>;

const LUT_SAMPLES: u32 = 1024u;

@compute @workgroup_size(8, 8, 1)
fn integrate_brdf(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(table);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let n_dot_v = (f32(id.x) + 0.5) / f32(size.x);
    let roughness = (f32(id.y) + 0.5) / f32(size.y);
    let alpha = roughness * roughness;
    let v = vec3<f32>(sqrt(1.0 - n_dot_v * n_dot_v), 0.0, n_dot_v);
    let n = vec3<f32>(0.0, 0.0, 1.0);
    var a = 0.0;
    var b = 0.0;
    for (var i = 0u; i < LUT_SAMPLES; i++) {
        let h = importance_sample_ggx(hammersley(i, LUT_SAMPLES), alpha, n);
        let v_dot_h = dot(v, h);
        let l = 2.0 * v_dot_h * h - v;
        let n_dot_l = l.z;
        let n_dot_h = h.z;
        if n_dot_l <= 0.0 || v_dot_h <= 0.0 {
            continue;
        }
        // f·cosθ / pdf with pdf = D·(n·h) / (4·(v·h)): D cancels.
        let weight = v_smith_ggx_correlated(n_dot_v, n_dot_l, alpha) * 4.0 * n_dot_l * v_dot_h / n_dot_h;
        let fc = pow(1.0 - v_dot_h, 5.0);
        a += (1.0 - fc) * weight;
        b += fc * weight;
    }
    textureStore(table, id.xy, vec4<f32>(a / f32(LUT_SAMPLES), b / f32(LUT_SAMPLES), sheen_albedo(v, alpha), 1.0));
}

// ∫ f_sheen·cosθ dl for a white sheen: with l drawn with pdf cosθ / π, the mean of f_sheen · π.
fn sheen_albedo(v: vec3<f32>, alpha: f32) -> f32 {
    let n = vec3<f32>(0.0, 0.0, 1.0);
    // The sheen's roughness is clamped as the shading clamps it (MIN_PERCEPTUAL_ROUGHNESS).
    let a = max(alpha, 0.045 * 0.045);
    var sum = 0.0;
    for (var i = 0u; i < LUT_SAMPLES; i++) {
        let u = hammersley(i, LUT_SAMPLES);
        let phi = 2.0 * PI * u.y;
        let sin_theta = sqrt(u.x);
        let l = vec3<f32>(sin_theta * cos(phi), sin_theta * sin(phi), sqrt(1.0 - u.x));
        if l.z <= 0.0 {
            continue;
        }
        let h = normalize(l + v);
        sum += sheen_cos_white(n, h, v.z, l.z, a) / l.z;
    }
    return sum * PI / f32(LUT_SAMPLES);
}
