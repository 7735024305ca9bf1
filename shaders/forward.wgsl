// Forward PBR: glTF metallic-roughness shading of every draw. Global lights (directional,
// ambient) light every fragment; local lights (every other kind) are found through the fragment's
// cluster list (CLUSTERED_LIGHTS), or, in the brute-force reference variants, by walking them all.
//
// Spaces: `world` is scene space; `rel` is world translated so the camera sits at the origin
// (positions far from the origin keep their precision, see vs_main); `clip` is reverse-Z.
// Lighting happens in `rel` space. Output is linear HDR radiance times exposure, clamped to f16.
//
// Variants (shader defs, set per pipeline by the forward pipeline family (features/forward/pipeline.rs and the draw key in resources/draws.rs) from what each draw uses; code a
// draw does not need is not compiled): ALPHA_MASK, ALPHA_BLEND, UNLIT, BASE_COLOR_TEXTURE,
// METALLIC_ROUGHNESS_TEXTURE, NORMAL_MAP, OCCLUSION_TEXTURE, EMISSIVE_TEXTURE, MATERIAL_SPECULAR
// (KHR_materials_ior / KHR_materials_specular: the dielectric's reflectance from the material,
// with SPECULAR_TEXTURE and SPECULAR_COLOR_TEXTURE), MATERIAL_CLEARCOAT (KHR_materials_clearcoat,
// with CLEARCOAT_TEXTURE, CLEARCOAT_ROUGHNESS_TEXTURE and CLEARCOAT_NORMAL_MAP), MATERIAL_SHEEN
// (KHR_materials_sheen, with SHEEN_COLOR_TEXTURE and SHEEN_ROUGHNESS_TEXTURE),
// MATERIAL_TRANSMISSION (KHR_materials_transmission with _volume and _dispersion, with
// TRANSMISSION_TEXTURE and THICKNESS_TEXTURE: the opaque colour's copy is seen through the
// surface, see transmitted_light), MATERIAL_ANISOTROPY (KHR_materials_anisotropy, with
// ANISOTROPY_TEXTURE), MATERIAL_IRIDESCENCE (KHR_materials_iridescence, with
// IRIDESCENCE_TEXTURE and IRIDESCENCE_THICKNESS_TEXTURE; these six read the material's
// extension group, MATERIAL_EXTENSION),
// TRANSFORMED_UVS
// (some texture reads TEXCOORD_1 or has a KHR_texture_transform, see material_texel),
// OCCLUSION_IN_METALLIC_ROUGHNESS (one texture for both: sampled once), LOCAL_LIGHTS
// (with CLUSTERED_LIGHTS, or UNBOUNDED_LIGHTS for the window-error reference; SPHERE_TUBE_LIGHTS
// and LTC_LIGHTS add the code of lights with a size when the scene has them), SHADOWS
// (directional lights read their cascaded shadow maps, shadows.wgsl), IBL (the environment's
// light, ibl.wgsl), and the debug
// views DEBUG_CLUSTER_HEAT, DEBUG_CASCADES, DEBUG_NORMALS and DEBUG_UVS. DEFERRED_LOCAL_LIGHTS:
// local lights are shaded by a compute pass (deferred_lights.wgsl) instead, from the surface
// each fragment also writes out. TONEMAP_IN_FORWARD (with display.wgsl's switches): nothing
// reads the HDR colour, so the output is tonemapped here and drawn straight into the output
// target; the tonemap pass does not run. LINE_QUADS: the draw is a line list held as quads
// (resources/line_quads.rs), widened to one pixel here (line_quads.wgsl). VERTEX_COLORS: the mesh
// has vertex colours other than white, so the colour is interpolated and multiplied in.
// ALPHA_COVERAGE or ALPHA_SAMPLE_RATE (with ALPHA_MASK at MSAA 4): the alpha test runs at each
// sample, see alpha_coverage. VISIBILITY_OCCLUSION: a hybrid frame's draw over the visibility
// buffer, whose samples it is tested against (visibility_occlusion.wgsl). SAMPLE_MASK_OUT (set with
// either ALPHA_COVERAGE or VISIBILITY_OCCLUSION): the fragment writes its sample mask.

#import penumbra::common::{F16_MAX, STANDARD_SAMPLES_4, safe_normalize}
#import penumbra::view::{View, eye_direction}
#ifdef DEFERRED_LOCAL_LIGHTS
#import penumbra::gbuffer::encode_surface
#endif
#ifdef TONEMAP_IN_FORWARD
#import penumbra::display::{display_rgb, srgb_encode}
#endif
#ifdef VISIBILITY_TONEMAP
#import penumbra::display::{display_rgb, srgb_encode}
#endif
#import penumbra::brdf::{Surface, DIELECTRIC_F0, MIN_PERCEPTUAL_ROUGHNESS, with_reflectance}
#ifdef MATERIAL_CLEARCOAT
#import penumbra::brdf::with_coat
#endif
#ifdef MATERIAL_SHEEN
#import penumbra::brdf::with_sheen
#endif
#ifdef MATERIAL_TRANSMISSION
#import penumbra::brdf::{coat_base, dielectric_albedo, sheen_base}
#endif
#ifdef MATERIAL_ANISOTROPY
#import penumbra::brdf::with_anisotropy
#endif
#ifdef MATERIAL_IRIDESCENCE
#import penumbra::brdf::with_iridescence
#endif
#ifndef UNLIT
#import penumbra::split_sum::split_sum
#endif
#import penumbra::light_data::Light
#import penumbra::draw_data::{Instance, Material, MaterialExtension, MATERIAL_DOUBLE_SIDED, TexCoord, UvSets, slot_coord, transformed_coord, place_vertex}
#import penumbra::lights::shade_light
#ifdef SHADOWS
#import penumbra::light_data::LIGHT_DIRECTIONAL
#import penumbra::shadows::directional_shadow
#endif
#ifdef DEBUG_CASCADES
#import penumbra::shadows::cascade_tint
#endif
#ifdef CLUSTERED_LIGHTS
#import penumbra::clusters::{ClusterGrid, fragment_cluster}
#import penumbra::lights::within_reach
#endif
#ifdef IBL
#import penumbra::ibl::environment_light
#endif
#ifdef VISIBILITY_OCCLUSION
#import penumbra::visibility_occlusion::{OcclusionParams, first_sample, overlay_clip, unoccluded_mask}
#endif
#ifdef LINE_QUADS
#import penumbra::line_quads::{behind_eye_fraction, line_corner}
#endif

@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<storage, read> instances: array<Instance>;
@group(0) @binding(2) var<storage, read> draw_slots: array<u32>;
@group(0) @binding(3) var<storage, read> materials: array<Material>;
@group(0) @binding(4) var<storage, read> lights: array<Light>;
#ifndef GLOBAL_LIGHTS_IN_STORAGE
// The global lights, which lead the light store: its first slots bound again as a uniform array
// (mirrors UNIFORM_GLOBAL_LIGHTS in resources/light_store.rs), which every lit fragment walks. A
// uniform read at an index all lanes share is one load on llvmpipe, where a storage read is
// gathered lane by lane. More global lights than this walk `lights` (GLOBAL_LIGHTS_IN_STORAGE).
@group(0) @binding(5) var<uniform> global_lights: array<Light, 64>;
#endif
#ifdef CLUSTERED_LIGHTS
@group(0) @binding(8) var<uniform> grid: ClusterGrid;
// Per cluster (offset, count) into cluster_lights, which holds light slots.
@group(0) @binding(9) var<storage, read> cluster_ranges: array<vec2<u32>>;
@group(0) @binding(10) var<storage, read> cluster_lights: array<u32>;
#endif

