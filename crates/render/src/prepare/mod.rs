//! Prepare: CPU to GPU uploads, one owner module per resource kind. Each owner keeps what it
//! uploaded and re-uploads only what extraction reports as changed.
pub mod buffer;
pub mod deform;
pub mod ies_profiles;
pub mod instances;
pub mod light_store;
pub mod line_quads;
pub mod materials;
pub mod mesh_pool;
pub mod textures;
