//! The pipeline cache: owns the bind group layouts, the shader library and every render
//! pipeline, each compiled once per key and kept until a shader it uses changes.
//!
//! Keys include the shader variant: which material textures a draw samples, its alpha mode,
//! whether it is unlit, whether the scene has point or spot lights. Each variant's shader is
//! composed with only that code (`#ifdef` switches, see `shader_library.rs`), so a scene without
//! normal maps or local lights runs shaders without them. Every draw is instanced (a batch of one
//! has an instance count of one), so instancing is not a key dimension.
//!
//! Hot reload ([`PipelineCache::reload`]): a candidate shader library is built from the changed
//! files, every cached pipeline whose entry shader depends on them is rebuilt with it inside a
//! wgpu error scope, and only if all succeed are the library and those pipelines swapped in.
//! Pipelines that do not use the changed files are untouched. On any error nothing changes and
//! the frame keeps drawing with the last good pipelines.

use std::collections::{HashMap, HashSet};

mod casters;
mod culling;
mod deform;
mod environment;
mod gizmos;
mod post;
mod visibility;
pub use casters::CasterKey;
pub use culling::{CullPhase, HzbStep};
pub use environment::{BackgroundMode, ENVIRONMENT_FORMAT, EQUIRECT_FORMAT, EnvStep};
pub use gizmos::GIZMO_VERTEX_BYTES;
pub use post::{BloomStep, ExposureStep, TonemapKey};
pub use visibility::{DISPLAY_FORMAT, RasterStep, ShadeKey, ShadeOutput, shade_key};

use penumbra_engine::mesh::Topology;

use super::shader_library::{ShaderDefs, ShaderError, ShaderLibrary};
use crate::context::Capabilities;
use crate::prepare::light_store::LightShapes;
use crate::prepare::materials::AlphaKey;
use crate::prepare::mesh_pool::GpuVertex;

/// Which material textures a draw samples (bits in `StandardMaterial::textures()` order), and
/// whether any of them maps its coordinate (`TRANSFORMED_UVS`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct TextureSet(pub u8);

impl TextureSet {
    pub const BASE_COLOR: u8 = 1;
    pub const METALLIC_ROUGHNESS: u8 = 2;
    pub const NORMAL: u8 = 4;
    pub const OCCLUSION: u8 = 8;
    pub const EMISSIVE: u8 = 16;
    /// Some texture reads TEXCOORD_1 or has a KHR_texture_transform. Without this bit every
    /// texture samples TEXCOORD_0 as it is, with the sampler's own derivatives.
    pub const TRANSFORMED_UVS: u8 = 32;
    /// The occlusion texture is the metallic-roughness texture (same image, sampler and
    /// coordinates: glTF's ORM packing, occlusion in red), so one sample serves both.
    pub const OCCLUSION_IN_METALLIC_ROUGHNESS: u8 = 64;

    pub fn has(self, bit: u8) -> bool {
        self.0 & bit != 0
    }
}

/// Everything that selects a forward pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PipelineKey {
    pub unlit: bool,
    pub alpha: AlphaKey,
    pub textures: TextureSet,
    /// How (and whether) local lights are found; without any, their code is left out.
    pub local_lights: LocalLights,
    /// Which lights with a size need their shading code.
    pub light_shapes: LightShapes,
    /// More global lights than the uniform array holds (`LightStore::global_lights_fit_uniform`):
    /// they are walked in the storage array.
    pub global_lights_in_storage: bool,
    /// Directional lights cast shadows this frame: the shadow-map lookups are compiled in.
    pub shadows: bool,
    /// Some local light reads a shadow map this frame.
    pub local_shadows: bool,
    /// The scene has an environment: image-based light is compiled in.
    pub ibl: bool,
    pub debug: DebugView,
    pub topology: TopologyKey,
    /// The mesh has vertex colours other than white (`PoolEntry::vertex_colors`).
    pub vertex_colors: bool,
    /// Double-sided materials draw both faces.
    pub cull_back_faces: bool,
    /// Mirrored instances (negative determinant) wind clockwise.
    pub front_face_cw: bool,
    pub sample_count: u32,
    /// Where a masked draw tests its alpha.
    pub alpha_test: AlphaTest,
    pub color_format: FormatKey,
    /// `None`: the frame has no depth target (its draws cannot cover a pixel twice).
    pub depth_format: Option<FormatKey>,
    /// The fragment shader tonemaps (with this curve) and writes the output itself, when
    /// nothing reads the HDR colour (`color_format` is then the output's format).
    pub tonemap: Option<Tonemapper>,
    /// A triangle-culled draw: the vertex shader reads its vertices from the mesh pool, named
    /// by the culled index list (`passes::culling`), instead of from a vertex buffer.
    pub pulled_vertices: bool,
}

