//! Shaders and pipelines, knowing no feature: the shader library (embedded or on-disk WGSL,
//! composed and validated), the feature switches its variants may test, the folder watcher
//! behind hot reload, the generic pipeline cache whose families the features define, and the
//! store that keeps the driver's compiled pipelines in a file between runs.
pub mod cache;
#[cfg(test)]
mod feature_switch_tests;
pub mod feature_switches;
pub mod parts;
pub mod shader_error;
pub mod shader_library;
pub mod shader_watcher;
pub mod store;

pub use cache::{Compiler, PipelineCache, PipelineFamily, ReloadReport};
pub use shader_library::{ShaderDefs, ShaderError, ShaderLibrary};
pub use store::{PipelineCacheDir, PipelineStore};
