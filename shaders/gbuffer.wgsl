// The surface a fragment hands to the compute pass that shades local lights (deferred light
// shading), written by forward.wgsl and read by deferred_lights.wgsl. Fragment output is what
// limits the forward pass on GPUs with few graphics units, so the surface takes one extra
// 64-bit target and the HDR colour's otherwise unused alpha:
//   HDR colour .a:     perceptual roughness for a lit surface; 0 for unlit surfaces and the
//                      background (cleared to 0 in this mode);
//   shape (Rgba16Uint): the normal in octahedral encoding (Cigolle et al. 2014, "A Survey of
//                      Efficient Representations for Independent Unit Vectors") as two unorm16
//                      (within about 3e-5 rad, well inside the narrowest GGX lobe the BRDF
//                      allows); base colour as 8-bit sRGB (the precision of the textures it
//                      usually comes from) and metallic as unorm8, packed in .z and .w.
#define_import_path penumbra::gbuffer

#import penumbra::brdf::{Surface, DIELECTRIC_F0, with_reflectance}
#import penumbra::split_sum::split_sum

fn sign_not_zero(v: vec2<f32>) -> vec2<f32> {
    return select(vec2<f32>(-1.0), vec2<f32>(1.0), v >= vec2<f32>(0.0));
}

// A unit vector to [0, 1]².
fn oct_encode(n: vec3<f32>) -> vec2<f32> {
    let p = n.xy / max(abs(n.x) + abs(n.y) + abs(n.z), 1e-30);
    let folded = (1.0 - abs(p.yx)) * sign_not_zero(p);
    return select(folded, p, n.z >= 0.0) * 0.5 + 0.5;
}

fn oct_decode(e: vec2<f32>) -> vec3<f32> {
    let f = e * 2.0 - 1.0;
    var n = vec3<f32>(f, 1.0 - abs(f.x) - abs(f.y));
    let t = max(-n.z, 0.0);
    n = vec3<f32>(n.xy - t * sign_not_zero(n.xy), n.z);
    return normalize(n);
}

fn srgb_encode(c: vec3<f32>) -> vec3<f32> {
    let x = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    return select(1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - 0.055, 12.92 * x, x <= vec3<f32>(0.0031308));
}

fn srgb_decode(c: vec3<f32>) -> vec3<f32> {
    return select(pow((c + 0.055) / 1.055, vec3<f32>(2.4)), c / 12.92, c <= vec3<f32>(0.04045));
}

// The `shape` target's value for surface `s`; its roughness goes in the colour's alpha.
fn encode_surface(s: Surface) -> vec4<u32> {
    let unorm_max = 65535.0;
    let e = vec2<u32>(round(clamp(oct_encode(s.n), vec2<f32>(0.0), vec2<f32>(1.0)) * unorm_max));
    let c = vec3<u32>(round(srgb_encode(s.base_color) * 255.0));
    let m = u32(round(clamp(s.metallic, 0.0, 1.0) * 255.0));
    return vec4<u32>(e, (c.r << 8u) | c.g, (c.b << 8u) | m);
}

// The surface as forward.wgsl builds it, seen from direction `v`.
fn decode_surface(perceptual_roughness: f32, shape: vec4<u32>, v: vec3<f32>) -> Surface {
    let unorm_step = 1.0 / 65535.0;
    let base = srgb_decode(vec3<f32>(vec3<u32>(shape.z >> 8u, shape.z & 255u, shape.w >> 8u)) / 255.0);
    let metallic = f32(shape.w & 255u) / 255.0;
    var s: Surface;
    s.base_color = base;
    s.metallic = metallic;
    s.diffuse_color = base * (1.0 - metallic);
    s.perceptual_roughness = perceptual_roughness;
    s.alpha = perceptual_roughness * perceptual_roughness;
    s.n = oct_decode(vec2<f32>(shape.xy) * unorm_step);
    s.v = v;
    s.n_dot_v = max(dot(s.n, v), 1e-4);
    s.occlusion = 1.0;
    s.dfg = split_sum(s.n_dot_v, perceptual_roughness);
    // Only glTF's default dielectric reaches the surface buffer (MaterialFeatures::fits_surface_buffer).
    s = with_reflectance(s, DIELECTRIC_F0, 1.0);
    return s;
}
