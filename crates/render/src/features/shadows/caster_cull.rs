//! Shadow casters culled per shadow map on the GPU (`shaders/shadow_cull.wgsl`): the one owner
//! of each map's culled draw list and indirect arguments.
//!
//! A shadow map (a cascade's layer, a spot light's map, a cube face) holds only what lies in its
//! clip volume: a cascade's box is fitted around one slice of the view, and the hardware clips
//! every caster outside it after transforming all its vertices. Drawing the whole list into every
//! map made each map cost the whole scene (a million cubes four times over for four cascades).
//!
//! Data flow: the view's culling owner ([`GpuCulling`](crate::features::culling::GpuCulling))
//! already uploads, when batches are rebuilt, which batch each draw-list entry belongs to, each
//! batch's mesh bounds and a template of its indirect arguments with no instance; this module
//! reads those ([`BatchBuffers`]). Per frame, for the maps the orchestrator draws, in passes of
//! up to [`MAX_MAPS`] (fewer where the lists and arguments would pass [`SLOT_BUDGET`]): the template is copied
//! to each map's arguments, one dispatch tests every entry against each map's clip volume and
//! appends the kept ones to the map's list, and the caster passes that follow draw each batch
//! indirectly from it (the caster view's `slot_base` says where the map's list starts). The
//! next group of maps reuses the lists. Nothing per draw happens on the CPU.

use crate::features::culling::{ARGS_WORDS, BatchBuffers, dispatch_grid};
use crate::gpu::buffer::GrowableBuffer;
use crate::gpu::timing::GpuTimer;
use crate::pipelines::parts::{self, dynamic_uniform, storage, storage_rw};
use crate::pipelines::{Compiler, PipelineCache, PipelineFamily, ShaderDefs};

/// Shadow maps one dispatch culls for at most (`MAX_MAPS` in `shaders/shadow_cull.wgsl`).
pub const MAX_MAPS: usize = 16;
/// Bytes the maps' culled lists and arguments may take at once: maps beyond it are culled in a
/// later pass, after the earlier maps were drawn (a million entries: 8 maps a pass).
pub const SLOT_BUDGET: u64 = 32 << 20;
const WORKGROUP: u32 = 64;
/// Planes a map may add to its clip volume (`MAX_PLANES` in `shaders/shadow_cull.wgsl`).
pub const MAX_PLANES: usize = 6;
/// Per-pass parameters sit this far apart (a multiple of the uniform offset alignment).
const PARAMS_STRIDE: u64 = 2816;

/// What one map holds: its clip volume and, for a cascade, the planes bounding the casters that
/// can shadow its receivers (`ShadowFrame::receiver_planes`), camera-relative, `xyz · p + w >= 0`
/// inside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapVolume {
    pub clip_from_rel: glam::Mat4,
    pub planes: [glam::Vec4; MAX_PLANES],
    pub plane_count: usize,
}

impl MapVolume {
    /// A map bounded by its clip volume alone (a local light's).
    pub fn clip(clip_from_rel: glam::Mat4) -> Self {
        Self { clip_from_rel, planes: [glam::Vec4::ZERO; MAX_PLANES], plane_count: 0 }
    }
}

/// Mirrors `ShadowCullParams` in `shaders/shadow_cull.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuShadowCullParams {
    item_count: u32,
    batch_count: u32,
    map_count: u32,
    slot_stride: u32,
    camera_position: [f32; 3],
    _pad: u32,
    clip_from_rel: [[[f32; 4]; 4]; MAX_MAPS],
    planes: [[f32; 4]; MAX_MAPS * MAX_PLANES],
    plane_counts: [[u32; 4]; MAX_MAPS / 4],
}

/// What the cull reads that other owners hold: the instances, the full draw list, and the view
/// culling's per-batch data for its opaque and masked entries.
#[derive(Clone, Copy)]
pub struct CasterSources<'a> {
    pub instances: &'a wgpu::Buffer,
    pub draw_slots: &'a wgpu::Buffer,
    pub batches: BatchBuffers<'a>,
}

