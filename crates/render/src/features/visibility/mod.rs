//! The visibility buffer: opaque draws rasterised and shaded in compute (`Raster::Compute`).
//! The one owner of the visibility buffer, the raster batch table, the records of large
//! triangles and the shading groups.
//!
//! Why: GPUs built for compute rasterise on a small part of the chip. The H100 runs vertex and
//! fragment work on 2 of its 66 TPCs, so a multisampled 1080p frame costs it much fixed-function
//! time before any shading, while compute runs on every TPC (docs/performance.md, "Rasterising
//! in compute").
//!
//! Data flow, each frame, after the cull pass (`features::culling`) has written each opaque
//! batch's visible instances (`visible_slots`) and their counts (its indirect arguments):
//! 1. `raster_prepare` numbers the visible triangles batch after batch (each batch's first number
//!    in `counters`; the batch table holds each raster bin's batches together, unmasked ones
//!    first) and sizes the first bin's raster dispatch (`shaders/visibility_raster.wgsl`).
//! 2. Per bin (`RasterBin`: the unmasked batches, then the masked ones by alpha-test variant and
//!    base colour texture), `raster_triangles`, one thread per triangle of the bin, writes
//!    `depth << 32 | number` into each covered sample with a 64-bit atomicMax (nearest wins;
//!    ties go to the larger number, so the result is the same whatever order threads run in);
//!    a masked bin's variant covers only samples where the alpha test passes. Triangles larger
//!    than 8×8 pixels (16×16 at one sample a pixel) leave a record instead; `raster_scan`
//!    numbers their 16×16-pixel tiles, and `raster_tiles` spreads those jobs over the GPU. A
//!    later bin starts with `raster_begin` (its dispatch's size, an empty job list); each bin's
//!    range is a dynamic offset into
//!    `bin_params`.
//! 3. The shading pass (`forward.wgsl`'s `cs_shade`, one pipeline per forward variant and one
//!    dispatch per group of batches sharing variant and material textures) shades each
//!    pixel's triangles once at the pixel's centre, weighs each by the samples it covers, adds
//!    the environment or the clear colour for the samples nothing covers, and writes the
//!    resolved HDR colour; or, when nothing else reads HDR colour (no post-processing, no HDR
//!    readback) and the output takes copies, the displayed colour itself (tonemapped,
//!    sRGB-encoded), which is copied into the output. Full-screen fragment passes are dear on
//!    such GPUs (the background composite, the tonemap pass); these frames have neither.
//!
//! A hybrid frame (line or point meshes, blended or transmissive draws, gizmo lines: what only
//! the forward pass rasterises) splits the work: `encode_raster`, then the forward pass draws
//! those into the overlay (`overlay`), each sample tested against the visibility buffer's depth,
//! then `encode_shade`, which composites each overlay sample over its own sample's colour. With
//! transmissive draws, which read the opaque colour, `encode_first_shade` runs before the
//! overlay and writes it into the transmission copy's level 0 (`FrameInputs::transmission`);
//! `encode_shade` then takes each pixel whose samples all hold one triangle, or all none, from
//! there and shades again only the others (edges, and pixels partly empty).
//!
//! What a frame needs for this path (else the forward pass draws it, and the plan says why):
//! GPU culling (the visible lists), no occlusion culling, at least one opaque or masked
//! triangle mesh, and 64-bit atomics. The buffer rasterises opaque and masked triangle meshes (skinned and morphed ones
//! from the deformation pass's vertices, like any other). A frame without a hybrid part has no
//! depth or multisampled targets.

use bytemuck::{Pod, Zeroable};

use crate::features::culling::ARGS_WORDS;
use crate::features::transmission::CopyViews;
use crate::frame_context::FrameContext;
use crate::gpu::buffer::GrowableBuffer;
use crate::gpu::formats::DISPLAY_FORMAT;
use crate::pipelines::{PipelineCache, ShaderError};
use crate::resources::draws::{Batch, PipelineKey};
use crate::resources::materials::extension::EXTENSION_GROUP;
use crate::resources::materials::{AlphaKey, MaterialKey, MaterialTable};
use crate::resources::mesh_pool::MeshPool;

mod overlay;
mod pipelines;
use overlay::GpuOcclusionParams;
pub use overlay::{OverlayRect, OverlayTargets, occlusion_layouts};
pub use pipelines::BIN_BYTES;
pub use pipelines::{
    CasterRasterFamily, MaskKey, RasterFamily, RasterStep, ShadeFamily, ShadeKey, ShadeOutput, shade_key,
};

/// Where opaque draws are rasterised.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Raster {
    /// The default: `Compute` on GPUs whose graphics units are a small part of the chip
    /// (`Capabilities::few_graphics_units`: NVIDIA's Hopper compute GPUs, where it is several
    /// times faster), `Hardware` elsewhere (CPU rasterisers such as lavapipe, and GPUs whose
    /// rasterisers keep up with their shaders).
    #[default]
    Auto,
    /// The GPU's rasteriser, drawing each batch (the forward pass).
    Hardware,
    /// Compute shaders (`features::visibility`): each sample's nearest triangle goes into a
    /// visibility buffer with 64-bit atomics, then a compute pass shades each pixel's
    /// triangles. For GPUs whose graphics units are few next to their compute units (the
    /// H100 rasterises on 2 of its 66 TPCs). Blended draws and gizmo lines are drawn over the
    /// result by the forward pass (a hybrid frame). Frames it cannot draw yet rasterise in
    /// hardware, and `--explain` says why ([`RasterGate`]).
    Compute,
}