#ifdef POOL_VERTICES
// The mesh pool's vertices (GpuVertex, 16 words each: position, normal, tangent, uv0, uv1,
// colour as four unorm16): a line quad's corner reads its segment's opposite endpoint here
// (resources/line_quads.rs), and a triangle-culled draw all of its vertices (PULLED_VERTICES).
@group(0) @binding(22) var<storage, read> pool_vertices: array<f32>;
#endif

@group(1) @binding(0) var base_color_texture: texture_2d<f32>;
@group(1) @binding(1) var base_color_sampler: sampler;
@group(1) @binding(2) var metallic_roughness_texture: texture_2d<f32>;
@group(1) @binding(3) var metallic_roughness_sampler: sampler;
@group(1) @binding(4) var normal_texture: texture_2d<f32>;
@group(1) @binding(5) var normal_sampler: sampler;
@group(1) @binding(6) var occlusion_texture: texture_2d<f32>;
@group(1) @binding(7) var occlusion_sampler: sampler;
@group(1) @binding(8) var emissive_texture: texture_2d<f32>;
@group(1) @binding(9) var emissive_sampler: sampler;
// The material extension group (resources/materials/extension.rs): bound only for materials
// that use a glTF material extension, holding what those extensions read. A texture's binding
// is fixed by its slot; the group holds only the textures of the material's extensions.
#ifdef MATERIAL_EXTENSION
@group(3) @binding(0) var<uniform> material_extension: MaterialExtension;
#endif
@group(3) @binding(1) var specular_texture: texture_2d<f32>;
@group(3) @binding(2) var specular_sampler: sampler;
@group(3) @binding(3) var specular_color_texture: texture_2d<f32>;
@group(3) @binding(4) var specular_color_sampler: sampler;
@group(3) @binding(5) var clearcoat_texture: texture_2d<f32>;
@group(3) @binding(6) var clearcoat_sampler: sampler;
@group(3) @binding(7) var clearcoat_roughness_texture: texture_2d<f32>;
@group(3) @binding(8) var clearcoat_roughness_sampler: sampler;
@group(3) @binding(9) var clearcoat_normal_texture: texture_2d<f32>;
@group(3) @binding(10) var clearcoat_normal_sampler: sampler;
@group(3) @binding(11) var sheen_color_texture: texture_2d<f32>;
@group(3) @binding(12) var sheen_color_sampler: sampler;
@group(3) @binding(13) var sheen_roughness_texture: texture_2d<f32>;
@group(3) @binding(14) var sheen_roughness_sampler: sampler;
@group(3) @binding(15) var transmission_texture: texture_2d<f32>;
@group(3) @binding(16) var transmission_factor_sampler: sampler;
@group(3) @binding(17) var thickness_texture: texture_2d<f32>;
@group(3) @binding(18) var thickness_sampler: sampler;
@group(3) @binding(19) var anisotropy_texture: texture_2d<f32>;
@group(3) @binding(20) var anisotropy_sampler: sampler;
@group(3) @binding(21) var iridescence_texture: texture_2d<f32>;
@group(3) @binding(22) var iridescence_sampler: sampler;
@group(3) @binding(23) var iridescence_thickness_texture: texture_2d<f32>;
@group(3) @binding(24) var iridescence_thickness_sampler: sampler;
#ifdef MATERIAL_TRANSMISSION
// The opaque colour's copy with its mip chain (features/transmission), as exposed radiance; in a
// hybrid frame after the visibility buffer's occlusion bindings, in the same group.
#ifdef VISIBILITY_OCCLUSION
@group(2) @binding(2) var transmission_scene: texture_2d<f32>;
@group(2) @binding(3) var transmission_sampler: sampler;
#else
@group(2) @binding(0) var transmission_scene: texture_2d<f32>;
@group(2) @binding(1) var transmission_sampler: sampler;
#endif
#endif
#ifdef VISIBILITY_OCCLUSION
// A hybrid frame's visibility buffer (visibility_occlusion.wgsl).
@group(2) @binding(0) var<storage, read> occluders: array<vec2<u32>>;
@group(2) @binding(1) var<uniform> occlusion: OcclusionParams;

// The samples of the fragment at `position` nearer than the visibility buffer's.
fn unoccluded_samples(position: vec4<f32>, dz: vec2<f32>) -> u32 {
    let first = first_sample(position, occlusion);
    if first == 0xffffffffu {
        return 0u;
    }
    var held = vec4<f32>(0.0);
    for (var k = 0u; k < min(occlusion.samples, 4u); k++) {
        held[k] = bitcast<f32>(occluders[first + k].y);
    }
    return unoccluded_mask(position, dz, false, held, occlusion.samples);
}
#endif

#ifdef PULLED_VERTICES
// A triangle-culled draw (cull.wgsl, TRIANGLE_CULLING): each index names its instance and
// vertex (`slot << 8 | vertex`), and the draw's first instance is the mesh's first vertex in
// the pool. The vertex is read from the pool, not from a vertex buffer.
struct VertexIn {
    @builtin(instance_index) instance_index: u32,
    @builtin(vertex_index) vertex_index: u32,
};
#else
struct VertexIn {
    @builtin(instance_index) instance_index: u32,
#ifdef LINE_QUADS
    @builtin(vertex_index) vertex_index: u32,
#endif
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) tangent: vec4<f32>,
    @location(3) uv0: vec2<f32>,
    @location(4) uv1: vec2<f32>,
    @location(5) color: vec4<f32>,
};
#endif

struct VertexAttributes {
    position: vec3<f32>,
    normal: vec3<f32>,
    tangent: vec4<f32>,
    uv0: vec2<f32>,
    uv1: vec2<f32>,
    color: vec4<f32>,
};

#ifdef PULLED_VERTICES
fn pool_vertex(vertex: u32) -> VertexAttributes {
    let at = vertex * 16u;
    return VertexAttributes(
        vec3<f32>(pool_vertices[at], pool_vertices[at + 1u], pool_vertices[at + 2u]),
        vec3<f32>(pool_vertices[at + 3u], pool_vertices[at + 4u], pool_vertices[at + 5u]),
        vec4<f32>(pool_vertices[at + 6u], pool_vertices[at + 7u], pool_vertices[at + 8u], pool_vertices[at + 9u]),
        vec2<f32>(pool_vertices[at + 10u], pool_vertices[at + 11u]),
        vec2<f32>(pool_vertices[at + 12u], pool_vertices[at + 13u]),
        vec4<f32>(
            unpack2x16unorm(bitcast<u32>(pool_vertices[at + 14u])),
            unpack2x16unorm(bitcast<u32>(pool_vertices[at + 15u])),
        ),
    );
}
#endif

struct VertexOut {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) rel_position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) tangent: vec4<f32>,
#ifdef ALPHA_SAMPLE_RATE
    // Interpolated at each sample, which makes the fragment shader run once per sample: its
    // alpha test (and discard) then decides each sample on its own (see alpha_coverage).
    @location(3) @interpolate(perspective, sample) uv0: vec2<f32>,
    @location(4) @interpolate(perspective, sample) uv1: vec2<f32>,
#else
    @location(3) uv0: vec2<f32>,
    @location(4) uv1: vec2<f32>,
#endif
#ifdef VERTEX_COLORS
    // Only meshes with colours other than white interpolate one: on GPUs that rasterise small
    // triangles slowly, each interpolated value costs (a sixth of a million-cube frame).
#ifdef ALPHA_SAMPLE_RATE
    @location(5) @interpolate(perspective, sample) color: vec4<f32>,