/// How this frame's maps are grouped: maps per cull pass and the distance between their lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CullLayout {
    pub maps_per_pass: usize,
    /// Entries between one map's list and the next's.
    pub slot_stride: u32,
}

impl CullLayout {
    /// For a draw list of `item_count` opaque entries in `batch_count` batches.
    pub fn new(item_count: u32, batch_count: u32) -> Self {
        // Lists start on 256-byte boundaries.
        let slot_stride = item_count.max(1).next_multiple_of(64);
        let per_map = slot_stride as u64 * 4 + batch_count as u64 * ARGS_WORDS * 4;
        let fit = (SLOT_BUDGET / per_map).max(1);
        Self { maps_per_pass: (fit as usize).min(MAX_MAPS), slot_stride }
    }

    /// Where the list of the `index`th map of a pass starts.
    pub fn slot_base(&self, index: usize) -> u32 {
        index as u32 * self.slot_stride
    }

    /// Byte offset of a batch's arguments for the `index`th map of a pass.
    pub fn args_offset(&self, index: usize, batch_count: u32, batch: usize) -> u64 {
        (index as u64 * batch_count as u64 + batch as u64) * ARGS_WORDS * 4
    }
}

pub struct ShadowCullFamily {
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
}

impl ShadowCullFamily {
    fn new(device: &wgpu::Device) -> Self {
        let compute = wgpu::ShaderStages::COMPUTE;
        let params = dynamic_uniform(0, compute, Some(std::mem::size_of::<GpuShadowCullParams>() as u64));
        let layout = parts::bind_group_layout(
            device,
            "shadow cull",
            &[
                params,
                storage(1, compute),
                storage(2, compute),
                storage(3, compute),
                storage(4, compute),
                storage_rw(5, compute),
                storage_rw(6, compute),
            ],
        );
        let pipeline_layout = parts::pipeline_layout(device, "shadow cull", &[&layout]);
        Self { layout, pipeline_layout }
    }
}

impl PipelineFamily for ShadowCullFamily {
    type Key = ();
    type Pipeline = wgpu::ComputePipeline;
    const NAME: &'static str = "shadow cull";

    fn shader(&self, _: &()) -> (&'static str, ShaderDefs) {
        ("shadow_cull.wgsl", ShaderDefs::default())
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, _: &()) -> wgpu::ComputePipeline {
        parts::compute_pipeline(device, &self.pipeline_layout, module, "cull_casters", "shadow cull")
    }
}

pub struct CasterCulling {
    /// Each map's culled list, `slot_stride` entries apart.
    slots: GrowableBuffer,
    /// Each map's indirect arguments, batch by batch.
    args: GrowableBuffer,
    /// One `GpuShadowCullParams` per cull pass of the frame, `PARAMS_STRIDE` apart.
    params: GrowableBuffer,
    /// The bind group and the buffers it was made with, compared by identity.
    group: Option<([wgpu::Buffer; 7], wgpu::BindGroup)>,
    /// The last cull pass encoded: its maps and the batch count (what `read_counts` reads).
    last: Option<(usize, u32)>,
}

impl CasterCulling {
    /// Registers the cull's pipeline family (once, before any [`CasterCulling`] is made).
    pub fn register(device: &wgpu::Device, pipelines: &mut PipelineCache) {
        pipelines.register(ShadowCullFamily::new(device));
    }

    pub fn new(device: &wgpu::Device) -> Self {
        use wgpu::BufferUsages as U;
        Self {
            slots: GrowableBuffer::new(device, "shadow caster lists", U::STORAGE, 256),
            args: GrowableBuffer::new(device, "shadow caster args", U::STORAGE | U::INDIRECT | U::COPY_SRC, 256),
            params: GrowableBuffer::new(device, "shadow cull params", U::UNIFORM, PARAMS_STRIDE),
            group: None,
            last: None,
        }
    }

