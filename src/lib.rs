//! Penumbra: a real-time glTF renderer built like a small game engine.
//!
//! A scene is ordinary [bevy_ecs](https://docs.rs/bevy_ecs) data in an [`engine::App`]:
//! entities with `Transform`, `Mesh3d` + `MeshMaterial3d`, lights and a `Camera`, changed by
//! plain systems. `use penumbra::prelude::*;` brings in everything a scene script needs:
//!
//! ```no_run
//! use penumbra::prelude::*;
//!
//! fn main() {
//!     let mut app = App::new();
//!     app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
//!     let cube = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
//!     let paint = app.world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial::default());
//!     app.world.spawn((Mesh3d(cube), MeshMaterial3d(paint), Transform::IDENTITY));
//!     app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y)));
//!     app.add_systems(Update, |time: Res<Time>, mut q: Query<&mut Transform, With<Mesh3d>>| {
//!         for mut t in &mut q {
//!             t.rotation = Quat::from_rotation_y(time.elapsed_secs());
//!         }
//!     });
//!     // A window, or with `--headless out.png` a screenshot: the same program.
//!     penumbra::run(&mut app);
//! }
//! ```
//!
//! The pieces:
//! - [`engine`]: the main world: `App` and its schedules (`Startup`, `Update`, `PostUpdate`),
//!   `Time` (wall clock or fixed step), components, `Assets<T>`, glTF and OBJ import
//!   ([`engine::import::load_scene`] spawns a file under one root entity that moves and
//!   despawns as a whole), built-in meshes ([`engine::mesh::Mesh`]'s `cuboid`, `uv_sphere`, …)
//!   and animation ([`engine::animation::AnimationPlayer`]).
//! - [`render`]: extraction into the render world and the wgpu renderer; [`RenderPlugin`]
//!   wires it into an app; [`HeadlessRunner`] renders fixed-step frames offscreen (screenshot
//!   tests: see `examples/headless_screenshot.rs`).
//! - [`window`]: [`WindowRunner`] runs the same app in a window.
//!
//! [`RenderPlugin`]: render::RenderPlugin
//! [`HeadlessRunner`]: render::headless::HeadlessRunner
//! [`WindowRunner`]: window::WindowRunner

pub use penumbra_engine as engine;
pub use penumbra_render as render;
pub use penumbra_viewer::{soak, window};

use std::path::PathBuf;

use engine::App;
use render::headless::HeadlessRunner;
use window::WindowRunner;

pub mod prelude {
    pub use penumbra_engine::prelude::*;
    pub use penumbra_render::headless::HeadlessRunner;
    pub use penumbra_render::{RenderPlugin, RenderSettings, Renderer};
    pub use penumbra_viewer::window::WindowRunner;
}

/// How [`run`] runs an app, from the command line: `--headless OUT.png [--frames N] [--size
/// WxH]` renders N fixed-step frames (default 1) at WxH (default 640x360) and saves the last;
/// anything else opens a window.
#[derive(Debug, Clone, PartialEq)]
pub enum RunMode {
    Window,
    Headless { out: PathBuf, frames: u32, size: (u32, u32) },
}

impl RunMode {
    /// Parses the flags above out of `args` (the program name excluded); unknown ones are left to
    /// the program. A malformed value is an error naming the flag.
    pub fn from_args(args: impl IntoIterator<Item = String>) -> Result<RunMode, String> {
        let args: Vec<String> = args.into_iter().collect();
        let value = |flag: &str| args.iter().position(|a| a == flag).map(|i| args.get(i + 1).cloned());
        let Some(out) = value("--headless") else { return Ok(RunMode::Window) };
        let out = out.ok_or("--headless needs an output file")?;
        let frames = match value("--frames") {
            None => 1,
            Some(v) => v.and_then(|v| v.parse::<u32>().ok()).filter(|&n| n > 0).ok_or("--frames needs a count ≥ 1")?,
        };
        let size = match value("--size") {
            None => (640, 360),
            Some(v) => v
                .and_then(|v| {
                    let (w, h) = v.split_once('x')?;
                    Some((w.parse().ok()?, h.parse().ok()?))
                })
                .ok_or("--size needs WIDTHxHEIGHT")?,
        };
        Ok(RunMode::Headless { out: out.into(), frames, size })
    }
}

/// The program's own arguments: the command line without the program name and without the
/// [`RunMode`] flags and their values (`--headless OUT`, `--frames N`, `--size WxH`), so that an
/// example's `MODEL.glb` is never confused with the screenshot's path.
pub fn program_args() -> Vec<String> {
    strip_run_flags(std::env::args().skip(1))
}

fn strip_run_flags(args: impl IntoIterator<Item = String>) -> Vec<String> {
    let mut out = Vec::new();
    let mut args = args.into_iter();
    while let Some(a) = args.next() {
        if matches!(a.as_str(), "--headless" | "--frames" | "--size") {
            args.next();
        } else {
            out.push(a);
        }
    }
    out
}

/// Runs `app` in a window, or headless when the command line says `--headless OUT.png` (see
/// [`RunMode`]). Exits the process with a message on a bad flag or a failed run.
pub fn run(app: &mut App) {
    match RunMode::from_args(std::env::args().skip(1)) {
        Ok(RunMode::Window) => {
            app.add_plugins(WindowRunner::default());
        }
        Ok(RunMode::Headless { out, frames, size }) => {
            app.add_plugins(HeadlessRunner::screenshot(out, size, frames));
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    }
    app.run();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn program_args_leave_out_the_run_flags_and_their_values() {
        let args = ["--headless", "/tmp/x.png", "model.glb", "--frames", "3", "--size", "64x32", "--other"];
        assert_eq!(strip_run_flags(args.map(String::from)), ["model.glb", "--other"]);
    }

    fn mode(args: &[&str]) -> Result<RunMode, String> {
        RunMode::from_args(args.iter().map(|s| s.to_string()))
    }

    #[test]
    fn run_mode_flags() {
        assert_eq!(mode(&[]), Ok(RunMode::Window));
        assert_eq!(
            mode(&["--headless", "a.png", "--frames", "3", "--size", "64x32"]),
            Ok(RunMode::Headless { out: "a.png".into(), frames: 3, size: (64, 32) })
        );
        assert!(mode(&["--headless"]).is_err());
        assert!(mode(&["--headless", "a.png", "--frames", "0"]).is_err());
        assert!(mode(&["--headless", "a.png", "--size", "64"]).is_err());
    }
}
