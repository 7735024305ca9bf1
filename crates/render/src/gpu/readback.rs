//! Reading back to the CPU: textures (the tonemapped output for screenshots, the linear HDR
//! target for tests that check radiance before tonemapping; rows are copied at wgpu's 256-byte
//! alignment and unpadded here) and buffers, blocking; and [`AsyncSlot`], the state of a
//! readback buffer read a frame or two late without waiting (GPU timings, occlusion feedback).

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

/// Where a non-blocking readback buffer is in its cycle: free; claimed by the frame being
/// recorded (which copies into it); mapping after that frame's submission; mapped (read it,
/// unmap, [`AsyncSlot::release`]); or failed (release it).
#[derive(Clone)]
pub struct AsyncSlot(Arc<AtomicU8>);

/// What [`AsyncSlot::arrived`] finds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arrival {
    /// Free, claimed or still mapping.
    NotYet,
    Mapped,
    Failed,
}

impl Default for AsyncSlot {
    fn default() -> Self {
        Self(Arc::new(AtomicU8::new(Self::FREE)))
    }
}

impl AsyncSlot {
    const FREE: u8 = 0;
    const CLAIMED: u8 = 1;
    const MAPPING: u8 = 2;
    const MAPPED: u8 = 3;
    const FAILED: u8 = 4;

    pub fn is_free(&self) -> bool {
        self.0.load(Ordering::Acquire) == Self::FREE
    }

    /// Claims a free slot for the frame being recorded.
    pub fn claim(&self) {
        self.0.store(Self::CLAIMED, Ordering::Release);
    }

    /// Frees the slot: read and unmapped, failed, or claimed but given nothing to read.
    pub fn release(&self) {
        self.0.store(Self::FREE, Ordering::Release);
    }

    /// After the claiming frame's submission: maps `slice` (of the buffer the frame copied into)
    /// once the GPU is done with it.
    pub fn map_after_submit(&self, slice: wgpu::BufferSlice<'_>) {
        self.0.store(Self::MAPPING, Ordering::Release);
        let state = self.0.clone();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            state.store(if r.is_ok() { Self::MAPPED } else { Self::FAILED }, Ordering::Release);
        });
    }

    /// Whether the map has completed, without waiting (the device must be polled for it to).
    pub fn arrived(&self) -> Arrival {
        match self.0.load(Ordering::Acquire) {
            Self::MAPPED => Arrival::Mapped,
            Self::FAILED => Arrival::Failed,
            _ => Arrival::NotYet,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ReadbackError {
    #[error("mapping the readback buffer failed: {0}")]
    Map(String),
    #[error("the GPU did not finish: {0}")]
    Poll(String),
}

/// Copies a whole single-sampled 2D texture with `bytes_per_pixel` and returns tightly packed rows.
pub fn read_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    bytes_per_pixel: u32,
) -> Result<Vec<u8>, ReadbackError> {
    read_texture_region(device, queue, texture, 0, (texture.width(), texture.height()), bytes_per_pixel)
}

/// Copies `(w, h)` texels from the top-left corner of layer `layer` of a single-sampled 2D
/// texture with `bytes_per_pixel` and returns tightly packed rows.
pub fn read_texture_region(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    layer: u32,
    (w, h): (u32, u32),
    bytes_per_pixel: u32,
) -> Result<Vec<u8>, ReadbackError> {
    let unpadded = w * bytes_per_pixel;
    let padded = unpadded.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: padded as u64 * h as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d { x: 0, y: 0, z: layer },
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded), rows_per_image: Some(h) },
        },
        wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
    );
    let data = submit_and_map(device, queue, encoder, &buffer)?;
    let mut out = Vec::with_capacity((unpadded * h) as usize);
    for row in data.chunks_exact(padded as usize) {
        out.extend_from_slice(&row[..unpadded as usize]);
    }
    Ok(out)
}

/// Submits `encoder` (which copies into `buffer`), waits, and returns the buffer's bytes.
fn submit_and_map(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    encoder: wgpu::CommandEncoder,
    buffer: &wgpu::Buffer,
) -> Result<Vec<u8>, ReadbackError> {
    queue.submit([encoder.finish()]);
    let slice = buffer.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| ReadbackError::Poll(e.to_string()))?;
    rx.recv().map_err(|e| ReadbackError::Map(e.to_string()))?.map_err(|e| ReadbackError::Map(e.to_string()))?;
    let data = slice.get_mapped_range().map_err(|e| ReadbackError::Map(format!("{e:?}")))?.to_vec();
    buffer.unmap();
    Ok(data)
}

/// Copies `size` bytes of `source` (which needs `COPY_SRC`) back to the CPU, blocking.
pub fn read_buffer(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    source: &wgpu::Buffer,
    size: u64,
) -> Result<Vec<u8>, ReadbackError> {
    let size = size.next_multiple_of(4).max(4);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("buffer readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
    encoder.copy_buffer_to_buffer(source, 0, &buffer, 0, size.min(source.size()));
    submit_and_map(device, queue, encoder, &buffer)
}

/// IEEE 754 binary16 to f32 (handles subnormals, infinities and NaN).
pub fn f16_to_f32(h: u16) -> f32 {
    let sign = ((h >> 15) as u32) << 31;
    let exp = ((h >> 10) & 0x1f) as u32;
    let mant = (h & 0x3ff) as u32;
    let bits = match (exp, mant) {
        (0, 0) => sign,
        (0, m) => {
            // Subnormal: value = m · 2^−24.
            let v = m as f32 * (1.0 / 16_777_216.0);
            return if sign != 0 { -v } else { v };
        }
        (0x1f, 0) => sign | 0x7f80_0000,
        (0x1f, m) => sign | 0x7f80_0000 | (m << 13),
        (e, m) => sign | ((e + 112) << 23) | (m << 13),
    };
    f32::from_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f16_conversion_matches_known_values() {
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0xc000), -2.0);
        assert_eq!(f16_to_f32(0x7bff), 65504.0);
        assert_eq!(f16_to_f32(0x0001), 2f32.powi(-24));
        assert!(f16_to_f32(0x7c00).is_infinite());
        assert!(f16_to_f32(0x7e00).is_nan());
    }
}
