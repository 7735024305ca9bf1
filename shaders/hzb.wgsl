// The hierarchical depth buffer for occlusion culling (see shaders/cull.wgsl and
// crates/render/src/features/culling/): level 0 is the largest power of two no bigger than the
// frame in each dimension; each texel holds the farthest depth (reverse-Z: the smallest value)
// of every sample of the frame's depth that its footprint touches, and each further level the
// farthest of the 2×2 texels below it. A box nearer than the farthest depth over its rectangle
// may be visible; a box behind it cannot be.

#ifdef FROM_DEPTH
#ifdef MULTISAMPLED
@group(0) @binding(0) var depth: texture_depth_multisampled_2d;
#else
@group(0) @binding(0) var depth: texture_depth_2d;
#endif
#else
@group(0) @binding(0) var finer: texture_2d<f32>;
#endif
@group(0) @binding(1) var coarser: texture_storage_2d<r32float, write>;

@compute @workgroup_size(8, 8)
fn reduce(@builtin(global_invocation_id) id: vec3<u32>) {
    let out_size = textureDimensions(coarser);
    if id.x >= out_size.x || id.y >= out_size.y {
        return;
    }
    var farthest = 1.0;
#ifdef FROM_DEPTH
    // This texel's footprint in the frame: between one and three texels each way, since the
    // level is between half the frame's size and the frame's size.
    let in_size = textureDimensions(depth);
    let ratio = vec2<f32>(in_size) / vec2<f32>(out_size);
    let lo = vec2<u32>(floor(vec2<f32>(id.xy) * ratio));
    let hi = min(vec2<u32>(ceil(vec2<f32>(id.xy + 1u) * ratio)), in_size) - 1u;
    for (var y = lo.y; y <= hi.y; y++) {
        for (var x = lo.x; x <= hi.x; x++) {
#ifdef MULTISAMPLED
            for (var s = 0; s < i32(textureNumSamples(depth)); s++) {
                farthest = min(farthest, textureLoad(depth, vec2<u32>(x, y), s));
            }
#else
            farthest = min(farthest, textureLoad(depth, vec2<u32>(x, y), 0));
#endif
        }
    }
#else
    let in_size = textureDimensions(finer);
    let base = id.xy * 2u;
    for (var dy = 0u; dy < 2u; dy++) {
        for (var dx = 0u; dx < 2u; dx++) {
            let p = min(base + vec2<u32>(dx, dy), in_size - 1u);
            farthest = min(farthest, textureLoad(finer, p, 0).x);
        }
    }
#endif
    textureStore(coarser, id.xy, vec4<f32>(farthest, 0.0, 0.0, 0.0));
}
