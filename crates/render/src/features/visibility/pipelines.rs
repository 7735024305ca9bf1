//! The visibility buffer's pipeline families: the rasteriser (`visibility_raster.wgsl`: its
//! per-frame numbering, the triangles, the tiles of large ones) and the shading pass, one per
//! forward variant (`forward.wgsl` with VISIBILITY_SHADE), each with the layouts it binds.

use crate::gpu::formats::{DISPLAY_FORMAT, FormatKey, HDR_FORMAT};
use crate::pipelines::parts::{self, dynamic_uniform, storage, storage_rw, uniform};
use crate::pipelines::{Compiler, PipelineFamily, ShaderDefs};
use crate::resources::draws::{AlphaTest, LocalLights, PipelineKey, Tonemapper};
use crate::resources::materials::MaterialTable;
use crate::resources::materials::extension::PipelineLayouts;
use crate::resources::materials::{AlphaKey, TextureSet};

/// What a masked bin's raster steps compile in to test alpha (`visibility_raster.wgsl`'s
/// `alpha_passes`): the forward variant's switches that its alpha reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MaskKey {
    /// A base colour texture (the bin binds its material group).
    pub texture: bool,
    pub transformed_uvs: bool,
    pub vertex_colors: bool,
}

impl MaskKey {
    /// The alpha test of a masked batch drawn with `key`.
    pub fn of(key: &PipelineKey) -> Self {
        Self {
            texture: key.textures.has(TextureSet::BASE_COLOR),
            transformed_uvs: key.textures.has(TextureSet::TRANSFORMED_UVS),
            vertex_colors: key.vertex_colors,
        }
    }
}

/// The rasteriser's entry points, in `visibility_raster.wgsl`: the steps of every bin, and those
/// a masked bin compiles with its alpha test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RasterStep {
    Prepare,
    Begin,
    Triangles(Option<MaskKey>),
    Scan,
    Tiles(Option<MaskKey>),
}

impl RasterStep {
    /// What a frame of opaque bins runs, in order.
    pub const OPAQUE: [RasterStep; 4] =
        [RasterStep::Prepare, RasterStep::Triangles(None), RasterStep::Scan, RasterStep::Tiles(None)];

    fn entry(self) -> &'static str {
        match self {
            RasterStep::Prepare => "raster_prepare",
            RasterStep::Begin => "raster_begin",
            RasterStep::Triangles(_) => "raster_triangles",
            RasterStep::Scan => "raster_scan",
            RasterStep::Tiles(_) => "raster_tiles",
        }
    }

    fn mask(self) -> Option<MaskKey> {
        match self {
            RasterStep::Triangles(m) | RasterStep::Tiles(m) => m,
            _ => None,
        }
    }
}

/// What the shading pass writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ShadeOutput {
    /// Resolved HDR radiance, into the frame's HDR target.
    Hdr,
    /// The displayed colour (sRGB-encoded, for a copy into the output): each triangle's colour
    /// tonemapped before the samples are averaged (`MsaaResolve::Display`).
    DisplayPerSample(Tonemapper),
    /// The displayed colour of the averaged radiance.
    DisplayResolved(Tonemapper),
}

impl ShadeOutput {
    pub fn display(self) -> bool {
        self != ShadeOutput::Hdr
    }
}

/// One shading pipeline: the forward variant of the batches it shades, what it writes, and
/// whether it can show the environment behind the scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ShadeKey {
    /// A `shade_key`.
    pub forward: PipelineKey,
    pub output: ShadeOutput,
    pub background: bool,
    /// A hybrid frame's overlay to composite (`overlay`): its sample count, 0 for none.
    pub overlay: u32,
    /// The second shading of a frame with transmissive draws: pixels whose samples all hold one
    /// triangle take the colour the first shading wrote into the transmission copy.
    pub reuse: bool,
}

/// Which overlay binding a shading pipeline has: none, single-sampled, multisampled.
fn overlay_kind(samples: u32) -> usize {
    match samples {
        0 => 0,
        1 => 1,
        _ => 2,
    }
}

