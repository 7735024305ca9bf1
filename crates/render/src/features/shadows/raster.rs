//! Shadow casters rasterised in compute: the one owner of the caster raster's counters, job
//! list, per-map uniforms and bind groups.
//!
//! Why: a shadow map's casters are mostly small (a far cascade holds a whole city, each building
//! a few texels), and GPUs built for compute set triangles up and rasterise them on a small part
//! of the chip, as they do the view's (`features::visibility`). In a frame whose view is
//! rasterised in compute, each cascade layer's casters are too, by the same steps
//! (`visibility_raster.wgsl` with SHADOW_DEPTH: the batch table and bins the visibility buffer
//! made, masked bins with their alpha test), into the layer's staging buffer
//! ([`super::atlas::LayerStaging`]) with 32-bit atomicMax of the depth, which is then copied into
//! the atlas.
//!
//! Data flow per layer drawn, after the caster cull wrote the map's lists and instance counts
//! ([`super::caster_cull`]): the staging buffer's rows are emptied, the numbering reads the map's
//! counts (`args_base`), the triangles and tiles steps read its lists (`slot_base`) and place
//! vertices with its matrix, and the window is copied into the layer. Local lights' maps (spot
//! and cube faces, perspective) stay with the hardware pass.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};

use super::atlas::LayerStaging;
use crate::features::visibility::{
    CasterRasterFamily, GpuRasterParams, RasterGroups, RasterTable, TILE_GROUPS, entry, job_buffer, job_capacity,
};
use crate::gpu::buffer::GrowableBuffer;
use crate::pipelines::{PipelineCache, ShaderError};
use crate::resources::materials::MaterialTable;
use crate::resources::mesh_pool::MeshPool;

/// Largest layer (texels across or down) rasterised in compute: snapped coordinates must stay
/// exact in f32 within the raster's guard band (`visibility_raster.wgsl`, GUARD).
pub const MAX_EXTENT: u32 = 8192;
/// A map's uniforms sit this far apart: its view, then at `PARAMS_OFFSET` its raster
/// parameters (offsets are multiples of the uniform offset alignment).
const MAP_STRIDE: u64 = 512;
const PARAMS_OFFSET: u64 = 256;

/// Mirrors `struct CasterRasterView` in `shaders/visibility_raster.wgsl` (SHADOW_DEPTH).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GpuCasterRasterView {
    clip_from_rel: [[f32; 4]; 4],
    camera_position: [f32; 3],
    slot_base: u32,
    args_base: u32,
    slope_bias: f32,
    _pad: [u32; 2],
}

/// One map rasterised this frame.
#[derive(Debug, Clone, Copy)]
pub struct MapRaster {
    /// The layer's clip space from camera-relative positions (the hardware pass's matrix).
    pub clip_from_rel: Mat4,
    /// Where the map's culled lists start (entries) and its instance counts (words).
    pub slot_base: u32,
    pub args_base: u32,
}

/// What the caster raster reads that other owners hold.
pub struct RasterInputs<'a> {
    /// The visibility buffer's batch table and bins (this frame's view is rasterised in compute).
    pub table: RasterTable<'a>,
    pub instances: &'a wgpu::Buffer,
    /// The caster cull's lists and arguments (handles: the cull encodes between the maps).
    pub lists: wgpu::Buffer,
    pub args: wgpu::Buffer,
    pub mesh_pool: &'a MeshPool,
    pub materials: &'a MaterialTable,
}

pub struct CasterRaster {
    /// Per batch its first number, then the total, the large triangles and their jobs.
    counters: GrowableBuffer,
    dispatch: wgpu::Buffer,
    jobs: wgpu::Buffer,
    job_capacity: u32,
    /// Per map: its view and raster parameters, `MAP_STRIDE` apart.
    maps: GrowableBuffer,
    /// Per map its group 0, the dispatch group, and the buffers they were made with.
    bound: Option<(Vec<wgpu::Buffer>, Vec<wgpu::BindGroup>, wgpu::BindGroup)>,
}

