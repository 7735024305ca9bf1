//! Transmission (KHR_materials_transmission, with KHR_materials_volume and
//! KHR_materials_dispersion): what lies behind a transmissive surface is seen through it,
//! refracted, blurred by its roughness and tinted by its colour and volume.
//!
//! The real-time method of Filament, Bevy and the Khronos sample viewer: after the opaque draws
//! and the background (whose pass resolves its samples, and keeps them for the draws after),
//! [`Transmission::encode_copy`] copies the resolved HDR colour into level 0 of this feature's
//! texture and halves it down a full mip chain (`shaders/transmission.wgsl`). Transmissive surfaces are drawn after that, back to front with
//! the blended ones (`DrawList` sorts them together), binding [`Transmission::bind_group`] as
//! group 2; `forward.wgsl` (MATERIAL_TRANSMISSION) reads the copy where the refracted ray leaves
//! the volume, at a level that grows with the surface's roughness.
//!
//! The copy is taken once per frame, before any transmissive surface is drawn: a transmissive
//! surface seen through another is not in the copy, so the nearer one shows what is behind both
//! (the opaque scene and the background), not the farther one (Bevy's default of one
//! transmission step does the same). A blended surface behind a transmissive one is not seen
//! through it either; one in front blends over it as usual.
//!
//! A frame whose opaque draws the visibility buffer rasterises (`features::visibility`) has no
//! colour target to copy: its shading pass writes the opaque colour straight into level 0 (a
//! storage binding, [`CopyViews`]), [`Transmission::encode_downsample`] fills the mip chain,
//! and the overlay's transmissive draws read it through the visibility buffer's occlusion group.
//!
//! The texture and its pipelines exist only in frames that draw a transmissive surface: a frame
//! without one drops the texture and runs no pass of this feature.

use crate::frame_context::FrameContext;
use crate::gpu::formats::HDR_FORMAT;
use crate::pipelines::{Compiler, PipelineCache, PipelineFamily, ShaderDefs, ShaderError, parts};

/// The two steps of the copy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CopyStep {
    /// The frame's resolved colour into level 0.
    Level0,
    /// Level i − 1 into level i.
    Down,
}

/// The copy's pipelines (`transmission.wgsl`) and the layouts of what they read.
pub struct CopyFamily {
    source: wgpu::BindGroupLayout,
    down: wgpu::BindGroupLayout,
    layouts: [wgpu::PipelineLayout; 2],
}

impl CopyFamily {
    fn new(device: &wgpu::Device) -> Self {
        let source = parts::bind_group_layout(device, "transmission copy source", &[parts::texture(0, false)]);
        let down = parts::filtered_source_layout(device);
        let layouts = [
            parts::pipeline_layout(device, "transmission copy", &[&source]),
            parts::pipeline_layout(device, "transmission downsample", &[&down]),
        ];
        Self { source, down, layouts }
    }
}

impl PipelineFamily for CopyFamily {
    type Key = CopyStep;
    type Pipeline = wgpu::RenderPipeline;
    const NAME: &'static str = "transmission copy";

    fn shader(&self, key: &CopyStep) -> (&'static str, ShaderDefs) {
        let defs = ShaderDefs::default().with("DOWNSAMPLE", *key == CopyStep::Down);
        ("transmission.wgsl", defs)
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, key: &CopyStep) -> wgpu::RenderPipeline {
        let layout = &self.layouts[(*key == CopyStep::Down) as usize];
        parts::fullscreen_pipeline(device, layout, module, HDR_FORMAT, "transmission copy")
    }
}

/// The copy of one frame size: the texture, a view of each level, the group transmissive draws
/// bind and the groups each downsampling step reads.
struct Copy {
    size: (u32, u32),
    /// Level 0 is a storage binding (the visibility buffer's shading pass writes it).
    storage: bool,
    texture: wgpu::Texture,
    levels: Vec<wgpu::TextureView>,
    whole: wgpu::TextureView,
    bind_group: wgpu::BindGroup,
    down_groups: Vec<wgpu::BindGroup>,
}

/// What a visibility-buffer frame's passes bind of the copy.
pub struct CopyViews<'a> {
    /// Level 0, which the shading pass writes the opaque colour into.
    pub level0: &'a wgpu::TextureView,
    /// The whole copy and its sampler, which transmissive draws read.
    pub whole: &'a wgpu::TextureView,
    pub sampler: &'a wgpu::Sampler,
}

pub struct Transmission {
    /// Group 2 of transmissive draws' pipelines: the copy and its sampler.
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    copy: Option<Copy>,
}

