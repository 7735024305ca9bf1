#define_import_path penumbra::display

// Display transform: linear HDR scene colour (already exposed) -> display colour in 0..1, the
// one place the tonemap curves live. Used by the tonemap pass (tonemap.wgsl) and, when nothing
// reads the HDR colour, by the forward shader itself (TONEMAP_IN_FORWARD), which then writes
// straight into the output. `features/tonemap/` mirrors the curves on the CPU for clear colours.

// Variants: TONEMAP_NEUTRAL or TONEMAP_ACES (neither: clamp only); ENCODE_SRGB when the output
// format is not an sRGB format (else the hardware encodes, exactly once).

// Khronos PBR Neutral (Khronos 3D Commerce working group, 2024): hue-preserving, leaves colours
// below 0.76 untouched so that base colours reproduce as authored.
fn pbr_neutral(color_in: vec3<f32>) -> vec3<f32> {
    let start_compression = 0.8 - 0.04;
    let desaturation = 0.15;
    var color = color_in;
    let x = min(color.r, min(color.g, color.b));
    let offset = select(0.04, x - 6.25 * x * x, x < 0.08);
    color -= offset;
    let peak = max(color.r, max(color.g, color.b));
    if peak < start_compression {
        return color;
    }
    let d = 1.0 - start_compression;
    let new_peak = 1.0 - d * d / (peak + d - start_compression);
    color *= new_peak / peak;
    let g = 1.0 - 1.0 / (desaturation * (peak - new_peak) + 1.0);
    return mix(color, vec3<f32>(new_peak), g);
}

// ACES RRT+ODT fit by Stephen Hill (BakingLab, MIT licence), with the sRGB <-> ACEScg matrices.
fn rrt_and_odt_fit(v: vec3<f32>) -> vec3<f32> {
    let a = v * (v + 0.0245786) - 0.000090537;
    let b = v * (0.983729 * v + 0.4329510) + 0.238081;
    return a / b;
}

fn aces_hill(color: vec3<f32>) -> vec3<f32> {
    // Column-major: these are the transposes of Hill's row-major HLSL matrices.
    let aces_input = mat3x3<f32>(
        vec3<f32>(0.59719, 0.07600, 0.02840),
        vec3<f32>(0.35458, 0.90834, 0.13383),
        vec3<f32>(0.04823, 0.01566, 0.83777),
    );
    let aces_output = mat3x3<f32>(
        vec3<f32>(1.60475, -0.10208, -0.00327),
        vec3<f32>(-0.53108, 1.10813, -0.07276),
        vec3<f32>(-0.07367, -0.00605, 1.07602),
    );
    return clamp(aces_output * rrt_and_odt_fit(aces_input * color), vec3<f32>(0.0), vec3<f32>(1.0));
}

fn srgb_encode(c: vec3<f32>) -> vec3<f32> {
    let lo = c * 12.92;
    let hi = 1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, c <= vec3<f32>(0.0031308));
}

fn display_rgb(c: vec3<f32>) -> vec3<f32> {
    var mapped = max(c, vec3<f32>(0.0));
#ifdef TONEMAP_NEUTRAL
    mapped = pbr_neutral(mapped);
#endif
#ifdef TONEMAP_ACES
    mapped = aces_hill(mapped);
#endif
    mapped = clamp(mapped, vec3<f32>(0.0), vec3<f32>(1.0));
#ifdef ENCODE_SRGB
    mapped = srgb_encode(mapped);
#endif
    return mapped;
}
