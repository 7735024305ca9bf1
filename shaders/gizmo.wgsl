// Gizmo lines (axes, selection boxes, scripts' debug lines): camera-relative endpoints, drawn in
// the forward pass after the scene, depth-tested against it without writing depth. Each line is
// a quad a pixel wide (line_quads.wgsl), six vertices that each carry both ends. The colour
// is display-referred: it is written as is, not multiplied by the exposure, so red stays red
// however bright the scene is. Alpha 1 marks the pixel covered (the background composite leaves
// it alone). VISIBILITY_OCCLUSION: drawn over the visibility buffer in a hybrid frame, tested
// against its depth (visibility_occlusion.wgsl).

#import penumbra::view::View
#import penumbra::line_quads::{behind_eye_fraction, line_corner}
#ifdef VISIBILITY_OCCLUSION
#import penumbra::visibility_occlusion::{OcclusionParams, first_sample, overlay_clip, unoccluded_mask}
#endif

@group(0) @binding(0) var<uniform> view: View;
#ifdef VISIBILITY_OCCLUSION
// A hybrid frame's visibility buffer (visibility_occlusion.wgsl).
@group(1) @binding(0) var<storage, read> occluders: array<vec2<u32>>;
@group(1) @binding(1) var<uniform> occlusion: OcclusionParams;
#endif

struct VertexIn {
    @location(0) rel_position: vec3<f32>,
    @location(1) other_rel_position: vec3<f32>,
    @location(2) color: vec3<f32>,
    // Bit 0: the side of the line; bit 1: this is the segment's second end.
    @location(3) corner: u32,
};

struct VertexOut {
    @builtin(position) position: vec4<f32>,
    @location(0) color: vec3<f32>,
};

@vertex
fn vs_main(in: VertexIn) -> VertexOut {
    var out: VertexOut;
    var clip = view.clip_from_rel * vec4<f32>(in.rel_position, 1.0);
    let other_clip = view.clip_from_rel * vec4<f32>(in.other_rel_position, 1.0);
    // One colour along the line: only the position moves with an end behind the eye.
    clip = mix(clip, other_clip, behind_eye_fraction(clip, other_clip));
    let side = select(-1.0, 1.0, (in.corner & 1u) != 0u);
    out.position = line_corner(clip, other_clip, side, (in.corner & 2u) != 0u, view.target_size);
#ifdef VISIBILITY_OCCLUSION
    // Into the hybrid frame's overlay, which covers a rectangle of the frame.
    out.position = overlay_clip(out.position, occlusion);
#endif
    out.color = in.color;
    return out;
}

struct FragmentOut {
    @location(0) color: vec4<f32>,
#ifdef VISIBILITY_OCCLUSION
    @builtin(sample_mask) coverage: u32,
#endif
};

@fragment
fn fs_main(in: VertexOut) -> FragmentOut {
    var out: FragmentOut;
    out.color = vec4<f32>(max(in.color, vec3<f32>(0.0)), 1.0);
#ifdef VISIBILITY_OCCLUSION
    let dz = vec2<f32>(dpdxFine(in.position.z), dpdyFine(in.position.z));
    let first = first_sample(in.position, occlusion);
    var held = vec4<f32>(0.0);
    for (var k = 0u; k < min(occlusion.samples, 4u) && first != 0xffffffffu; k++) {
        held[k] = bitcast<f32>(occluders[first + k].y);
    }
    out.coverage = select(0u, unoccluded_mask(in.position, dz, true, held, occlusion.samples), first != 0xffffffffu);
    if out.coverage == 0u {
        discard;
    }
#endif
    return out;
}