impl Transmission {
    /// Registers the copy's pipeline family.
    pub fn new(device: &wgpu::Device, pipelines: &mut PipelineCache) -> Self {
        pipelines.register(CopyFamily::new(device));
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("transmission"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let layout = parts::bind_group_layout(
            device,
            "transmission",
            &[
                wgpu::BindGroupLayoutEntry { visibility: fragment, ..parts::texture(0, true) },
                wgpu::BindGroupLayoutEntry { visibility: fragment, ..parts::sampler(1) },
            ],
        );
        Self { layout, sampler, copy: None }
    }

    /// The layout transmissive draws bind as group 2.
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    /// Makes the copy's texture for a frame of `size` that draws transmissive surfaces
    /// (`needed`), with level 0 a storage binding where the visibility buffer's shading pass
    /// writes it (`storage`), and compiles its pipelines; drops it otherwise. A pipeline that
    /// does not compile is returned as the error (the frame then draws transmissive surfaces
    /// over the last copy, or black).
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        pipelines: &mut PipelineCache,
        size: (u32, u32),
        needed: bool,
        storage: bool,
    ) -> Result<(), ShaderError> {
        if !needed {
            self.copy = None;
            return Ok(());
        }
        if self.copy.as_ref().is_none_or(|c| c.size != size || c.storage != storage) {
            self.copy = Some(self.make(device, &pipelines.family::<CopyFamily>().down, size, storage));
        }
        pipelines.prepare::<CopyFamily>(device, [CopyStep::Level0, CopyStep::Down])
    }

    fn make(
        &self,
        device: &wgpu::Device,
        down_layout: &wgpu::BindGroupLayout,
        size: (u32, u32),
        storage: bool,
    ) -> Copy {
        let (w, h) = (size.0.max(1), size.1.max(1));
        let mip_level_count = 32 - w.max(h).leading_zeros();
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("transmission copy"),
            size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            mip_level_count,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: HDR_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | if storage { wgpu::TextureUsages::STORAGE_BINDING } else { wgpu::TextureUsages::empty() },
            view_formats: &[],
        });
        let levels: Vec<wgpu::TextureView> = (0..mip_level_count)
            .map(|level| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    base_mip_level: level,
                    mip_level_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        let whole = texture.create_view(&Default::default());
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("transmission"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&whole) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&self.sampler) },
            ],
        });
        let down_groups = levels[..levels.len() - 1]
            .iter()
            .map(|above| {
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("transmission downsample"),
                    layout: down_layout,
                    entries: &[
                        wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(above) },
                        wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&self.sampler) },
                    ],
                })
            })
            .collect();
        Copy { size, storage, texture, levels, whole, bind_group, down_groups }
    }

    /// The group transmissive draws bind, in a frame that draws them.
    pub fn bind_group(&self) -> Option<&wgpu::BindGroup> {
        self.copy.as_ref().map(|c| &c.bind_group)
    }

    /// The copy's views for a visibility-buffer frame (prepared with `storage`).
    pub fn views(&self) -> Option<CopyViews<'_>> {
        self.copy.as_ref().filter(|c| c.storage).map(|c| CopyViews {
            level0: &c.levels[0],
            whole: &c.whole,
            sampler: &self.sampler,
        })
    }

    /// GPU memory of the copy.
    pub fn bytes(&self) -> u64 {
        self.copy.as_ref().map_or(0, |c| {
            let (w, h) = (c.texture.width() as u64, c.texture.height() as u64);
            // A full mip chain adds a third.
            w * h * 8 * 4 / 3
        })
    }

    /// Copies `source` (the frame's resolved HDR colour) into level 0 and fills the mip chain.
    pub fn encode_copy(&self, cx: &mut FrameContext, source: &wgpu::TextureView) {
        let Some(copy) = &self.copy else { return };
        let family = cx.pipelines.family::<CopyFamily>();
        let Some(level0) = cx.pipelines.cached::<CopyFamily>(&CopyStep::Level0) else { return };
        let source_group = cx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("transmission copy source"),
            layout: &family.source,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(source) }],
        });
        let timestamps = cx.timer.as_deref_mut().and_then(|t| t.pass("transmission copy"));
        parts::draw_fullscreen(cx.encoder, "transmission copy", &copy.levels[0], level0, &source_group, timestamps);
        self.encode_downsample(cx);
    }

    /// Fills the mip chain from level 0 (written by `encode_copy` or by the visibility buffer's
    /// shading pass).
    pub fn encode_downsample(&self, cx: &mut FrameContext) {
        let (Some(copy), Some(down)) = (&self.copy, cx.pipelines.cached::<CopyFamily>(&CopyStep::Down)) else {
            return;
        };
        for (group, target) in copy.down_groups.iter().zip(&copy.levels[1..]) {
            // Each level's pass is timed under one label (the timer sums them).
            let timestamps = cx.timer.as_deref_mut().and_then(|t| t.pass("transmission downsample"));
            parts::draw_fullscreen(cx.encoder, "transmission downsample", target, down, group, timestamps);
        }
    }
}