impl PipelineKey {
    /// The shader variant this key compiles.
    pub fn shader_defs(&self) -> ShaderDefs {
        let t = self.textures;
        let lit = !self.unlit;
        // Deferred: the compute pass shades local lights; fragments only hand it their surface.
        let local = lit && !matches!(self.local_lights, LocalLights::None | LocalLights::Deferred);
        ShaderDefs::default()
            .with("UNLIT", self.unlit)
            .with("ALPHA_MASK", self.alpha == AlphaKey::Mask)
            .with("ALPHA_COVERAGE", self.alpha_test == AlphaTest::SampleMask)
            .with("ALPHA_SAMPLE_RATE", self.alpha_test == AlphaTest::SampleRate)
            .with("ALPHA_BLEND", self.alpha == AlphaKey::Blend)
            .with("BASE_COLOR_TEXTURE", t.has(TextureSet::BASE_COLOR))
            // An unlit surface reads only its base colour.
            .with("METALLIC_ROUGHNESS_TEXTURE", lit && t.has(TextureSet::METALLIC_ROUGHNESS))
            .with("NORMAL_MAP", lit && t.has(TextureSet::NORMAL))
            .with("OCCLUSION_TEXTURE", lit && t.has(TextureSet::OCCLUSION))
            .with("EMISSIVE_TEXTURE", lit && t.has(TextureSet::EMISSIVE))
            .with("TRANSFORMED_UVS", t.has(TextureSet::TRANSFORMED_UVS))
            // Set only with both textures (materials.rs).
            .with("OCCLUSION_IN_METALLIC_ROUGHNESS", lit && t.has(TextureSet::OCCLUSION_IN_METALLIC_ROUGHNESS))
            .with("LOCAL_LIGHTS", local)
            .with("GLOBAL_LIGHTS_IN_STORAGE", lit && self.global_lights_in_storage)
            .with("DEFERRED_LOCAL_LIGHTS", self.local_lights == LocalLights::Deferred)
            .with("CLUSTERED_LIGHTS", lit && self.local_lights == LocalLights::Clustered)
            .with("UNBOUNDED_LIGHTS", lit && self.local_lights == LocalLights::AllUnbounded)
            .with("SPHERE_TUBE_LIGHTS", local && self.light_shapes.sphere_tube)
            .with("LTC_LIGHTS", local && self.light_shapes.ltc)
            .with("IES_LIGHTS", local && self.light_shapes.ies)
            .with("SHADOWS", lit && self.shadows)
            .with("LOCAL_SHADOWS", local && self.local_shadows)
            .with("IBL", lit && self.ibl)
            .with("DEBUG_CLUSTER_HEAT", self.debug == DebugView::ClusterHeat)
            .with("DEBUG_CASCADES", self.debug == DebugView::Cascades)
            .with("DEBUG_NORMALS", self.debug == DebugView::Normals)
            .with("DEBUG_UVS", self.debug == DebugView::Uvs)
            .with("LINE_QUADS", self.topology == TopologyKey::Lines)
            .with("PULLED_VERTICES", self.pulled_vertices)
            .with("POOL_VERTICES", self.pulled_vertices || self.topology == TopologyKey::Lines)
            .with("VERTEX_COLORS", self.vertex_colors)
            .with("TONEMAP_IN_FORWARD", self.tonemap.is_some())
            .with("TONEMAP_NEUTRAL", self.tonemap == Some(Tonemapper::Neutral))
            .with("TONEMAP_ACES", self.tonemap == Some(Tonemapper::Aces))
            .with("ENCODE_SRGB", self.tonemap.is_some() && !self.color_format.0.is_srgb())
    }
}

/// Where a masked draw (glTF's alpha mode MASK) tests its alpha against the cutoff.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub enum AlphaTest {
    /// Once, at the pixel's centre: not masked, or one sample per pixel.
    #[default]
    PerPixel,
    /// At each of the 4 samples, by a sample mask the shader computes (`ALPHA_COVERAGE`,
    /// forward.wgsl's `alpha_coverage`): masked edges are antialiased like geometric ones.
    SampleMask,
    /// At each of the 4 samples, by shading each sample (`ALPHA_SAMPLE_RATE`): the same test
    /// where the backend cannot write a sample mask (`Capabilities::sample_mask_output`).
    SampleRate,
}

impl AlphaTest {
    /// The test for a draw with `alpha` mode in a frame of `samples` per pixel. `alpha_varies`:
    /// the draw's alpha can change within a pixel (a base colour texture or vertex colours);
    /// a constant alpha passes or fails every sample alike, so it is tested once.
    pub fn choose(alpha: AlphaKey, samples: u32, alpha_varies: bool, caps: &Capabilities) -> Self {
        if alpha != AlphaKey::Mask || samples != 4 || !alpha_varies {
            AlphaTest::PerPixel
        } else if caps.sample_mask_output {
            AlphaTest::SampleMask
        } else if caps.sample_rate_shading {
            AlphaTest::SampleRate
        } else {
            AlphaTest::PerPixel
        }
    }
}

/// How the forward shader walks local lights (every kind but directional and ambient).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub enum LocalLights {
    /// The scene has none: no local-light code at all.
    #[default]
    None,
    /// Each fragment walks its cluster's list (the normal path).
    Clustered,
    /// Each fragment walks every local light, windowed by range: the brute-force reference the
    /// clustered path must equal.
    All,
    /// Every local light with no range window (inverse square to infinity): the reference for
    /// the error the window introduces.
    AllUnbounded,
    /// Opaque fragments write their surface to extra targets and a compute pass walks the
    /// cluster lists (`deferred_lights.wgsl`); blended draws keep `Clustered`.
    Deferred,
}

/// Selects a deferred-lights compute pipeline: the frame's sample count and the kinds of lights
/// with a size it must shade.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DeferredKey {
    pub multisampled: bool,
    pub light_shapes: LightShapes,
    /// Some local light reads a shadow map.
    pub local_shadows: bool,
}

/// Format of the surface target opaque fragments write for the deferred-lights pass, beside
/// roughness in the colour's alpha (see `gbuffer.wgsl`).
pub const SURFACE_SHAPE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Uint;
/// What the deferred-lights pass writes and the composite adds.
pub const LOCAL_LIGHT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// Debug views replacing the shaded colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub enum DebugView {
    #[default]
    None,
    /// Lights in each fragment's cluster as a heat map (black 0, then blue → green → yellow →
    /// red → white on a log scale up to 256 and beyond).
    ClusterHeat,
    /// The first shadowed directional light's cascade of each fragment (red, green, blue,
    /// yellow from near to far; grey beyond them), shaded by the lit image's brightness.
    Cascades,
    /// The shading normal (after normal mapping) in world space, as colour: n · 0.5 + 0.5.
    Normals,
    /// The first texture coordinate set, as colour: red u, green v (wrapped into 0..1).
    Uvs,
}

/// The entry points of `cluster_bin.wgsl`, in the order they run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ClusterEntry {
    Count,
    ScanBlocks,
    ScanApply,
    Fill,
    SortShort,
    SortLong,
}

