//! Culling's results read back for tests and tools (each waits for the GPU): instances each
//! batch drew, and triangles each triangle-culled batch drew.

use super::*;

impl GpuCulling {
    /// Triangles each opaque batch drew in the last frame that culled triangles (`None` for a
    /// batch drawing instances). Reads back; tests and tools.
    pub fn read_triangle_counts(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Option<Vec<Option<u32>>>, ReadbackError> {
        if !self.triangles_active() || self.batch_count == 0 {
            return Ok(None);
        }
        let bytes = self.batch_count as u64 * ARGS_WORDS * 4;
        let counts = |buffer: &wgpu::Buffer| -> Result<Vec<u32>, ReadbackError> {
            let words: Vec<u32> = bytemuck::pod_collect_to_vec(&readback::read_buffer(device, queue, buffer, bytes)?);
            // A batch's index count is its triangles' indices.
            Ok(words.chunks_exact(ARGS_WORDS as usize).map(|w| w[0] / 3).collect())
        };
        let mut drawn = counts(self.args.buffer())?;
        if self.occlusion {
            for (d, late) in drawn.iter_mut().zip(counts(self.late_args.buffer())?) {
                *d += late;
            }
        }
        Ok(Some(drawn.into_iter().zip(self.triangle_batches.iter()).map(|(n, &culled)| culled.then_some(n)).collect()))
    }

    /// Instances each opaque batch drew in the last culled frame (reads back; tests and tools).
    pub fn read_visible_counts(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Vec<u32>, ReadbackError> {
        if self.batch_count == 0 {
            return Ok(Vec::new());
        }
        let n = self.batch_count as u64;
        // Without triangle culling only the arguments; with it, after the hidden-count word,
        // each triangle-culled batch's count of the instances it drew.
        let tail = if self.triangles_active() { 4 * (1 + n) } else { 0 };
        let counts = |buffer: &wgpu::Buffer| -> Result<Vec<u32>, ReadbackError> {
            let bytes = n * ARGS_WORDS * 4 + tail;
            let words: Vec<u32> = bytemuck::pod_collect_to_vec(&readback::read_buffer(device, queue, buffer, bytes)?);
            let (args, rest) = words.split_at((n * ARGS_WORDS) as usize);
            let drawn = rest.get(1..).unwrap_or(&[]);
            Ok(args
                .chunks_exact(ARGS_WORDS as usize)
                .enumerate()
                .map(|(i, w)| match (self.triangle_batches.get(i), drawn.get(i)) {
                    (Some(true), Some(&d)) if self.triangles_active() => d,
                    _ => w[1],
                })
                .collect())
        };
        let mut drawn = counts(self.args.buffer())?;
        if self.occlusion {
            for (d, late) in drawn.iter_mut().zip(counts(self.late_args.buffer())?) {
                *d += late;
            }
        }
        Ok(drawn)
    }
}
