// A hybrid frame's hand-over (features/visibility/hand_over.rs): after the visibility buffer's
// samples were shaded, the draws only the forward pass rasterises (blended draws, gizmo lines)
// are drawn over them in a render pass that needs what opaque draws would have left there:
// each sample's depth and, multisampled, each sample's colour. One full-screen triangle, run
// once per sample (`sample_index`), writes the sample's depth from the visibility buffer (the
// far plane, 0 in reverse-Z, where nothing covers it) and, with MULTISAMPLED, the pixel's
// resolved colour into each of its samples: averaging them again gives the same colour back.

#import penumbra::common::fullscreen_position

// The prefix of visibility_raster.wgsl's RasterParams this pass reads.
struct HandOverParams {
    target_size: vec2<u32>,
    samples: u32,
};

@group(0) @binding(0) var<storage, read> vis: array<vec2<u32>>;
@group(0) @binding(1) var<uniform> params: HandOverParams;
#ifdef MULTISAMPLED
@group(0) @binding(2) var shaded: texture_2d<f32>;
#endif

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    return fullscreen_position(i);
}

struct HandOver {
    @builtin(frag_depth) depth: f32,
#ifdef MULTISAMPLED
    @location(0) color: vec4<f32>,
#endif
};

@fragment
fn fs_main(@builtin(position) position: vec4<f32>, @builtin(sample_index) sample: u32) -> HandOver {
    let at = vec2<u32>(position.xy);
    let v = vis[(at.y * params.target_size.x + at.x) * params.samples + sample];
    var out: HandOver;
    // An empty sample holds 0: the far plane's depth.
    out.depth = bitcast<f32>(v.y);
#ifdef MULTISAMPLED
    out.color = textureLoad(shaded, at, 0);
#endif
    return out;
}
