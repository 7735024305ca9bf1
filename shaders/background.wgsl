// The background: where no surface was drawn (depth still at the cleared far plane, 0 in
// reverse-Z), the environment along the pixel's view ray, sharp or blurred (a mip of the
// specular cube); exposed like the scene and clamped to f16. (A solid background is the forward
// pass's clear colour; this pass does not run for it.)

#import penumbra::common::{F16_MAX, fullscreen_position, safe_normalize}
#import penumbra::view::View
#import penumbra::ibl::{environment, prefiltered_radiance}

@group(0) @binding(0) var<uniform> view: View;

struct VertexOut {
    // Invariant: the depth test compares it for equality with the cleared far plane.
    @builtin(position) @invariant position: vec4<f32>,
    @location(0) ndc: vec2<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> VertexOut {
    var out: VertexOut;
    out.position = fullscreen_position(i);
    out.ndc = out.position.xy;
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    // A point on the near plane (reverse-Z: depth 1), seen from the camera at the origin.
    let near = view.rel_from_clip * vec4<f32>(in.ndc, 1.0, 1.0);
    var dir = safe_normalize(near.xyz / near.w, view.camera_forward);
    if view.is_orthographic != 0u {
        dir = view.camera_forward;
    }
    let radiance = prefiltered_radiance(dir, environment.background_lod / max(environment.max_lod, 1.0));
    let out = radiance * view.exposure;
    return vec4<f32>(select(vec3<f32>(0.0), clamp(out, vec3<f32>(0.0), vec3<f32>(F16_MAX)), out == out), 1.0);
}