#else
    @location(5) color: vec4<f32>,
#endif
#endif
    @location(6) @interpolate(flat) material: u32,
#ifdef MATERIAL_TRANSMISSION
    // The instance's scale (the mean length of its axes): KHR_materials_volume's thickness is
    // in the mesh's units.
    @location(7) @interpolate(flat) model_scale: f32,
#endif
};

// A vertex as the rasteriser interpolates it: placed camera-relative by its instance.
fn vertex_out(inst: Instance, v: VertexAttributes) -> VertexOut {
    let placed = place_vertex(inst, v.position, view.camera_position);
    var out: VertexOut;
    out.clip_position = view.clip_from_rel * vec4<f32>(placed.rel, 1.0);
    out.rel_position = placed.rel;
    // Normalised here: the cofactor scales normals by the square of the object's scale, which for
    // a 1e-4 scale model would be 1e-8 before interpolation.
    out.normal = safe_normalize(placed.cofactor * v.normal, vec3<f32>(0.0));
    out.tangent = vec4<f32>(safe_normalize(placed.linear * v.tangent.xyz, vec3<f32>(0.0)), v.tangent.w * placed.mirror);
    out.uv0 = v.uv0;
    out.uv1 = v.uv1;
#ifdef VERTEX_COLORS
    out.color = v.color;
#endif
    out.material = inst.material;
#ifdef MATERIAL_TRANSMISSION
    out.model_scale = (length(placed.linear[0]) + length(placed.linear[1]) + length(placed.linear[2])) / 3.0;
#endif
    return out;
}

