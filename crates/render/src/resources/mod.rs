//! Shared owners every feature reads: one module per resource kind (mesh pool, textures,
//! materials, instances, light store) and the draw list that batches the scene's draws. Each
//! owner keeps what it uploaded and re-uploads only what extraction reports as changed.
pub mod draw_list;
pub mod draws;
pub mod ies_profiles;
pub mod instances;
pub mod light_store;
pub mod line_quads;
pub mod materials;
pub mod mesh_pool;
pub mod mipmap;
pub mod textures;
