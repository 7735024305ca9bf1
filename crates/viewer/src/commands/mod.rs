//! Headless subcommands.
pub mod bench;
pub mod bench_reload;
pub mod render;