impl ClusterEntry {
    fn name(self) -> &'static str {
        match self {
            ClusterEntry::Count => "count_lights",
            ClusterEntry::ScanBlocks => "scan_blocks",
            ClusterEntry::ScanApply => "scan_apply",
            ClusterEntry::Fill => "fill_lists",
            ClusterEntry::SortShort => "sort_short",
            ClusterEntry::SortLong => "sort_long",
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum TopologyKey {
    Triangles,
    Lines,
    Points,
}

impl From<Topology> for TopologyKey {
    fn from(t: Topology) -> Self {
        match t {
            Topology::TriangleList => TopologyKey::Triangles,
            Topology::LineList => TopologyKey::Lines,
            Topology::PointList => TopologyKey::Points,
        }
    }
}

/// A texture format usable as a map key with a total order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FormatKey(pub wgpu::TextureFormat);

impl PartialOrd for FormatKey {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for FormatKey {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        // Batch sorting compares a draw's key with its neighbour's: nearly always equal, and
        // then no string is built. Different formats order by name (wgpu gives no other).
        if self.0 == other.0 {
            return std::cmp::Ordering::Equal;
        }
        format!("{:?}", self.0).cmp(&format!("{:?}", other.0))
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Tonemapper {
    /// Khronos PBR Neutral: hue-preserving, base colours reproduce as authored. The default.
    Neutral,
    /// ACES filmic (Hill's RRT+ODT fit).
    Aces,
    /// Clamp only.
    None,
}

/// What a hot reload did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReloadReport {
    /// The files that differ from the library replaced (sorted), whichever events announced them.
    pub files: Vec<String>,
    /// Pipelines rebuilt because they use a changed file.
    pub rebuilt: usize,
    /// Those pipelines by family (`forward`, `tonemap`, `environment`, …), families with none
    /// left out.
    pub families: Vec<(&'static str, usize)>,
    /// Pipelines left alone.
    pub untouched: usize,
    /// An environment step (the source, its filters or the split-sum table) was rebuilt: what
    /// it made must be made again with the new code.
    pub environment_steps: bool,
}

pub struct PipelineCache {
    shaders: ShaderLibrary,
    pub view_layout: wgpu::BindGroupLayout,
    pub material_layout: wgpu::BindGroupLayout,
    pub tonemap_layout: wgpu::BindGroupLayout,
    /// One level of a texture, loaded texel by texel, and the sRGB decoding table (mip
    /// generation).
    pub mipmap_layout: wgpu::BindGroupLayout,
    /// The multisampled colour a shader resolve reads.
    pub resolve_layout: wgpu::BindGroupLayout,
    /// A texture and a linear clamping sampler (bloom, FXAA).
    pub filtered_source_layout: wgpu::BindGroupLayout,
    pub cluster_layout: wgpu::BindGroupLayout,
    cluster_pipeline_layout: wgpu::PipelineLayout,
    forward_layout: wgpu::PipelineLayout,
    tonemap_pipeline_layout: wgpu::PipelineLayout,
    mipmap_pipeline_layout: wgpu::PipelineLayout,
    resolve_pipeline_layout: wgpu::PipelineLayout,
    filtered_source_pipeline_layout: wgpu::PipelineLayout,
    forward: HashMap<PipelineKey, wgpu::RenderPipeline>,
    tonemap: HashMap<TonemapKey, wgpu::RenderPipeline>,
    post_layouts: post::PostLayouts,
    bloom: HashMap<BloomStep, wgpu::RenderPipeline>,
    exposure: HashMap<ExposureStep, wgpu::ComputePipeline>,
    /// Keyed by output format.
    fxaa: HashMap<wgpu::TextureFormat, wgpu::RenderPipeline>,
    /// By the format of the views drawn through, and whether the shader converts sRGB.
    mipmap: HashMap<(wgpu::TextureFormat, bool), wgpu::RenderPipeline>,
    /// Shader MSAA resolves, by the format written.
    resolve: HashMap<FormatKey, wgpu::RenderPipeline>,
    cluster: HashMap<ClusterEntry, wgpu::ComputePipeline>,
    /// Inputs of the deferred-lights pass, single-sampled and multisampled.
    pub deferred_layouts: [wgpu::BindGroupLayout; 2],
    deferred_pipeline_layouts: [wgpu::PipelineLayout; 2],
    pub composite_layout: wgpu::BindGroupLayout,
    composite_pipeline_layout: wgpu::PipelineLayout,
    deferred: HashMap<DeferredKey, wgpu::ComputePipeline>,
    /// Keyed by sample count and depth format.
    composite: HashMap<(u32, FormatKey), wgpu::RenderPipeline>,
    pub caster_layout: wgpu::BindGroupLayout,
    /// Opaque casters (caster group only) and masked ones (with the material group).
    caster_pipeline_layouts: [wgpu::PipelineLayout; 2],
    caster: HashMap<CasterKey, wgpu::RenderPipeline>,
    cull_layouts: culling::CullLayouts,
    cull: HashMap<CullPhase, wgpu::ComputePipeline>,
    hzb: HashMap<HzbStep, wgpu::ComputePipeline>,
    deform_layouts: deform::DeformLayouts,
    visibility_layouts: visibility::VisibilityLayouts,
    visibility_raster: HashMap<RasterStep, wgpu::ComputePipeline>,
    visibility_shade: HashMap<ShadeKey, wgpu::ComputePipeline>,
    deform: Option<wgpu::ComputePipeline>,
    env_layouts: environment::EnvLayouts,
    env: HashMap<EnvStep, wgpu::ComputePipeline>,
    background: HashMap<BackgroundMode, wgpu::RenderPipeline>,
    gizmo_layout: wgpu::PipelineLayout,
    /// By sample count.
    gizmo: HashMap<u32, wgpu::RenderPipeline>,
    /// Pipelines created since start-up (a pipeline compiled twice would show here).
    pub compiled: usize,
    /// Incremented by every successful reload.
    pub generation: u64,
}

fn storage(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    buffer_entry(binding, visibility, wgpu::BufferBindingType::Storage { read_only: true })
}

fn buffer_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    ty: wgpu::BufferBindingType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    }
}

fn texture(binding: u32, filterable: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

/// A 2D-array texture (the shadow atlases: as depth for comparisons, as floats for loads).
fn array_texture(
    binding: u32,
    visibility: wgpu::ShaderStages,
    sample_type: wgpu::TextureSampleType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        },
        count: None,
    }
}

fn sampler(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    }
}

/// Logs (debug) how long the driver took to create a pipeline, when dropped.
struct PipelineTiming(std::time::Instant);

impl Drop for PipelineTiming {
    fn drop(&mut self) {
        tracing::debug!("render pipeline created in {:.1} ms", self.0.elapsed().as_secs_f64() * 1e3);
    }
}

