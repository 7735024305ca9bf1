// What every draw reads: its instance (placement, material slot) and its material, and the
// helpers that place a vertex camera-relative and find a material texture's coordinate. Shared
// by the forward shader and the shadow casters, which must place vertices identically.
#define_import_path penumbra::draw_data

struct Instance {
    // Rows of world_from_local (3×4 affine, translation in .w).
    row_x: vec4<f32>,
    row_y: vec4<f32>,
    row_z: vec4<f32>,
    material: u32,
    flags: u32,
    _pad_a: u32,
    _pad_b: u32,
};

const MATERIAL_DOUBLE_SIDED: u32 = 2u;

struct Material {
    base_color: vec4<f32>,
    emissive: vec3<f32>,
    alpha_cutoff: f32,
    metallic: f32,
    roughness: f32,
    normal_scale: f32,
    occlusion_strength: f32,
    flags: u32,
    _pad_a: u32,
    _pad_b: u32,
    _pad_c: u32,
    // Per core texture slot two rows of the 2×3 UV transform; row 0's .w is the UV set.
    uv: array<vec4<f32>, 10>,
};

// The parameters of a material's extensions, a uniform in its material group read only by the
// variants compiled with them (mirrors `GpuMaterialExtension` in resources/materials.rs), so that
// materials without extensions load no more than glTF's core parameters.
struct MaterialExtension {
    // KHR_materials_ior / KHR_materials_specular: the dielectric's reflectance at normal
    // incidence before the specular colour texture (the IOR's ((ior − 1) / (ior + 1))² times
    // the specular colour), and the specular strength (the specular texture's alpha multiplies it).
    dielectric_f0_color: vec3<f32>,
    specular: f32,
    // KHR_materials_clearcoat: the coat's strength and perceptual roughness (their textures' red
    // and green multiply them) and its normal map's scale.
    clearcoat: f32,
    clearcoat_roughness: f32,
    clearcoat_normal_scale: f32,
    // KHR_materials_sheen: the sheen's perceptual roughness and linear colour (their textures'
    // alpha and RGB multiply them).
    sheen_roughness: f32,
    sheen_color: vec3<f32>,
    // KHR_materials_transmission's share (its texture's red multiplies it); KHR_materials_volume:
    // what white light becomes after attenuation_distance (f32's largest: none) and the volume's
    // thickness in mesh units (its texture's green multiplies it); the IOR refraction bends by
    // and KHR_materials_dispersion's spread of it.
    transmission: f32,
    attenuation_color: vec3<f32>,
    thickness: f32,
    attenuation_distance: f32,
    ior: f32,
    dispersion: f32,
    // KHR_materials_anisotropy: the strength (its texture's blue multiplies it) and the
    // rotation's (cos, sin), which turns the texture's direction (or the tangent).
    anisotropy_strength: f32,
    anisotropy_direction: vec2<f32>,
    // KHR_materials_iridescence: the film's strength (its texture's red multiplies it), its IOR
    // and its thickness range in nanometres (the thickness texture's green picks).
    iridescence: f32,
    iridescence_ior: f32,
    iridescence_thickness: vec2<f32>,
    _pad: vec2<f32>,
    // The UV transform rows of the extension slots (specular, specular colour, clearcoat,
    // clearcoat roughness, clearcoat normal, sheen colour, sheen roughness, transmission,
    // thickness, anisotropy, iridescence, iridescence thickness), as `Material::uv`.
    uv: array<vec4<f32>, 24>,
};

// A vertex placed by its instance.
struct PlacedVertex {
    // Camera-relative position.
    rel: vec3<f32>,
    // The instance's linear part (columns), for tangents.
    linear: mat3x3<f32>,
    // The cofactor matrix (inverse transpose times |det|), for normals.
    cofactor: mat3x3<f32>,
    // -1 for mirroring instances (negative determinant), else 1.
    mirror: f32,
};

fn place_vertex(inst: Instance, p: vec3<f32>, camera_position: vec3<f32>) -> PlacedVertex {
    let m0 = inst.row_x.xyz;
    let m1 = inst.row_y.xyz;
    let m2 = inst.row_z.xyz;
    // Camera-relative translation: both terms are f32 values; for geometry near the camera they
    // are within a factor of two of each other, so the subtraction is exact (Sterbenz lemma) and
    // nearby geometry keeps full precision however far from the origin the scene sits.
    let t_rel = vec3<f32>(inst.row_x.w, inst.row_y.w, inst.row_z.w) - camera_position;
    let rel = vec3<f32>(dot(m0, p), dot(m1, p), dot(m2, p)) + t_rel;

    // Normals transform by the cofactor matrix (inverse transpose times det): correct under
    // non-uniform scale and shear; the sign of det keeps them outward under mirroring.
    let c0 = vec3<f32>(m0.x, m1.x, m2.x);
    let c1 = vec3<f32>(m0.y, m1.y, m2.y);
    let c2 = vec3<f32>(m0.z, m1.z, m2.z);
    let det = dot(c0, cross(c1, c2));
    let s = select(1.0, -1.0, det < 0.0);
    let cof = mat3x3<f32>(cross(c1, c2), cross(c2, c0), cross(c0, c1)) * s;
    let linear = mat3x3<f32>(c0, c1, c2);
    return PlacedVertex(rel, linear, cof, s);
}

// A texture coordinate with its screen-space gradients.
struct TexCoord {
    uv: vec2<f32>,
    ddx: vec2<f32>,
    ddy: vec2<f32>,
};

// Raw UV sets (TEXCOORD_0 and _1) and their gradients, taken once in uniform control flow.
struct UvSets {
    first: vec2<f32>,
    second: vec2<f32>,
    first_ddx: vec2<f32>,
    first_ddy: vec2<f32>,
    second_ddx: vec2<f32>,
    second_ddy: vec2<f32>,
};

// The texture coordinate of material texture `slot` (KHR_texture_transform applied). Gradients
// are transformed from the raw UV gradients rather than taken from the transformed UVs, because
// the transform is read from a storage buffer and some drivers (llvmpipe) do not execute loads in
// helper invocations: derivatives of loaded values are garbage at triangle edges there.
fn slot_coord(mat: Material, slot: u32, sets: UvSets) -> TexCoord {
    return transformed_coord(mat.uv[slot * 2u], mat.uv[slot * 2u + 1u], sets);
}

// `slot_coord` from a slot's two transform rows.
fn transformed_coord(r0: vec4<f32>, r1: vec4<f32>, sets: UvSets) -> TexCoord {
    let second = r0.w > 0.5;
    let uv = select(sets.first, sets.second, second);
    let dx = select(sets.first_ddx, sets.second_ddx, second);
    let dy = select(sets.first_ddy, sets.second_ddy, second);
    let linear = mat2x2<f32>(vec2<f32>(r0.x, r1.x), vec2<f32>(r0.y, r1.y));
    return TexCoord(linear * uv + vec2<f32>(r0.z, r1.z), linear * dx, linear * dy);
}
