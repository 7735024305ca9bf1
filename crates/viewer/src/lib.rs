//! The viewer crate's library part: [`window::WindowRunner`], which runs a scripted `App` in a
//! window, and [`surface::WindowSurface`], the window-and-surface plumbing it shares with the
//! `penumbra` binary's own viewer (its `view` module).

pub mod surface;
pub mod window;