/// The forward pipeline of `key` from its composed `module`.
fn forward_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    key: PipelineKey,
) -> Result<wgpu::RenderPipeline, ShaderError> {
    let blend = (key.alpha == AlphaKey::Blend).then_some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING);
    let label = format!("forward {key:?}");
    let color = Some(wgpu::ColorTargetState { format: key.color_format.0, blend, write_mask: wgpu::ColorWrites::ALL });
    let surface = |format| Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL });
    let targets = if key.local_lights == LocalLights::Deferred {
        vec![color, surface(SURFACE_SHAPE_FORMAT)]
    } else {
        vec![color]
    };
    let vertex_buffers = [Some(GpuVertex::layout())];
    let _timing = PipelineTiming(std::time::Instant::now());
    checked_pipeline(device, "forward.wgsl", || {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(&label),
            layout: Some(layout),
            vertex: wgpu::VertexState {
                module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: if key.pulled_vertices { &[] } else { &vertex_buffers },
            },
            primitive: wgpu::PrimitiveState {
                // Lines are drawn as quads (prepare/line_quads.rs); keys of lines and points
                // never cull (see `Renderer::pipeline_key`).
                topology: match key.topology {
                    TopologyKey::Triangles | TopologyKey::Lines => wgpu::PrimitiveTopology::TriangleList,
                    TopologyKey::Points => wgpu::PrimitiveTopology::PointList,
                },
                strip_index_format: None,
                front_face: if key.front_face_cw { wgpu::FrontFace::Cw } else { wgpu::FrontFace::Ccw },
                cull_mode: key.cull_back_faces.then_some(wgpu::Face::Back),
                unclipped_depth: false,
                polygon_mode: wgpu::PolygonMode::Fill,
                conservative: false,
            },
            depth_stencil: key.depth_format.map(|depth| wgpu::DepthStencilState {
                format: depth.0,
                // Blended surfaces are sorted back to front and must not hide what lies
                // behind them in later draws.
                depth_write_enabled: Some(key.alpha != AlphaKey::Blend),
                // Reverse-Z: nearer is greater.
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState::default(),
            }),
            multisample: wgpu::MultisampleState { count: key.sample_count, mask: !0, alpha_to_coverage_enabled: false },
            fragment: Some(wgpu::FragmentState {
                module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &targets,
            }),
            multiview_mask: None,
            cache: None,
        })
    })
}

/// Creates a pipeline inside a validation error scope, so a shader that composes but does not
/// fit the pipeline (a renamed entry point, a changed binding) is an error, not a crash.
fn checked_pipeline<P>(device: &wgpu::Device, file: &str, create: impl FnOnce() -> P) -> Result<P, ShaderError> {
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let pipeline = create();
    match pollster::block_on(scope.pop()) {
        None => Ok(pipeline),
        Some(e) => Err(ShaderError::from_wgpu(file, &e)),
    }
}

