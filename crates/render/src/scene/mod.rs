//! The render world's input: extraction (the only code that reads the ECS) and the plain data
//! it produces, [`world::RenderScene`].
pub mod entity_table;
pub mod extract;
pub mod world;
