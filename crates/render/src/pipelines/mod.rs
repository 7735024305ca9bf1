//! Shaders and pipelines, knowing no feature: the shader library (embedded or on-disk WGSL,
//! composed and validated), the feature switches its variants may test, the folder watcher
//! behind hot reload, and the generic pipeline cache whose families the features define.
pub mod cache;
#[cfg(test)]
mod feature_switch_tests;
pub mod feature_switches;
pub mod parts;
pub mod shader_error;
pub mod shader_library;
pub mod shader_watcher;

pub use cache::{PipelineCache, PipelineFamily, ReloadReport};
pub use shader_library::{ShaderDefs, ShaderError, ShaderLibrary};
