//! Frame targets: the linear HDR colour target (`Rgba16Float`), its MSAA twin when multisampling,
//! and the reverse-Z depth target (`Depth32Float`, cleared to 0); with deferred local lights also
//! the surface targets opaque fragments write, and the local light the compute pass writes (see
//! `passes/deferred_lights.rs`). A frame whose HDR colour nothing reads (see
//! `Renderer::render`'s direct output) has no HDR target at all: the forward pass tonemaps and
//! draws into the output. Recreated only when the size, the sample count, whether lights are
//! deferred or whether there is an HDR target changes.

use crate::pipelines::pipeline_cache::{LOCAL_LIGHT_FORMAT, PipelineCache, SURFACE_SHAPE_FORMAT};

pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

pub struct FrameTargets {
    pub size: (u32, u32),
    pub samples: u32,
    /// `None`: the frame draws straight into the output.
    pub hdr: Option<HdrTargets>,
    /// `None`: nothing drawn this frame can cover a pixel twice (see `Renderer::render`).
    pub depth_view: Option<wgpu::TextureView>,
    pub deferred: Option<DeferredTargets>,
}

pub struct HdrTargets {
    /// Single-sampled HDR colour: rendered directly (MSAA 1) or resolved into (MSAA 4).
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    pub msaa_view: Option<wgpu::TextureView>,
}

fn view_entry(binding: u32, view: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry { binding, resource: wgpu::BindingResource::TextureView(view) }
}

/// What deferred local lights add: the surface each opaque sample holds (with roughness in the
/// colour's alpha), and the local light per pixel, bound for the compute pass and for the
/// composite.
pub struct DeferredTargets {
    pub surface_shape_view: wgpu::TextureView,
    /// Group 1 of the deferred-lights compute pass.
    pub compute_bind_group: wgpu::BindGroup,
    /// Group 0 of the composite.
    pub composite_bind_group: wgpu::BindGroup,
}

impl FrameTargets {
    /// `deferred_params`: the deferred-lights pass's uniform when lights are deferred (which
    /// needs the HDR target and depth). Without `hdr` and `depth` nothing at all is made.
    pub fn new(
        device: &wgpu::Device,
        pipelines: &PipelineCache,
        size: (u32, u32),
        samples: u32,
        deferred_params: Option<&wgpu::Buffer>,
        hdr: bool,
        depth: bool,
    ) -> Self {
        let extent = wgpu::Extent3d { width: size.0.max(1), height: size.1.max(1), depth_or_array_layers: 1 };
        let tex = |label, format, samples, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: extent,
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let attach = wgpu::TextureUsages::RENDER_ATTACHMENT;
        let sampled = wgpu::TextureUsages::TEXTURE_BINDING;
        let hdr = (hdr || deferred_params.is_some()).then(|| {
            let texture = tex(
                "hdr colour",
                HDR_FORMAT,
                1,
                attach | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
            );
            let view = texture.create_view(&Default::default());
            // The deferred-lights pass reads the colour's alpha.
            let msaa_usage = if deferred_params.is_some() { attach | sampled } else { attach };
            let msaa_view = (samples > 1)
                .then(|| tex("hdr colour msaa", HDR_FORMAT, samples, msaa_usage).create_view(&Default::default()));
            HdrTargets { texture, view, msaa_view }
        });
        // Sampled by the deferred-lights pass and by occlusion culling's depth pyramid.
        let depth_usage = attach | sampled;
        let depth_view = (depth || deferred_params.is_some())
            .then(|| tex("depth", DEPTH_FORMAT, samples, depth_usage).create_view(&Default::default()));
        let deferred = deferred_params.zip(hdr.as_ref().zip(depth_view.as_ref())).map(|(params, (hdr, depth_view))| {
            let view = |t: wgpu::Texture| t.create_view(&Default::default());
            let surface_shape_view = view(tex("surface shape", SURFACE_SHAPE_FORMAT, samples, attach | sampled));
            let local_light_view =
                view(tex("local light", LOCAL_LIGHT_FORMAT, 1, wgpu::TextureUsages::STORAGE_BINDING | sampled));
            let compute_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("deferred lights"),
                layout: &pipelines.deferred_layouts[(samples > 1) as usize],
                entries: &[
                    view_entry(0, hdr.msaa_view.as_ref().unwrap_or(&hdr.view)),
                    view_entry(1, &surface_shape_view),
                    view_entry(2, depth_view),
                    view_entry(3, &local_light_view),
                    wgpu::BindGroupEntry { binding: 4, resource: params.as_entire_binding() },
                ],
            });
            let composite_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("deferred composite"),
                layout: &pipelines.composite_layout,
                entries: &[view_entry(0, &local_light_view)],
            });
            DeferredTargets { surface_shape_view, compute_bind_group, composite_bind_group }
        });
        Self { size, samples, hdr, depth_view, deferred }
    }

    /// The single-sampled HDR colour, if the frame has one.
    pub fn hdr_view(&self) -> Option<&wgpu::TextureView> {
        self.hdr.as_ref().map(|h| &h.view)
    }

    /// Where the forward pass draws, and what it resolves into: the HDR targets, or else the
    /// output (`direct`, single-sampled).
    pub fn color_attachment<'a>(
        &'a self,
        direct: &'a wgpu::TextureView,
    ) -> (&'a wgpu::TextureView, Option<&'a wgpu::TextureView>) {
        match &self.hdr {
            Some(HdrTargets { view, msaa_view: Some(msaa), .. }) => (msaa, Some(view)),
            Some(HdrTargets { view, msaa_view: None, .. }) => (view, None),
            None => (direct, None),
        }
    }

    pub fn bytes(&self) -> u64 {
        let px = self.size.0 as u64 * self.size.1 as u64;
        let samples = self.samples as u64;
        // Depth 4 B per sample; HDR 8 B per sample plus the single-sampled resolve target;
        // deferred lights add 8 B of surface per sample and 8 B of local light per pixel.
        let depth = if self.depth_view.is_some() { px * 4 * samples } else { 0 };
        let hdr = if self.hdr.is_some() { px * 8 * samples + if samples > 1 { px * 8 } else { 0 } } else { 0 };
        let deferred = if self.deferred.is_some() { px * (8 * samples + 8) } else { 0 };
        depth + hdr + deferred
    }
}
