//! The viewer crate's library part: [`window::WindowRunner`], which runs a scripted `App` in a
//! window (the `penumbra` binary's own viewer lives in its `view` module).

pub mod window;