impl PipelineCache {
    pub fn new(device: &wgpu::Device, shaders: ShaderLibrary) -> Self {
        let vf = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
        // What the deferred-lights compute pass reads as well.
        let lit = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
        let view_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("view"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: vf,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                // Compute too: the visibility buffer's shading pass places vertices and reads
                // materials (passes/visibility.rs).
                storage(1, wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::COMPUTE),
                storage(2, wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::COMPUTE),
                storage(3, lit),
                storage(4, lit),
                buffer_entry(5, lit, wgpu::BufferBindingType::Uniform),
                storage(6, lit),
                storage(7, lit),
                storage(8, lit),
                storage(9, lit),
                // Shadows (shaders/shadows.wgsl): the uniform, the atlas, the comparison sampler.
                buffer_entry(10, lit, wgpu::BufferBindingType::Uniform),
                array_texture(11, lit, wgpu::TextureSampleType::Depth),
                wgpu::BindGroupLayoutEntry {
                    binding: 12,
                    visibility: lit,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
                    count: None,
                },
                // Local lights' shadows: one entry per layer, and the layers.
                storage(13, lit),
                array_texture(14, lit, wgpu::TextureSampleType::Depth),
                // The environment (shaders/ibl.wgsl): parameters, irradiance harmonics, the
                // specular cube; then the split-sum table every lit surface reads
                // (shaders/split_sum.wgsl) and the sampler it shares with the cube.
                buffer_entry(15, lit, wgpu::BufferBindingType::Uniform),
                storage(16, lit),
                wgpu::BindGroupLayoutEntry {
                    binding: 17,
                    visibility: lit,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::Cube,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry { visibility: lit, ..texture(18, true) },
                wgpu::BindGroupLayoutEntry { visibility: lit, ..sampler(19) },
                // The directional shadow atlas as floats, for the PCSS blocker search's loads.
                array_texture(20, lit, wgpu::TextureSampleType::Float { filterable: false }),
                // The mesh pool's vertices, where a line quad's corner finds its opposite
                // endpoint (prepare/line_quads.rs).
                storage(21, wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::COMPUTE),
                // The light store's first slots again, as the uniform array of global lights
                // (LightStore::global_lights_binding).
                buffer_entry(22, lit, wgpu::BufferBindingType::Uniform),
            ],
        });
        let compute = wgpu::ShaderStages::COMPUTE;
        let read_write = wgpu::BufferBindingType::Storage { read_only: false };
        let cluster_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cluster binning"),
            entries: &[
                buffer_entry(0, compute, wgpu::BufferBindingType::Uniform),
                storage(1, compute),
                buffer_entry(2, compute, read_write),
                buffer_entry(3, compute, read_write),
                buffer_entry(4, compute, read_write),
                buffer_entry(5, compute, read_write),
                buffer_entry(6, compute, read_write),
            ],
        });
        let material_entries: Vec<_> = (0..5u32)
            .flat_map(|i| [texture(2 * i, true), sampler(2 * i + 1)])
            .map(|e| wgpu::BindGroupLayoutEntry { visibility: lit, ..e })
            .collect();
        let material_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("material"),
            entries: &material_entries,
        });
        // The resolved HDR frame, the bloom chain's level 0, its sampler, the post parameters.
        let tonemap_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("tonemap"),
            entries: &[texture(0, false), texture(1, true), sampler(2), storage(3, wgpu::ShaderStages::FRAGMENT)],
        });
        let mipmap_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("mipmap"),
            entries: &[
                texture(0, false),
                buffer_entry(1, wgpu::ShaderStages::FRAGMENT, wgpu::BufferBindingType::Uniform),
            ],
        });
        let resolve_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("resolve"),
            entries: &[wgpu::BindGroupLayoutEntry {
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: true,
                },
                ..texture(0, false)
            }],
        });
        let filtered_source_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("filtered source"),
            entries: &[texture(0, true), sampler(1)],
        });
        let layout = |label, groups: &[Option<&wgpu::BindGroupLayout>]| {
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: groups,
                immediate_size: 0,
            })
        };
        let forward_layout = layout("forward", &[Some(&view_layout), Some(&material_layout)]);
        let tonemap_pipeline_layout = layout("tonemap", &[Some(&tonemap_layout)]);
        let mipmap_pipeline_layout = layout("mipmap", &[Some(&mipmap_layout)]);
        let resolve_pipeline_layout = layout("resolve", &[Some(&resolve_layout)]);
        let filtered_source_pipeline_layout = layout("filtered source", &[Some(&filtered_source_layout)]);
        let cluster_pipeline_layout = layout("cluster binning", &[Some(&cluster_layout)]);
        let deferred_layouts = [false, true].map(|multisampled| {
            let surface = |binding, sample_type| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: compute,
                ty: wgpu::BindingType::Texture {
                    sample_type,
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled,
                },
                count: None,
            };
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(if multisampled { "deferred lights (msaa)" } else { "deferred lights" }),
                entries: &[
                    surface(0, wgpu::TextureSampleType::Float { filterable: false }),
                    surface(1, wgpu::TextureSampleType::Uint),
                    surface(2, wgpu::TextureSampleType::Depth),
                    wgpu::BindGroupLayoutEntry {
                        binding: 3,
                        visibility: compute,
                        ty: wgpu::BindingType::StorageTexture {
                            access: wgpu::StorageTextureAccess::WriteOnly,
                            format: LOCAL_LIGHT_FORMAT,
                            view_dimension: wgpu::TextureViewDimension::D2,
                        },
                        count: None,
                    },
                    buffer_entry(4, compute, wgpu::BufferBindingType::Uniform),
                ],
            })
        });
        let deferred_pipeline_layouts =
            [0, 1].map(|i| layout("deferred lights", &[Some(&view_layout), Some(&deferred_layouts[i])]));
        let composite_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("deferred composite"),
            entries: &[texture(0, false)],
        });
        let composite_pipeline_layout = layout("deferred composite", &[Some(&composite_layout)]);
        let cull_layouts = culling::cull_layouts(device);
        let gizmo_layout = layout("gizmos", &[Some(&view_layout)]);
        let env_layouts = environment::env_layouts(device, &view_layout);
        let post_layouts = post::post_layouts(device);
        let caster_layout = casters::caster_layout(device);
        let caster_pipeline_layouts = [
            layout("shadow casters", &[Some(&caster_layout)]),
            layout("masked shadow casters", &[Some(&caster_layout), Some(&material_layout)]),
        ];
        Self {
            post_layouts,
            bloom: HashMap::new(),
            exposure: HashMap::new(),
            fxaa: HashMap::new(),
            env_layouts,
            env: HashMap::new(),
            background: HashMap::new(),
            gizmo_layout,
            gizmo: HashMap::new(),
            cull_layouts,
            cull: HashMap::new(),
            hzb: HashMap::new(),
            deform_layouts: deform::deform_layouts(device),
            visibility_layouts: visibility::visibility_layouts(device, &view_layout, &material_layout),
            visibility_raster: HashMap::new(),
            visibility_shade: HashMap::new(),
            deform: None,
            caster_layout,
            caster_pipeline_layouts,
            caster: HashMap::new(),
            deferred_layouts,
            deferred_pipeline_layouts,
            composite_layout,
            composite_pipeline_layout,
            deferred: HashMap::new(),
            composite: HashMap::new(),
            cluster_layout,
            cluster_pipeline_layout,
            cluster: HashMap::new(),
            shaders,
            view_layout,
            material_layout,
            tonemap_layout,
            mipmap_layout,
            resolve_layout,
            filtered_source_layout,
            forward_layout,
            tonemap_pipeline_layout,
            mipmap_pipeline_layout,
            resolve_pipeline_layout,
            filtered_source_pipeline_layout,
            forward: HashMap::new(),
            tonemap: HashMap::new(),
            mipmap: HashMap::new(),
            resolve: HashMap::new(),
            compiled: 0,
            generation: 0,
        }
    }

    pub fn shaders(&self) -> &ShaderLibrary {
        &self.shaders
    }

    pub fn forward_pipeline_count(&self) -> usize {
        self.forward.len()
    }

    /// Keys of the forward pipelines compiled so far.
    pub fn forward_keys(&self) -> impl Iterator<Item = &PipelineKey> {
        self.forward.keys()
    }

    /// A pipeline already created by [`PipelineCache::prepare_forward`].
    pub fn forward_cached(&self, key: &PipelineKey) -> Option<&wgpu::RenderPipeline> {
        self.forward.get(key)
    }

    pub fn tonemap(&mut self, device: &wgpu::Device, key: TonemapKey) -> Result<&wgpu::RenderPipeline, ShaderError> {
        if !self.tonemap.contains_key(&key) {
            let p = self.create_tonemap(device, &mut None, key)?;
            self.tonemap.insert(key, p);
        }
        Ok(&self.tonemap[&key])
    }

    /// The pipeline that writes one mip level of a texture from the level above, through views
    /// of `format` (`shader_srgb`: the views are unorm views of an sRGB texture, and the shader
    /// decodes and encodes the sRGB curve itself).
    pub fn mipmap(
        &mut self,
        device: &wgpu::Device,
        format: wgpu::TextureFormat,
        shader_srgb: bool,
    ) -> Result<&wgpu::RenderPipeline, ShaderError> {
        let key = (format, shader_srgb);
        if !self.mipmap.contains_key(&key) {
            let p = self.create_mipmap(device, &mut None, format, shader_srgb)?;
            self.mipmap.insert(key, p);
        }
        Ok(&self.mipmap[&key])
    }

    /// The pipeline that resolves a multisampled colour target into one of `format`.
    pub fn resolve(
        &mut self,
        device: &wgpu::Device,
        format: wgpu::TextureFormat,
    ) -> Result<&wgpu::RenderPipeline, ShaderError> {
        let key = FormatKey(format);
        if !self.resolve.contains_key(&key) {
            let p = self.create_resolve(device, &mut None, format)?;
            self.resolve.insert(key, p);
        }
        Ok(&self.resolve[&key])
    }

    pub fn resolve_cached(&self, format: wgpu::TextureFormat) -> Option<&wgpu::RenderPipeline> {
        self.resolve.get(&FormatKey(format))
    }

    /// A cluster-binning compute pipeline, compiling it on first use.
    pub fn cluster(
        &mut self,
        device: &wgpu::Device,
        entry: ClusterEntry,
    ) -> Result<&wgpu::ComputePipeline, ShaderError> {
        if !self.cluster.contains_key(&entry) {
            let p = self.create_cluster(device, &mut None, entry)?;
            self.cluster.insert(entry, p);
        }
        Ok(&self.cluster[&entry])
    }

    pub fn cluster_cached(&self, entry: ClusterEntry) -> Option<&wgpu::ComputePipeline> {
        self.cluster.get(&entry)
    }

    /// The deferred-lights compute pipeline for `key`, compiling it on first use.
    pub fn deferred(&mut self, device: &wgpu::Device, key: DeferredKey) -> Result<&wgpu::ComputePipeline, ShaderError> {
        if !self.deferred.contains_key(&key) {
            let p = self.create_deferred(device, &mut None, key)?;
            self.deferred.insert(key, p);
        }
        Ok(&self.deferred[&key])
    }

    pub fn composite_cached(&self, samples: u32, depth_format: wgpu::TextureFormat) -> Option<&wgpu::RenderPipeline> {
        self.composite.get(&(samples, FormatKey(depth_format)))
    }

    /// The pipeline adding deferred local lights into a frame of `samples` samples whose pass
    /// has a depth attachment of `depth_format`.
    pub fn composite(
        &mut self,
        device: &wgpu::Device,
        samples: u32,
        depth_format: wgpu::TextureFormat,
    ) -> Result<&wgpu::RenderPipeline, ShaderError> {
        let key = (samples, FormatKey(depth_format));
        if !self.composite.contains_key(&key) {
            let p = self.create_composite(device, &mut None, key)?;
            self.composite.insert(key, p);
        }
        Ok(&self.composite[&key])
    }

    /// Re-reads the shader folder after `files` changed and rebuilds the pipelines that use what
    /// changed; on any error keeps everything as it was and returns the error. What changed is
    /// what differs between the folder and the library in use, not only `files`: an event can
    /// arrive after the reload that read its file (a save of several files), and a library that
    /// fell back to the embedded shaders differs from the folder in every file the folder edits.
    pub fn reload(&mut self, device: &wgpu::Device, files: &[String]) -> Result<ReloadReport, ShaderError> {
        let start = std::time::Instant::now();
        let mut candidate = Some(self.shaders.reloaded(files)?);
        tracing::debug!("candidate shader library built in {:.1} ms", start.elapsed().as_secs_f64() * 1e3);
        let lib = candidate.as_ref().expect("just built");
        let changed = lib.changed_files(&self.shaders);
        if changed.is_empty() {
            // An event that changed nothing (a save of the same text, a restored file, a second
            // event of one save): the pipelines in use were compiled from exactly these sources.
            let total = self.pipeline_count();
            return Ok(ReloadReport {
                files: changed,
                rebuilt: 0,
                families: Vec::new(),
                untouched: total,
                environment_steps: false,
            });
        }
        let files = &changed[..];
        let reach = Reach::new(lib, &self.shaders, files);
        // Families whose entry imports under switches are rebuilt per variant; the rest import
        // the same modules in every variant.
        let forward_keys = reach.variants("forward.wgsl", &self.forward, |k| k.shader_defs());
        let shade_keys = reach.variants("forward.wgsl", &self.visibility_shade, visibility::shade_defs);
        let deferred_keys = reach.variants("deferred_lights.wgsl", &self.deferred, deferred_defs);
        let caster_keys = reach.variants("shadow_caster.wgsl", &self.caster, casters::caster_defs);
        let cull_keys = reach.variants("cull.wgsl", &self.cull, culling::cull_defs);
        let hit: HashSet<&str> = WHOLE_ENTRIES.iter().copied().filter(|e| reach.entry(e)).collect();
        let tonemap_hit = hit.contains("tonemap.wgsl");
        let mipmap_hit = hit.contains("mipmap.wgsl");
        let resolve_hit = hit.contains("resolve.wgsl");
        let cluster_hit = hit.contains("cluster_bin.wgsl");
        let composite_hit = hit.contains("deferred_composite.wgsl");
        let hzb_hit = hit.contains("hzb.wgsl");
        let deform_hit = hit.contains("deform.wgsl");
        let gizmo_hit = hit.contains("gizmo.wgsl");
        let raster_hit = hit.contains("visibility_raster.wgsl");
        let forward = self.create_forward_many(device, &mut candidate, &forward_keys)?;
        let tonemap = rebuild(stale(tonemap_hit, &self.tonemap), |k| self.create_tonemap(device, &mut candidate, k))?;
        let mipmap =
            rebuild(stale(mipmap_hit, &self.mipmap), |k| self.create_mipmap(device, &mut candidate, k.0, k.1))?;
        let resolve = rebuild(stale(resolve_hit, &self.resolve), |k| self.create_resolve(device, &mut candidate, k.0))?;
        let cluster = rebuild(stale(cluster_hit, &self.cluster), |k| self.create_cluster(device, &mut candidate, k))?;
        let deferred = rebuild(deferred_keys, |k| self.create_deferred(device, &mut candidate, k))?;
        let composite =
            rebuild(stale(composite_hit, &self.composite), |k| self.create_composite(device, &mut candidate, k))?;
        let caster = rebuild(caster_keys, |k| self.create_caster(device, &mut candidate, k))?;
        let cull = rebuild(cull_keys, |k| self.create_cull(device, &mut candidate, k))?;
        let hzb = rebuild(stale(hzb_hit, &self.hzb), |k| self.create_hzb(device, &mut candidate, k))?;
        let deform = match (deform_hit, self.deform.is_some()) {
            (true, true) => Some(self.create_deform(device, &mut candidate)?),
            _ => None,
        };
        let gizmo = rebuild(stale(gizmo_hit, &self.gizmo), |k| self.create_gizmo(device, &mut candidate, k))?;
        let visibility_raster = rebuild(stale(raster_hit, &self.visibility_raster), |k| {
            self.create_visibility_raster(device, &mut candidate, k)
        })?;
        // The visibility buffer's shading pass composes forward.wgsl's `shade`.
        let visibility_shade = rebuild(shade_keys, |k| self.create_visibility_shade(device, &mut candidate, k))?;
        let env = self.reload_env(device, &mut candidate, &hit)?;
        let environment_steps = env.rebuilds_steps();
        let post = self.reload_post(device, &mut candidate, &hit)?;
        let total = self.pipeline_count();
        let mut families = vec![
            ("forward", forward.len()),
            ("visibility shade", visibility_shade.len()),
            ("visibility raster", visibility_raster.len()),
            ("shadow caster", caster.len()),
            ("cull", cull.len()),
            ("depth pyramid", hzb.len()),
            ("deform", deform.is_some() as usize),
            ("cluster binning", cluster.len()),
            ("deferred lights", deferred.len()),
            ("deferred composite", composite.len()),
            ("resolve", resolve.len()),
            ("tonemap", tonemap.len()),
            ("mipmap", mipmap.len()),
            ("gizmo", gizmo.len()),
        ];
        // A changed file that no rebuilt pipeline composed (a pass this scene does not run, a
        // module only other variants import) is composed and validated in its plain variant all
        // the same, so a mistake shows now rather than when a scene first needs it. Nothing to do
        // for an edited entry whose pipelines were rebuilt (the reload benchmark's).
        let lib = self.library(&mut candidate);
        let unchecked: Vec<String> = files
            .iter()
            .filter(|f| lib.source(f).is_some() && !(lib.is_entry(f) && lib.has_composed(f)))
            .cloned()
            .collect();
        for file in unchecked {
            lib.check_plain(&file)?;
        }
        self.shaders = candidate.expect("still there");
        self.visibility_raster.extend(visibility_raster);
        self.visibility_shade.extend(visibility_shade);
        self.forward.extend(forward);
        self.tonemap.extend(tonemap);
        self.mipmap.extend(mipmap);
        self.resolve.extend(resolve);
        self.cluster.extend(cluster);
        self.deferred.extend(deferred);
        self.composite.extend(composite);
        self.caster.extend(caster);
        self.cull.extend(cull);
        self.hzb.extend(hzb);
        self.gizmo.extend(gizmo);
        if deform.is_some() {
            self.deform = deform;
        }
        families.extend(self.apply_env_reload(env));
        families.extend(self.apply_post_reload(post));
        families.retain(|(_, n)| *n > 0);
        let rebuilt = families.iter().map(|(_, n)| n).sum::<usize>();
        self.generation += 1;
        Ok(ReloadReport { files: changed, rebuilt, families, untouched: total - rebuilt, environment_steps })
    }

    /// Every pipeline compiled so far.
    fn pipeline_count(&self) -> usize {
        self.env_pipeline_count()
            + self.post_pipeline_count()
            + self.cull.len()
            + self.hzb.len()
            + self.deform.is_some() as usize
            + self.caster.len()
            + self.forward.len()
            + self.tonemap.len()
            + self.mipmap.len()
            + self.resolve.len()
            + self.cluster.len()
            + self.deferred.len()
            + self.composite.len()
            + self.gizmo.len()
            + self.visibility_raster.len()
            + self.visibility_shade.len()
    }

    /// Compiles with `candidate` if given, else with the current library.
    fn library<'a>(&'a mut self, candidate: &'a mut Option<ShaderLibrary>) -> &'a mut ShaderLibrary {
        match candidate {
            Some(c) => c,
            None => &mut self.shaders,
        }
    }

    /// The forward pipelines of `keys` (in that order); for a reload, so the first error, in
    /// key order, fails it.
    fn create_forward_many(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        keys: &[PipelineKey],
    ) -> Result<Vec<(PipelineKey, wgpu::RenderPipeline)>, ShaderError> {
        self.build_forward(device, candidate, keys).into_iter().map(|(key, p)| p.map(|p| (key, p))).collect()
    }

    /// Compiles the forward pipelines of `keys` not compiled yet (a frame's new batches, at
    /// once); returns the last error.
    pub fn prepare_forward(
        &mut self,
        device: &wgpu::Device,
        keys: impl IntoIterator<Item = PipelineKey>,
    ) -> Option<ShaderError> {
        let mut missing: Vec<PipelineKey> = keys.into_iter().filter(|k| !self.forward.contains_key(k)).collect();
        if missing.is_empty() {
            return None;
        }
        missing.sort();
        missing.dedup();
        let mut error = None;
        for (key, pipeline) in self.build_forward(device, &mut None, &missing) {
            match pipeline {
                Ok(p) => {
                    self.forward.insert(key, p);
                }
                Err(e) => error = Some(e),
            }
        }
        error
    }

    /// Builds the forward pipelines of `keys`, each with its own outcome, in key order. Each
    /// variant is composed once, however many keys share it (keys that differ only in raster
    /// state: face culling, winding, topology). The pipelines are created on up to one thread
    /// per core: a driver that compiles at creation (NVIDIA's takes about 70 ms for the lit
    /// variant) would otherwise make a frame or a reload wait for the sum of those times.
    fn build_forward(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        keys: &[PipelineKey],
    ) -> Vec<(PipelineKey, Result<wgpu::RenderPipeline, ShaderError>)> {
        let mut modules: HashMap<ShaderDefs, Result<wgpu::ShaderModule, ShaderError>> = HashMap::new();
        for key in keys {
            if let std::collections::hash_map::Entry::Vacant(slot) = modules.entry(key.shader_defs()) {
                let module = self.library(candidate).create_module(device, "forward.wgsl", slot.key());
                slot.insert(module);
            }
        }
        self.compiled += keys.len();
        let layout = &self.forward_layout;
        let build = |key: &PipelineKey| match &modules[&key.shader_defs()] {
            Ok(module) => forward_pipeline(device, layout, module, *key),
            Err(e) => Err(e.clone()),
        };
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(keys.len());
        let mut built: Vec<(usize, Result<wgpu::RenderPipeline, ShaderError>)> = if threads <= 1 {
            keys.iter().map(build).enumerate().collect()
        } else {
            let next = std::sync::atomic::AtomicUsize::new(0);
            std::thread::scope(|scope| {
                let workers: Vec<_> = (0..threads)
                    .map(|_| {
                        scope.spawn(|| {
                            let mut mine = Vec::new();
                            loop {
                                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                                let Some(key) = keys.get(i) else { break mine };
                                mine.push((i, build(key)));
                            }
                        })
                    })
                    .collect();
                workers
                    .into_iter()
                    .flat_map(|w| w.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)))
                    .collect()
            })
        };
        built.sort_by_key(|(i, _)| *i);
        built.into_iter().map(|(i, pipeline)| (keys[i], pipeline)).collect()
    }

    fn create_tonemap(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        key: TonemapKey,
    ) -> Result<wgpu::RenderPipeline, ShaderError> {
        let format = key.format;
        let defs = ShaderDefs::default()
            .with("TONEMAP_NEUTRAL", key.tonemapper == Tonemapper::Neutral)
            .with("TONEMAP_ACES", key.tonemapper == Tonemapper::Aces)
            .with("ENCODE_SRGB", !format.is_srgb())
            .with("BLOOM", key.bloom)
            .with("AUTO_EXPOSURE", key.auto_exposure);
        let module = self.library(candidate).create_module(device, "tonemap.wgsl", &defs)?;
        self.compiled += 1;
        checked_pipeline(device, "tonemap.wgsl", || {
            fullscreen_pipeline(device, &self.tonemap_pipeline_layout, &module, format, "tonemap")
        })
    }

    fn create_resolve(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        format: wgpu::TextureFormat,
    ) -> Result<wgpu::RenderPipeline, ShaderError> {
        let module = self.library(candidate).create_module(device, "resolve.wgsl", &ShaderDefs::default())?;
        self.compiled += 1;
        checked_pipeline(device, "resolve.wgsl", || {
            fullscreen_pipeline(device, &self.resolve_pipeline_layout, &module, format, "resolve")
        })
    }

    fn create_mipmap(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        format: wgpu::TextureFormat,
        shader_srgb: bool,
    ) -> Result<wgpu::RenderPipeline, ShaderError> {
        let defs = ShaderDefs::default().with("SRGB", shader_srgb);
        let module = self.library(candidate).create_module(device, "mipmap.wgsl", &defs)?;
        self.compiled += 1;
        checked_pipeline(device, "mipmap.wgsl", || {
            fullscreen_pipeline(device, &self.mipmap_pipeline_layout, &module, format, "mipmap")
        })
    }
}