/// What decides where one frame's opaque draws are rasterised, checked in this order: the first
/// that fails sends them to the forward pass, and `--explain` names it.
#[derive(Debug, Clone, Copy)]
pub struct RasterGate {
    pub setting: Raster,
    /// The adapter has 64-bit atomic min/max (`Capabilities::visibility_raster`; not GL).
    pub atomics: bool,
    /// `Capabilities::few_graphics_units`.
    pub few_graphics_units: bool,
    /// GPU culling runs this frame (the visibility buffer rasterises its visible lists).
    pub culling: bool,
    /// The buffer (8 bytes a sample) fits the adapter's largest storage binding ([`fits`]).
    pub fits: bool,
    /// `--occlusion on` (its depth pyramid comes from the forward pass).
    pub occlusion_on: bool,
    /// Some opaque batch is an opaque or masked triangle list ([`batch_supported`]): a frame of
    /// line and point meshes alone has nothing for the buffer.
    pub opaque: bool,
}

impl RasterGate {
    /// `Ok(why)` where the visibility buffer rasterises this frame's opaque draws, `Err(why)`
    /// where the forward pass does.
    pub fn decide(&self) -> Result<&'static str, &'static str> {
        match self.setting {
            Raster::Hardware => return Err("--raster hardware"),
            Raster::Auto if !self.few_graphics_units => {
                return Err("--raster auto: this GPU's rasteriser keeps up with its shaders (compute raster is \
                            chosen on GPUs with few graphics units, NVIDIA's Hopper compute GPUs)");
            }
            _ => {}
        }
        let checks = [
            (self.atomics, "the adapter has no 64-bit atomic min/max (GL, or a Vulkan device without them)"),
            (self.culling, "GPU culling is off or unsupported"),
            (self.fits, "the visibility buffer would exceed the adapter's largest storage binding"),
            (!self.occlusion_on, "occlusion culling was asked for (--occlusion on)"),
            (self.opaque, "no opaque or masked triangle meshes to rasterise"),
        ];
        if let Some((_, why)) = checks.iter().find(|(ok, _)| !ok) {
            return Err(why);
        }
        Ok(match self.setting {
            Raster::Compute => "--raster compute",
            _ => "--raster auto on a GPU with few graphics units (NVIDIA Hopper), where compute rasterises faster",
        })
    }
}

/// Bytes of one visibility sample (depth and triangle number).
const SAMPLE_BYTES: u64 = 8;
/// Records of large triangles (a box wider or taller than 8 pixels, 16 at one sample) the list
/// holds per 16×16-pixel tile of the frame, and at least. A triangle whose record does not fit is
/// rasterised whole by its own thread: the same samples, slower, and on lavapipe only while
/// that thread's loops stay within Mesa's limit of 65 535 iterations an invocation (gallivm's
/// loop limiter; a view-filling triangle at 192×112 passes it), so the list is sized for far
/// more large triangles than frames have.
const JOBS_PER_TILE: u32 = 8;
const MIN_JOBS: u32 = 1 << 16;
const TILE: u32 = 16;
/// Bytes of one record.
const RECORD_BYTES: u64 = 16;
/// Thread groups of `raster_tiles`, each looping over a run of the tile jobs. Each group's first
/// lane sets a record's triangle up while the group waits, so more groups hide more of that
/// latency, until runs get so short that each group sets up as many triangles as it covers
/// tiles (docs/performance.md, "Rasterising in compute", has the measurements).
pub const TILE_GROUPS: u32 = 4096;
const CULL_BACK: u32 = 1;
const FRONT_CW: u32 = 2;
const NON_INDEXED: u32 = 4;

/// Mirrors `struct RasterBatch` in `shaders/visibility.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GpuRasterBatch {
    first: u32,
    index_start: u32,
    vertex_start: u32,
    triangle_count: u32,
    flags: u32,
    count_word: u32,
    shade_group: u32,
    _pad: u32,
}

/// Mirrors `struct RasterParams` in `shaders/visibility_raster.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuRasterParams {
    pub target_size: [u32; 2],
    pub samples: u32,
    pub batch_count: u32,
    pub job_capacity: u32,
    pub tile_groups: u32,
    pub row_pitch: u32,
    pub _pad: u32,
}

/// Mirrors `struct ShadeParams` in `shaders/forward.wgsl` (VISIBILITY_SHADE).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GpuShadeParams {
    target_size: [u32; 2],
    samples: u32,
    batch_count: u32,
    group: u32,
    accumulate: u32,
    last: u32,
    background: u32,
    clear: [f32; 4],
    overlay_origin: [u32; 2],
    overlay_size: [u32; 2],
}

/// Batches rasterised by one run of the raster steps (`raster_triangles`, `raster_scan`,
/// `raster_tiles`): every batch that is not masked, or the masked batches sharing an alpha test
/// and, where it reads a texture, material textures. The batch table holds each bin's batches
/// together (unmasked first), so its triangle numbers are contiguous.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RasterBin {
    mask: Option<MaskKey>,
    /// The material group the alpha test reads (a masked bin's base colour texture).
    material: Option<MaterialKey>,
    first_batch: u32,
    end_batch: u32,
}

impl RasterBin {
    fn steps(&self) -> [RasterStep; 2] {
        [RasterStep::Triangles(self.mask), RasterStep::Tiles(self.mask)]
    }
}

/// The batch table and its bins (`VisibilityBuffer::raster_table`).
pub struct RasterTable<'a> {
    /// `struct RasterBatch` per batch, each bin's together.
    pub batches: &'a wgpu::Buffer,
    pub batch_count: u32,
    bins: &'a [RasterBin],
    /// One `struct RasterBin` uniform per bin, `bin_stride` bytes apart.
    pub bin_params: &'a wgpu::Buffer,
    bin_stride: u64,
}

/// What the raster steps bind: group 0 (its bin uniform at a dynamic offset), the raster
/// dispatch's group for the steps that size it, and that dispatch's arguments.
pub struct RasterGroups<'a> {
    pub raster: &'a wgpu::BindGroup,
    pub dispatch: &'a wgpu::BindGroup,
    pub args: &'a wgpu::Buffer,
}