impl CasterRaster {
    /// Registers the caster raster's pipelines (masked bins bind the `material` group).
    pub fn register(device: &wgpu::Device, pipelines: &mut PipelineCache, material: &wgpu::BindGroupLayout) {
        pipelines.register(CasterRasterFamily::new(device, material));
    }

    /// Whether layers of `extent` can be rasterised here: within the raster's exact range, and
    /// their staging buffer one storage binding.
    pub fn supports(limits: &wgpu::Limits, extent: (u32, u32)) -> bool {
        let bytes = super::atlas::row_pitch(extent.0) as u64 * extent.1 as u64;
        extent.0 <= MAX_EXTENT
            && extent.1 <= MAX_EXTENT
            && bytes <= limits.max_storage_buffer_binding_size
            && bytes <= limits.max_buffer_size
    }

    pub fn new(device: &wgpu::Device) -> Self {
        use wgpu::BufferUsages as U;
        Self {
            counters: GrowableBuffer::new(device, "shadow raster counters", U::STORAGE, 256),
            dispatch: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("shadow raster dispatch"),
                size: 16,
                usage: U::STORAGE | U::INDIRECT,
                mapped_at_creation: false,
            }),
            jobs: job_buffer(device, 1),
            job_capacity: 1,
            maps: GrowableBuffer::new(device, "shadow raster maps", U::UNIFORM | U::COPY_DST, MAP_STRIDE),
            bound: None,
        }
    }

    /// Drops the bind groups, and with them the staging buffer they hold (it was replaced, or
    /// this frame's layers are not rasterised here).
    pub fn unbind(&mut self) {
        self.bound = None;
    }

    pub fn gpu_bytes(&self) -> u64 {
        self.counters.capacity() + 16 + self.jobs.size() + self.maps.capacity()
    }

    /// Compiles the steps the table's bins run, sizes the buffers for layers of `extent`, and
    /// writes each map's uniforms. `Err` names a step that failed (its bins are not drawn).
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipelines: &mut PipelineCache,
        inputs: &RasterInputs,
        staging: &LayerStaging,
        extent: (u32, u32),
        camera_position: Vec3,
        slope_bias: f32,
        maps: &[MapRaster],
    ) -> Result<(), ShaderError> {
        let compiled = pipelines.prepare::<CasterRasterFamily>(device, inputs.table.steps());
        self.counters.reserve(device, (inputs.table.batch_count as u64 + 3) * 4);
        let capacity = job_capacity(extent);
        if capacity != self.job_capacity {
            self.jobs = job_buffer(device, capacity);
            self.job_capacity = capacity;
            self.bound = None;
        }
        self.maps.reserve(device, maps.len().max(1) as u64 * MAP_STRIDE);
        let params = GpuRasterParams {
            target_size: [extent.0, extent.1],
            samples: 1,
            batch_count: inputs.table.batch_count,
            job_capacity: self.job_capacity,
            tile_groups: TILE_GROUPS,
            row_pitch: staging.pitch_texels(),
            _pad: 0,
        };
        for (k, map) in maps.iter().enumerate() {
            let view = GpuCasterRasterView {
                clip_from_rel: map.clip_from_rel.to_cols_array_2d(),
                camera_position: camera_position.to_array(),
                slot_base: map.slot_base,
                args_base: map.args_base,
                slope_bias,
                _pad: [0; 2],
            };
            let at = k as u64 * MAP_STRIDE;
            queue.write_buffer(self.maps.buffer(), at, bytemuck::bytes_of(&view));
            queue.write_buffer(self.maps.buffer(), at + PARAMS_OFFSET, bytemuck::bytes_of(&params));
        }
        self.bind(device, pipelines, inputs, staging, maps.len());
        compiled
    }

    fn bind(
        &mut self,
        device: &wgpu::Device,
        pipelines: &PipelineCache,
        inputs: &RasterInputs,
        staging: &LayerStaging,
        map_count: usize,
    ) {
        let made_with = vec![
            inputs.instances.clone(),
            inputs.lists.clone(),
            inputs.table.batches.clone(),
            inputs.args.clone(),
            inputs.mesh_pool.index_buffer().clone(),
            inputs.mesh_pool.vertex_buffer().clone(),
            self.counters.buffer().clone(),
            staging.buffer().clone(),
            self.jobs.clone(),
            inputs.table.bin_params.clone(),
            inputs.materials.buffer().clone(),
            self.maps.buffer().clone(),
        ];
        if self.bound.as_ref().is_some_and(|(held, groups, _)| *held == made_with && groups.len() >= map_count) {
            return;
        }
        let family = pipelines.family::<CasterRasterFamily>();
        let range = |binding, buffer, offset, size: usize| wgpu::BindGroupEntry {
            binding,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer,
                offset,
                size: wgpu::BufferSize::new(size as u64),
            }),
        };
        let maps = self.maps.buffer();
        let groups = (0..map_count as u64)
            .map(|k| {
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("shadow raster"),
                    layout: &family.raster,
                    entries: &[
                        range(0, maps, k * MAP_STRIDE, std::mem::size_of::<GpuCasterRasterView>()),
                        entry(1, inputs.instances),
                        entry(2, &inputs.lists),
                        entry(3, inputs.table.batches),
                        entry(4, &inputs.args),
                        entry(5, inputs.mesh_pool.index_buffer()),
                        entry(6, inputs.mesh_pool.vertex_buffer()),
                        range(7, maps, k * MAP_STRIDE + PARAMS_OFFSET, std::mem::size_of::<GpuRasterParams>()),
                        entry(8, self.counters.buffer()),
                        entry(9, staging.buffer()),
                        entry(10, &self.jobs),
                        range(11, inputs.table.bin_params, 0, crate::features::visibility::BIN_BYTES as usize),
                        entry(12, inputs.materials.buffer()),
                    ],
                })
            })
            .collect();
        let dispatch = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shadow raster dispatch"),
            layout: &family.dispatch,
            entries: &[entry(0, &self.dispatch)],
        });
        self.bound = Some((made_with, groups, dispatch));
    }

    /// Rasterises map `k` of those prepared into the staging buffer's first `rows` rows (emptied
    /// first), in a compute pass timed as `label`.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        pipelines: &PipelineCache,
        timer: Option<&mut crate::gpu::timing::GpuTimer>,
        inputs: &RasterInputs,
        staging: &LayerStaging,
        k: usize,
        rows: u32,
        label: &'static str,
    ) {
        // Emptied first whatever follows: the window is copied into the layer next, and a map
        // that cannot be drawn must read as lit, not as the previous layer's casters.
        staging.clear_rows(encoder, rows);
        let Some((_, groups, dispatch)) = &self.bound else { return };
        let Some(group) = groups.get(k) else { return };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: timer.and_then(|t| t.compute_pass(label)),
        });
        let groups = RasterGroups { raster: group, dispatch, args: &self.dispatch };
        inputs.table.encode::<true>(&mut pass, pipelines, &groups, inputs.materials);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipelines::shader_library::assert_mirrors_wgsl;

    #[test]
    fn the_caster_raster_view_mirrors_the_shader() {
        assert_mirrors_wgsl!(
            GpuCasterRasterView,
            "visibility_raster.wgsl",
            ["SHADOW_DEPTH"],
            "CasterRasterView",
            [clip_from_rel, camera_position, slot_base, args_base, slope_bias]
        );
        assert!(std::mem::size_of::<GpuCasterRasterView>() as u64 <= PARAMS_OFFSET);
        assert!(PARAMS_OFFSET + std::mem::size_of::<GpuRasterParams>() as u64 <= MAP_STRIDE);
    }
}
