// Gizmo lines (axes, selection boxes, scripts' debug lines): camera-relative endpoints, drawn in
// the forward pass after the scene, depth-tested against it without writing depth. The colour
// is display-referred: it is written as is, not multiplied by the exposure, so red stays red
// however bright the scene is. Alpha 1 marks the pixel covered (the background composite leaves
// it alone).

#import penumbra::view::View

@group(0) @binding(0) var<uniform> view: View;

struct VertexIn {
    @location(0) rel_position: vec3<f32>,
    @location(1) color: vec3<f32>,
};

struct VertexOut {
    @builtin(position) position: vec4<f32>,
    @location(0) color: vec3<f32>,
};

@vertex
fn vs_main(in: VertexIn) -> VertexOut {
    var out: VertexOut;
    out.position = view.clip_from_rel * vec4<f32>(in.rel_position, 1.0);
    out.color = in.color;
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    return vec4<f32>(max(in.color, vec3<f32>(0.0)), 1.0);
}