impl RasterTable<'_> {
    /// The raster steps the bins run, in order (each compiled once).
    pub fn steps(&self) -> Vec<RasterStep> {
        let begin = (self.bins.len() > 1).then_some(RasterStep::Begin);
        RasterStep::OPAQUE.into_iter().chain(begin).chain(self.bins.iter().flat_map(RasterBin::steps)).collect()
    }

    /// Encodes every bin's raster steps into `pass` with `RasterFamily<DEPTH_ONLY>`'s
    /// pipelines: the numbering, then per bin its triangles, the scan of its large ones and
    /// their tiles. A step that did not compile (reported when prepared), or a masked bin whose
    /// material is not there yet, leaves the bin's triangles undrawn.
    pub fn encode<const DEPTH_ONLY: bool>(
        &self,
        pass: &mut wgpu::ComputePass,
        pipelines: &PipelineCache,
        groups: &RasterGroups,
        materials: &MaterialTable,
    ) {
        let step = |s: RasterStep| pipelines.cached::<RasterFamily<DEPTH_ONLY>>(&s);
        let (Some(prepare), Some(scan)) = (step(RasterStep::Prepare), step(RasterStep::Scan)) else { return };
        // The first bin starts with the numbering; each later one with raster_begin.
        pass.set_bind_group(0, groups.raster, &[0]);
        pass.set_bind_group(1, groups.dispatch, &[]);
        pass.set_pipeline(prepare);
        pass.dispatch_workgroups(1, 1, 1);
        for (k, bin) in self.bins.iter().enumerate() {
            let [triangles, tiles] = bin.steps().map(step);
            let material = match bin.material {
                Some(key) => materials.get(&key).map(|m| Some(&m.bind_group)),
                None => Some(None),
            };
            let (Some(triangles), Some(tiles), Some(material)) = (triangles, tiles, material) else {
                continue;
            };
            if k > 0 {
                let Some(begin) = step(RasterStep::Begin) else { continue };
                pass.set_bind_group(0, groups.raster, &[(k as u64 * self.bin_stride) as u32]);
                pass.set_bind_group(1, groups.dispatch, &[]);
                pass.set_pipeline(begin);
                pass.dispatch_workgroups(1, 1, 1);
            }
            if let Some(material) = material {
                pass.set_bind_group(1, material, &[]);
            }
            pass.set_pipeline(triangles);
            pass.dispatch_workgroups_indirect(groups.args, 0);
            pass.set_pipeline(scan);
            pass.dispatch_workgroups(1, 1, 1);
            pass.set_pipeline(tiles);
            pass.dispatch_workgroups(TILE_GROUPS, 1, 1);
        }
    }
}

/// Batches shaded by one dispatch: one pipeline variant, one set of material textures.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ShadeGroup {
    key: PipelineKey,
    material: MaterialKey,
}

/// Whether a frame of `size` at `samples` fits the adapter: its visibility buffer (8 bytes a
/// sample: 66 MiB at 1920×1080 with MSAA 4, 265 MiB at 3840×2160) must be one storage binding.
pub fn fits(limits: &wgpu::Limits, size: (u32, u32), samples: u32) -> bool {
    let bytes = size.0 as u64 * size.1 as u64 * samples as u64 * SAMPLE_BYTES;
    bytes <= limits.max_storage_buffer_binding_size && bytes <= limits.max_buffer_size
}

/// Records of large triangles a frame of `size` pixels holds (see `JOBS_PER_TILE`).
pub fn job_capacity((w, h): (u32, u32)) -> u32 {
    (w.div_ceil(TILE) * h.div_ceil(TILE)).saturating_mul(JOBS_PER_TILE).max(MIN_JOBS)
}

/// The buffer of `capacity` records of large triangles (`big` in `visibility_raster.wgsl`).
pub fn job_buffer(device: &wgpu::Device, capacity: u32) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("visibility large triangles"),
        size: capacity as u64 * RECORD_BYTES,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    })
}

/// Clears `view` (a render attachment) to black.
fn clear_black(encoder: &mut wgpu::CommandEncoder, view: &wgpu::TextureView, label: &str) {
    let _ = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
}

/// A bind group entry binding all of `buffer`.
pub(crate) fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry { binding, resource: buffer.as_entire_binding() }
}

/// Whether a batch can be rasterised here (see the module doc): opaque and masked triangle
/// lists. Line and point meshes are drawn by the forward pass over the result (a hybrid frame).
pub fn batch_supported(b: &Batch) -> bool {
    use crate::resources::draws::TopologyKey;
    b.key.topology == TopologyKey::Triangles && b.key.alpha != AlphaKey::Blend
}

/// The forward key a hybrid frame's overlay draws `key` with: into the overlay's HDR colour and
/// depth (not the frame's output, even when the visibility buffer writes it directly), tested
/// against the visibility buffer; local lights walked by the fragment shader (a visibility frame
/// has no deferred-lights pass).
pub fn overlay_key(key: PipelineKey) -> PipelineKey {
    use crate::gpu::formats::{DEPTH_FORMAT, FormatKey, HDR_FORMAT};
    use crate::resources::draws::LocalLights;
    PipelineKey {
        color_format: FormatKey(HDR_FORMAT),
        depth_format: Some(FormatKey(DEPTH_FORMAT)),
        tonemap: None,
        local_lights: if key.local_lights == LocalLights::Deferred { LocalLights::Clustered } else { key.local_lights },
        visibility_occlusion: true,
        ..key
    }
}

/// The alpha test a batch's raster bin runs, and the material group it reads.
fn bin_of(b: &Batch) -> (Option<MaskKey>, Option<MaterialKey>) {
    if b.key.alpha != AlphaKey::Mask {
        return (None, None);
    }
    let mask = MaskKey::of(&b.key);
    (Some(mask), mask.texture.then_some(b.material))
}

