//! The viewer crate's library part: [`window::WindowRunner`], which runs a scripted `App` in a
//! window, and [`surface::WindowSurface`], the window-and-surface plumbing it shares with the
//! `penumbra` binary's own viewer (its `view` module); and [`soak::Soak`], the long-run churn that `penumbra bench soak` and
//! the soak test share.

pub mod soak;
pub mod surface;
pub mod window;
