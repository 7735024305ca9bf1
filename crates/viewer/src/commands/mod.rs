//! Headless subcommands.
pub mod bench;
pub mod render;
