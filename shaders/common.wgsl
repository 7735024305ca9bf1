// Shared constants and helpers.
#define_import_path penumbra::common

const PI: f32 = 3.141592653589793;
// Largest finite f16: anything brighter written to an Rgba16Float target would become +Inf.
const F16_MAX: f32 = 65504.0;
// The standard 4× sample positions within a pixel (from its top-left corner, y down), in
// sample-index order: Vulkan's standardSampleLocations; D3D and Metal use the same pattern.
const STANDARD_SAMPLES_4 = array<vec2<f32>, 4>(
    vec2<f32>(0.375, 0.125),
    vec2<f32>(0.875, 0.375),
    vec2<f32>(0.125, 0.625),
    vec2<f32>(0.625, 0.875),
);

// Normalises, or returns `fallback` for a zero, denormal or NaN vector. The threshold is just above
// f32's smallest normal number so that vectors of tiny scenes (1e-12 m²) still normalise.
fn safe_normalize(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let l2 = dot(v, v);
    if !(l2 > 1e-36) {
        return fallback;
    }
    return v * inverseSqrt(l2);
}

// The clip-space position of vertex `i` of one triangle covering the screen (no vertex buffer,
// no diagonal seam).
fn fullscreen_position(i: u32) -> vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}
