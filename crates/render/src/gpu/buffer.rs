//! A GPU buffer that grows geometrically. Owners keep a CPU mirror and re-upload after growth
//! (growth is rare: capacity doubles), and rebuild bind groups when `reserve` says it grew.

pub struct GrowableBuffer {
    buffer: wgpu::Buffer,
    label: &'static str,
    usage: wgpu::BufferUsages,
}

impl GrowableBuffer {
    pub fn new(device: &wgpu::Device, label: &'static str, usage: wgpu::BufferUsages, initial_bytes: u64) -> Self {
        let usage = usage | wgpu::BufferUsages::COPY_DST;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: initial_bytes.max(256),
            usage,
            mapped_at_creation: false,
        });
        Self { buffer, label, usage }
    }

    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }

    pub fn capacity(&self) -> u64 {
        self.buffer.size()
    }

    /// Makes room for `bytes`; returns true when the buffer was replaced (contents are lost).
    pub fn reserve(&mut self, device: &wgpu::Device, bytes: u64) -> bool {
        if bytes <= self.buffer.size() {
            return false;
        }
        // Doubling stops at what the device can hold (and bind, for storage buffers), so that a
        // request the caller checked against those limits never grows past them.
        let mut limit = device.limits().max_buffer_size;
        if self.usage.contains(wgpu::BufferUsages::STORAGE) {
            limit = limit.min(device.limits().max_storage_buffer_binding_size);
        }
        let size = bytes.max((self.buffer.size() * 2).min(limit & !255)).next_multiple_of(256);
        self.buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(self.label),
            size,
            usage: self.usage,
            mapped_at_creation: false,
        });
        tracing::debug!("{}: grew to {size} bytes", self.label);
        true
    }
}