@vertex
fn vs_main(in: VertexIn) -> VertexOut {
#ifdef PULLED_VERTICES
    let inst = instances[in.vertex_index >> 8u];
    let v = pool_vertex(in.instance_index + (in.vertex_index & 255u));
#else
    let inst = instances[draw_slots[in.instance_index]];
    let v = VertexAttributes(in.position, in.normal, in.tangent, in.uv0, in.uv1, in.color);
#endif
    var out = vertex_out(inst, v);
#ifdef LINE_QUADS
    let placed = place_vertex(inst, v.position, view.camera_position);
    // The segment's other end: the vertex whose index differs in bit 1 (resources/line_quads.rs).
    let at = (in.vertex_index ^ 2u) * 16u;
    if at + 15u < arrayLength(&pool_vertices) {
        let other = vec3<f32>(pool_vertices[at], pool_vertices[at + 1u], pool_vertices[at + 2u]);
        let other_rel = place_vertex(inst, other, view.camera_position).rel;
        let other_clip = view.clip_from_rel * vec4<f32>(other_rel, 1.0);
        // An end behind the eye moves along the segment to just in front of it, with every
        // attribute taken at that point (see behind_eye_fraction).
        let t = behind_eye_fraction(out.clip_position, other_clip);
        if t > 0.0 {
            let n = vec3<f32>(pool_vertices[at + 3u], pool_vertices[at + 4u], pool_vertices[at + 5u]);
            let tangent = vec3<f32>(pool_vertices[at + 6u], pool_vertices[at + 7u], pool_vertices[at + 8u]);
            out.clip_position = mix(out.clip_position, other_clip, t);
            out.rel_position = mix(placed.rel, other_rel, t);
            out.normal = safe_normalize(placed.cofactor * mix(v.normal, n, t), vec3<f32>(0.0));
            out.tangent = vec4<f32>(safe_normalize(placed.linear * mix(v.tangent.xyz, tangent, t), vec3<f32>(0.0)), out.tangent.w);
            out.uv0 = mix(v.uv0, vec2<f32>(pool_vertices[at + 10u], pool_vertices[at + 11u]), t);
            out.uv1 = mix(v.uv1, vec2<f32>(pool_vertices[at + 12u], pool_vertices[at + 13u]), t);
#ifdef VERTEX_COLORS
            let color = vec4<f32>(unpack2x16unorm(bitcast<u32>(pool_vertices[at + 14u])), unpack2x16unorm(bitcast<u32>(pool_vertices[at + 15u])));
            out.color = mix(v.color, color, t);
#endif
        }
        let side = select(-1.0, 1.0, (in.vertex_index & 1u) != 0u);
        out.clip_position = line_corner(out.clip_position, other_clip, side, (in.vertex_index & 2u) != 0u, view.target_size);
    } else {
        // Beyond what the device binds for reading (the mesh pool warns): not drawn.
        out.clip_position = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
#endif
#ifdef VISIBILITY_OCCLUSION
    // Into the hybrid frame's overlay, which covers a rectangle of the frame.
    out.clip_position = overlay_clip(out.clip_position, occlusion);
#endif
    return out;
}


// Distance along the view direction.
fn view_depth(rel: vec3<f32>) -> f32 {
    return dot(rel, view.camera_forward);
}

#ifdef DEBUG_CLUSTER_HEAT
// Lights in the fragment's cluster: black for none, then blue, green, yellow, red, white at 256
// and beyond (log scale).
fn cluster_heat(frag_xy: vec2<f32>, rel: vec3<f32>) -> vec3<f32> {
    var n = 0u;
#ifdef CLUSTERED_LIGHTS
    n = cluster_ranges[fragment_cluster(grid, frag_xy, view_depth(rel))].y;
#endif
    if n == 0u {
        return vec3<f32>(0.0);
    }
    let t = clamp(log2(f32(n)) / 8.0, 0.0, 1.0) * 4.0;
    let stops = array<vec3<f32>, 5>(
        vec3<f32>(0.0, 0.1, 0.8),
        vec3<f32>(0.0, 0.7, 0.2),
        vec3<f32>(0.9, 0.8, 0.0),
        vec3<f32>(0.9, 0.1, 0.0),
        vec3<f32>(1.0, 1.0, 1.0)
    );
    let k = min(u32(t), 3u);
    return mix(stops[k], stops[k + 1u], t - f32(k));
}
#endif

// Material texture `slot`'s texel at this fragment. Without TRANSFORMED_UVS every texture reads
// TEXCOORD_0 as it is and the sampler takes its own derivatives: explicit gradients cost more to
// compile and to run (on llvmpipe each such read adds LLVM time that hot reload waits for: see
// docs/shaders.md, "What a lavapipe compile costs"). With it, the coordinate and its gradients
// come from the slot's transform rows (transformed_coord).
fn material_texel(t: texture_2d<f32>, s: sampler, mat: Material, slot: u32, sets: UvSets) -> vec4<f32> {
    return slot_texel(t, s, mat.uv[slot * 2u], mat.uv[slot * 2u + 1u], sets);
}

#ifdef MATERIAL_EXTENSION
// `material_texel` for an extension slot: `slot` counts the extensions' slots (0: specular,
// 1: specular colour, 2: clearcoat, 3: clearcoat roughness, 4: clearcoat normal, 5: sheen
// colour, 6: sheen roughness, 7: transmission, 8: thickness, 9: anisotropy, 10: iridescence,
// 11: iridescence thickness), whose transforms are in the material's extension uniform.
fn extension_texel(t: texture_2d<f32>, s: sampler, slot: u32, sets: UvSets) -> vec4<f32> {
    return slot_texel(t, s, material_extension.uv[slot * 2u], material_extension.uv[slot * 2u + 1u], sets);
}
#endif

// A texture's texel at this fragment, for the slot whose transform rows are `r0` and `r1` (read
// only with TRANSFORMED_UVS).
fn slot_texel(t: texture_2d<f32>, s: sampler, r0: vec4<f32>, r1: vec4<f32>, sets: UvSets) -> vec4<f32> {
#ifdef TRANSFORMED_UVS
    let c = transformed_coord(r0, r1, sets);
    return textureSampleGrad(t, s, c.uv, c.ddx, c.ddy);
#else
#ifdef VISIBILITY_SHADE
    // Compute has no implicit derivatives: the shading pass computes the gradients.
    return textureSampleGrad(t, s, sets.first, sets.first_ddx, sets.first_ddy);
#else
    return textureSample(t, s, sets.first);
#endif
#endif
}

#ifdef MATERIAL_TRANSMISSION
// The light that passes through surface `s` towards the eye, before the surface's tint: the
// opaque colour's copy read where the ray refracted by the IOR leaves a volume `thickness`
// deep (thin walls, thickness 0, show what is straight behind), blurred by reading a coarser
// level the rougher the surface (scaled by the IOR's refraction as the Khronos sample viewer
// does: IOR 1 bends and blurs nothing). KHR_materials_dispersion
// refracts red, green and blue by IORs spread by (IOR − 1) · dispersion / 40 about it.
fn transmitted_light(s: Surface, rel_position: vec3<f32>, thickness: f32) -> vec3<f32> {
    let ior = max(material_extension.ior, 1.0);
    let width = f32(textureDimensions(transmission_scene).x);
    let lod = log2(width) * s.perceptual_roughness * clamp(ior * 2.0 - 2.0, 0.0, 1.0);
    var seen: vec3<f32>;
    let spread = (ior - 1.0) * 0.025 * max(material_extension.dispersion, 0.0);
    if spread > 0.0 {
        seen = vec3<f32>(
            seen_through(s, rel_position, thickness, ior - spread, lod).r,
            seen_through(s, rel_position, thickness, ior, lod).g,
            seen_through(s, rel_position, thickness, ior + spread, lod).b
        );
    } else {
        seen = seen_through(s, rel_position, thickness, ior, lod);
    }
    // The copy holds exposed radiance; the caller's colour is exposed at the end.
    return seen / max(view.exposure, 1e-30);
}

// What the volume leaves of light crossing `thickness` of it (Beer's law).
fn volume_attenuation(thickness: f32) -> vec3<f32> {
    let distance = material_extension.attenuation_distance;
    return pow(max(material_extension.attenuation_color, vec3<f32>(1e-6)), vec3<f32>(thickness / distance));
}

// The copy where the ray refracted by `ior` leaves a volume `thickness` deep.
fn seen_through(s: Surface, rel_position: vec3<f32>, thickness: f32, ior: f32, lod: f32) -> vec3<f32> {
    let refracted = refract(-s.v, s.n, 1.0 / ior);
    let exit = rel_position + safe_normalize(refracted, -s.v) * thickness;
    let clip = view.clip_from_rel * vec4<f32>(exit, 1.0);
    let ndc = clip.xy / max(clip.w, 1e-30);
    let uv = vec2<f32>(0.5 * ndc.x + 0.5, 0.5 - 0.5 * ndc.y);
    return textureSampleLevel(transmission_scene, transmission_sampler, uv, lod).rgb;
}
#endif

#ifdef ALPHA_COVERAGE
// glTF's alpha test at each of the pixel's 4 samples (the standard positions) instead of once at
// its centre: the alpha (factor × vertex colour × base colour texel) is evaluated at each sample,
// and the samples where it reaches the cutoff are covered. A masked edge is then antialiased like
// a geometric one. Computed here rather than by the hardware's alpha-to-coverage, whose dither
// patterns differ between drivers, so the mask is the same on every adapter; and where the
// filtered alpha sits at the cutoff (so that a driver's filtering precision decides it) a pixel
// changes by one sample, not all at once. The texel is fetched at each sample with the pixel's
// gradients rather than extrapolated from the centre's along derivatives of the alpha: exact at
// texel boundaries, and the alpha's derivatives would include the material's factor, read from a
// storage buffer that llvmpipe does not read in helper invocations (see slot_coord). NaN alpha
// covers nothing, as the per-pixel test below discards it. Where a backend cannot write a sample
// mask, ALPHA_SAMPLE_RATE shades each sample instead and the per-pixel test discards it.
fn alpha_coverage(mat: Material, sets: UvSets, vertex_alpha: f32, vertex_alpha_gradient: vec2<f32>) -> u32 {
#ifdef BASE_COLOR_TEXTURE
#ifdef TRANSFORMED_UVS
    let c = slot_coord(mat, 0u, sets);
#else
    let c = TexCoord(sets.first, sets.first_ddx, sets.first_ddy);
#endif
#endif
    var mask = 0u;
    for (var i = 0u; i < 4u; i++) {
        let o = STANDARD_SAMPLES_4[i] - vec2<f32>(0.5);
        var alpha = mat.base_color.a;
#ifdef VERTEX_COLORS
        alpha *= vertex_alpha + dot(vertex_alpha_gradient, o);
#endif
#ifdef BASE_COLOR_TEXTURE
        let uv = c.uv + c.ddx * o.x + c.ddy * o.y;
        alpha *= textureSampleGrad(base_color_texture, base_color_sampler, uv, c.ddx, c.ddy).a;
#endif
        if alpha >= mat.alpha_cutoff {
            mask |= 1u << i;
        }
    }
    return mask;
}
#endif

struct FragmentOut {
    @location(0) color: vec4<f32>,
#ifdef SAMPLE_MASK_OUT
    @builtin(sample_mask) coverage: u32,
#endif
#ifdef DEFERRED_LOCAL_LIGHTS
    // The surface for the local-light pass (see gbuffer.wgsl, which also puts roughness in
    // `color`'s alpha); all zero for unlit surfaces.
    @location(1) surface_shape: vec4<u32>,
#endif
};

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front_facing: bool) -> FragmentOut {
    let sets = UvSets(in.uv0, in.uv1, dpdx(in.uv0), dpdy(in.uv0), dpdx(in.uv1), dpdy(in.uv1));
#ifdef VISIBILITY_OCCLUSION
    // A hybrid frame's draw: the visibility buffer holds the opaque depth (see
    // visibility_occlusion.wgsl). Not discarded before shading: its textures take implicit
    // derivatives, which need the whole quad.
    let dz = vec2<f32>(dpdxFine(in.clip_position.z), dpdyFine(in.clip_position.z));
    let unoccluded = unoccluded_samples(in.clip_position, dz);
    // Shading reads the frame's pixel position (cluster lists, shadow noise), not the overlay's.
    var at_frame = in;
    at_frame.clip_position = vec4<f32>(in.clip_position.xy + vec2<f32>(occlusion.origin), in.clip_position.zw);
    var frag = shade(at_frame, front_facing, sets);
#else
    var frag = shade(in, front_facing, sets);
#endif
#ifdef VISIBILITY_OCCLUSION
    frag.coverage &= unoccluded;
    if frag.coverage == 0u {
        discard;
    }
#endif
    return frag;
}

