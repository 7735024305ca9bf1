//! The visibility buffer's compute pipelines: the rasteriser (`shaders/visibility_raster.wgsl`:
//! its per-frame numbering, the triangles, the tiles of large ones) and the shading pass, one
//! per forward variant (`shaders/forward.wgsl` with VISIBILITY_SHADE). The part of the pipeline
//! cache that serves `passes::visibility`.

use super::{PipelineCache, PipelineKey, Tonemapper, buffer_entry, checked_pipeline, compute_pipeline, storage};
use crate::pipelines::shader_library::{ShaderDefs, ShaderError, ShaderLibrary};
use crate::targets::HDR_FORMAT;

/// What the shading pass writes the displayed colour into (sRGB-encoded by the shader; storage
/// textures cannot be sRGB), copied into an `Rgba8Unorm` or `Rgba8UnormSrgb` output.
pub const DISPLAY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// The rasteriser's entry points, in `visibility_raster.wgsl`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RasterStep {
    Prepare,
    Triangles,
    Scan,
    Tiles,
}

impl RasterStep {
    pub const ALL: [RasterStep; 4] = [RasterStep::Prepare, RasterStep::Triangles, RasterStep::Scan, RasterStep::Tiles];

    fn entry(self) -> &'static str {
        match self {
            RasterStep::Prepare => "raster_prepare",
            RasterStep::Triangles => "raster_triangles",
            RasterStep::Scan => "raster_scan",
            RasterStep::Tiles => "raster_tiles",
        }
    }
}

pub(super) struct VisibilityLayouts {
    /// The rasteriser's group 0 (see `visibility_raster.wgsl`'s bindings).
    pub raster: wgpu::BindGroupLayout,
    /// `raster_prepare`'s group 1: the raster dispatch's arguments.
    pub dispatch: wgpu::BindGroupLayout,
    /// The shading pass's group 2 (after the forward pass's view and material groups), writing
    /// HDR colour and writing display colour.
    pub shade: [wgpu::BindGroupLayout; 2],
    raster_pipeline: wgpu::PipelineLayout,
    prepare_pipeline: wgpu::PipelineLayout,
    shade_pipeline: [wgpu::PipelineLayout; 2],
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
}

pub(super) fn visibility_layouts(
    device: &wgpu::Device,
    view: &wgpu::BindGroupLayout,
    material: &wgpu::BindGroupLayout,
) -> VisibilityLayouts {
    let compute = wgpu::ShaderStages::COMPUTE;
    let read_write = wgpu::BufferBindingType::Storage { read_only: false };
    let uniform = wgpu::BufferBindingType::Uniform;
    let layout = |label, entries: &[wgpu::BindGroupLayoutEntry]| {
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries })
    };
    let raster = layout(
        "visibility raster",
        &[
            buffer_entry(0, compute, uniform),
            storage(1, compute),
            storage(2, compute),
            storage(3, compute),
            storage(4, compute),
            storage(5, compute),
            storage(6, compute),
            buffer_entry(7, compute, uniform),
            buffer_entry(8, compute, read_write),
            buffer_entry(9, compute, read_write),
            buffer_entry(10, compute, read_write),
        ],
    );
    let dispatch = layout("visibility raster dispatch", &[buffer_entry(0, compute, read_write)]);
    let shade = [HDR_FORMAT, DISPLAY_FORMAT].map(|format| {
        layout(
            "visibility shade",
            &[
                buffer_entry(0, compute, uniform),
                storage(1, compute),
                storage(2, compute),
                storage(3, compute),
                storage(4, compute),
                buffer_entry(5, compute, read_write),
                wgpu::BindGroupLayoutEntry {
                    binding: 6,
                    visibility: compute,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format,
                        view_dimension: wgpu::TextureViewDimension::D2,
                    },
                    count: None,
                },
            ],
        )
    });
    let pipeline = |label, groups: &[Option<&wgpu::BindGroupLayout>]| {
        device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: groups,
            immediate_size: 0,
        })
    };
    VisibilityLayouts {
        raster_pipeline: pipeline("visibility raster", &[Some(&raster)]),
        prepare_pipeline: pipeline("visibility raster prepare", &[Some(&raster), Some(&dispatch)]),
        shade_pipeline: [0, 1].map(|i| pipeline("visibility shade", &[Some(view), Some(material), Some(&shade[i])])),
        raster,
        dispatch,
        shade,
    }
}

