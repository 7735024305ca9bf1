// Prefiltering the environment's source cube, one variant per step (shader defs):
//
// - DOWNSAMPLE: each mip of the source cube from the one above (2 × 2 box), so that
//   prefiltering can read a level whose texels are as large as a sample's footprint.
// - SPECULAR: one roughness level of the specular cube by GGX importance sampling with the
//   split-sum assumption n = v = r (Karis 2013), reading the source at the mip whose texel
//   solid angle matches each sample's (filtered importance sampling, Křivánek and Colbert 2008),
//   so a bright texel spreads over the lobe instead of sparkling.
// - IRRADIANCE_SH: the source projected on the nine real spherical harmonics of bands 0-2 and
//   convolved with the clamped cosine (Ramamoorthi and Hanrahan 2001), divided by π: the shader
//   gets a Lambertian surface's outgoing radiance per unit albedo as Σ c_i·Y_i(n).

#import penumbra::common::PI
#import penumbra::cubemap::{face_direction, texel_solid_angle, hammersley, importance_sample_ggx}

struct FilterParams {
    // Perceptual roughness of the level written (SPECULAR).
    roughness: f32,
    sample_count: u32,
    // Face size of the source's level 0, and of the level written.
    source_size: u32,
    face_size: u32,
    // Mips of the source cube.
    source_levels: u32,
    _pad_a: u32,
    _pad_b: u32,
    _pad_c: u32,
};

#ifdef DOWNSAMPLE
@group(0) @binding(0) var above: texture_2d_array<f32>;
@group(0) @binding(1) var level_out: texture_storage_2d_array<rgba16float, write>;

@compute @workgroup_size(8, 8, 1)
fn downsample(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(level_out).x;
    if id.x >= size || id.y >= size {
        return;
    }
    let p = vec2<i32>(id.xy) * 2;
    let layer = i32(id.z);
    let sum = textureLoad(above, p, layer, 0) + textureLoad(above, p + vec2<i32>(1, 0), layer, 0)
        + textureLoad(above, p + vec2<i32>(0, 1), layer, 0) + textureLoad(above, p + vec2<i32>(1, 1), layer, 0);
    textureStore(level_out, id.xy, id.z, vec4<f32>(sum.rgb * 0.25, 1.0));
}
#endif

#ifdef SPECULAR
@group(0) @binding(0) var<uniform> params: FilterParams;
@group(0) @binding(1) var source_cube: texture_cube<f32>;
@group(0) @binding(2) var trilinear: sampler;
@group(0) @binding(3) var level_out: texture_storage_2d_array<rgba16float, write>;

fn d_ggx(n_dot_h: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let f = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
    return a2 / (PI * f * f);
}

@compute @workgroup_size(8, 8, 1)
fn prefilter_specular(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.face_size || id.y >= params.face_size {
        return;
    }
    let n = face_direction(id.z, id.xy, params.face_size);
    let alpha = params.roughness * params.roughness;
    // Solid angle of one texel of the source's level 0 (average over the cube).
    let texel_omega = 4.0 * PI / (6.0 * f32(params.source_size * params.source_size));
    let max_lod = f32(params.source_levels - 1u);
    var sum = vec3<f32>(0.0);
    var weight = 0.0;
    for (var i = 0u; i < params.sample_count; i++) {
        let h = importance_sample_ggx(hammersley(i, params.sample_count), alpha, n);
        let n_dot_h = max(dot(n, h), 0.0);
        let l = 2.0 * n_dot_h * h - n;
        let n_dot_l = dot(n, l);
        if n_dot_l <= 0.0 {
            continue;
        }
        // With v = n the sampling density of l is D(h)·(n·h) / (4·(v·h)) = D(h) / 4.
        let pdf = max(d_ggx(n_dot_h, alpha) * 0.25, 1e-6);
        let sample_omega = 1.0 / (f32(params.sample_count) * pdf);
        // The level whose texels are as large as the sample's share of the lobe (no bias:
        // measured against a 2048-sample reference, a +1 bias's extra blur costs more than the
        // overlap saves, tests/ibl.rs).
        let lod = clamp(0.5 * log2(sample_omega / texel_omega), 0.0, max_lod);
        sum += textureSampleLevel(source_cube, trilinear, l, lod).rgb * n_dot_l;
        weight += n_dot_l;
    }
    textureStore(level_out, id.xy, id.z, vec4<f32>(sum / max(weight, 1e-6), 1.0));
}
#endif

#ifdef IRRADIANCE_SH
@group(0) @binding(0) var<uniform> params: FilterParams;
@group(0) @binding(1) var level_in: texture_2d_array<f32>;
@group(0) @binding(2) var<storage, read_write> sh_out: array<vec4<f32>, 9>;

const SH_THREADS: u32 = 64u;
var<workgroup> partial: array<array<vec3<f32>, 9>, SH_THREADS>;

fn sh_basis(d: vec3<f32>) -> array<f32, 9> {
    return array<f32, 9>(
        0.282095,
        0.488603 * d.y,
        0.488603 * d.z,
        0.488603 * d.x,
        1.092548 * d.x * d.y,
        1.092548 * d.y * d.z,
        0.315392 * (3.0 * d.z * d.z - 1.0),
        1.092548 * d.x * d.z,
        0.546274 * (d.x * d.x - d.y * d.y)
    );
}

// One workgroup: each invocation sums a strided share of the level's texels, then a tree
// reduction in workgroup memory. `params.face_size` is the level read (a few thousand texels:
// band-2 harmonics vary slowly, a 32² face resolves them).
@compute @workgroup_size(64, 1, 1)
fn project_sh(@builtin(local_invocation_index) t: u32) {
    let size = params.face_size;
    let per_face = size * size;
    var acc: array<vec3<f32>, 9>;
    for (var k = 0u; k < 9u; k++) {
        acc[k] = vec3<f32>(0.0);
    }
    for (var i = t; i < per_face * 6u; i += SH_THREADS) {
        let face = i / per_face;
        let xy = vec2<u32>((i % per_face) % size, (i % per_face) / size);
        let d = face_direction(face, xy, size);
        let radiance = textureLoad(level_in, vec2<i32>(xy), i32(face), 0).rgb * texel_solid_angle(xy, size);
        var y = sh_basis(d);
        for (var k = 0u; k < 9u; k++) {
            acc[k] += radiance * y[k];
        }
    }
    partial[t] = acc;
    workgroupBarrier();
    for (var stride = SH_THREADS / 2u; stride > 0u; stride /= 2u) {
        if t < stride {
            for (var k = 0u; k < 9u; k++) {
                partial[t][k] += partial[t + stride][k];
            }
        }
        workgroupBarrier();
    }
    if t < 9u {
        // Clamped-cosine convolution (Â_l = π, 2π/3, π/4) over π.
        let band_scale = select(select(0.25, 2.0 / 3.0, t < 4u), 1.0, t == 0u);
        sh_out[t] = vec4<f32>(partial[0][t] * band_scale, 0.0);
    }
}
#endif
