// The split-sum table (brdf_lut.wgsl fills it once per renderer): the directional albedo of
// glTF's specular lobe at (n·v, perceptual roughness), which every lit surface reads once
// (forward.wgsl per fragment, gbuffer.wgsl per deferred sample) into `Surface::dfg` for
// brdf.wgsl's lobe weights and ibl.wgsl's split sum.
#define_import_path penumbra::split_sum

@group(0) @binding(20) var brdf_lut: texture_2d<f32>;
// Linear within a level, nearest between levels, clamped: the table (one level), and the
// environment's cube (ibl.wgsl blends two levels itself).
@group(0) @binding(21) var linear_sampler: sampler;

// (A, B): ∫ f_spec·cosθ = f0·A + B, single scattering.
fn split_sum(n_dot_v: f32, perceptual_roughness: f32) -> vec2<f32> {
    return textureSampleLevel(brdf_lut, linear_sampler, vec2<f32>(n_dot_v, perceptual_roughness), 0.0).rg;
}

// The directional albedo of a white KHR_materials_sheen lobe (sheen.wgsl) at (n·x, the sheen's
// perceptual roughness): what it reflects of light arriving evenly, and the albedo scaling of
// the material beneath it.
fn sheen_albedo(n_dot_x: f32, perceptual_roughness: f32) -> f32 {
    return textureSampleLevel(brdf_lut, linear_sampler, vec2<f32>(n_dot_x, perceptual_roughness), 0.0).b;
}
