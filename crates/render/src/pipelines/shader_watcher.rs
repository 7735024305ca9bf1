//! Watches a shader folder and reports which files changed, once their burst of events settles.
//!
//! Editors save in several steps (truncate then write, write a temporary file and rename it over
//! the original, delete and recreate), each a file-system event; reacting to the first would read
//! a half-written file. A file is reported once no event has touched it for [`DEBOUNCE`]. Events
//! are keyed by file name, so a rename onto `forward.wgsl` counts as a change of `forward.wgsl`.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

use notify::{RecursiveMode, Watcher};

/// Quiet time before a changed file is reloaded: longer than the gap between an editor's write
/// steps (a few milliseconds), short enough to leave most of the 100 ms edit-to-frame budget to
/// compilation. Should a slow save outlast it, the half-written file is reported as an error and
/// its next event reloads it whole.
pub const DEBOUNCE: Duration = Duration::from_millis(15);

pub struct ShaderWatcher {
    _watcher: notify::RecommendedWatcher,
    // A Mutex only to make the watcher Sync (the renderer is an ECS resource); one thread polls.
    // Each event with the time it arrived, so the quiet time counts from the write itself and
    // not from whenever the frame loop next polled.
    events: Mutex<Receiver<(Instant, notify::Result<notify::Event>)>>,
    pending: HashMap<String, Instant>,
    dir: PathBuf,
}

impl ShaderWatcher {
    pub fn new(dir: &Path) -> notify::Result<Self> {
        let (tx, events) = channel();
        let mut watcher = notify::recommended_watcher(move |e| {
            let _ = tx.send((Instant::now(), e));
        })?;
        watcher.watch(dir, RecursiveMode::NonRecursive)?;
        Ok(Self { _watcher: watcher, events: Mutex::new(events), pending: HashMap::new(), dir: dir.to_path_buf() })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Files whose events have settled since the last call (sorted, without repeats).
    pub fn poll(&mut self) -> Vec<String> {
        let now = Instant::now();
        let events = self.events.get_mut().unwrap_or_else(|poisoned| poisoned.into_inner());
        while let Ok((arrived, event)) = events.try_recv() {
            let Ok(event) = event else { continue };
            if matches!(event.kind, notify::EventKind::Access(_)) {
                continue;
            }
            for path in event.paths {
                if path.extension().and_then(|e| e.to_str()) == Some("wgsl")
                    && let Some(name) = path.file_name().and_then(|n| n.to_str())
                {
                    let last = self.pending.entry(name.to_owned()).or_insert(arrived);
                    *last = (*last).max(arrived);
                }
            }
        }
        let mut ready: Vec<String> =
            self.pending.iter().filter(|(_, t)| now.duration_since(**t) >= DEBOUNCE).map(|(f, _)| f.clone()).collect();
        ready.sort();
        for f in &ready {
            self.pending.remove(f);
        }
        ready
    }

    /// Whether events are waiting to settle.
    pub fn busy(&self) -> bool {
        !self.pending.is_empty()
    }
}
