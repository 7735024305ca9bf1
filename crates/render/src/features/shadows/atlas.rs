//! The shadow atlases' textures and the way casters reach the cascade atlas.
//!
//! Two atlases, both 2D arrays of reverse-Z depth from the light: the local lights' maps
//! ([`Atlas::depth`], `Depth32Float`, drawn into directly and read through a comparison sampler),
//! and the cascades'. The cascades' layers are a depth target drawn into directly where the
//! hardware draws their casters, and floats ([`Atlas::floats`], `R32Float`) where they are
//! rasterised in compute (`super::raster`), which writes a buffer: a depth texture can be neither
//! written by compute nor copied into. `shaders/shadows.wgsl` reads either kind through one
//! unfilterable-float binding and makes the comparisons itself from gathered texels.
//!
//! Data flow per layer of a float atlas drawn: its casters land in [`LayerStaging`]'s buffer
//! (one `u32` of depth bits a texel, rows a multiple of 256 bytes apart), written there by the
//! compute raster (or, where that raster cannot run this frame, copied there from a staging
//! depth target the hardware drew into); then the stored window is copied into the layer. One
//! staging serves every layer in turn.

use crate::gpu::array_layers::ArrayLayers;
use crate::gpu::formats::{SHADOW_ATLAS_FORMAT, SHADOW_DEPTHS_FORMAT};

pub struct Atlas {
    texture: wgpu::Texture,
    pub array_view: wgpu::TextureView,
    /// Each layer as a render attachment (a depth atlas's; a float atlas's layers are copied into).
    pub layer_views: Vec<wgpu::TextureView>,
    /// Texels across and down a layer.
    pub extent: (u32, u32),
    /// Layers in use (the texture may have a spare one: `ArrayLayers`).
    layers: u32,
    /// `R32Float`, filled by copies ([`Atlas::floats`]); else a depth target.
    pub floats: bool,
}

impl Atlas {
    /// Depth targets the caster passes draw into (the local lights' maps; the cascades' where
    /// the hardware draws them). Copied out only by tests and tools (`read_layer`).
    pub fn depth(device: &wgpu::Device, rule: ArrayLayers, extent: (u32, u32), layers: u32) -> Self {
        use wgpu::TextureUsages as U;
        let usage = U::RENDER_ATTACHMENT | U::TEXTURE_BINDING | U::COPY_SRC;
        Self::new(device, rule, extent, layers, SHADOW_ATLAS_FORMAT, usage)
    }

    /// Cascade layers as floats, filled by copies from [`LayerStaging`].
    pub fn floats(device: &wgpu::Device, rule: ArrayLayers, extent: (u32, u32), layers: u32) -> Self {
        use wgpu::TextureUsages as U;
        let usage = U::COPY_DST | U::TEXTURE_BINDING | U::COPY_SRC;
        Self::new(device, rule, extent, layers, SHADOW_DEPTHS_FORMAT, usage)
    }

    fn new(
        device: &wgpu::Device,
        rule: ArrayLayers,
        (width, height): (u32, u32),
        layers: u32,
        format: wgpu::TextureFormat,
        usage: wgpu::TextureUsages,
    ) -> Self {
        let allocated = rule.allocate(layers, width, height);
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("shadow atlas"),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: allocated },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        });
        let array_view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let attachable = usage.contains(wgpu::TextureUsages::RENDER_ATTACHMENT);
        let layer_views = (0..if attachable { layers } else { 0 })
            .map(|layer| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    label: Some("shadow atlas layer"),
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: layer,
                    array_layer_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        let floats = format == SHADOW_DEPTHS_FORMAT;
        Self { texture, array_view, layer_views, extent: (width, height), layers, floats }
    }

    /// The depths of `size` texels at layer `layer`'s top-left corner, row by row. Reads back
    /// (waits for the GPU): for tests and tools.
    pub fn read_layer(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        layer: u32,
        size: (u32, u32),
    ) -> Result<Vec<f32>, crate::gpu::readback::ReadbackError> {
        // A depth texture copies out whole.
        let copied = if self.floats { size } else { self.extent };
        let bytes = crate::gpu::readback::read_texture_region(device, queue, &self.texture, layer, copied, 4)?;
        let row = copied.0 as usize * 4;
        let bytes: Vec<u8> =
            bytes.chunks_exact(row).take(size.1 as usize).flat_map(|r| &r[..size.0 as usize * 4]).copied().collect();
        Ok(bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect())
    }

    pub fn layers(&self) -> u32 {
        self.layers
    }

    pub fn bytes(&self) -> u64 {
        self.extent.0 as u64 * self.extent.1 as u64 * 4 * self.texture.depth_or_array_layers() as u64
    }
}

