//! GPU timing with timestamp queries written at pass boundaries. Enabled on request (stats
//! panel, `penumbra bench`); reading results waits for the GPU, so it stays off otherwise.

pub struct GpuTimer {
    query_set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    labels: Vec<&'static str>,
    capacity: u32,
    period_ns: f32,
}

impl GpuTimer {
    pub const MAX_PASSES: u32 = 16;

    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        let capacity = Self::MAX_PASSES * 2;
        let query_set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("pass timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: capacity,
        });
        let bytes = capacity as u64 * 8;
        let resolve = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamp resolve"),
            size: bytes,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamp readback"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self { query_set, resolve, readback, labels: Vec::new(), capacity, period_ns: queue.get_timestamp_period() }
    }

    pub fn begin_frame(&mut self) {
        self.labels.clear();
    }

    /// Timestamp writes for a render pass named `label`.
    pub fn pass(&mut self, label: &'static str) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        let i = self.labels.len() as u32;
        if 2 * i + 1 >= self.capacity {
            return None;
        }
        self.labels.push(label);
        Some(wgpu::RenderPassTimestampWrites {
            query_set: &self.query_set,
            beginning_of_pass_write_index: Some(2 * i),
            end_of_pass_write_index: Some(2 * i + 1),
        })
    }

    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        let n = self.labels.len() as u32 * 2;
        if n == 0 {
            return;
        }
        encoder.resolve_query_set(&self.query_set, 0..n, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, n as u64 * 8);
    }

    /// Milliseconds per pass of the last submitted frame; blocks until the GPU is done.
    pub fn read(&self, device: &wgpu::Device) -> Vec<(&'static str, f64)> {
        let n = self.labels.len() as u64 * 2;
        if n == 0 {
            return Vec::new();
        }
        let slice = self.readback.slice(0..n * 8);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        if device.poll(wgpu::PollType::wait_indefinitely()).is_err() {
            return Vec::new();
        }
        let out = match slice.get_mapped_range() {
            Ok(data) => {
                let ticks: &[u64] = bytemuck::cast_slice(&data);
                self.labels
                    .iter()
                    .enumerate()
                    .map(|(i, l)| {
                        let dt = ticks[2 * i + 1].saturating_sub(ticks[2 * i]);
                        (*l, dt as f64 * self.period_ns as f64 / 1e6)
                    })
                    .collect()
            }
            Err(_) => Vec::new(),
        };
        self.readback.unmap();
        out
    }
}
