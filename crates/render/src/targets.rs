//! Frame targets: the linear HDR colour target (`Rgba16Float`), its MSAA twin when multisampling,
//! and the reverse-Z depth target (`Depth32Float`, cleared to 0). Recreated only when the size or
//! sample count changes.

pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

pub struct FrameTargets {
    pub size: (u32, u32),
    pub samples: u32,
    /// Single-sampled HDR colour: rendered directly (MSAA 1) or resolved into (MSAA 4).
    pub hdr: wgpu::Texture,
    pub hdr_view: wgpu::TextureView,
    pub hdr_msaa_view: Option<wgpu::TextureView>,
    pub depth_view: wgpu::TextureView,
    pub tonemap_bind_group: wgpu::BindGroup,
}

impl FrameTargets {
    pub fn new(device: &wgpu::Device, tonemap_layout: &wgpu::BindGroupLayout, size: (u32, u32), samples: u32) -> Self {
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
        let hdr = tex(
            "hdr colour",
            HDR_FORMAT,
            1,
            attach | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
        );
        let hdr_view = hdr.create_view(&Default::default());
        let hdr_msaa_view =
            (samples > 1).then(|| tex("hdr colour msaa", HDR_FORMAT, samples, attach).create_view(&Default::default()));
        let depth_view = tex("depth", DEPTH_FORMAT, samples, attach).create_view(&Default::default());
        let tonemap_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("tonemap input"),
            layout: tonemap_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&hdr_view) }],
        });
        Self { size, samples, hdr, hdr_view, hdr_msaa_view, depth_view, tonemap_bind_group }
    }

    /// Where the forward pass draws, and what it resolves into.
    pub fn color_attachment(&self) -> (&wgpu::TextureView, Option<&wgpu::TextureView>) {
        match &self.hdr_msaa_view {
            Some(msaa) => (msaa, Some(&self.hdr_view)),
            None => (&self.hdr_view, None),
        }
    }

    pub fn bytes(&self) -> u64 {
        let px = self.size.0 as u64 * self.size.1 as u64;
        // HDR 8 B + depth 4 B per sample, plus the single-sampled resolve target.
        px * (8 + 12 * self.samples as u64) + if self.samples > 1 { px * 8 } else { 0 }
    }
}
