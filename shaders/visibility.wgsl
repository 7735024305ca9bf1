// What the visibility buffer's raster pass (visibility_raster.wgsl) and its shading pass
// (forward.wgsl, VISIBILITY_SHADE) agree on: the batch table that turns a triangle number
// back into its batch, instance and vertices, and a visibility sample's layout.
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
