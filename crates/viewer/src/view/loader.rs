//! Loading a scene file off the window's thread: the import (reading, parsing, decoding
//! images) runs on a worker thread and reports progress; the window keeps drawing the current
//! scene and polls for the outcome each frame. Only spawning the decoded scene and making its
//! renderer happen on the window's thread, when the import has finished.

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Instant;

use penumbra_engine::import::{ImportProgress, ProgressSnapshot, SceneFile};

use crate::cli::SceneArgs;
use crate::scene;

/// One import in flight.
pub struct Loader {
    /// What is being loaded (`None`: the embedded default scene).
    pub path: Option<PathBuf>,
    pub started: Instant,
    progress: ImportProgress,
    outcome: mpsc::Receiver<Result<SceneFile, String>>,
    /// The import's outcome, once it has arrived: the next frame shows "preparing" over the old
    /// scene, the one after stages it (the GPU work and shader compiles of its first frame
    /// happen then, under that message).
    pub ready: Option<Result<SceneFile, String>>,
}

impl Loader {
    pub fn start(path: Option<&Path>, args: &SceneArgs) -> Loader {
        let progress = ImportProgress::default();
        let mut options = scene::options(args);
        options.progress = Some(progress.clone());
        let (send, outcome) = mpsc::channel();
        let owned = path.map(Path::to_path_buf);
        let job = owned.clone();
        std::thread::Builder::new()
            .name("scene import".into())
            .spawn(move || {
                // The window may have closed meanwhile; then nobody wants the result.
                let _ = send.send(scene::load_with(job.as_deref(), &options).map_err(|e| e.to_string()));
            })
            .expect("spawning a thread");
        Loader { path: owned, started: Instant::now(), progress, outcome, ready: None }
    }

    /// Collects the finished import into [`Self::ready`]; whether it is there.
    pub fn poll(&mut self) -> bool {
        if self.ready.is_none() {
            self.ready = match self.outcome.try_recv() {
                Ok(r) => Some(r),
                Err(mpsc::TryRecvError::Empty) => None,
                Err(mpsc::TryRecvError::Disconnected) => {
                    Some(Err(format!("{}: the import stopped unexpectedly", self.name())))
                }
            };
        }
        self.ready.is_some()
    }

    pub fn progress(&self) -> ProgressSnapshot {
        self.progress.snapshot()
    }

    pub fn name(&self) -> String {
        self.path.as_ref().map_or_else(|| scene::DEFAULT_SCENE_NAME.to_owned(), |p| p.display().to_string())
    }
}
