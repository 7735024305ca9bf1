//! Shaders and pipelines: the shader library (embedded WGSL, validated) and the pipeline cache.
pub mod pipeline_cache;
pub mod shader_library;