/// The forward key a shading pipeline compiles: what a visibility-buffer frame cannot have
/// (deferred local lights: the pass walks the clusters itself; tonemapping: it writes HDR
/// colour) taken out, raster state (culling, winding, formats, the alpha test: the raster
/// steps tested it) that compute does not have reduced to one value.
pub fn shade_key(key: PipelineKey) -> PipelineKey {
    // An sRGB format: a display variant's tonemap leaves the encoding to the shading pass,
    // which averages first.
    PipelineKey {
        local_lights: if key.local_lights == LocalLights::Deferred { LocalLights::Clustered } else { key.local_lights },
        tonemap: None,
        cull_back_faces: false,
        front_face_cw: false,
        pulled_vertices: true,
        color_format: FormatKey(wgpu::TextureFormat::Rgba8UnormSrgb),
        depth_format: None,
        sample_count: 1,
        alpha: if key.alpha == AlphaKey::Mask { AlphaKey::Opaque } else { key.alpha },
        alpha_test: AlphaTest::PerPixel,
        ..key
    }
}

/// The rasteriser's pipelines and the layouts of its groups: into the visibility buffer, or
/// (`DEPTH_ONLY`, `visibility_raster.wgsl` with SHADOW_DEPTH) a shadow map's casters into a
/// buffer of depths (`features::shadows::raster`). Both bind the same groups.
pub struct RasterFamily<const DEPTH_ONLY: bool = false> {
    /// Group 0 (see `visibility_raster.wgsl`'s bindings).
    pub raster: wgpu::BindGroupLayout,
    /// `raster_prepare`'s and `raster_begin`'s group 1: the raster dispatch's arguments.
    pub dispatch: wgpu::BindGroupLayout,
    raster_pipeline: wgpu::PipelineLayout,
    prepare_pipeline: wgpu::PipelineLayout,
    /// Masked steps with a base colour texture: group 1 is the bin's material group.
    textured_pipeline: wgpu::PipelineLayout,
}

/// The shadow casters' rasteriser.
pub type CasterRasterFamily = RasterFamily<true>;

impl<const DEPTH_ONLY: bool> RasterFamily<DEPTH_ONLY> {
    /// `material`: the material group's layout (a masked bin's group 1).
    pub fn new(device: &wgpu::Device, material: &wgpu::BindGroupLayout) -> Self {
        let compute = wgpu::ShaderStages::COMPUTE;
        let bin = dynamic_uniform(11, compute, Some(BIN_BYTES));
        let raster = parts::bind_group_layout(
            device,
            "visibility raster",
            &[
                uniform(0, compute),
                storage(1, compute),
                storage(2, compute),
                storage(3, compute),
                storage(4, compute),
                storage(5, compute),
                storage(6, compute),
                uniform(7, compute),
                storage_rw(8, compute),
                storage_rw(9, compute),
                storage_rw(10, compute),
                bin,
                storage(12, compute),
            ],
        );
        let dispatch = parts::bind_group_layout(device, "visibility raster dispatch", &[storage_rw(0, compute)]);
        Self {
            raster_pipeline: parts::pipeline_layout(device, "visibility raster", &[&raster]),
            prepare_pipeline: parts::pipeline_layout(device, "visibility raster prepare", &[&raster, &dispatch]),
            textured_pipeline: parts::pipeline_layout(device, "visibility raster masked", &[&raster, material]),
            raster,
            dispatch,
        }
    }
}

/// Bytes of one bin's uniform (`struct RasterBin`).
pub const BIN_BYTES: u64 = 16;

impl<const DEPTH_ONLY: bool> PipelineFamily for RasterFamily<DEPTH_ONLY> {
    type Key = RasterStep;
    type Pipeline = wgpu::ComputePipeline;
    const NAME: &'static str = if DEPTH_ONLY { "shadow raster" } else { "visibility raster" };

    fn shader(&self, step: &RasterStep) -> (&'static str, ShaderDefs) {
        let base = ShaderDefs::default().with("SHADOW_DEPTH", DEPTH_ONLY);
        let defs = match step.mask() {
            None => base,
            Some(m) => base
                .with("ALPHA_MASK", true)
                .with("BASE_COLOR_TEXTURE", m.texture)
                .with("TRANSFORMED_UVS", m.texture && m.transformed_uvs)
                .with("VERTEX_COLORS", m.vertex_colors),
        };
        ("visibility_raster.wgsl", defs)
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, step: &RasterStep) -> wgpu::ComputePipeline {
        let layout = match step {
            RasterStep::Prepare | RasterStep::Begin => &self.prepare_pipeline,
            _ if step.mask().is_some_and(|m| m.texture) => &self.textured_pipeline,
            _ => &self.raster_pipeline,
        };
        parts::compute_pipeline(device, layout, module, step.entry(), step.entry())
    }
}