    /// The maps' lists, which the caster passes bind as their draw list.
    pub fn slots(&self) -> &wgpu::Buffer {
        self.slots.buffer()
    }

    /// The maps' indirect arguments (see [`CullLayout::args_offset`]).
    pub fn args(&self) -> &wgpu::Buffer {
        self.args.buffer()
    }

    pub fn gpu_bytes(&self) -> u64 {
        self.slots.capacity() + self.args.capacity() + self.params.capacity()
    }

    /// Instances each batch drew into each map of the last cull pass encoded (map by map, batch
    /// by batch); `None` before any. Reads back (waits for the GPU): for tests and tools.
    pub fn read_counts(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Option<Vec<Vec<u32>>>, crate::gpu::readback::ReadbackError> {
        let Some((maps, batch_count)) = self.last else { return Ok(None) };
        let words = maps as u64 * batch_count as u64 * ARGS_WORDS;
        let bytes = crate::gpu::readback::read_buffer(device, queue, self.args.buffer(), words * 4)?;
        let word = |i: usize| u32::from_le_bytes(bytes[4 * i..4 * i + 4].try_into().expect("4 bytes"));
        let per_map = batch_count as usize * ARGS_WORDS as usize;
        Ok(Some(
            (0..maps).map(|m| (0..batch_count as usize).map(|b| word(m * per_map + b * 5 + 1)).collect()).collect(),
        ))
    }

    /// Compiles the cull, so that a failure can be known before a frame commits to indirect
    /// shadow draws.
    pub fn compile(device: &wgpu::Device, pipelines: &mut PipelineCache) -> Result<(), crate::pipelines::ShaderError> {
        pipelines.get::<ShadowCullFamily>(device, ()).map(|_| ())
    }

    /// Writes every cull pass's parameters for this frame's maps (in the order they are drawn)
    /// and makes room for the lists.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        sources: &CasterSources,
        layout: CullLayout,
        maps: &[MapVolume],
        camera_position: glam::Vec3,
    ) {
        let per_pass = layout.maps_per_pass.min(maps.len()).max(1);
        self.slots.reserve(device, per_pass as u64 * layout.slot_stride as u64 * 4);
        self.args.reserve(device, per_pass as u64 * sources.batches.batch_count.max(1) as u64 * ARGS_WORDS * 4);
        let passes: Vec<u8> = maps
            .chunks(layout.maps_per_pass)
            .flat_map(|chunk| {
                let mut p = GpuShadowCullParams {
                    item_count: sources.batches.item_count,
                    batch_count: sources.batches.batch_count,
                    map_count: chunk.len() as u32,
                    slot_stride: layout.slot_stride,
                    camera_position: camera_position.to_array(),
                    ..bytemuck::Zeroable::zeroed()
                };
                for (m, map) in chunk.iter().enumerate() {
                    p.clip_from_rel[m] = map.clip_from_rel.to_cols_array_2d();
                    let count = map.plane_count.min(MAX_PLANES);
                    for (i, plane) in map.planes[..count].iter().enumerate() {
                        p.planes[m * MAX_PLANES + i] = plane.to_array();
                    }
                    p.plane_counts[m / 4][m % 4] = count as u32;
                }
                let mut bytes = bytemuck::bytes_of(&p).to_vec();
                bytes.resize(PARAMS_STRIDE as usize, 0);
                bytes
            })
            .collect();
        self.params.reserve(device, passes.len() as u64);
        if !passes.is_empty() {
            queue.write_buffer(self.params.buffer(), 0, &passes);
        }
    }

