// Shadow casters: depth only, into one layer of the shadow atlas per pass (see shadows.wgsl for
// how it is read). Vertices are placed exactly as the forward shader places them
// (draw_data::place_vertex), relative to the camera, then by the cascade's light projection.
// ALPHA_MASK casters discard where the base colour's alpha is below the cutoff, so foliage casts
// leaf-shaped shadows; opaque casters have no fragment stage at all.

#import penumbra::draw_data::{Instance, Material, place_vertex}
#ifdef ALPHA_MASK
#import penumbra::draw_data::{UvSets, slot_coord}
#endif

struct CasterView {
    clip_from_rel: mat4x4<f32>,
    camera_position: vec3<f32>,
    // Where this map's draw list starts in `draw_slots`: 0 for the full draw list; a culled
    // map's own list lies at its place among the lists shadow_cull.wgsl wrote.
    slot_base: u32,
};

@group(0) @binding(0) var<uniform> caster: CasterView;
@group(0) @binding(1) var<storage, read> instances: array<Instance>;
@group(0) @binding(2) var<storage, read> draw_slots: array<u32>;
#ifdef ALPHA_MASK
@group(0) @binding(3) var<storage, read> materials: array<Material>;
@group(1) @binding(0) var base_color_texture: texture_2d<f32>;
@group(1) @binding(1) var base_color_sampler: sampler;
#endif

struct VertexIn {
    @builtin(instance_index) instance_index: u32,
    @location(0) position: vec3<f32>,
    @location(3) uv0: vec2<f32>,
    @location(4) uv1: vec2<f32>,
    @location(5) color: vec4<f32>,
};

struct VertexOut {
    @builtin(position) clip_position: vec4<f32>,
#ifdef ALPHA_MASK
    @location(0) uv0: vec2<f32>,
    @location(1) uv1: vec2<f32>,
    @location(2) alpha: f32,
    @location(3) @interpolate(flat) material: u32,
#endif
};

@vertex
fn vs_main(in: VertexIn) -> VertexOut {
    let inst = instances[draw_slots[caster.slot_base + in.instance_index]];
    let placed = place_vertex(inst, in.position, caster.camera_position);
    var out: VertexOut;
    out.clip_position = caster.clip_from_rel * vec4<f32>(placed.rel, 1.0);
#ifdef ALPHA_MASK
    out.uv0 = in.uv0;
    out.uv1 = in.uv1;
    out.alpha = in.color.a;
    out.material = inst.material;
#endif
    return out;
}

#ifdef ALPHA_MASK
@fragment
fn fs_main(in: VertexOut) {
    let mat = materials[in.material];
    var alpha = mat.base_color.a * in.alpha;
#ifdef BASE_COLOR_TEXTURE
    let sets = UvSets(in.uv0, in.uv1, dpdx(in.uv0), dpdy(in.uv0), dpdx(in.uv1), dpdy(in.uv1));
    let bc = slot_coord(mat, 0u, sets);
    alpha *= textureSampleGrad(base_color_texture, base_color_sampler, bc.uv, bc.ddx, bc.ddy).a;
#endif
    // NaN alpha casts nothing, as forward.wgsl cuts it out.
    if !(alpha >= mat.alpha_cutoff) {
        discard;
    }
}
#endif