/// The shading pass's pipelines: group 2 (after the forward pass's view and material groups),
/// writing HDR colour or writing display colour, without an overlay or with a single-sampled or
/// multisampled one, reading the first shading's colour (`ShadeKey::reuse`) or not.
pub struct ShadeFamily {
    /// Per output kind, overlay kind and reuse.
    shade: [[[wgpu::BindGroupLayout; 2]; 3]; 2],
    /// The same: the view, material and shade groups, and the extension group of the key's
    /// material extensions.
    pipeline: [[[PipelineLayouts; 2]; 3]; 2],
}

impl ShadeFamily {
    pub fn new(device: &wgpu::Device, view: &wgpu::BindGroupLayout, materials: &MaterialTable) -> Self {
        let compute = wgpu::ShaderStages::COMPUTE;
        let texture = |binding, multisampled| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: compute,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled,
            },
            count: None,
        };
        let shade = [HDR_FORMAT, DISPLAY_FORMAT].map(|format| {
            [None, Some(false), Some(true)].map(|overlay| {
                [false, true].map(|reuse| {
                    let mut entries = vec![
                        uniform(0, compute),
                        storage(1, compute),
                        storage(2, compute),
                        storage(3, compute),
                        storage(4, compute),
                        storage_rw(5, compute),
                        parts::storage_texture(6, format, wgpu::TextureViewDimension::D2),
                    ];
                    if let Some(multisampled) = overlay {
                        entries.push(texture(7, multisampled));
                    }
                    if reuse {
                        entries.push(texture(8, false));
                    }
                    parts::bind_group_layout(device, "visibility shade", &entries)
                })
            })
        });
        let pipeline = [0, 1].map(|i| {
            [0, 1, 2].map(|k| {
                [0, 1].map(|r| {
                    let groups = [Some(view), Some(materials.layout()), Some(&shade[i][k][r])];
                    PipelineLayouts::new("visibility shade", &groups, materials.extension_layouts().clone())
                })
            })
        });
        Self { shade, pipeline }
    }

    /// The shade group's layout of `key`'s output, overlay and reuse.
    pub fn layout(&self, key: &ShadeKey) -> &wgpu::BindGroupLayout {
        &self.shade[key.output.display() as usize][overlay_kind(key.overlay)][key.reuse as usize]
    }
}

impl PipelineFamily for ShadeFamily {
    type Key = ShadeKey;
    type Pipeline = wgpu::ComputePipeline;
    const NAME: &'static str = "visibility shade";
    const PER_VARIANT: bool = true;

    fn shader(&self, key: &ShadeKey) -> (&'static str, ShaderDefs) {
        ("forward.wgsl", shade_defs(*key))
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, key: &ShadeKey) -> wgpu::ComputePipeline {
        let layout = self.pipeline[key.output.display() as usize][overlay_kind(key.overlay)][key.reuse as usize]
            .get(device, key.forward.features);
        parts::compute_pipeline(device, &layout, module, "cs_shade", "visibility shade")
    }
}

/// The switches of the visibility buffer's shading pipeline `key` (forward.wgsl's `cs_shade`).
fn shade_defs(key: ShadeKey) -> ShaderDefs {
    let (forward, tonemapper) = match key.output {
        ShadeOutput::Hdr => (key.forward, None),
        ShadeOutput::DisplayPerSample(t) => (PipelineKey { tonemap: Some(t), ..key.forward }, None),
        ShadeOutput::DisplayResolved(t) => (key.forward, Some(t)),
    };
    forward
        .shader_defs()
        .with("VISIBILITY_SHADE", true)
        .with("VISIBILITY_DISPLAY", key.output.display())
        .with("VISIBILITY_TONEMAP", tonemapper.is_some())
        .with("TONEMAP_NEUTRAL", forward.tonemap.or(tonemapper) == Some(Tonemapper::Neutral))
        .with("TONEMAP_ACES", forward.tonemap.or(tonemapper) == Some(Tonemapper::Aces))
        .with("VISIBILITY_BACKGROUND", key.background)
        .with("VISIBILITY_OVERLAY", key.overlay > 0)
        .with("OVERLAY_MULTISAMPLED", key.overlay > 1)
        .with("VISIBILITY_REUSE", key.reuse)
}
