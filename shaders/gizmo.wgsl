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
#import penumbra::visibility_occlusion::unoccluded_samples
#endif

@group(0) @binding(0) var<uniform> view: View;

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
    out.coverage = unoccluded_samples(in.position, dz, true);
    if out.coverage == 0u {
        discard;
    }
#endif
    return out;
}
