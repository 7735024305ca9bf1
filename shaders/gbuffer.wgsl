// The surface a fragment hands to the compute pass that shades local lights (deferred light
// shading): two render targets per sample, written by forward.wgsl and read by
// deferred_lights.wgsl.
//   color (Rgba16Float): base colour, metallic;
//   shape (Rgba16Uint):  the normal in octahedral encoding (Cigolle et al. 2014, "A Survey of
//                        Efficient Representations for Independent Unit Vectors") as two
//                        unorm16, perceptual roughness as unorm16, and 1 in .w for a lit
//                        surface (0, the clear value, for the background and unlit surfaces).
// 16 bits per normal axis keep the direction within about 3e-5 rad, well inside the narrowest
// GGX lobe the BRDF allows.
#define_import_path penumbra::gbuffer

#import penumbra::brdf::{Surface, DIELECTRIC_F0}

struct EncodedSurface {
    color: vec4<f32>,
    shape: vec4<u32>,
};

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

fn encode_surface(s: Surface) -> EncodedSurface {
    let unorm_max = 65535.0;
    let e = vec2<u32>(round(clamp(oct_encode(s.n), vec2<f32>(0.0), vec2<f32>(1.0)) * unorm_max));
    let r = u32(round(clamp(s.perceptual_roughness, 0.0, 1.0) * unorm_max));
    return EncodedSurface(vec4<f32>(s.base_color, s.metallic), vec4<u32>(e, r, 1u));
}

// The surface as forward.wgsl builds it, seen from direction `v`.
fn decode_surface(color: vec4<f32>, shape: vec4<u32>, v: vec3<f32>) -> Surface {
    let unorm_step = 1.0 / 65535.0;
    var s: Surface;
    s.base_color = color.rgb;
    s.metallic = color.a;
    s.diffuse_color = color.rgb * (1.0 - color.a);
    s.f0_color = mix(DIELECTRIC_F0, color.rgb, color.a);
    s.perceptual_roughness = f32(shape.z) * unorm_step;
    s.alpha = s.perceptual_roughness * s.perceptual_roughness;
    s.n = oct_decode(vec2<f32>(shape.xy) * unorm_step);
    s.v = v;
    s.n_dot_v = max(dot(s.n, v), 1e-4);
    s.occlusion = 1.0;
    return s;
}
