//! The bottom layer: the GPU context (adapter, device, capabilities), every texture format, the
//! growable buffers, readback, GPU timing and host-memory import. Knows no feature.
pub mod array_layers;
pub mod buffer;
pub mod context;
pub mod formats;
pub mod host_memory;
pub mod readback;
pub mod timing;
