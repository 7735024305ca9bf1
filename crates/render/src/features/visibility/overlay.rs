//! A hybrid frame's overlay: what only the forward pass rasterises (line and point meshes,
//! blended draws, gizmo lines) drawn over the visibility buffer. The owner of the overlay's
//! targets and of the occlusion group its draws read.
//!
//! Data flow, after the raster steps and before the shading pass: the forward pass draws those
//! into the overlay's multisampled colour (cleared to transparent: premultiplied colour, and
//! coverage in alpha) and depth (cleared to the far plane: they test each other), each fragment
//! keeping only the samples nearer than the visibility buffer's depth there
//! (`shaders/visibility_occlusion.wgsl`; the buffer is group 2 of the forward pipelines, group 1
//! of the gizmos', whose layouts then share their groups' prefix). The shading pass
//! then composites each overlay sample over its own sample's colour: blending is linear, so a
//! triangle's colour counts by how much the overlay samples over those it covers let through.
//! No full-screen pass hands depth or colour to the forward pass, which on GPUs with few graphics
//! units costs more than the draws themselves. With transmissive draws a first shading writes the
//! opaque colour their draws read, and the shading pass after the overlay reuses it for pixels
//! whose samples hold one triangle (`FrameInputs::transmission`).
//!
//! Only the rectangle the overlay's draws can cover ([`OverlayRect`]: the screen box of the
//! blended draws' bounds and the gizmo lines) is drawn: the targets are that rectangle's size,
//! and the draws' clip positions are cropped to it (the same pixels and samples, shifted), so a
//! small glass in a large frame clears and stores a small target. On GPUs with few graphics
//! units a multisampled full-frame target costs milliseconds to clear and hand to compute.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3, Vec4};
use penumbra_engine::bounds::Aabb;

use crate::gpu::formats::{DEPTH_FORMAT, HDR_FORMAT};
use crate::pipelines::parts::{buffer_entry, storage};
use crate::targets::render_target;

/// The overlay's pipelines' occlusion group (2 of the forward pipelines, 1 of the gizmos'): the
/// visibility buffer's samples and the overlay's parameters (`visibility_occlusion.wgsl`); and
/// the same group for transmissive draws, which also read the opaque colour's copy and its
/// sampler there (bindings 2 and 3: their forward layout has it as group 2 as well).
pub fn occlusion_layouts(device: &wgpu::Device) -> [wgpu::BindGroupLayout; 2] {
    let fragment = wgpu::ShaderStages::FRAGMENT;
    let both = wgpu::ShaderStages::VERTEX_FRAGMENT;
    let occlusion = [storage(0, fragment), buffer_entry(1, both, wgpu::BufferBindingType::Uniform)];
    let layout = crate::pipelines::parts::bind_group_layout;
    let copy = [crate::pipelines::parts::texture(2, true), crate::pipelines::parts::sampler(3)];
    let transmissive = [occlusion.as_slice(), copy.as_slice()].concat();
    [
        layout(device, "visibility occlusion", &occlusion),
        layout(device, "visibility occlusion with transmission", &transmissive),
    ]
}

/// The pixels a hybrid frame's overlay draws can cover, within the frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OverlayRect {
    pub origin: (u32, u32),
    pub size: (u32, u32),
}

impl OverlayRect {
    pub fn full(frame: (u32, u32)) -> Self {
        Self { origin: (0, 0), size: (frame.0.max(1), frame.1.max(1)) }
    }

    /// The screen box of world-space `boxes` and `points` seen through `clip_from_rel` from
    /// `camera`, grown by 2 pixels (line widths, sample positions, rounding) and clamped to the
    /// `frame`: the whole frame when a point lies on or behind the eye's plane (its projection
    /// is unbounded) or is not finite.
    pub fn covering(
        boxes: &[Aabb],
        points: impl Iterator<Item = Vec3>,
        clip_from_rel: Mat4,
        camera: Vec3,
        frame: (u32, u32),
    ) -> Self {
        let corners = boxes.iter().flat_map(|b| {
            (0..8).map(move |i| {
                Vec3::new(
                    if i & 1 == 0 { b.min.x } else { b.max.x },
                    if i & 2 == 0 { b.min.y } else { b.max.y },
                    if i & 4 == 0 { b.min.z } else { b.max.z },
                )
            })
        });
        let (w, h) = (frame.0.max(1) as f32, frame.1.max(1) as f32);
        let (mut lo, mut hi) = (glam::Vec2::splat(f32::INFINITY), glam::Vec2::splat(f32::NEG_INFINITY));
        for p in corners.chain(points) {
            let c = clip_from_rel * Vec4::from(((p - camera), 1.0));
            if !c.is_finite() || c.w <= 1e-6 {
                return Self::full(frame);
            }
            let pixel = glam::Vec2::new((c.x / c.w * 0.5 + 0.5) * w, (0.5 - c.y / c.w * 0.5) * h);
            lo = lo.min(pixel);
            hi = hi.max(pixel);
        }
        if lo.x > hi.x {
            return Self { origin: (0, 0), size: (1, 1) };
        }
        let lo = (lo - 2.0).floor().clamp(glam::Vec2::ZERO, glam::Vec2::new(w - 1.0, h - 1.0));
        let hi = (hi + 2.0).ceil().clamp(lo + 1.0, glam::Vec2::new(w, h));
        Self { origin: (lo.x as u32, lo.y as u32), size: ((hi.x - lo.x) as u32, (hi.y - lo.y) as u32) }
    }
}

/// Mirrors `struct OcclusionParams` in `shaders/visibility_occlusion.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuOcclusionParams {
    target_size: [u32; 2],
    samples: u32,
    _pad: u32,
    origin: [u32; 2],
    _pad_b: [u32; 2],
    crop_scale: [f32; 2],
    crop_offset: [f32; 2],
}

