//! F12 screenshots: the scene as drawn this frame, without the UI, saved as a PNG.
//!
//! The swap-chain image is copied right after the scene is rendered into it and before the
//! overlay draws, so the file holds exactly the pixels on screen minus the panels. Surfaces
//! that cannot be copied from (no COPY_SRC usage) fall back to rendering the frame again into
//! the renderer's offscreen target. Encoding and writing run on a worker thread; the outcome
//! comes back to the status line.

use std::path::{Path, PathBuf};
use std::sync::mpsc;

use penumbra_engine::output;
use penumbra_render::{RenderScene, Renderer};

/// Screenshots being written, and their outcomes.
pub struct Screenshots {
    dir: PathBuf,
    /// Captures whose outcome has not been collected yet.
    in_flight: std::cell::Cell<usize>,
    done: mpsc::Receiver<Result<PathBuf, String>>,
    send: mpsc::Sender<Result<PathBuf, String>>,
}

impl Screenshots {
    pub fn new(dir: PathBuf) -> Screenshots {
        let (send, done) = mpsc::channel();
        Screenshots { dir, in_flight: std::cell::Cell::new(0), done, send }
    }

    /// Reads `texture` (the frame without UI; when `None`, re-renders into the renderer's
    /// offscreen output) and saves it on a worker thread.
    pub fn capture(
        &self,
        renderer: &mut Renderer,
        scene: &RenderScene,
        texture: Option<&wgpu::Texture>,
        size: (u32, u32),
    ) {
        let ctx = renderer.context().clone();
        let pixels = match texture {
            Some(t) => penumbra_render::gpu::readback::read_texture(&ctx.device, &ctx.queue, t, 4).map(|mut px| {
                if matches!(t.format(), wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb) {
                    px.chunks_exact_mut(4).for_each(|p| p.swap(0, 2));
                }
                px
            }),
            None => {
                renderer.render_headless(scene, size);
                renderer.read_headless()
            }
        };
        let (dir, send) = (self.dir.clone(), self.send.clone());
        self.in_flight.set(self.in_flight.get() + 1);
        std::thread::spawn(move || {
            let outcome = pixels.map_err(|e| format!("screenshot: {e}")).and_then(|px| save(&dir, size, px));
            let _ = send.send(outcome);
        });
    }

    /// Outcomes of finished saves.
    pub fn finished(&self) -> Vec<Result<PathBuf, String>> {
        let done: Vec<_> = self.done.try_iter().collect();
        self.in_flight.set(self.in_flight.get().saturating_sub(done.len()));
        done
    }

    /// Captures still being written (their outcome not yet collected by [`Self::finished`]).
    pub fn in_flight(&self) -> usize {
        self.in_flight.get()
    }
}

/// Writes `penumbra-NNNN.png` with the first free number in `dir`.
fn save(dir: &Path, size: (u32, u32), mut rgba: Vec<u8>) -> Result<PathBuf, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("screenshot folder {}: {e}", dir.display()))?;
    // The swap chain's alpha is whatever compositing left there; a screenshot is opaque.
    rgba.chunks_exact_mut(4).for_each(|p| p[3] = 255);
    for n in 1..10_000 {
        let path = dir.join(format!("penumbra-{n:04}.png"));
        if path.exists() {
            continue;
        }
        // Written whole under a temporary name, then given this one unless another screenshot
        // took it meanwhile (then the next number).
        match output::save_new_image(&path, &rgba, size, image::ExtendedColorType::Rgba8) {
            Ok(()) => return Ok(path),
            Err(_) if path.exists() => continue,
            Err(e) => return Err(format!("screenshot: {e}")),
        }
    }
    Err(format!("screenshot: {} already holds 9999 screenshots", dir.display()))
}