impl PipelineCache {
    fn create_deferred(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        key: DeferredKey,
    ) -> Result<wgpu::ComputePipeline, ShaderError> {
        let module = self.library(candidate).create_module(device, "deferred_lights.wgsl", &deferred_defs(key))?;
        self.compiled += 1;
        let layout = &self.deferred_pipeline_layouts[key.multisampled as usize];
        checked_pipeline(device, "deferred_lights.wgsl", || {
            compute_pipeline(device, layout, &module, "shade_local_lights", "deferred lights")
        })
    }

    fn create_composite(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        (samples, depth_format): (u32, FormatKey),
    ) -> Result<wgpu::RenderPipeline, ShaderError> {
        let module =
            self.library(candidate).create_module(device, "deferred_composite.wgsl", &ShaderDefs::default())?;
        self.compiled += 1;
        // Adds radiance; leaves alpha as it is.
        let add = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let keep = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::Zero,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        checked_pipeline(device, "deferred_composite.wgsl", || {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("deferred composite"),
                layout: Some(&self.composite_pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState::default(),
                // The pass keeps the opaque depth for the blended draws after it; the composite
                // neither tests nor writes it.
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: depth_format.0,
                    depth_write_enabled: Some(false),
                    depth_compare: Some(wgpu::CompareFunction::Always),
                    stencil: wgpu::StencilState::default(),
                    bias: wgpu::DepthBiasState::default(),
                }),
                multisample: wgpu::MultisampleState { count: samples, mask: !0, alpha_to_coverage_enabled: false },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: crate::targets::HDR_FORMAT,
                        blend: Some(wgpu::BlendState { color: add, alpha: keep }),
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        })
    }

    fn create_cluster(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        entry: ClusterEntry,
    ) -> Result<wgpu::ComputePipeline, ShaderError> {
        let module = self.library(candidate).create_module(device, "cluster_bin.wgsl", &ShaderDefs::default())?;
        self.compiled += 1;
        checked_pipeline(device, "cluster_bin.wgsl", || {
            compute_pipeline(device, &self.cluster_pipeline_layout, &module, entry.name(), entry.name())
        })
    }
}

