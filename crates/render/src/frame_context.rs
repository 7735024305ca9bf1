//! What every feature receives to record its passes: the device and queue, the frame's command
//! encoder, the pipeline cache (to compile what it draws and to bind it), the GPU timer (when
//! the frame is timed) and the frame's targets. The renderer makes one per frame after prepare
//! and hands it to each pass the frame plan runs, in order.

use crate::gpu::timing::GpuTimer;
use crate::pipelines::PipelineCache;
use crate::targets::FrameTargets;

pub struct FrameContext<'a> {
    pub device: &'a wgpu::Device,
    pub queue: &'a wgpu::Queue,
    pub encoder: &'a mut wgpu::CommandEncoder,
    pub pipelines: &'a mut PipelineCache,
    pub timer: Option<&'a mut GpuTimer>,
    pub targets: &'a FrameTargets,
}
