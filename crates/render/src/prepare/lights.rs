//! The light buffer: every extracted light packed into one storage buffer with no fixed count.
//! A stepping stone: issue #3 replaces it with the light store (change-tracked uploads, area and
//! IES lights) and clustered binning; the shader then stops looping over every light.

use bytemuck::{Pod, Zeroable};

use super::buffer::GrowableBuffer;
use crate::world::{ExtractedLight, LightKind};

/// Mirrors `struct Light` in `shaders/forward.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuLight {
    pub position: [f32; 3],
    pub kind: u32,
    pub direction: [f32; 3],
    pub range: f32,
    pub color: [f32; 3],
    pub spot_scale: f32,
    pub spot_offset: f32,
    pub _pad: [f32; 3],
}

pub const KIND_DIRECTIONAL: u32 = 0;
pub const KIND_POINT: u32 = 1;
pub const KIND_SPOT: u32 = 2;
pub const KIND_AMBIENT: u32 = 3;

pub fn pack(light: &ExtractedLight) -> GpuLight {
    let (kind, spot_scale, spot_offset) = match light.kind {
        LightKind::Directional => (KIND_DIRECTIONAL, 0.0, 0.0),
        LightKind::Point => (KIND_POINT, 0.0, 0.0),
        LightKind::Ambient => (KIND_AMBIENT, 0.0, 0.0),
        LightKind::Spot { inner_cone_angle, outer_cone_angle } => {
            // KHR_lights_punctual's smooth cone falloff as scale/offset of cos(angle); the
            // 0.001 floor keeps inner == outer from dividing by zero (a hard-edged cone).
            let cos_outer = outer_cone_angle.cos();
            let cos_inner = inner_cone_angle.min(outer_cone_angle).cos();
            let scale = 1.0 / (cos_inner - cos_outer).max(0.001);
            (KIND_SPOT, scale, -cos_outer * scale)
        }
    };
    GpuLight {
        position: light.position.to_array(),
        kind,
        direction: light.direction.normalize_or(glam::Vec3::NEG_Z).to_array(),
        range: light.range.unwrap_or(0.0).max(0.0),
        color: light.color.to_array(),
        spot_scale,
        spot_offset,
        _pad: [0.0; 3],
    }
}

pub struct LightBuffer {
    buffer: GrowableBuffer,
    count: u32,
}

impl LightBuffer {
    pub fn new(device: &wgpu::Device) -> Self {
        Self { buffer: GrowableBuffer::new(device, "lights", wgpu::BufferUsages::STORAGE, 64 * 64), count: 0 }
    }

    pub fn buffer(&self) -> &wgpu::Buffer {
        self.buffer.buffer()
    }

    pub fn count(&self) -> u32 {
        self.count
    }

    /// Packs and uploads all lights; returns true when the buffer was replaced.
    pub fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, lights: &[ExtractedLight]) -> bool {
        let packed: Vec<GpuLight> = lights.iter().map(pack).collect();
        let bytes: &[u8] = bytemuck::cast_slice(&packed);
        let grew = self.buffer.reserve(device, bytes.len() as u64);
        if !bytes.is_empty() {
            queue.write_buffer(self.buffer.buffer(), 0, bytes);
        }
        self.count = packed.len() as u32;
        grew
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn light(kind: LightKind) -> ExtractedLight {
        ExtractedLight { kind, color: Vec3::ONE, position: Vec3::ZERO, direction: Vec3::NEG_Z, range: None }
    }

    #[test]
    fn every_light_kind_packs_its_own_discriminant() {
        let kinds = [
            (LightKind::Directional, KIND_DIRECTIONAL),
            (LightKind::Point, KIND_POINT),
            (LightKind::Spot { inner_cone_angle: 0.1, outer_cone_angle: 0.5 }, KIND_SPOT),
            (LightKind::Ambient, KIND_AMBIENT),
        ];
        for (k, want) in kinds {
            assert_eq!(pack(&light(k)).kind, want, "{k:?}");
        }
        assert_eq!(std::mem::size_of::<GpuLight>(), 64);
    }

    #[test]
    fn spot_falloff_is_one_inside_and_zero_outside() {
        let g = pack(&light(LightKind::Spot { inner_cone_angle: 0.2, outer_cone_angle: 0.4 }));
        let at = |angle: f32| (angle.cos() * g.spot_scale + g.spot_offset).clamp(0.0, 1.0);
        assert!((at(0.1) - 1.0).abs() < 1e-5);
        assert!(at(0.41) == 0.0);
        let g = pack(&light(LightKind::Spot { inner_cone_angle: 0.4, outer_cone_angle: 0.4 }));
        assert!(g.spot_scale.is_finite());
    }
}
