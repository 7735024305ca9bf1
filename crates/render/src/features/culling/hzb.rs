//! The hierarchical depth buffer occlusion culling's late phase tests against: a mip chain of
//! the frame's depth, each texel the farthest (reverse-Z: smallest) depth below it.

/// The hierarchical depth buffer: level 0 is the largest power of two within the frame.
pub(super) struct Hzb {
    pub(super) frame_size: (u32, u32),
    pub(super) full_view: wgpu::TextureView,
    pub(super) level_views: Vec<wgpu::TextureView>,
    /// Each level's reduction inputs, for the depth target they were made with.
    pub(super) level_groups: Option<(wgpu::TextureView, Vec<wgpu::BindGroup>)>,
}

impl Hzb {
    pub(super) fn new(device: &wgpu::Device, frame_size: (u32, u32)) -> Self {
        let floor_pow2 = |v: u32| if v <= 1 { 1 } else { 1u32 << (31 - v.leading_zeros()) };
        let (w, h) = (floor_pow2(frame_size.0), floor_pow2(frame_size.1));
        let levels = 32 - w.max(h).leading_zeros();
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("hierarchical depth"),
            size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            mip_level_count: levels,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let level_views = (0..levels)
            .map(|level| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    base_mip_level: level,
                    mip_level_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        Self { frame_size, full_view: texture.create_view(&Default::default()), level_views, level_groups: None }
    }

    pub(super) fn levels(&self) -> u32 {
        self.level_views.len() as u32
    }
}
