//! Shaders and pipelines: the shader library (embedded or on-disk WGSL, composed and validated),
//! the feature switches its variants may test, the folder watcher behind hot reload, and the
//! pipeline cache.
pub mod feature_switches;
pub mod pipeline_cache;
pub mod shader_library;
pub mod shader_watcher;