/// The forward key a shading pipeline compiles: what a visibility-buffer frame cannot have
/// (deferred local lights: the pass walks the clusters itself; tonemapping: it writes HDR
/// colour) taken out, raster state (culling, winding, formats) that compute does not have
/// reduced to one value.
pub fn shade_key(key: PipelineKey) -> PipelineKey {
    use super::{AlphaTest, LocalLights};
    // An sRGB format: a display variant's tonemap leaves the encoding to the shading pass,
    // which averages first.
    PipelineKey {
        local_lights: if key.local_lights == LocalLights::Deferred { LocalLights::Clustered } else { key.local_lights },
        tonemap: None,
        cull_back_faces: false,
        front_face_cw: false,
        pulled_vertices: true,
        color_format: super::FormatKey(wgpu::TextureFormat::Rgba8UnormSrgb),
        depth_format: None,
        sample_count: 1,
        alpha_test: AlphaTest::PerPixel,
        ..key
    }
}

impl PipelineCache {
    pub fn visibility_raster_layout(&self) -> &wgpu::BindGroupLayout {
        &self.visibility_layouts.raster
    }

    pub fn visibility_dispatch_layout(&self) -> &wgpu::BindGroupLayout {
        &self.visibility_layouts.dispatch
    }

    pub fn visibility_shade_layout(&self, output: ShadeOutput) -> &wgpu::BindGroupLayout {
        &self.visibility_layouts.shade[output.display() as usize]
    }

    /// Compiles the rasteriser and the shading pipelines of `keys` not compiled yet. Each is
    /// tried (a variant that fails leaves the others usable); the first error is returned.
    pub fn prepare_visibility(
        &mut self,
        device: &wgpu::Device,
        keys: impl IntoIterator<Item = ShadeKey>,
    ) -> Result<(), ShaderError> {
        let mut first_error = None;
        for step in RasterStep::ALL {
            if !self.visibility_raster.contains_key(&step) {
                match self.create_visibility_raster(device, &mut None, step) {
                    Ok(p) => {
                        self.visibility_raster.insert(step, p);
                    }
                    Err(e) => first_error = first_error.or(Some(e)),
                }
            }
        }
        for key in keys {
            if !self.visibility_shade.contains_key(&key) {
                match self.create_visibility_shade(device, &mut None, key) {
                    Ok(p) => {
                        self.visibility_shade.insert(key, p);
                    }
                    Err(e) => first_error = first_error.or(Some(e)),
                }
            }
        }
        first_error.map_or(Ok(()), Err)
    }

    pub fn visibility_raster_cached(&self, step: RasterStep) -> Option<&wgpu::ComputePipeline> {
        self.visibility_raster.get(&step)
    }

    pub fn visibility_shade_cached(&self, key: &ShadeKey) -> Option<&wgpu::ComputePipeline> {
        self.visibility_shade.get(key)
    }

    pub(super) fn create_visibility_raster(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        step: RasterStep,
    ) -> Result<wgpu::ComputePipeline, ShaderError> {
        let module = self.library(candidate).create_module(device, "visibility_raster.wgsl", &Default::default())?;
        self.compiled += 1;
        let layout = match step {
            RasterStep::Prepare => &self.visibility_layouts.prepare_pipeline,
            _ => &self.visibility_layouts.raster_pipeline,
        };
        checked_pipeline(device, "visibility_raster.wgsl", || {
            compute_pipeline(device, layout, &module, step.entry(), step.entry())
        })
    }

    pub(super) fn create_visibility_shade(
        &mut self,
        device: &wgpu::Device,
        candidate: &mut Option<ShaderLibrary>,
        key: ShadeKey,
    ) -> Result<wgpu::ComputePipeline, ShaderError> {
        let module = self.library(candidate).create_module(device, "forward.wgsl", &shade_defs(key))?;
        self.compiled += 1;
        let layout = &self.visibility_layouts.shade_pipeline[key.output.display() as usize];
        checked_pipeline(device, "forward.wgsl", || {
            compute_pipeline(device, layout, &module, "cs_shade", "visibility shade")
        })
    }
}

/// The switches of the visibility buffer's shading pipeline `key` (forward.wgsl's `cs_shade`).
pub(super) fn shade_defs(key: ShadeKey) -> ShaderDefs {
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
}