    /// Culls for the maps of pass `pass` (as [`CasterCulling::prepare`] grouped them, `maps` of
    /// them): resets their arguments from the template, then one dispatch over the draw list.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        device: &wgpu::Device,
        pipelines: &PipelineCache,
        timer: Option<&mut GpuTimer>,
        sources: &CasterSources,
        pass: usize,
        maps: usize,
    ) {
        let Some(pipeline) = pipelines.cached::<ShadowCullFamily>(&()) else { return };
        let args_bytes = sources.batches.batch_count as u64 * ARGS_WORDS * 4;
        if args_bytes == 0 || sources.batches.item_count == 0 {
            return;
        }
        self.last = Some((maps, sources.batches.batch_count));
        for m in 0..maps as u64 {
            encoder.copy_buffer_to_buffer(
                sources.batches.args_template,
                0,
                self.args.buffer(),
                m * args_bytes,
                args_bytes,
            );
        }
        let buffers = [
            self.params.buffer().clone(),
            sources.instances.clone(),
            sources.draw_slots.clone(),
            sources.batches.item_batch.clone(),
            sources.batches.batches.clone(),
            self.args.buffer().clone(),
            self.slots.buffer().clone(),
        ];
        if self.group.as_ref().is_none_or(|(held, _)| *held != buffers) {
            let mut entries: Vec<wgpu::BindGroupEntry> = buffers
                .iter()
                .enumerate()
                .map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() })
                .collect();
            entries[0].resource = wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: self.params.buffer(),
                offset: 0,
                size: wgpu::BufferSize::new(std::mem::size_of::<GpuShadowCullParams>() as u64),
            });
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("shadow cull"),
                layout: &pipelines.family::<ShadowCullFamily>().layout,
                entries: &entries,
            });
            self.group = Some((buffers, group));
        }
        let group = &self.group.as_ref().expect("made above").1;
        let mut cpass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("shadow cull"),
            timestamp_writes: timer.and_then(|t| t.compute_pass("shadow cull")),
        });
        cpass.set_pipeline(pipeline);
        cpass.set_bind_group(0, group, &[(pass as u64 * PARAMS_STRIDE) as u32]);
        let (x, y) = dispatch_grid(
            sources.batches.item_count.div_ceil(WORKGROUP),
            device.limits().max_compute_workgroups_per_dimension,
        );
        cpass.dispatch_workgroups(x, y, 1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn params_mirror_the_shaders_struct() {
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuShadowCullParams,
            "shadow_cull.wgsl",
            [],
            "ShadowCullParams",
            [item_count, batch_count, map_count, slot_stride, camera_position, clip_from_rel, planes, plane_counts]
        );
    }

    #[test]
    fn params_fit_their_stride() {
        let size = std::mem::size_of::<GpuShadowCullParams>() as u64;
        assert!(size <= PARAMS_STRIDE && PARAMS_STRIDE % 256 == 0, "{size} in {PARAMS_STRIDE}");
    }

    #[test]
    fn lists_stay_within_the_budget_and_on_aligned_starts() {
        for items in [0, 1, 63, 65, 10_000, 1_000_000, 4_000_000, 20_000_000] {
            for batches in [1, 100, 100_000] {
                let l = CullLayout::new(items, batches);
                assert!((1..=MAX_MAPS).contains(&l.maps_per_pass), "{items}: {l:?}");
                assert!(l.slot_stride >= items && l.slot_stride % 64 == 0, "{items}: {l:?}");
                // One map always fits; more only within the budget.
                let per_map = l.slot_stride as u64 * 4 + batches as u64 * ARGS_WORDS * 4;
                assert!(l.maps_per_pass == 1 || l.maps_per_pass as u64 * per_map <= SLOT_BUDGET, "{items}: {l:?}");
            }
        }
        assert_eq!(CullLayout::new(10_000, 1).maps_per_pass, MAX_MAPS);
        assert_eq!(CullLayout::new(1_000_000, 1).maps_per_pass, 8);
        assert_eq!(CullLayout::new(100_000, 100_000).maps_per_pass, 13);
    }
}
