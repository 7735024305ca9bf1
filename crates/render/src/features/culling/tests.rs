//! Tests of `culling`.

use super::*;

#[test]
fn gpu_cull_batch_mirrors_the_shaders_batch() {
    crate::pipelines::shader_library::assert_mirrors_wgsl!(
        GpuCullBatch,
        "cull.wgsl",
        [],
        "CullBatch",
        [center, first, half_extent, triangles_first, index_start, triangle_count, vertex_start, flags]
    );
}

#[test]
fn the_dispatch_grid_covers_every_group_within_the_limit() {
    for (groups, limit) in [(1, 65535), (65535, 65535), (65536, 65535), (1 << 24, 65535), (9, 3), (7, 3)] {
        let (x, y) = dispatch_grid(groups, limit);
        assert!(x <= limit && y <= limit, "{groups}: {x}x{y}");
        assert!(x * y >= groups, "{groups}: {x}x{y}");
    }
}