// The fragment's colour (and with it, what masked and deferred variants add): shared by the
// fragment shader and the visibility buffer's shading pass, which computes the UV gradients
// itself.
fn shade(in: VertexOut, front_facing: bool, sets: UvSets) -> FragmentOut {
    var frag: FragmentOut;
#ifdef SAMPLE_MASK_OUT
    frag.coverage = 0xffffffffu;
#endif
    // What the colour's alpha carries for deferred local lights (see gbuffer.wgsl): stays 0
    // for unlit surfaces.
    var surface_alpha = 0.0;
    let mat = materials[in.material];
    var base = mat.base_color;
#ifdef VERTEX_COLORS
    base *= in.color;
#endif
#ifdef BASE_COLOR_TEXTURE
    base *= material_texel(base_color_texture, base_color_sampler, mat, 0u, sets);
#endif

#ifdef ALPHA_MASK
#ifdef ALPHA_COVERAGE
#ifdef VERTEX_COLORS
    let vertex_alpha_gradient = vec2<f32>(dpdxFine(in.color.a), dpdyFine(in.color.a));
    frag.coverage = alpha_coverage(mat, sets, in.color.a, vertex_alpha_gradient);
#else
    frag.coverage = alpha_coverage(mat, sets, 1.0, vec2<f32>(0.0));
#endif
    if frag.coverage == 0u {
        discard;
    }
#else
    // Written so that NaN alpha is cut out, as alpha_coverage leaves it uncovered.
    if !(base.a >= mat.alpha_cutoff) {
        discard;
    }
#endif
#endif

#ifdef UNLIT
    let color = base.rgb;
#else
    let v = eye_direction(view, in.rel_position);
    var n = safe_normalize(in.normal, v);
#ifdef LINE_QUADS
    // A line has no back; its quad's winding follows the segment's direction on screen.
    let double_sided_back = false;
#else
    let double_sided_back = (mat.flags & MATERIAL_DOUBLE_SIDED) != 0u && !front_facing;
#endif
#ifdef NORMAL_MAP
    // Like every material texture: implicit derivatives unless TRANSFORMED_UVS. Explicit
    // gradients here add markedly to llvmpipe's code generation for the lit variant on every
    // hot reload (docs/shaders.md, "What a lavapipe compile costs"); the price is that the level
    // of detail is chosen per 2×2 quad, so GL, which draws flipped, may put a sharp highlight
    // one pixel off (tests/backend_parity.rs).
    let nm = material_texel(normal_texture, normal_sampler, mat, 2u, sets);
    if dot(in.tangent.xyz, in.tangent.xyz) > 1e-12 {
        // Gram-Schmidt: interpolation leaves T and N slightly non-orthogonal.
        var t = safe_normalize(in.tangent.xyz - n * dot(n, in.tangent.xyz), vec3<f32>(1.0, 0.0, 0.0));
        var b = cross(n, t) * select(1.0, -1.0, in.tangent.w < 0.0);
        if double_sided_back {
            // The back face's frame is the front's, mirrored: all three axes flip.
            n = -n;
            t = -t;
            b = -b;
        }
        let tn = (nm.xyz * 2.0 - 1.0) * vec3<f32>(mat.normal_scale, mat.normal_scale, 1.0);
        n = safe_normalize(t * tn.x + b * tn.y + n * tn.z, n);
    } else if double_sided_back {
        n = -n;
    }
#else
    if double_sided_back {
        n = -n;
    }
#endif

    var metallic = mat.metallic;
    var roughness = mat.roughness;
#ifdef METALLIC_ROUGHNESS_TEXTURE
    let mr = material_texel(metallic_roughness_texture, metallic_roughness_sampler, mat, 1u, sets);
    metallic *= mr.b;
    roughness *= mr.g;
#endif
    metallic = clamp(metallic, 0.0, 1.0);
    let perceptual_roughness = clamp(roughness, MIN_PERCEPTUAL_ROUGHNESS, 1.0);
    // The dielectric's reflectance: glTF's default, or KHR_materials_ior's and
    // KHR_materials_specular's (F0 clamped to 1 after its texture, the specular strength
    // scaling the whole dielectric lobe).
    var dielectric_f0_color = DIELECTRIC_F0;
    var specular_weight = 1.0;
#ifdef MATERIAL_SPECULAR
    var specular_color = material_extension.dielectric_f0_color;
#ifdef SPECULAR_COLOR_TEXTURE
    specular_color *= extension_texel(specular_color_texture, specular_color_sampler, 1u, sets).rgb;
#endif
    dielectric_f0_color = min(specular_color, vec3<f32>(1.0));
    specular_weight = clamp(material_extension.specular, 0.0, 1.0);
#ifdef SPECULAR_TEXTURE
    specular_weight *= extension_texel(specular_texture, specular_sampler, 0u, sets).a;
#endif
#endif

    var s: Surface;
    s.base_color = base.rgb;
    s.metallic = metallic;
    s.diffuse_color = base.rgb * (1.0 - metallic);
    s.perceptual_roughness = perceptual_roughness;
    s.alpha = perceptual_roughness * perceptual_roughness;
    s.n = n;
    s.v = v;
    // 1e-4 floor: at grazing angles N·V → 0 and the visibility term divides by it.
    s.n_dot_v = max(dot(n, v), 1e-4);
    s.occlusion = 1.0;
    s.dfg = split_sum(s.n_dot_v, perceptual_roughness);
    s = with_reflectance(s, dielectric_f0_color, specular_weight);
#ifdef MATERIAL_IRIDESCENCE
    // KHR_materials_iridescence: the film's strength and thickness (the thickness texture's
    // green picks within the range; without it, the maximum).
    var iridescence = material_extension.iridescence;
#ifdef IRIDESCENCE_TEXTURE
    iridescence *= extension_texel(iridescence_texture, iridescence_sampler, 10u, sets).r;
#endif
    let film_range = material_extension.iridescence_thickness;
    var film = film_range.y;
#ifdef IRIDESCENCE_THICKNESS_TEXTURE
    film = mix(film_range.x, film_range.y, extension_texel(iridescence_thickness_texture, iridescence_thickness_sampler, 11u, sets).g);
#endif
    s = with_iridescence(s, clamp(iridescence, 0.0, 1.0), material_extension.iridescence_ior, max(film, 0.0), dielectric_f0_color, specular_weight);
#endif
#ifdef MATERIAL_ANISOTROPY
    // KHR_materials_anisotropy: the direction in tangent space (the texture's, else the
    // tangent), turned by the rotation, placed in the geometry's tangent frame (mirrored on a
    // back face, as the normal map's).
    var anisotropy = material_extension.anisotropy_strength;
    var direction = vec2<f32>(1.0, 0.0);
#ifdef ANISOTROPY_TEXTURE
    let anisotropy_texel = extension_texel(anisotropy_texture, anisotropy_sampler, 9u, sets);
    direction = safe_normalize(vec3<f32>(anisotropy_texel.rg * 2.0 - 1.0, 0.0), vec3<f32>(1.0, 0.0, 0.0)).xy;
    anisotropy *= anisotropy_texel.b;
#endif
    let rotation = material_extension.anisotropy_direction;
    direction = vec2<f32>(
        rotation.x * direction.x - rotation.y * direction.y,
        rotation.y * direction.x + rotation.x * direction.y
    );
    let frame_n = safe_normalize(in.normal, v);
    let any_t = safe_normalize(cross(frame_n, select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(frame_n.x) > 0.9)), vec3<f32>(1.0, 0.0, 0.0));
    let frame_t = safe_normalize(in.tangent.xyz - frame_n * dot(frame_n, in.tangent.xyz), any_t);
    let frame_b = cross(frame_n, frame_t) * select(1.0, -1.0, in.tangent.w < 0.0);
    let facing = select(1.0, -1.0, double_sided_back);
    s = with_anisotropy(s, clamp(anisotropy, 0.0, 1.0), facing * (frame_t * direction.x + frame_b * direction.y));
#endif
#ifdef MATERIAL_SHEEN
    var sheen_color = material_extension.sheen_color;
#ifdef SHEEN_COLOR_TEXTURE
    sheen_color *= extension_texel(sheen_color_texture, sheen_color_sampler, 5u, sets).rgb;
