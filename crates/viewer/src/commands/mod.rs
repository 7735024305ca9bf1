//! Headless subcommands.
pub mod bench;
pub mod bench_characters;
pub mod bench_cubes;
pub mod bench_lights;
pub mod bench_reload;
pub mod bench_shadows;
pub mod render;
