// A hybrid frame with transmissive draws (crates/render/src/features/visibility/mod.rs): the
// shading pass wrote the opaque colour into the transmission copy's level 0, which the
// transmissive draws in the overlay read; this pass then writes the frame's HDR colour, the
// overlay's samples over the opaque colour. Blending is linear, so the mean of the samples
// blended over one colour is their mean blended over it (as the shading pass composites when no
// copy is needed). Outside the overlay's rectangle nothing was drawn over the opaque colour.
// VISIBILITY_DISPLAY (with display.wgsl's tonemap switches): the displayed colour instead,
// sRGB-encoded, which the renderer copies into the output (no tonemap pass).

#ifdef VISIBILITY_DISPLAY
#import penumbra::display::{display_rgb, srgb_encode}
#endif

struct CompositeParams {
    // The overlay's rectangle: its target's pixel (0, 0) is the frame's pixel `origin`.
    origin: vec2<u32>,
    size: vec2<u32>,
};

@group(0) @binding(0) var<uniform> params: CompositeParams;
@group(0) @binding(1) var opaque: texture_2d<f32>;
#ifdef OVERLAY_MULTISAMPLED
@group(0) @binding(2) var overlay: texture_multisampled_2d<f32>;
#else
@group(0) @binding(2) var overlay: texture_2d<f32>;
#endif
#ifdef VISIBILITY_DISPLAY
@group(0) @binding(3) var written: texture_storage_2d<rgba8unorm, write>;
#else
@group(0) @binding(3) var written: texture_storage_2d<rgba16float, write>;
#endif

@compute @workgroup_size(8, 8)
fn cs_composite(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(written);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    var rgb = textureLoad(opaque, id.xy, 0).rgb;
    let at = id.xy - params.origin;
    if all(id.xy >= params.origin) && all(at < params.size) {
#ifdef OVERLAY_MULTISAMPLED
        let samples = textureNumSamples(overlay);
        var over = vec4<f32>(0.0);
        for (var s = 0u; s < samples; s++) {
            over += textureLoad(overlay, at, i32(s));
        }
        over /= f32(samples);
#else
        let over = textureLoad(overlay, at, 0);
#endif
        rgb = over.rgb + rgb * (1.0 - over.a);
    }
#ifdef VISIBILITY_DISPLAY
    rgb = srgb_encode(clamp(display_rgb(rgb), vec3<f32>(0.0), vec3<f32>(1.0)));
#endif
    textureStore(written, id.xy, vec4<f32>(rgb, 1.0));
}
