//! Shaders and pipelines: the shader library (embedded or on-disk WGSL, composed and validated),
//! the folder watcher behind hot reload, and the pipeline cache.
pub mod pipeline_cache;
pub mod shader_library;
pub mod shader_watcher;