/// The switches of the deferred-lights pipeline `key`.
fn deferred_defs(key: DeferredKey) -> ShaderDefs {
    ShaderDefs::default()
        .with("MULTISAMPLED", key.multisampled)
        .with("LOCAL_LIGHTS", true)
        .with("CLUSTERED_LIGHTS", true)
        .with("SPHERE_TUBE_LIGHTS", key.light_shapes.sphere_tube)
        .with("LTC_LIGHTS", key.light_shapes.ltc)
        .with("IES_LIGHTS", key.light_shapes.ies)
        .with("LOCAL_SHADOWS", key.local_shadows)
}

/// A compute pipeline of `module`'s `entry` (no overrides, no pipeline cache).
fn compute_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    entry: &str,
    label: &str,
) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

fn fullscreen_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    format: wgpu::TextureFormat,
    label: &str,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// The keys of a pipeline family to compile again: all of them when a file it uses changed
/// (`hit`), else none.
pub(super) fn stale<K: Copy, P>(hit: bool, family: &HashMap<K, P>) -> Vec<K> {
    if hit { family.keys().copied().collect() } else { Vec::new() }
}

/// The entry files whose variants all import the same modules: their pipelines are stale together.
const WHOLE_ENTRIES: &[&str] = &[
    "tonemap.wgsl",
    "mipmap.wgsl",
    "resolve.wgsl",
    "cluster_bin.wgsl",
    "deferred_composite.wgsl",
    "hzb.wgsl",
    "deform.wgsl",
    "gizmo.wgsl",
    "visibility_raster.wgsl",
    "env_source.wgsl",
    "env_filter.wgsl",
    "brdf_lut.wgsl",
    "background.wgsl",
    "bloom.wgsl",
    "exposure.wgsl",
    "fxaa.wgsl",
];

