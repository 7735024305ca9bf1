//! The cluster binner's pipeline family: the entry points of `cluster_bin.wgsl`, with the one
//! bind group layout they share (grid, lights, counts, ranges, indices, scan blocks, dispatch).

use crate::pipelines::parts::{self, storage, storage_rw, uniform};
use crate::pipelines::{Compiler, PipelineFamily, ShaderDefs};

/// The entry points of `cluster_bin.wgsl`, in the order they run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ClusterEntry {
    Count,
    ScanBlocks,
    ScanApply,
    Fill,
    SortShort,
    SortLong,
}

impl ClusterEntry {
    pub const ALL: [ClusterEntry; 6] = [
        ClusterEntry::Count,
        ClusterEntry::ScanBlocks,
        ClusterEntry::ScanApply,
        ClusterEntry::Fill,
        ClusterEntry::SortShort,
        ClusterEntry::SortLong,
    ];

    fn name(self) -> &'static str {
        match self {
            ClusterEntry::Count => "count_lights",
            ClusterEntry::ScanBlocks => "scan_blocks",
            ClusterEntry::ScanApply => "scan_apply",
            ClusterEntry::Fill => "fill_lists",
            ClusterEntry::SortShort => "sort_short",
            ClusterEntry::SortLong => "sort_long",
        }
    }
}

pub struct ClusterFamily {
    pub layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
}

impl ClusterFamily {
    pub fn new(device: &wgpu::Device) -> Self {
        let compute = wgpu::ShaderStages::COMPUTE;
        let layout = parts::bind_group_layout(
            device,
            "cluster binning",
            &[
                uniform(0, compute),
                storage(1, compute),
                storage_rw(2, compute),
                storage_rw(3, compute),
                storage_rw(4, compute),
                storage_rw(5, compute),
                storage_rw(6, compute),
            ],
        );
        let pipeline_layout = parts::pipeline_layout(device, "cluster binning", &[&layout]);
        Self { layout, pipeline_layout }
    }
}

impl PipelineFamily for ClusterFamily {
    type Key = ClusterEntry;
    type Pipeline = wgpu::ComputePipeline;
    const NAME: &'static str = "cluster binning";

    fn shader(&self, _: &ClusterEntry) -> (&'static str, ShaderDefs) {
        ("cluster_bin.wgsl", ShaderDefs::default())
    }

    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, entry: &ClusterEntry) -> wgpu::ComputePipeline {
        parts::compute_pipeline(device, &self.pipeline_layout, module, entry.name(), entry.name())
    }
}