#endif
    var sheen_roughness = material_extension.sheen_roughness;
#ifdef SHEEN_ROUGHNESS_TEXTURE
    sheen_roughness *= extension_texel(sheen_roughness_texture, sheen_roughness_sampler, 6u, sets).a;
#endif
    s = with_sheen(s, clamp(sheen_color, vec3<f32>(0.0), vec3<f32>(1.0)), sheen_roughness);
#endif
#ifdef MATERIAL_CLEARCOAT
    // The coat follows the geometry's normal, or its own normal map; not the base's.
    let coat_geometric_n = select(1.0, -1.0, double_sided_back) * safe_normalize(in.normal, v);
    var coat_n = coat_geometric_n;
#ifdef CLEARCOAT_NORMAL_MAP
    let cnm = extension_texel(clearcoat_normal_texture, clearcoat_normal_sampler, 4u, sets);
    if dot(in.tangent.xyz, in.tangent.xyz) > 1e-12 {
        let g = safe_normalize(in.normal, v);
        let flip = select(1.0, -1.0, double_sided_back);
        // The base's frame (see NORMAL_MAP) about the geometric normal, mirrored on a back face.
        let t0 = safe_normalize(in.tangent.xyz - g * dot(g, in.tangent.xyz), vec3<f32>(1.0, 0.0, 0.0));
        let b0 = cross(g, t0) * select(1.0, -1.0, in.tangent.w < 0.0);
        let ct = flip * t0;
        let cb = flip * b0;
        let scale = material_extension.clearcoat_normal_scale;
        let tn = (cnm.xyz * 2.0 - 1.0) * vec3<f32>(scale, scale, 1.0);
        coat_n = safe_normalize(ct * tn.x + cb * tn.y + coat_geometric_n * tn.z, coat_geometric_n);
    }
#endif
    var coat = material_extension.clearcoat;
#ifdef CLEARCOAT_TEXTURE
    coat *= extension_texel(clearcoat_texture, clearcoat_sampler, 2u, sets).r;
#endif
    var coat_roughness = material_extension.clearcoat_roughness;
#ifdef CLEARCOAT_ROUGHNESS_TEXTURE
    coat_roughness *= extension_texel(clearcoat_roughness_texture, clearcoat_roughness_sampler, 3u, sets).g;
#endif
    coat_roughness = clamp(coat_roughness, MIN_PERCEPTUAL_ROUGHNESS, 1.0);
    let coat_n_dot_v = max(dot(coat_n, v), 1e-4);
    s = with_coat(s, clamp(coat, 0.0, 1.0), coat_roughness, coat_n, split_sum(coat_n_dot_v, coat_roughness));
#endif
#ifdef MATERIAL_TRANSMISSION
    // KHR_materials_transmission: this share of the dielectric's diffuse lobe passes through
    // instead (metals transmit nothing); what it shows is added after the lights.
    var transmission = material_extension.transmission;
#ifdef TRANSMISSION_TEXTURE
    transmission *= extension_texel(transmission_texture, transmission_factor_sampler, 7u, sets).r;
#endif
    transmission = clamp(transmission, 0.0, 1.0);
    var thickness = material_extension.thickness;
#ifdef THICKNESS_TEXTURE
    thickness *= extension_texel(thickness_texture, thickness_sampler, 8u, sets).g;
#endif
    let volume_thickness = max(thickness, 0.0) * in.model_scale;
    s.transmission = transmission * (1.0 - metallic);
    s.transmission_tint = base.rgb * volume_attenuation(volume_thickness);
    let transmission_ior = max(material_extension.ior, 1.0);
    s.transmission_alpha = max(s.alpha * clamp(transmission_ior * 2.0 - 2.0, 0.0, 1.0), MIN_PERCEPTUAL_ROUGHNESS * MIN_PERCEPTUAL_ROUGHNESS);
    let transmitted = transmitted_light(s, in.rel_position, volume_thickness) * s.transmission * s.transmission_tint
        * (vec3<f32>(1.0) - dielectric_albedo(s));
    s.diffuse_color *= 1.0 - transmission;
#endif
#ifdef OCCLUSION_TEXTURE
#ifdef OCCLUSION_IN_METALLIC_ROUGHNESS
    // The same texel (glTF's ORM packing): occlusion is its red channel.
    let ao = mr;
#else
    let ao = material_texel(occlusion_texture, occlusion_sampler, mat, 3u, sets);
#endif
    s.occlusion = 1.0 + mat.occlusion_strength * (ao.r - 1.0);
#endif

#ifdef DEFERRED_LOCAL_LIGHTS
    frag.surface_shape = encode_surface(s);
    surface_alpha = s.perceptual_roughness;
#endif

    var color = vec3<f32>(0.0);
#ifdef SHADOWS
    // The interpolated vertex normal, not the normal-mapped one: the receiver offset must follow
    // the surface the shadow map saw.
    let geometric_n = safe_normalize(select(in.normal, -in.normal, double_sided_back), n);
#endif
    for (var i = 0u; i < view.global_light_count; i++) {
#ifdef GLOBAL_LIGHTS_IN_STORAGE
        let light = lights[i];
#else
        let light = global_lights[i];
#endif
        var lit = shade_light(s, light, in.rel_position, view.camera_position);
#ifdef SHADOWS
        if light.kind == LIGHT_DIRECTIONAL && any(lit > vec3<f32>(0.0)) {
            let n_dot_l = dot(geometric_n, -light.direction);
            let depth = view_depth(in.rel_position);
            lit *= directional_shadow(i, in.rel_position, geometric_n, n_dot_l, depth, in.clip_position.xy);
        }
#endif
        color += lit;
    }
#ifdef IBL
    color += environment_light(s);
#endif
#ifdef LOCAL_LIGHTS
#ifdef CLUSTERED_LIGHTS
    let range = cluster_ranges[fragment_cluster(grid, in.clip_position.xy, view_depth(in.rel_position))];
    for (var i = 0u; i < range.y; i++) {
        let slot = cluster_lights[range.x + i];
        let reach = lights[slot].range;
        if within_reach(lights[slot].position - view.camera_position, reach * reach, in.rel_position) {
            color += shade_light(s, lights[slot], in.rel_position, view.camera_position);
        }
    }
#else
    let local_end = view.global_light_count + view.local_light_count;
    for (var i = view.global_light_count; i < local_end; i++) {
        color += shade_light(s, lights[i], in.rel_position, view.camera_position);
    }
#endif
#endif
#ifdef MATERIAL_TRANSMISSION
    color += transmitted * sheen_base(s) * coat_base(s);
#endif
    var emissive = mat.emissive;
#ifdef EMISSIVE_TEXTURE
    emissive *= material_texel(emissive_texture, emissive_sampler, mat, 4u, sets).rgb;
#endif
    color += emissive;
#endif

    var out = color * view.exposure;
#ifdef DEBUG_CLUSTER_HEAT
    out = cluster_heat(in.clip_position.xy, in.rel_position);
#endif
#ifdef DEBUG_CASCADES
    // Tinted by cascade, shaded by the lit image's luminance so shapes and shadows still read.
    let luminance = dot(out, vec3<f32>(0.2126, 0.7152, 0.0722));
    out = cascade_tint(view_depth(in.rel_position)) * (0.25 + 0.75 * clamp(luminance, 0.0, 1.0));
#endif
#ifdef DEBUG_NORMALS
#ifdef UNLIT
    out = safe_normalize(in.normal, vec3<f32>(0.0, 0.0, 1.0)) * 0.5 + 0.5;