pub struct FrameInputs<'a> {
    pub view: &'a wgpu::Buffer,
    pub view_bind_group: &'a wgpu::BindGroup,
    pub instances: &'a wgpu::Buffer,
    pub visible_slots: &'a wgpu::Buffer,
    pub cull_args: &'a wgpu::Buffer,
    pub mesh_pool: &'a MeshPool,
    pub materials: &'a MaterialTable,
    /// What the shading pass writes: HDR colour into `hdr`, or the displayed colour, which is
    /// then copied into `output`.
    pub shade_output: ShadeOutput,
    pub hdr: Option<&'a wgpu::TextureView>,
    pub output: &'a wgpu::Texture,
    pub size: (u32, u32),
    pub samples: u32,
    /// The environment shows where nothing is covered (else `clear`).
    pub background: bool,
    /// Exposed linear radiance where nothing is covered.
    pub clear: [f32; 3],
    /// A hybrid frame: the forward pass draws into the overlay (`overlay`) between the raster
    /// steps and the shading pass, which composites it; the rectangle its draws can cover.
    pub overlay: Option<OverlayRect>,
    /// A hybrid frame with transmissive draws (`shade_output` is `Hdr` or `DisplayResolved`):
    /// a first shading writes the opaque colour, as radiance, into the copy's level 0
    /// (`encode_first_shade`); the copy's mip chain is made, the overlay's transmissive draws
    /// read it, and `encode_shade` writes the output with the overlay composited, shading again
    /// only the pixels whose samples hold more than one triangle, or some none.
    pub transmission: Option<CopyViews<'a>>,
}

pub struct VisibilityBuffer {
    batches: GrowableBuffer,
    counters: GrowableBuffer,
    dispatch: wgpu::Buffer,
    samples: GrowableBuffer,
    jobs: wgpu::Buffer,
    job_capacity: u32,
    /// `set_large_triangle_capacity`'s figure, in place of the one sized from the frame.
    job_capacity_set: Option<u32>,
    partial: GrowableBuffer,
    raster_params: wgpu::Buffer,
    /// One uniform per shading group.
    shade_params: Vec<wgpu::Buffer>,
    /// The groups this frame shades (those whose pipeline and material are there), in order.
    shaded: Vec<usize>,
    /// The displayed colour (`ShadeOutput::Display*`), copied into the output.
    display: Option<(wgpu::Texture, wgpu::TextureView)>,
    groups: Vec<ShadeGroup>,
    bins: Vec<RasterBin>,
    /// One `struct RasterBin` uniform per bin, `bin_stride` bytes apart (dynamic offsets).
    bin_params: GrowableBuffer,
    bin_stride: u64,
    batch_count: u32,
    /// The bind groups, and the buffers they were made with (made again when one changes).
    bound: Option<Bound>,
    /// A hybrid frame's overlay (`overlay`); dropped with the first frame without one.
    overlay: Option<OverlayTargets>,
    /// `occlusion_layouts`: without and with the transmission copy.
    occlusion_layouts: [wgpu::BindGroupLayout; 2],
}

struct Bound {
    made_with: Vec<wgpu::Buffer>,
    target: wgpu::TextureView,
    overlay: Option<wgpu::TextureView>,
    /// With transmissive draws: the copy's level 0, which the first shading writes.
    first_target: Option<wgpu::TextureView>,
    raster: wgpu::BindGroup,
    dispatch: wgpu::BindGroup,
    shade: Vec<wgpu::BindGroup>,
    /// The first shading's groups, with transmissive draws.
    first: Vec<wgpu::BindGroup>,
}

