//! The CPU reference binner: the same walk as `shaders/cluster_bin.wgsl`, one light at a time,
//! producing each cluster's sorted list of light slots. Tests compare the GPU's lists with it.

use glam::UVec3;

use super::grid::ClusterGrid;
use crate::resources::light_store::GpuLight;

/// Sorted light slots per cluster, for the local lights `lights` stored from slot `first`.
pub fn bin(grid: &ClusterGrid, lights: &[GpuLight], first: u32) -> Vec<Vec<u32>> {
    bin_scaled(grid, lights, first, 1.0)
}

/// As [`bin`], with every light's range multiplied by `range_scale`. Binning with a range a
/// hair smaller and a hair larger brackets what any correct implementation may produce when
/// its rounding differs from this one's: a test scene whose two bracketing lists are equal has
/// no light within rounding of a cluster boundary, so there the GPU must match exactly.
pub fn bin_scaled(grid: &ClusterGrid, lights: &[GpuLight], first: u32, range_scale: f32) -> Vec<Vec<u32>> {
    let mut lists = vec![Vec::new(); grid.cluster_count() as usize];
    for (i, light) in lights.iter().enumerate() {
        let mut light = *light;
        light.range *= range_scale;
        let b = grid.light_bounds(&light);
        let bx = grid.candidate_box(&b, super::grid::CANDIDATE_MARGIN);
        for k in bx.lo[2]..=bx.hi[2] {
            for j in bx.lo[1]..=bx.hi[1] {
                for i_tile in bx.lo[0]..=bx.hi[0] {
                    let c = UVec3::new(i_tile as u32, j as u32, k as u32);
                    if grid.touches(&b, c) {
                        lists[grid.cluster_id(c) as usize].push(first + i as u32);
                    }
                }
            }
        }
    }
    // Lights are visited in slot order, so every list is already sorted.
    lists
}