#else
    out = n * 0.5 + 0.5;
#endif
#endif
#ifdef DEBUG_UVS
    out = vec3<f32>(fract(in.uv0), 0.0);
#endif
    // No NaN or Inf may reach the render target: a NaN fails every comparison, so it becomes 0.
    // With deferred local lights their pass adds up to as much again, so each half stays below
    // half of f16's range and the sum cannot overflow to Inf.
#ifdef DEFERRED_LOCAL_LIGHTS
    let limit = 0.5 * F16_MAX;
#else
    let limit = F16_MAX;
#endif
    out = select(vec3<f32>(0.0), clamp(out, vec3<f32>(0.0), vec3<f32>(limit)), out == out);
#ifdef TONEMAP_IN_FORWARD
    // Nothing reads the HDR colour this frame: this pass writes the output itself.
    out = display_rgb(out);
#endif
    let alpha = clamp(base.a, 0.0, 1.0);
#ifdef ALPHA_BLEND
    // Premultiplied alpha: the blend state is (ONE, ONE_MINUS_SRC_ALPHA).
    frag.color = vec4<f32>(out * alpha, alpha);
#else
#ifdef DEFERRED_LOCAL_LIGHTS
    frag.color = vec4<f32>(out, surface_alpha);
#else
    frag.color = vec4<f32>(out, 1.0);
#endif
#endif
    return frag;
}

#ifdef VISIBILITY_SHADE
// Shading from the visibility buffer (features/visibility/): one thread per pixel finds the
// triangles its samples hold (visibility_raster.wgsl numbered them), shades each triangle of
// this dispatch's group once at the pixel's centre, as multisampling shades a fragment, and
// weighs it by the samples it covers. The vertices are placed as vs_main places them and
// interpolated perspective-correctly; the UV gradients are the fine derivatives a fragment of
// the same 2×2 quad would take. Groups (a pipeline variant and material
// textures each) add into `partial`; the last writes the pixel, with the clear colour or the
// environment (VISIBILITY_BACKGROUND) in the samples nothing covers.
//
// What it writes: HDR radiance (the frame goes on to post-processing and the tonemap pass), or,
// with VISIBILITY_DISPLAY, the displayed colour itself, sRGB-encoded, which the renderer copies
// into the output: each triangle's colour tonemapped before the samples are averaged (the
// display resolve, TONEMAP_IN_FORWARD) or the averaged radiance tonemapped (VISIBILITY_TONEMAP).
// VISIBILITY_OVERLAY (with OVERLAY_MULTISAMPLED): a hybrid frame's overlay is composited before
// the radiance is tonemapped (never with TONEMAP_IN_FORWARD), each overlay sample over its own
// sample's colour: a triangle's colour counts by the transparency of the overlay samples over
// the samples it covers, the background by that over the empty ones.
#import penumbra::visibility::{RasterBatch, FRONT_CW, NON_INDEXED, pixel_weights, sample_empty}
#ifdef VISIBILITY_BACKGROUND
#import penumbra::ibl::{environment, prefiltered_radiance}
#endif

struct ShadeParams {
    target_size: vec2<u32>,
    samples: u32,
    batch_count: u32,
    // This dispatch's group; whether an earlier group's sums are in `partial`; whether this is
    // the last group.
    group: u32,
    accumulate: u32,
    last: u32,
    // The environment shows where nothing is covered (else the clear colour).
    background: u32,
    // Exposed radiance shown where nothing is covered, without an environment.
    clear: vec4<f32>,
    // The overlay's rectangle (VISIBILITY_OVERLAY): its target's pixel (0, 0) is the frame's
    // pixel overlay_origin.
    overlay_origin: vec2<u32>,
    overlay_size: vec2<u32>,
};

@group(2) @binding(0) var<uniform> shade_params: ShadeParams;
@group(2) @binding(1) var<storage, read> vis: array<vec2<u32>>;
@group(2) @binding(2) var<storage, read> raster_batches: array<RasterBatch>;
// Per batch its first triangle number, then the total (visibility_raster.wgsl).
@group(2) @binding(3) var<storage, read> first_numbers: array<u32>;
@group(2) @binding(4) var<storage, read> pool_indices: array<u32>;
@group(2) @binding(5) var<storage, read_write> partial: array<vec4<f32>>;
#ifdef VISIBILITY_DISPLAY
@group(2) @binding(6) var shaded: texture_storage_2d<rgba8unorm, write>;
#else
@group(2) @binding(6) var shaded: texture_storage_2d<rgba16float, write>;
#endif
#ifdef VISIBILITY_REUSE
// The second shading of a frame with transmissive draws: the first wrote each pixel's opaque
// colour (exposed radiance) into the transmission copy's level 0, which its draws read.
@group(2) @binding(8) var first_shading: texture_2d<f32>;
#endif
#ifdef VISIBILITY_OVERLAY
// A hybrid frame's overlay (features/visibility/overlay.rs): what the forward pass drew over the
// visibility buffer, premultiplied, with its coverage in alpha.
#ifdef OVERLAY_MULTISAMPLED
@group(2) @binding(7) var overlay: texture_multisampled_2d<f32>;
#else
@group(2) @binding(7) var overlay: texture_2d<f32>;
#endif
#endif