/// Bytes between rows of a staging buffer `width` texels wide (copies need multiples of 256).
pub fn row_pitch(width: u32) -> u32 {
    (width * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
}

/// Where a cascade layer's casters are drawn before their window is copied into the atlas: a
/// buffer of depth bits (what the compute raster writes, and where the hardware's depth target
/// is copied) and, for the hardware, that depth target. Sized to the atlas's layers.
pub struct LayerStaging {
    buffer: wgpu::Buffer,
    depth: Option<(wgpu::Texture, wgpu::TextureView)>,
    extent: (u32, u32),
}

impl LayerStaging {
    /// Staging for layers of `extent`; `depth`: with the hardware's depth target.
    pub fn new(device: &wgpu::Device, extent: (u32, u32), depth: bool) -> Self {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("shadow layer depths"),
            size: row_pitch(extent.0) as u64 * extent.1 as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut staging = Self { buffer, depth: None, extent };
        if depth {
            staging.add_depth_target(device);
        }
        staging
    }

    /// Whether this staging serves layers of `extent` (with the depth target where `depth`).
    pub fn fits(&self, extent: (u32, u32), depth: bool) -> bool {
        self.extent == extent && (!depth || self.depth.is_some())
    }

    fn add_depth_target(&mut self, device: &wgpu::Device) {
        let (width, height) = self.extent;
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("shadow layer depth"),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: SHADOW_ATLAS_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        self.depth = Some((texture, view));
    }

    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }

    /// Texels between the buffer's rows.
    pub fn pitch_texels(&self) -> u32 {
        row_pitch(self.extent.0) / 4
    }

    /// The hardware's depth target (made by `new` with `depth`).
    pub fn depth_view(&self) -> Option<&wgpu::TextureView> {
        self.depth.as_ref().map(|(_, v)| v)
    }

    /// Empties the buffer's first `rows` rows (depth 0: reverse-Z's far side, where nothing
    /// casts), before the compute raster writes them.
    pub fn clear_rows(&self, encoder: &mut wgpu::CommandEncoder, rows: u32) {
        encoder.clear_buffer(&self.buffer, 0, Some(row_pitch(self.extent.0) as u64 * rows as u64));
    }

    /// Copies the depth target into the buffer (whole: depth copies cannot be partial).
    pub fn copy_depth_to_buffer(&self, encoder: &mut wgpu::CommandEncoder) {
        let Some((texture, _)) = &self.depth else { return };
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::DepthOnly,
            },
            self.buffer_copy(),
            extent(self.extent),
        );
    }

    /// Copies `size` texels from the buffer's start into layer `layer` of `atlas`, at its
    /// top-left corner.
    pub fn copy_to_layer(&self, encoder: &mut wgpu::CommandEncoder, atlas: &Atlas, layer: u32, size: (u32, u32)) {
        encoder.copy_buffer_to_texture(
            self.buffer_copy(),
            wgpu::TexelCopyTextureInfo {
                texture: &atlas.texture,
                mip_level: 0,
                origin: wgpu::Origin3d { x: 0, y: 0, z: layer },
                aspect: wgpu::TextureAspect::All,
            },
            extent(size),
        );
    }

    fn buffer_copy(&self) -> wgpu::TexelCopyBufferInfo<'_> {
        wgpu::TexelCopyBufferInfo {
            buffer: &self.buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row_pitch(self.extent.0)),
                rows_per_image: Some(self.extent.1),
            },
        }
    }

    pub fn bytes(&self) -> u64 {
        let texels = self.extent.0 as u64 * self.extent.1 as u64;
        self.buffer.size() + self.depth.as_ref().map_or(0, |_| texels * 4)
    }
}

fn extent((width, height): (u32, u32)) -> wgpu::Extent3d {
    wgpu::Extent3d { width, height, depth_or_array_layers: 1 }
}