/// Which pipelines a reload's changed files reach. A file removed from the folder is traced in
/// the library it was removed from, whose imports still know who read it: that importer is
/// rebuilt, and fails to compose where it uses the file instead of running on with the deleted
/// code.
struct Reach<'a> {
    new: &'a ShaderLibrary,
    old: &'a ShaderLibrary,
    files: &'a [String],
    removed: Vec<String>,
}

impl<'a> Reach<'a> {
    fn new(new: &'a ShaderLibrary, old: &'a ShaderLibrary, files: &'a [String]) -> Self {
        let removed = files.iter().filter(|f| new.source(f).is_none()).cloned().collect();
        Self { new, old, files, removed }
    }

    /// Whether any variant of `entry` may read a changed file.
    fn entry(&self, entry: &str) -> bool {
        self.new.depends_on(entry, self.files) || self.old.depends_on(entry, &self.removed)
    }

    /// The keys of a pipeline family whose variant of `entry` (its switches from `defs`) reads a
    /// changed file (`ShaderLibrary::variant_uses`).
    fn variants<K: Copy, P>(&self, entry: &str, family: &HashMap<K, P>, defs: impl Fn(K) -> ShaderDefs) -> Vec<K> {
        let reads = |k: K| {
            let defs = defs(k);
            self.new.variant_uses(entry, &defs, self.files) || self.old.variant_uses(entry, &defs, &self.removed)
        };
        family.keys().copied().filter(|k| reads(*k)).collect()
    }
}

/// A pipeline for each key, from `create`; the first error fails the whole reload, which then
/// swaps in nothing.
pub(super) fn rebuild<K: Copy, P>(
    keys: Vec<K>,
    mut create: impl FnMut(K) -> Result<P, ShaderError>,
) -> Result<Vec<(K, P)>, ShaderError> {
    keys.into_iter().map(|k| create(k).map(|p| (k, p))).collect()
}