fn number_batch(number: u32) -> u32 {
    var lo = 0u;
    var hi = shade_params.batch_count;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if first_numbers[mid] <= number {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

fn mix3_2(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, w: vec3<f32>) -> vec2<f32> {
    return a * w.x + b * w.y + c * w.z;
}

// The colour of triangle `number` (of batch `b`) at the pixel whose centre is `frag_xy`.
fn shade_triangle(number: u32, b: u32, frag_xy: vec2<f32>) -> vec3<f32> {
    let batch = raster_batches[b];
    let local = number - first_numbers[b];
    let inst = instances[draw_slots[batch.first + local / batch.triangle_count]];
    let triangle = local % batch.triangle_count;
    var vertices: vec3<u32>;
    if (batch.flags & NON_INDEXED) != 0u {
        let v = batch.index_start + 3u * triangle;
        vertices = vec3<u32>(v, v + 1u, v + 2u);
    } else {
        let at = batch.index_start + 3u * triangle;
        vertices = batch.vertex_start + vec3<u32>(pool_indices[at], pool_indices[at + 1u], pool_indices[at + 2u]);
    }
    let a = vertex_out(inst, pool_vertex(vertices.x));
    let bv = vertex_out(inst, pool_vertex(vertices.y));
    let c = vertex_out(inst, pool_vertex(vertices.z));
    let ca = a.clip_position.xyw;
    let cb = bv.clip_position.xyw;
    let cc = c.clip_position.xyw;
    let r = array<vec3<f32>, 3>(cross(cb, cc), cross(cc, ca), cross(ca, cb));
    let pw = pixel_weights(r, frag_xy, shade_params.target_size);
    let w = pw.centre;
    let left = pw.left;
    let right = pw.right;
    let top = pw.top;
    let bottom = pw.bottom;
    // The winding as the rasteriser sees it: the determinant's sign is the projected
    // triangle's orientation in normalised device coordinates (y up) when all w are positive.
    let det = dot(ca, r[0]);
    let front_facing = (det > 0.0) != ((batch.flags & FRONT_CW) != 0u);

    var v: VertexOut;
    v.clip_position = vec4<f32>(frag_xy, 0.0, 1.0);
    v.rel_position = a.rel_position * w.x + bv.rel_position * w.y + c.rel_position * w.z;
    v.normal = a.normal * w.x + bv.normal * w.y + c.normal * w.z;
    v.tangent = a.tangent * w.x + bv.tangent * w.y + c.tangent * w.z;
    v.uv0 = mix3_2(a.uv0, bv.uv0, c.uv0, w);
    v.uv1 = mix3_2(a.uv1, bv.uv1, c.uv1, w);
#ifdef VERTEX_COLORS
    v.color = a.color * w.x + bv.color * w.y + c.color * w.z;
#endif
    v.material = inst.material;
    let sets = UvSets(
        v.uv0,
        v.uv1,
        mix3_2(a.uv0, bv.uv0, c.uv0, right) - mix3_2(a.uv0, bv.uv0, c.uv0, left),
        mix3_2(a.uv0, bv.uv0, c.uv0, bottom) - mix3_2(a.uv0, bv.uv0, c.uv0, top),
        mix3_2(a.uv1, bv.uv1, c.uv1, right) - mix3_2(a.uv1, bv.uv1, c.uv1, left),
        mix3_2(a.uv1, bv.uv1, c.uv1, bottom) - mix3_2(a.uv1, bv.uv1, c.uv1, top),
    );
    return shade(v, front_facing, sets).color.rgb;
}

// What nothing covered shows at the pixel centre `frag_xy`: the environment or the clear colour,
// as the background pass or the cleared samples of a resolve do.
fn shown_behind(frag_xy: vec2<f32>, size: vec2<u32>) -> vec3<f32> {
    var behind = shade_params.clear.rgb;
#ifdef VISIBILITY_BACKGROUND
    if shade_params.background != 0u {
        let ndc = vec2<f32>(-1.0, 1.0) + frag_xy * vec2<f32>(2.0, -2.0) / vec2<f32>(size);
        let near = view.rel_from_clip * vec4<f32>(ndc, 1.0, 1.0);
        var dir = safe_normalize(near.xyz / near.w, view.camera_forward);
        if view.is_orthographic != 0u {
            dir = view.camera_forward;
        }
        let radiance = prefiltered_radiance(dir, environment.background_lod / max(environment.max_lod, 1.0)) * view.exposure;
        behind = select(vec3<f32>(0.0), clamp(radiance, vec3<f32>(0.0), vec3<f32>(F16_MAX)), radiance == radiance);
    }
#endif
#ifdef TONEMAP_IN_FORWARD
    // The display resolve: the covered samples hold tonemapped colours already.
    behind = display_rgb(behind);
#endif
    return behind;
}

#ifdef VISIBILITY_OVERLAY
// The sum of the overlay's (premultiplied) colours at the frame's pixel `at` (`overlay_pixel`).
fn overlay_sum(at: vec3<u32>, samples: u32) -> vec3<f32> {
    var over = vec3<f32>(0.0);
    if at.z != 0u {
        for (var s = 0u; s < samples; s++) {
            over += overlay_sample(at.xy, s).rgb;
        }
    }
    return over;
}

// What the overlay lets through over the samples in `mask` (all of each outside its rectangle).
fn through_sum(at: vec3<u32>, mask: u32, samples: u32) -> f32 {
    if at.z == 0u {
        return f32(countOneBits(mask));
    }
    var seen = 0.0;
    for (var s = 0u; s < samples; s++) {
        if (mask & (1u << s)) != 0u {
            seen += 1.0 - overlay_sample(at.xy, s).a;
        }
    }
    return seen;
}

// Whether the frame's pixel `at` lies in the overlay's rectangle; its pixel there.
fn overlay_pixel(at: vec2<u32>) -> vec3<u32> {
    let local = at - shade_params.overlay_origin;
    let inside = all(at >= shade_params.overlay_origin) && all(local < shade_params.overlay_size);
    return vec3<u32>(local, u32(inside));
}

// The overlay's sample `s` at its pixel `local` (premultiplied colour, coverage in alpha).
fn overlay_sample(local: vec2<u32>, s: u32) -> vec4<f32> {
#ifdef OVERLAY_MULTISAMPLED
    return textureLoad(overlay, local, i32(s));
#else
    return textureLoad(overlay, local, 0);
#endif
}
#endif

@compute @workgroup_size(8, 8)
fn cs_shade(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = shade_params.target_size;
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let pixel = id.y * size.x + id.x;
    let samples = shade_params.samples;
    let frag_xy = vec2<f32>(id.xy) + 0.5;
    var sum = vec4<f32>(0.0);
    if shade_params.accumulate != 0u {
        sum = partial[pixel];
    }
#ifdef VISIBILITY_OVERLAY
    let local = overlay_pixel(id.xy);
#endif
    // Samples already shaded (with an earlier sample of the same triangle) or empty.
    var done = 0u;
#ifdef VISIBILITY_REUSE
    // A pixel whose samples all hold one triangle, or all none, has its colour from the first
    // shading; only the others (edges, and pixels partly empty) are shaded again.
    let head = vis[pixel * samples];
    var reused = true;
    for (var j = 1u; j < samples; j++) {
        let u = vis[pixel * samples + j];
        let both_empty = sample_empty(u) && sample_empty(head);
        reused = reused && (both_empty || (!sample_empty(u) && !sample_empty(head) && u.x == head.x));
    }
    if reused {
        done = (1u << samples) - 1u;
    }
#endif
    let weight = 1.0 / f32(samples);
    for (var i = 0u; i < samples; i++) {
        if (done & (1u << i)) != 0u {
            continue;
        }
        let v = vis[pixel * samples + i];
        if sample_empty(v) {
            continue;
        }
        var count = 0u;
        var mask = 0u;
        for (var j = i; j < samples; j++) {
            let u = vis[pixel * samples + j];
            if !sample_empty(u) && u.x == v.x {
                done |= 1u << j;
                mask |= 1u << j;
                count++;
            }
        }
        let b = number_batch(v.x);
        if raster_batches[b].shade_group != shade_params.group {
            continue;
        }
        var seen = f32(count);
#ifdef VISIBILITY_OVERLAY
        seen = through_sum(local, mask, samples);
#endif
        // rgb: as much as the overlay lets through; alpha: the samples covered.
        sum += vec4<f32>(shade_triangle(v.x, b, frag_xy) * seen, f32(count)) * weight;
    }
    if shade_params.last == 0u {
        partial[pixel] = sum;
        return;
    }
    var rgb = sum.rgb;
#ifdef VISIBILITY_OVERLAY
    var empty = 0u;
    for (var j = 0u; j < samples; j++) {
        if sample_empty(vis[pixel * samples + j]) {
            empty |= 1u << j;
        }
    }
#ifdef VISIBILITY_REUSE
    if reused {
        rgb = textureLoad(first_shading, id.xy, 0).rgb * (through_sum(local, (1u << samples) - 1u, samples) * weight);
        empty = 0u;
    }
#endif
    // The empty samples show what is behind as far as the overlay lets them, and each overlay
    // sample adds its own colour (premultiplied).
    if empty != 0u {
        rgb += shown_behind(frag_xy, size) * (through_sum(local, empty, samples) * weight);
    }
    rgb += overlay_sum(local, samples) * weight;
#else
    if sum.a < 1.0 {
        rgb += shown_behind(frag_xy, size) * (1.0 - sum.a);
    }
#endif
#ifdef VISIBILITY_TONEMAP
    rgb = display_rgb(rgb);
#endif
#ifdef VISIBILITY_DISPLAY
    rgb = srgb_encode(clamp(rgb, vec3<f32>(0.0), vec3<f32>(1.0)));
#endif
    textureStore(shaded, id.xy, vec4<f32>(rgb, 1.0));
}
#endif