impl VisibilityBuffer {
    /// Registers the rasteriser's and the shading pass's pipeline families (shading binds the
    /// `view` and `material` groups). `occlusion`: [`occlusion_layouts`], which the renderer
    /// also gives the forward and gizmo pipelines.
    pub fn new(
        device: &wgpu::Device,
        pipelines: &mut PipelineCache,
        view: &wgpu::BindGroupLayout,
        materials: &MaterialTable,
        occlusion: &[wgpu::BindGroupLayout; 2],
    ) -> Self {
        pipelines.register(ShadeFamily::new(device, view, materials));
        pipelines.register(RasterFamily::<false>::new(device, materials.layout()));
        use wgpu::BufferUsages as U;
        let storage = U::STORAGE | U::COPY_DST;
        Self {
            batches: GrowableBuffer::new(device, "visibility batches", storage, 256),
            counters: GrowableBuffer::new(device, "visibility counters", storage, 256),
            dispatch: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("visibility raster dispatch"),
                size: 16,
                usage: U::STORAGE | U::INDIRECT,
                mapped_at_creation: false,
            }),
            samples: GrowableBuffer::new(device, "visibility samples", storage, 256),
            jobs: job_buffer(device, MIN_JOBS),
            job_capacity: MIN_JOBS,
            job_capacity_set: None,
            partial: GrowableBuffer::new(device, "visibility partial sums", U::STORAGE, 16),
            raster_params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("visibility raster params"),
                size: std::mem::size_of::<GpuRasterParams>() as u64,
                usage: U::UNIFORM | U::COPY_DST,
                mapped_at_creation: false,
            }),
            shade_params: Vec::new(),
            shaded: Vec::new(),
            display: None,
            groups: Vec::new(),
            bins: Vec::new(),
            bin_params: GrowableBuffer::new(device, "visibility raster bins", U::UNIFORM | U::COPY_DST, 256),
            bin_stride: (device.limits().min_uniform_buffer_offset_alignment as u64).max(BIN_BYTES),
            batch_count: 0,
            bound: None,
            overlay: None,
            occlusion_layouts: occlusion.clone(),
        }
    }

    /// Sets how many large triangles' records the list holds (for tests and tuning: a triangle
    /// whose record does not fit is rasterised whole by its own thread).
    pub fn set_large_triangle_capacity(&mut self, device: &wgpu::Device, capacity: u32) {
        self.job_capacity_set = Some(capacity.max(1));
        self.resize_jobs(device, capacity.max(1));
    }

    fn resize_jobs(&mut self, device: &wgpu::Device, capacity: u32) {
        if capacity != self.job_capacity {
            self.job_capacity = capacity;
            self.jobs = job_buffer(device, capacity);
            self.bound = None;
        }
    }

    /// GPU memory this owner holds, in bytes.
    pub fn gpu_bytes(&self) -> u64 {
        self.batches.capacity()
            + self.counters.capacity()
            + self.samples.capacity()
            + self.jobs.size()
            + self.partial.capacity()
            + self.display.as_ref().map_or(0, |(t, _)| t.width() as u64 * t.height() as u64 * 4)
            + self.overlay.as_ref().map_or(0, OverlayTargets::bytes)
            + self.bin_params.capacity()
            + 16
    }

    /// The batch table and shading groups, when batches were rebuilt. `batches` are the
    /// opaque batches in the cull pass's order (their arguments' order).
    pub fn prepare_batches(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        batches: &[Batch],
        mesh_pool: &MeshPool,
    ) {
        self.groups.clear();
        // Unmasked batches first, then each masked bin's together, in the order first seen.
        self.bins.clear();
        let mut keys: Vec<(Option<MaskKey>, Option<MaterialKey>)> = vec![(None, None)];
        let mut order: Vec<(usize, usize)> = Vec::with_capacity(batches.len());
        for (i, b) in batches.iter().enumerate().filter(|(_, b)| batch_supported(b)) {
            let key = bin_of(b);
            let bin = keys.iter().position(|k| *k == key).unwrap_or_else(|| {
                keys.push(key);
                keys.len() - 1
            });
            order.push((bin, i));
        }
        order.sort_by_key(|&(bin, _)| bin);
        for (k, &(bin, _)) in order.iter().enumerate() {
            match self.bins.last_mut() {
                Some(last) if last.mask == keys[bin].0 && last.material == keys[bin].1 => last.end_batch = k as u32 + 1,
                _ => self.bins.push(RasterBin {
                    mask: keys[bin].0,
                    material: keys[bin].1,
                    first_batch: k as u32,
                    end_batch: k as u32 + 1,
                }),
            }
        }
        if self.bins.is_empty() {
            // Nothing to draw; the first step still runs.
            self.bins.push(RasterBin { mask: None, material: None, first_batch: 0, end_batch: 0 });
        }
        let mut table = Vec::with_capacity(batches.len());
        for &(_, i) in &order {
            let b = &batches[i];
            let group = ShadeGroup { key: shade_key(b.key), material: b.material };
            let shade_group = match self.groups.iter().position(|g| *g == group) {
                Some(g) => g,
                None => {
                    self.groups.push(group);
                    self.groups.len() - 1
                }
            } as u32;
            let flags = (b.key.cull_back_faces as u32 * CULL_BACK) | (b.key.front_face_cw as u32 * FRONT_CW);
            let gpu = match mesh_pool.entry(b.mesh_id) {
                Some(e) => match &e.indices {
                    Some(r) => GpuRasterBatch {
                        first: b.first,
                        index_start: r.start,
                        vertex_start: e.vertices.start,
                        triangle_count: r.len() as u32 / 3,
                        flags,
                        count_word: i as u32 * ARGS_WORDS as u32 + 1,
                        shade_group,
                        _pad: 0,
                    },
                    None => GpuRasterBatch {
                        first: b.first,
                        index_start: e.vertices.start,
                        vertex_start: e.vertices.start,
                        triangle_count: e.vertices.len() as u32 / 3,
                        flags: flags | NON_INDEXED,
                        count_word: i as u32 * ARGS_WORDS as u32 + 1,
                        shade_group,
                        _pad: 0,
                    },
                },
                // Not uploaded (yet): no triangles.
                None => GpuRasterBatch {
                    first: b.first,
                    shade_group,
                    count_word: i as u32 * ARGS_WORDS as u32 + 1,
                    ..Zeroable::zeroed()
                },
            };
            table.push(gpu);
        }
        self.batch_count = table.len() as u32;
        self.bin_params.reserve(device, self.bins.len() as u64 * self.bin_stride);
        for (k, bin) in self.bins.iter().enumerate() {
            let words = [bin.first_batch, bin.end_batch, 0, 0];
            queue.write_buffer(self.bin_params.buffer(), k as u64 * self.bin_stride, bytemuck::cast_slice(&words));
        }
        let bytes: &[u8] = bytemuck::cast_slice(&table);
        self.batches.reserve(device, bytes.len().max(32) as u64);
        if !bytes.is_empty() {
            queue.write_buffer(self.batches.buffer(), 0, bytes);
        }
        // Per batch its first triangle number; the total; large triangles; their tile jobs.
        self.counters.reserve(device, (table.len() as u64 + 3) * 4);
        while self.shade_params.len() < self.groups.len() {
            self.shade_params.push(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("visibility shade params"),
                size: std::mem::size_of::<GpuShadeParams>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        self.bound = None;
    }

    /// The pipeline of `group` in the frame's shading pass, or (`first`) in the first
    /// shading of a frame with transmissive draws, which writes the opaque colour into the copy.
    fn shade_key(&self, group: &ShadeGroup, inputs: &FrameInputs, first: bool) -> ShadeKey {
        let (forward, background) = (group.key, inputs.background);
        if first {
            return ShadeKey { forward, output: ShadeOutput::Hdr, background, overlay: 0, reuse: false };
        }
        let overlay = if inputs.overlay.is_some() { inputs.samples } else { 0 };
        // Transmissive draws are blended-phase draws: their frames always have an overlay.
        let reuse = inputs.transmission.is_some() && overlay > 0;
        ShadeKey { forward, output: inputs.shade_output, background, overlay, reuse }
    }

    /// The shading passes' keys of `group`: the frame's, and the first shading's if it has one.
    fn shade_keys(&self, group: &ShadeGroup, inputs: &FrameInputs) -> Vec<ShadeKey> {
        let first = inputs.transmission.is_some().then(|| self.shade_key(group, inputs, true));
        std::iter::once(self.shade_key(group, inputs, false)).chain(first).collect()
    }

    /// A hybrid frame's overlay targets and occlusion group (made when the size, the sample
    /// count or the samples buffer changes); none without.
    fn prepare_overlay(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, inputs: &FrameInputs) {
        let Some(rect) = inputs.overlay else {
            self.overlay = None;
            return;
        };
        let extent = OverlayTargets::extent_for(rect, inputs.size);
        if self.overlay.as_ref().is_none_or(|o| o.extent != extent || o.samples != inputs.samples) {
            self.overlay = Some(OverlayTargets::new(device, extent, inputs.samples));
        }
        let overlay = self.overlay.as_mut().expect("made above");
        let params = GpuOcclusionParams::new(inputs.size, inputs.samples, rect, extent);
        queue.write_buffer(&overlay.params, 0, bytemuck::bytes_of(&params));
        let samples = self.samples.buffer();
        if overlay.occlusion.as_ref().is_none_or(|(b, _)| b != samples) {
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("visibility occlusion"),
                layout: &self.occlusion_layouts[0],
                entries: &[entry(0, samples), entry(1, &overlay.params)],
            });
            overlay.occlusion = Some((samples.clone(), group));
        }
        match &inputs.transmission {
            None => overlay.transmissive = None,
            Some(copy) if overlay.transmissive.as_ref().is_none_or(|(b, v, _)| b != samples || v != copy.whole) => {
                let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("visibility occlusion with transmission"),
                    layout: &self.occlusion_layouts[1],
                    entries: &[
                        entry(0, samples),
                        entry(1, &overlay.params),
                        wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(copy.whole) },
                        wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::Sampler(copy.sampler) },
                    ],
                });
                overlay.transmissive = Some((samples.clone(), copy.whole.clone(), group));
            }
            Some(_) => {}
        }
    }

    /// The overlay a hybrid frame's forward draws go into, after `prepare_frame`.
    pub fn overlay(&self) -> Option<&OverlayTargets> {
        self.overlay.as_ref()
    }

    /// Compiles the rasteriser's steps, which no material changes, ahead of the first frame
    /// rasterised in compute (`Renderer::warm_up`).
    pub fn warm_up(device: &wgpu::Device, pipelines: &mut PipelineCache) -> Result<(), ShaderError> {
        pipelines.prepare::<RasterFamily>(device, RasterStep::OPAQUE)
    }

    /// The batch table and its bins, as `prepare_batches` last made them: what rasterising the
    /// same batches elsewhere reads (the shadow casters', `features::shadows::raster`).
    pub fn raster_table(&self) -> RasterTable<'_> {
        RasterTable {
            batches: self.batches.buffer(),
            batch_count: self.batch_count,
            bins: &self.bins,
            bin_params: self.bin_params.buffer(),
            bin_stride: self.bin_stride,
        }
    }

    /// Compiles what the frame needs, sizes the buffers for it and writes its parameters.
    /// Returns the first pipeline error: groups whose pipeline (or material) is missing are
    /// not shaded, and the others add up as if they were the only ones.
    pub fn prepare_frame(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipelines: &mut PipelineCache,
        inputs: &FrameInputs,
    ) -> Result<(), ShaderError> {
        // Each is tried (a variant that fails leaves the others usable); the first error counts.
        let steps = self.raster_table().steps();
        let raster = pipelines.prepare::<RasterFamily>(device, steps);
        let shade =
            pipelines.prepare::<ShadeFamily>(device, self.groups.iter().flat_map(|g| self.shade_keys(g, inputs)));
        let compiled = raster.and(shade);
        self.shaded = (0..self.groups.len())
            .filter(|&g| {
                let group = &self.groups[g];
                self.shade_keys(group, inputs).iter().all(|k| pipelines.cached::<ShadeFamily>(k).is_some())
                    && inputs.materials.get(&group.material).is_some()
            })
            .collect();
        let (w, h) = inputs.size;
        let pixels = w as u64 * h as u64;
        self.samples.reserve(device, pixels * inputs.samples as u64 * SAMPLE_BYTES);
        self.prepare_overlay(device, queue, inputs);
        if self.groups.len() > 1 {
            self.partial.reserve(device, pixels * 16);
        }
        if inputs.shade_output.display() {
            if self.display.as_ref().is_none_or(|(t, _)| (t.width(), t.height()) != (w, h)) {
                let texture = device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("visibility display colour"),
                    size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: DISPLAY_FORMAT,
                    // A render attachment too: cleared when no group can be shaded.
                    usage: wgpu::TextureUsages::STORAGE_BINDING
                        | wgpu::TextureUsages::COPY_SRC
                        | wgpu::TextureUsages::RENDER_ATTACHMENT,
                    view_formats: &[],
                });
                let view = texture.create_view(&Default::default());
                self.display = Some((texture, view));
            }
        } else {
            self.display = None;
        }
        let jobs = self.job_capacity_set.unwrap_or_else(|| job_capacity((w, h)));
        self.resize_jobs(device, jobs);
        let raster = GpuRasterParams {
            target_size: [w, h],
            samples: inputs.samples,
            batch_count: self.batch_count,
            job_capacity: self.job_capacity,
            tile_groups: TILE_GROUPS,
            row_pitch: w,
            _pad: 0,
        };
        queue.write_buffer(&self.raster_params, 0, bytemuck::bytes_of(&raster));
        // The first group shaded starts the sums, the last writes the pixel.
        for (k, &g) in self.shaded.iter().enumerate() {
            let p = GpuShadeParams {
                target_size: [w, h],
                samples: inputs.samples,
                batch_count: self.batch_count,
                group: g as u32,
                accumulate: (k > 0) as u32,
                last: (k + 1 == self.shaded.len()) as u32,
                background: inputs.background as u32,
                clear: [inputs.clear[0], inputs.clear[1], inputs.clear[2], 1.0],
                overlay_origin: inputs.overlay.map_or([0; 2], |r| [r.origin.0, r.origin.1]),
                overlay_size: inputs.overlay.map_or([0; 2], |r| [r.size.0, r.size.1]),
            };
            queue.write_buffer(&self.shade_params[g], 0, bytemuck::bytes_of(&p));
        }
        compiled
    }

    fn bind(&mut self, device: &wgpu::Device, pipelines: &PipelineCache, inputs: &FrameInputs) {
        let made_with = vec![
            inputs.view.clone(),
            inputs.instances.clone(),
            inputs.visible_slots.clone(),
            inputs.cull_args.clone(),
            inputs.mesh_pool.index_buffer().clone(),
            inputs.mesh_pool.vertex_buffer().clone(),
            self.batches.buffer().clone(),
            self.counters.buffer().clone(),
            self.samples.buffer().clone(),
            self.partial.buffer().clone(),
            self.bin_params.buffer().clone(),
            inputs.materials.buffer().clone(),
        ];
        let target = match (&self.display, inputs.hdr) {
            (Some((_, view)), _) => view.clone(),
            (None, Some(hdr)) => hdr.clone(),
            (None, None) => unreachable!("an HDR frame passes its HDR target"),
        };
        let first_target = inputs.transmission.as_ref().map(|copy| copy.level0.clone());
        let overlay = self.overlay.as_ref().map(|o| o.colour.clone());
        if self.bound.as_ref().is_some_and(|b| {
            b.made_with == made_with && b.target == target && b.overlay == overlay && b.first_target == first_target
        }) {
            return;
        }
        let raster = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("visibility raster"),
            layout: &pipelines.family::<RasterFamily>().raster,
            entries: &[
                entry(0, inputs.view),
                entry(1, inputs.instances),
                entry(2, inputs.visible_slots),
                entry(3, self.batches.buffer()),
                entry(4, inputs.cull_args),
                entry(5, inputs.mesh_pool.index_buffer()),
                entry(6, inputs.mesh_pool.vertex_buffer()),
                entry(7, &self.raster_params),
                entry(8, self.counters.buffer()),
                entry(9, self.samples.buffer()),
                entry(10, &self.jobs),
                wgpu::BindGroupEntry {
                    binding: 11,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: self.bin_params.buffer(),
                        offset: 0,
                        size: wgpu::BufferSize::new(BIN_BYTES),
                    }),
                },
                entry(12, inputs.materials.buffer()),
            ],
        });
        let dispatch = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("visibility raster dispatch"),
            layout: &pipelines.family::<RasterFamily>().dispatch,
            entries: &[entry(0, &self.dispatch)],
        });
        let texture =
            |binding, view| wgpu::BindGroupEntry { binding, resource: wgpu::BindingResource::TextureView(view) };
        // Per group: the frame's shading pass's group, and the first shading's.
        let groups = |first: bool| -> Vec<wgpu::BindGroup> {
            if first && first_target.is_none() {
                return Vec::new();
            }
            self.shade_params[..self.groups.len()]
                .iter()
                .zip(&self.groups)
                .map(|(params, group)| {
                    let key = self.shade_key(group, inputs, first);
                    let written = if first { first_target.as_ref().expect("checked above") } else { &target };
                    let mut entries = vec![
                        entry(0, params),
                        entry(1, self.samples.buffer()),
                        entry(2, self.batches.buffer()),
                        entry(3, self.counters.buffer()),
                        entry(4, inputs.mesh_pool.index_buffer()),
                        entry(5, self.partial.buffer()),
                        texture(6, written),
                    ];
                    if let Some(view) = overlay.as_ref().filter(|_| key.overlay > 0) {
                        entries.push(texture(7, view));
                    }
                    if let Some(view) = first_target.as_ref().filter(|_| key.reuse) {
                        entries.push(texture(8, view));
                    }
                    device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("visibility shade"),
                        layout: pipelines.family::<ShadeFamily>().layout(&key),
                        entries: &entries,
                    })
                })
                .collect()
        };
        let (shade, first) = (groups(false), groups(true));
        self.bound = Some(Bound { made_with, target, overlay, first_target, raster, dispatch, shade, first });
    }

    /// Encodes the raster steps (after `prepare_frame`); then, in a hybrid frame, the forward
    /// pass draws into the overlay, and `encode_shade` shades (with transmissive draws:
    /// `encode_first_shade`, the copy's mip chain, the overlay, then `encode_shade`).
    pub fn encode_raster(&mut self, cx: &mut FrameContext, inputs: &FrameInputs) {
        let (encoder, device, pipelines, timer) =
            (&mut *cx.encoder, cx.device, &mut *cx.pipelines, cx.timer.as_deref_mut());
        self.bind(device, pipelines, inputs);
        let bound = self.bound.as_ref().expect("bound above");
        encoder.clear_buffer(self.samples.buffer(), 0, None);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("visibility raster"),
                timestamp_writes: timer.and_then(|t| t.compute_pass("visibility raster")),
            });
            let groups = RasterGroups { raster: &bound.raster, dispatch: &bound.dispatch, args: &self.dispatch };
            self.raster_table().encode::<false>(&mut pass, pipelines, &groups, inputs.materials);
        }
    }

    /// Encodes the shading pass (after `encode_raster` and a hybrid frame's overlay draws),
    /// which writes the frame's output.
    pub fn encode_shade(&mut self, cx: &mut FrameContext, inputs: &FrameInputs) {
        self.dispatch_shade(cx, inputs, false);
        self.copy_display(cx.encoder, inputs);
    }

    /// With transmissive draws (`FrameInputs::transmission`), before the overlay's draws: the
    /// first shading, which writes the opaque colour into the copy's level 0.
    pub fn encode_first_shade(&mut self, cx: &mut FrameContext, inputs: &FrameInputs) {
        self.dispatch_shade(cx, inputs, true);
    }

    fn dispatch_shade(&self, cx: &mut FrameContext, inputs: &FrameInputs, first: bool) {
        let (encoder, pipelines, timer) = (&mut *cx.encoder, &mut *cx.pipelines, cx.timer.as_deref_mut());
        let bound = self.bound.as_ref().expect("bound by encode_raster");
        let (groups, written) = match (first, &bound.first_target) {
            (true, Some(level0)) => (&bound.first, level0),
            (true, None) => return,
            (false, _) => (&bound.shade, &bound.target),
        };
        let (w, h) = inputs.size;
        {
            let label = if first { "visibility first shade" } else { "visibility shade" };
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(label),
                timestamp_writes: timer.and_then(|t| t.compute_pass(label)),
            });
            pass.set_bind_group(0, inputs.view_bind_group, &[]);
            for &g in &self.shaded {
                let group = &self.groups[g];
                let key = self.shade_key(group, inputs, first);
                let (Some(pipeline), Some(material)) =
                    (pipelines.cached::<ShadeFamily>(&key), inputs.materials.get(&group.material))
                else {
                    continue;
                };
                pass.set_pipeline(pipeline);
                pass.set_bind_group(1, &material.bind_group, &[]);
                pass.set_bind_group(2, &groups[g], &[]);
                if let Some((extension, _)) = &material.extension {
                    pass.set_bind_group(EXTENSION_GROUP, extension, &[]);
                }
                pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
            }
        }
        if self.shaded.is_empty() {
            // Nothing could be shaded (a broken shader folder at start-up): black, not the last
            // frame's colour (the error is reported).
            clear_black(encoder, written, "visibility shade, nothing shaded");
        }
    }

    /// Copies the displayed colour, if the frame writes it, into the output.
    fn copy_display(&self, encoder: &mut wgpu::CommandEncoder, inputs: &FrameInputs) {
        if let Some((display, _)) = &self.display {
            // Formats that differ only in sRGB-ness copy byte for byte: the bytes are encoded.
            encoder.copy_texture_to_texture(
                display.as_image_copy(),
                inputs.output.as_image_copy(),
                wgpu::Extent3d { width: inputs.size.0, height: inputs.size.1, depth_or_array_layers: 1 },
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{GpuRasterBatch, GpuRasterParams, GpuShadeParams, Raster, RasterGate, fits};
    use crate::pipelines::shader_library::assert_mirrors_wgsl;

    #[test]
    fn the_first_reason_that_applies_decides_where_opaque_draws_go() {
        let open = RasterGate {
            setting: Raster::Compute,
            atomics: true,
            few_graphics_units: false,
            culling: true,
            fits: true,
            occlusion_on: false,
            opaque: true,
        };
        assert_eq!(open.decide(), Ok("--raster compute"));
        assert!(RasterGate { setting: Raster::Auto, ..open }.decide().unwrap_err().contains("keeps up"));
        let hopper = RasterGate { setting: Raster::Auto, few_graphics_units: true, ..open };
        assert!(hopper.decide().unwrap().contains("few graphics units"));
        assert_eq!(RasterGate { setting: Raster::Hardware, ..hopper }.decide(), Err("--raster hardware"));
        // Several reasons: the first in order is named.
        let both = RasterGate { occlusion_on: true, opaque: false, ..hopper };
        assert!(both.decide().unwrap_err().starts_with("occlusion culling"));
        assert!(RasterGate { atomics: false, ..both }.decide().unwrap_err().contains("64-bit atomic"));
        assert!(
            RasterGate { opaque: false, ..hopper }.decide().unwrap_err().starts_with("no opaque or masked triangle")
        );
    }

    #[test]
    fn the_rust_structs_mirror_the_shaders() {
        assert_mirrors_wgsl!(
            GpuRasterBatch,
            "visibility_raster.wgsl",
            [],
            "RasterBatch",
            [first, index_start, vertex_start, triangle_count, flags, count_word, shade_group]
        );
        assert_mirrors_wgsl!(
            GpuRasterParams,
            "visibility_raster.wgsl",
            [],
            "RasterParams",
            [target_size, samples, batch_count, job_capacity, tile_groups, row_pitch]
        );
        assert_mirrors_wgsl!(
            GpuShadeParams,
            "forward.wgsl",
            ["VISIBILITY_SHADE", "PULLED_VERTICES", "POOL_VERTICES"],
            "ShadeParams",
            [
                target_size,
                samples,
                batch_count,
                group,
                accumulate,
                last,
                background,
                clear,
                overlay_origin,
                overlay_size
            ]
        );
    }

    #[test]
    fn the_visibility_buffer_must_be_one_storage_binding() {
        let limits = wgpu::Limits { max_storage_buffer_binding_size: 128 << 20, ..Default::default() };
        // 1920×1080×4 samples×8 bytes = 66 MiB; 3840×2160 at 4 samples 265 MiB.
        assert!(fits(&limits, (1920, 1080), 4));
        assert!(!fits(&limits, (3840, 2160), 4));
        assert!(fits(&limits, (3840, 2160), 1));
    }
}
