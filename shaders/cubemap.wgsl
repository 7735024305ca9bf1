// Cube-map and sampling helpers shared by the environment passes (env_source.wgsl,
// env_filter.wgsl) and the split-sum table (brdf_lut.wgsl).
//
// Face layout is the one WebGPU, Vulkan and D3D sample with: layers +X, −X, +Y, −Y, +Z, −Z,
// texel rows running down (−Y on the side faces).
#define_import_path penumbra::cubemap

#import penumbra::common::PI

// The unit direction through the centre of texel `xy` of face `face` in a `size`² face.
fn face_direction(face: u32, xy: vec2<u32>, size: u32) -> vec3<f32> {
    let st = (vec2<f32>(xy) + 0.5) / f32(size) * 2.0 - 1.0;
    let s = st.x;
    let t = st.y;
    var d: vec3<f32>;
    switch face {
        case 0u: { d = vec3<f32>(1.0, -t, -s); }
        case 1u: { d = vec3<f32>(-1.0, -t, s); }
        case 2u: { d = vec3<f32>(s, 1.0, t); }
        case 3u: { d = vec3<f32>(s, -1.0, -t); }
        case 4u: { d = vec3<f32>(s, -t, 1.0); }
        default: { d = vec3<f32>(-s, -t, -1.0); }
    }
    return normalize(d);
}

// Solid angle of texel `xy` of a `size`² face (exact: the signed area of its projection on
// the unit sphere, from the four corners).
fn texel_solid_angle(xy: vec2<u32>, size: u32) -> f32 {
    let inv = 1.0 / f32(size);
    let lo = vec2<f32>(xy) * 2.0 * inv - 1.0;
    let hi = lo + 2.0 * inv;
    return corner_area(lo.x, lo.y) - corner_area(lo.x, hi.y) - corner_area(hi.x, lo.y) + corner_area(hi.x, hi.y);
}

fn corner_area(x: f32, y: f32) -> f32 {
    return atan2(x * y, sqrt(x * x + y * y + 1.0));
}

// The `i`-th of `n` points of the Hammersley set in [0, 1)².
fn hammersley(i: u32, n: u32) -> vec2<f32> {
    return vec2<f32>(f32(i) / f32(n), f32(reverseBits(i)) * 2.3283064365386963e-10);
}

// A GGX half vector for `xi` around `n` (roughness `alpha` = perceptual²): D(h)·(n·h) is the
// sampling density over half vectors.
fn importance_sample_ggx(xi: vec2<f32>, alpha: f32, n: vec3<f32>) -> vec3<f32> {
    let phi = 2.0 * PI * xi.x;
    let cos_theta = sqrt((1.0 - xi.y) / (1.0 + (alpha * alpha - 1.0) * xi.y));
    let sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
    let h_local = vec3<f32>(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
    let up = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 0.0, 1.0), abs(n.z) < 0.999);
    let tangent = normalize(cross(up, n));
    let bitangent = cross(n, tangent);
    return normalize(tangent * h_local.x + bitangent * h_local.y + n * h_local.z);
}
