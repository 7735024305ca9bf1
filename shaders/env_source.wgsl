// The environment's source cube, level 0: from an equirectangular image, from the procedural
// clear sky (Preetham, Shirley and Smits 1999, "A Practical Analytic Model for Daylight"), or
// from the studio gradient. One invocation per texel, one dispatch layer per face.
//
// Values arrive divided by the source's scale (the image's texels on upload, the sky's zenith
// luminance here; see render/src/environment/mod.rs): the renderer multiplies it back at lookup,
// so the f16 cube does not clamp a bright source.

#import penumbra::common::{PI, F16_MAX}
#import penumbra::cubemap::face_direction

struct SourceParams {
    // Perez coefficients A, B, C, D for luminance Y and chromaticities x and y; E in `perez_e`.
    perez_lum: vec4<f32>,
    perez_x: vec4<f32>,
    perez_y: vec4<f32>,
    perez_e: vec4<f32>,
    // Zenith Y (already divided by the source scale), x and y, each over F(0, θs).
    zenith: vec4<f32>,
    // Direction towards the sun; w: the ground's radiance (Y).
    sun: vec4<f32>,
    // Studio gradient radiance: straight up, at the horizon, straight down.
    studio: vec4<f32>,
    // 0 sky, 1 studio, 2 image.
    mode: u32,
    face_size: u32,
    _pad_a: u32,
    _pad_b: u32,
};

@group(0) @binding(0) var<uniform> source: SourceParams;
@group(0) @binding(1) var cube_out: texture_storage_2d_array<rgba16float, write>;
@group(0) @binding(2) var equirect: texture_2d<f32>;

fn perez(c: vec4<f32>, e: f32, cos_theta: f32, gamma: f32) -> f32 {
    return (1.0 + c.x * exp(c.y / max(cos_theta, 0.01))) * (1.0 + c.z * exp(c.w * gamma) + e * cos(gamma) * cos(gamma));
}

// CIE xyY to linear sRGB (Rec. 709 primaries, D65).
fn xyy_to_rgb(x: f32, y: f32, lum: f32) -> vec3<f32> {
    let big_x = x / max(y, 1e-4) * lum;
    let big_z = (1.0 - x - y) / max(y, 1e-4) * lum;
    return vec3<f32>(
        3.2406 * big_x - 1.5372 * lum - 0.4986 * big_z,
        -0.9689 * big_x + 1.8758 * lum + 0.0415 * big_z,
        0.0557 * big_x - 0.2040 * lum + 1.0570 * big_z
    );
}

fn sky(d: vec3<f32>) -> vec3<f32> {
    // Below the horizon: a grey ground lit by the sun and sky (Lambertian), blended over the
    // last degrees so the horizon has no seam.
    let above = normalize(vec3<f32>(d.x, max(d.y, 0.02), d.z));
    let cos_theta = above.y;
    let gamma = acos(clamp(dot(above, source.sun.xyz), -1.0, 1.0));
    let lum = source.zenith.x * perez(source.perez_lum, source.perez_e.x, cos_theta, gamma);
    let x = source.zenith.y * perez(source.perez_x, source.perez_e.y, cos_theta, gamma);
    let y = source.zenith.z * perez(source.perez_y, source.perez_e.z, cos_theta, gamma);
    let sky_rgb = max(xyy_to_rgb(x, y, lum), vec3<f32>(0.0));
    let ground = vec3<f32>(source.sun.w);
    return mix(ground, sky_rgb, smoothstep(-0.02, 0.02, d.y));
}

fn studio(d: vec3<f32>) -> vec3<f32> {
    let up = smoothstep(0.0, 1.0, max(d.y, 0.0));
    let down = smoothstep(0.0, 1.0, max(-d.y, 0.0));
    let l = source.studio.y + (source.studio.x - source.studio.y) * sqrt(up) + (source.studio.z - source.studio.y) * sqrt(down);
    return vec3<f32>(l);
}

// Bilinear, wrapping in longitude and clamped in latitude (the image is not filterable: f32).
fn equirect_sample(d: vec3<f32>) -> vec3<f32> {
    let dims = vec2<i32>(textureDimensions(equirect));
    let u = atan2(d.x, -d.z) / (2.0 * PI) + 0.5;
    let v = acos(clamp(d.y, -1.0, 1.0)) / PI;
    let p = vec2<f32>(u, v) * vec2<f32>(dims) - 0.5;
    let base = vec2<i32>(floor(p));
    let f = p - floor(p);
    var sum = vec3<f32>(0.0);
    for (var j = 0; j < 2; j++) {
        for (var i = 0; i < 2; i++) {
            let x = (base.x + i + dims.x) % dims.x;
            let y = clamp(base.y + j, 0, dims.y - 1);
            let w = select(1.0 - f.x, f.x, i == 1) * select(1.0 - f.y, f.y, j == 1);
            sum += w * textureLoad(equirect, vec2<i32>(x, y), 0).rgb;
        }
    }
    return sum;
}

@compute @workgroup_size(8, 8, 1)
fn make_source(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= source.face_size || id.y >= source.face_size {
        return;
    }
    let d = face_direction(id.z, id.xy, source.face_size);
    var radiance: vec3<f32>;
    switch source.mode {
        case 0u: { radiance = sky(d); }
        case 1u: { radiance = studio(d); }
        default: { radiance = equirect_sample(d); }
    }
    // NaN never reaches the cube (it would spread through every prefiltered texel).
    radiance = select(vec3<f32>(0.0), clamp(radiance, vec3<f32>(0.0), vec3<f32>(F16_MAX)), radiance == radiance);
    textureStore(cube_out, id.xy, id.z, vec4<f32>(radiance, 1.0));
}
