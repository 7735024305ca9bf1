//! A hybrid frame's overlay: what only the forward pass rasterises (line and point meshes,
//! blended draws, gizmo lines) drawn over the visibility buffer. The owner of the overlay's
//! targets and of the occlusion group its draws read.
//!
//! Data flow, after the raster steps and before the shading pass: the forward pass draws those
//! into the overlay's multisampled colour (cleared to transparent: premultiplied colour, and
//! coverage in alpha) and depth (cleared to the far plane: they test each other), each fragment
//! keeping only the samples nearer than the visibility buffer's depth there
//! (`shaders/visibility_occlusion.wgsl`, bound as group 2 of their pipelines). The shading pass
//! then composites the overlay's mean over each pixel's resolved colour: blending is linear, so
//! the mean of the samples blended over one colour is the mean blended over it. No full-screen
//! pass hands depth or colour to the forward pass, which on GPUs with few graphics units costs
//! more than the draws themselves; where an overlay edge crosses an opaque edge in one pixel, its
//! samples blend over the pixel's mean colour rather than each sample's own.

use crate::gpu::formats::{DEPTH_FORMAT, HDR_FORMAT};
use crate::pipelines::parts::{storage, uniform};

/// Group 2 of the overlay's pipelines: the visibility buffer's samples and its parameters
/// (`visibility_occlusion.wgsl`).
pub fn occlusion_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let fragment = wgpu::ShaderStages::FRAGMENT;
    crate::pipelines::parts::bind_group_layout(
        device,
        "visibility occlusion",
        &[storage(0, fragment), uniform(1, fragment)],
    )
}

/// The overlay's targets at one size and sample count, and the occlusion group.
pub struct OverlayTargets {
    pub size: (u32, u32),
    pub samples: u32,
    pub colour: wgpu::TextureView,
    pub depth: wgpu::TextureView,
    /// The occlusion group, and the samples buffer it binds (made again when that changes).
    pub occlusion: Option<(wgpu::Buffer, wgpu::BindGroup)>,
}

impl OverlayTargets {
    pub fn new(device: &wgpu::Device, size: (u32, u32), samples: u32) -> Self {
        let target = |label, format, usage| {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: samples,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage,
                    view_formats: &[],
                })
                .create_view(&Default::default())
        };
        let attach = wgpu::TextureUsages::RENDER_ATTACHMENT;
        Self {
            size,
            samples,
            colour: target("visibility overlay colour", HDR_FORMAT, attach | wgpu::TextureUsages::TEXTURE_BINDING),
            depth: target("visibility overlay depth", DEPTH_FORMAT, attach),
            occlusion: None,
        }
    }

    /// GPU memory the targets hold, in bytes (8 bytes of colour and 4 of depth a sample).
    pub fn bytes(&self) -> u64 {
        self.size.0 as u64 * self.size.1 as u64 * self.samples as u64 * 12
    }
}
