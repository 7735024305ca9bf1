// What the visibility buffer's raster pass (visibility_raster.wgsl) and its shading pass
// (forward.wgsl, VISIBILITY_SHADE) agree on: the batch table that turns a triangle number
// back into its batch, instance and vertices, a visibility sample's layout, and how a point of
// a triangle is interpolated.
#define_import_path penumbra::visibility

// One opaque batch as rasterised (mirrors `GpuRasterBatch` in features/visibility/).
struct RasterBatch {
    // Where the batch's visible instances start in `visible_slots`.
    first: u32,
    // The mesh's first index in the pool (or first vertex, NON_INDEXED) and first vertex.
    index_start: u32,
    vertex_start: u32,
    triangle_count: u32,
    // CULL_BACK, FRONT_CW, NON_INDEXED.
    flags: u32,
    // The word of the cull pass's arguments that holds the batch's visible instance count.
    count_word: u32,
    // The shading dispatch that shades the batch's samples (its pipeline and material).
    shade_group: u32,
    _pad: u32,
};

const CULL_BACK: u32 = 1u;
const FRONT_CW: u32 = 2u;
const NON_INDEXED: u32 = 4u;

// A sample of the visibility buffer, read as two words: the triangle number (low) and the
// depth's bits (high; 0 for an empty sample).
fn sample_empty(v: vec2<u32>) -> bool {
    return v.y == 0u;
}

// Barycentric weights of the point at normalised device coordinates `ndc` on the triangle with
// clip positions whose (x, y, w) are the rows' cross products `r` (`r[0] = b × c` and so on):
// perspective-correct, the weights of the 3D point the pixel's ray meets, for vertices behind
// the eye too.
fn perspective_weights(r: array<vec3<f32>, 3>, ndc: vec2<f32>) -> vec3<f32> {
    let s = vec3<f32>(ndc, 1.0);
    let k = vec3<f32>(dot(r[0], s), dot(r[1], s), dot(r[2], s));
    let sum = k.x + k.y + k.z;
    return select(vec3<f32>(1.0 / 3.0), k / sum, abs(sum) > 0.0);
}

// A pixel's weights and those its fine derivatives take: across the pixel's 2×2 quad, the
// right pixel's value less the left's (in its row) and the bottom's less the top's (in its
// column), as a fragment of that quad would get them.
struct PixelWeights {
    centre: vec3<f32>,
    left: vec3<f32>,
    right: vec3<f32>,
    top: vec3<f32>,
    bottom: vec3<f32>,
};

// `perspective_weights` at the pixel whose centre is `frag_xy` (framebuffer coordinates, y
// down) of a `size` target, and at its quad's neighbours.
fn pixel_weights(r: array<vec3<f32>, 3>, frag_xy: vec2<f32>, size: vec2<u32>) -> PixelWeights {
    let to_ndc = vec2<f32>(2.0, -2.0) / vec2<f32>(size);
    let at_ndc = vec2<f32>(-1.0, 1.0);
    let quad = floor(frag_xy * 0.5) * 2.0 + 0.5;
    return PixelWeights(
        perspective_weights(r, at_ndc + frag_xy * to_ndc),
        perspective_weights(r, at_ndc + vec2<f32>(quad.x, frag_xy.y) * to_ndc),
        perspective_weights(r, at_ndc + vec2<f32>(quad.x + 1.0, frag_xy.y) * to_ndc),
        perspective_weights(r, at_ndc + vec2<f32>(frag_xy.x, quad.y) * to_ndc),
        perspective_weights(r, at_ndc + vec2<f32>(frag_xy.x, quad.y + 1.0) * to_ndc),
    );
}