impl GpuOcclusionParams {
    /// The visibility buffer's `frame` size and `samples`; the overlay's `rect` drawn into a
    /// target of `extent` pixels whose pixel (0, 0) is the rectangle's origin: clip positions
    /// scaled and offset so that each frame pixel lands on its target pixel.
    pub fn new(frame: (u32, u32), samples: u32, rect: OverlayRect, extent: (u32, u32)) -> Self {
        let (w, h) = (frame.0 as f32, frame.1 as f32);
        let (tw, th) = (extent.0 as f32, extent.1 as f32);
        let (x0, y0) = (rect.origin.0 as f32, rect.origin.1 as f32);
        Self {
            target_size: [frame.0, frame.1],
            samples,
            _pad: 0,
            origin: [rect.origin.0, rect.origin.1],
            _pad_b: [0; 2],
            crop_scale: [w / tw, h / th],
            crop_offset: [(w - 2.0 * x0) / tw - 1.0, 1.0 - (h - 2.0 * y0) / th],
        }
    }
}

/// The overlay's targets (sized to the rectangle, rounded up so that small changes keep them),
/// its parameters and the occlusion group.
pub struct OverlayTargets {
    pub extent: (u32, u32),
    pub samples: u32,
    pub colour: wgpu::TextureView,
    pub depth: wgpu::TextureView,
    /// `GpuOcclusionParams`, written each frame.
    pub params: wgpu::Buffer,
    /// The occlusion group, and the samples buffer it binds (made again when that changes).
    pub occlusion: Option<(wgpu::Buffer, wgpu::BindGroup)>,
    /// In a frame with transmissive draws: the occlusion group with the opaque colour's copy,
    /// and the samples buffer and copy it binds.
    pub transmissive: Option<(wgpu::Buffer, wgpu::TextureView, wgpu::BindGroup)>,
}

/// Target sizes are multiples of this many pixels.
const GRANULE: u32 = 64;

impl OverlayTargets {
    /// The extent targets for `rect` of a `frame` have: rounded up, within the frame.
    pub fn extent_for(rect: OverlayRect, frame: (u32, u32)) -> (u32, u32) {
        let round = |v: u32, limit: u32| v.div_ceil(GRANULE).saturating_mul(GRANULE).min(limit.max(1)).max(v);
        (round(rect.size.0, frame.0), round(rect.size.1, frame.1))
    }

    pub fn new(device: &wgpu::Device, extent: (u32, u32), samples: u32) -> Self {
        let target = |label, format, usage| {
            render_target(device, label, extent, samples, format, usage).create_view(&Default::default())
        };
        let attach = wgpu::TextureUsages::RENDER_ATTACHMENT;
        Self {
            extent,
            samples,
            colour: target("visibility overlay colour", HDR_FORMAT, attach | wgpu::TextureUsages::TEXTURE_BINDING),
            depth: target("visibility overlay depth", DEPTH_FORMAT, attach),
            params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("visibility overlay params"),
                size: std::mem::size_of::<GpuOcclusionParams>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            occlusion: None,
            transmissive: None,
        }
    }

    /// GPU memory the targets and parameters hold, in bytes (8 bytes of colour and 4 of depth a
    /// sample).
    pub fn bytes(&self) -> u64 {
        self.extent.0 as u64 * self.extent.1 as u64 * self.samples as u64 * 12 + self.params.size()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipelines::shader_library::assert_mirrors_wgsl;

    #[test]
    fn the_params_mirror_the_shader() {
        assert_mirrors_wgsl!(
            GpuOcclusionParams,
            "visibility_occlusion.wgsl",
            [],
            "OcclusionParams",
            [target_size, samples, origin, crop_scale, crop_offset]
        );
    }

    #[test]
    fn the_rectangle_covers_what_is_in_front_and_the_whole_frame_otherwise() {
        let frame = (200, 100);
        let projection =
            penumbra_engine::components::Projection::Perspective { yfov: 1.0, znear: 0.1, aspect_ratio: None };
        let clip_from_rel = projection.clip_from_view(2.0);
        let small = Aabb { min: Vec3::new(-0.1, -0.1, -5.1), max: Vec3::new(0.1, 0.1, -4.9) };
        let r = OverlayRect::covering(&[small], std::iter::empty(), clip_from_rel, Vec3::ZERO, frame);
        // About 0.2 / 5 of the half-height's 1 / tan(0.5) · 50 pixels each way, plus the margin.
        assert!(r.size.0 < 20 && r.size.1 < 20 && r.origin.0 > 80 && r.origin.1 > 30, "{r:?}");
        let behind = Aabb { min: Vec3::new(-1.0, -1.0, -1.0), max: Vec3::new(1.0, 1.0, 1.0) };
        assert_eq!(
            OverlayRect::covering(&[behind], std::iter::empty(), clip_from_rel, Vec3::ZERO, frame),
            OverlayRect::full(frame)
        );
        let point =
            OverlayRect::covering(&[], [Vec3::new(0.0, 0.0, -3.0)].into_iter(), clip_from_rel, Vec3::ZERO, frame);
        assert_eq!(point, OverlayRect { origin: (98, 48), size: (4, 4) });
        // Cropping maps the rectangle's origin to the target's corner, one pixel to one pixel.
        let p = GpuOcclusionParams::new(frame, 4, point, (64, 64));
        let ndc = |px: f32, size: f32| px / size * 2.0 - 1.0;
        let x = ndc(98.0, 200.0) * p.crop_scale[0] + p.crop_offset[0];
        assert!((x - ndc(0.0, 64.0)).abs() < 1e-5 && (p.crop_scale[0] * 2.0 / 200.0 - 2.0 / 64.0).abs() < 1e-6);
    }
}
