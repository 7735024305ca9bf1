//! Watches a shader folder and reports which files changed: at once, to try, and again once
//! their burst of events settles, to report.
//!
//! Editors save in several steps (truncate then write, write a temporary file and rename it over
//! the original, delete and recreate), each a file-system event, so the first event may find a
//! half-written file. Waiting for the burst to settle before every reload would add that wait to
//! every edit, so a changed file is offered twice: as *fresh* on the first poll after its event
//! (the renderer tries it and keeps the result only if it compiles, saying nothing otherwise),
//! and as *settled* once no event has touched it for [`DEBOUNCE`] (the renderer reloads it and
//! reports what fails). A file accepted while fresh is not offered again until its next event.
//! Events are keyed by file name, so a rename onto `forward.wgsl` counts as a change of
//! `forward.wgsl`. A folder deleted or moved away takes the operating system's watch with it
//! (inotify's watch follows the folder's inode), so the watcher watches the path again once a
//! folder is back there and offers every shader in it as changed.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

use notify::{RecursiveMode, Watcher};

use super::shader_library::shader_file_name;

/// Quiet time before a changed file that did not compile at once is reloaded and its error
/// reported: longer than the gap between an editor's write steps (a few milliseconds). Should a
/// slow save outlast it, the half-written file is reported as an error and its next event
/// reloads it whole.
pub const DEBOUNCE: Duration = Duration::from_millis(15);

/// What one poll found.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct ShaderChanges {
    /// Files whose events have settled (sorted): reload them and report errors.
    pub settled: Vec<String>,
    /// Files touched since the last poll that have not settled (sorted): try them quietly.
    pub fresh: Vec<String>,
}

struct Pending {
    last_event: Instant,
    /// Offered as fresh since its last event.
    tried: bool,
}

pub struct ShaderWatcher {
    watcher: notify::RecommendedWatcher,
    // A Mutex only to make the watcher Sync (the renderer is an ECS resource); one thread polls.
    // Each event with the time it arrived, so the quiet time counts from the write itself and
    // not from whenever the frame loop next polled.
    events: Mutex<Receiver<(Instant, notify::Result<notify::Event>)>>,
    pending: HashMap<String, Pending>,
    dir: PathBuf,
    /// `dir` made absolute, as the watcher reports paths (a relative `--shader-dir` too).
    absolute_dir: PathBuf,
    quiet_time: Duration,
    /// The folder itself was deleted or moved: watch its path again once a folder is there.
    rearm: bool,
}

impl ShaderWatcher {
    pub fn new(dir: &Path) -> notify::Result<Self> {
        Self::with_quiet_time(dir, DEBOUNCE)
    }

    /// A watcher that settles files after `quiet_time` instead of [`DEBOUNCE`] (tests).
    fn with_quiet_time(dir: &Path, quiet_time: Duration) -> notify::Result<Self> {
        let (tx, events) = channel();
        let mut watcher = notify::recommended_watcher(move |e| {
            let _ = tx.send((Instant::now(), e));
        })?;
        watcher.watch(dir, RecursiveMode::NonRecursive)?;
        Ok(Self {
            watcher,
            events: Mutex::new(events),
            pending: HashMap::new(),
            dir: dir.to_path_buf(),
            absolute_dir: std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf()),
            quiet_time,
            rearm: false,
        })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Files changed since the last call; settled files are forgotten once returned.
    pub fn poll(&mut self) -> ShaderChanges {
        let now = Instant::now();
        let events = self.events.get_mut().unwrap_or_else(|poisoned| poisoned.into_inner());
        while let Ok((arrived, event)) = events.try_recv() {
            let Ok(event) = event else { continue };
            if matches!(event.kind, notify::EventKind::Access(_)) {
                continue;
            }
            let moved_or_gone = matches!(
                event.kind,
                notify::EventKind::Remove(_) | notify::EventKind::Modify(notify::event::ModifyKind::Name(_))
            );
            for path in event.paths {
                if moved_or_gone && (path == self.absolute_dir || path == self.dir) {
                    // A moved folder keeps the watch (and its files' events come under the old
                    // path): end it now, not when a folder is back.
                    let _ = self.watcher.unwatch(&self.dir);
                    self.rearm = true;
                } else if !self.rearm
                    && let Some(name) = shader_file_name(&path)
                {
                    // (While the folder is gone, a file event is the moved-away folder's; once a
                    // folder is back, all its shaders are offered anyway.)
                    let p =
                        self.pending.entry(name.to_owned()).or_insert(Pending { last_event: arrived, tried: false });
                    p.last_event = p.last_event.max(arrived);
                    p.tried = false;
                }
            }
        }
        if self.rearm && self.dir.is_dir() {
            self.watch_again(now);
        }
        let mut changes = ShaderChanges::default();
        for (file, p) in &mut self.pending {
            if now.duration_since(p.last_event) >= self.quiet_time {
                changes.settled.push(file.clone());
            } else if !p.tried {
                p.tried = true;
                changes.fresh.push(file.clone());
            }
        }
        changes.settled.sort();
        changes.fresh.sort();
        for f in &changes.settled {
            self.pending.remove(f);
        }
        changes
    }

    /// Watches the folder's path again (a folder is back there) and offers every shader in it
    /// as changed: its files may differ from the ones in use, and their events came before the
    /// watch did. While the watch cannot be made, it is tried again at the next poll.
    fn watch_again(&mut self, now: Instant) {
        let _ = self.watcher.unwatch(&self.dir);
        if self.watcher.watch(&self.dir, RecursiveMode::NonRecursive).is_err() {
            return;
        }
        self.rearm = false;
        for entry in std::fs::read_dir(&self.dir).into_iter().flatten().flatten() {
            if let Some(name) = shader_file_name(&entry.path()) {
                self.pending.insert(name.to_owned(), Pending { last_event: now, tried: false });
            }
        }
    }

    /// `files` compiled while fresh: they need no settled reload unless touched again.
    pub fn accept(&mut self, files: &[String]) {
        for f in files {
            if self.pending.get(f).is_some_and(|p| p.tried) {
                self.pending.remove(f);
            }
        }
    }

    /// Whether `file` has had an event that has not settled yet (a save still under way).
    pub fn is_pending(&self, file: &str) -> bool {
        self.pending.contains_key(file)
    }

    /// Whether changed files wait to settle.
    pub fn busy(&self) -> bool {
        !self.pending.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Polls until a poll reports something (the event reaches the watcher's thread first).
    fn next_changes(w: &mut ShaderWatcher) -> ShaderChanges {
        let start = Instant::now();
        loop {
            let c = w.poll();
            if c != ShaderChanges::default() {
                return c;
            }
            assert!(start.elapsed() < Duration::from_secs(5), "no event");
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    fn changes(settled: &[&str], fresh: &[&str]) -> ShaderChanges {
        let own = |l: &[&str]| l.iter().map(|s| s.to_string()).collect();
        ShaderChanges { settled: own(settled), fresh: own(fresh) }
    }

    #[test]
    fn a_change_is_offered_at_once_then_again_when_it_settles_unless_accepted() {
        let dir = std::env::temp_dir().join(format!("penumbra-watcher-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // A quiet time long enough that this thread's own delays cannot settle a file early.
        let quiet = Duration::from_millis(400);
        let mut w = ShaderWatcher::with_quiet_time(&dir, quiet).unwrap();

        std::fs::write(dir.join("a.wgsl"), "fn a() {}").unwrap();
        std::fs::write(dir.join("notes.txt"), "not a shader").unwrap();
        std::fs::write(dir.join(".#a.wgsl"), "an editor's lock").unwrap();
        // One write is several events (create, modify); let all of them reach the channel.
        std::thread::sleep(Duration::from_millis(50));
        assert_eq!(next_changes(&mut w), changes(&[], &["a.wgsl"]));
        assert_eq!(w.poll(), ShaderChanges::default(), "offered once while fresh");
        assert!(w.busy() && w.is_pending("a.wgsl") && !w.is_pending("b.wgsl"));
        std::thread::sleep(quiet);
        assert_eq!(w.poll(), changes(&["a.wgsl"], &[]), "not accepted: offered again, settled");
        assert!(!w.busy() && !w.is_pending("a.wgsl"));

        std::fs::write(dir.join("b.wgsl"), "fn b() {}").unwrap();
        std::thread::sleep(Duration::from_millis(50));
        assert_eq!(next_changes(&mut w), changes(&[], &["b.wgsl"]));
        w.accept(&["b.wgsl".to_owned()]);
        assert!(!w.busy());
        std::thread::sleep(quiet);
        assert_eq!(w.poll(), ShaderChanges::default(), "accepted while fresh: done");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Deleting or moving the folder ends the operating system's watch of its path; a folder made
    /// again there is watched again, its shaders offered as changed, and later edits seen. The
    /// folder is named by a relative path, as `--shader-dir shaders` gives it (the watcher
    /// reports absolute paths).
    #[test]
    fn a_folder_deleted_or_moved_and_made_again_is_watched_again() {
        let absolute = std::env::temp_dir().join(format!("penumbra-watcher-gone-{}", std::process::id()));
        let cwd = std::env::current_dir().unwrap();
        let up = cwd.components().count() - 1;
        let dir: PathBuf =
            std::iter::repeat_n(Path::new(".."), up).collect::<PathBuf>().join(absolute.strip_prefix("/").unwrap());
        assert!(dir.is_relative());
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("a.wgsl"), "fn a() {}").unwrap();
        // Long enough that this thread's own delays cannot settle a file early.
        let mut w = ShaderWatcher::with_quiet_time(&dir, Duration::from_millis(400)).unwrap();
        // Polls until every change has settled and been handed out.
        let settle = |w: &mut ShaderWatcher| {
            let start = Instant::now();
            while w.poll() != ShaderChanges::default() || w.busy() {
                assert!(start.elapsed() < Duration::from_secs(5), "files did not settle");
                std::thread::sleep(Duration::from_millis(5));
            }
        };
        let until_rearmed = |w: &mut ShaderWatcher, what: &str| {
            let start = Instant::now();
            while !w.rearm {
                w.poll();
                assert!(start.elapsed() < Duration::from_secs(5), "the folder's {what} was not seen");
                std::thread::sleep(Duration::from_millis(1));
            }
        };

        std::fs::remove_dir_all(&dir).unwrap();
        until_rearmed(&mut w, "removal");
        settle(&mut w);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("a.wgsl"), "fn a() { }").unwrap();
        std::fs::write(dir.join("b.wgsl"), "fn b() {}").unwrap();
        assert_eq!(next_changes(&mut w), changes(&[], &["a.wgsl", "b.wgsl"]), "the folder's shaders, offered again");
        settle(&mut w);
        std::fs::write(dir.join("b.wgsl"), "fn b() { }").unwrap();
        assert_eq!(next_changes(&mut w), changes(&[], &["b.wgsl"]), "edits after the new watch are seen");
        settle(&mut w);

        // Moved away and replaced (`mv shaders old && cp -r new shaders`): the watch moved with
        // the old folder and ends; the path is watched again.
        let moved = absolute.with_extension("moved");
        let _ = std::fs::remove_dir_all(&moved);
        std::fs::rename(&dir, &moved).unwrap();
        until_rearmed(&mut w, "move");
        std::fs::write(moved.join("a.wgsl"), "fn a() {  }").unwrap();
        std::thread::sleep(Duration::from_millis(50));
        assert_eq!(w.poll(), ShaderChanges::default(), "the moved-away folder is not watched");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("c.wgsl"), "fn c() {}").unwrap();
        assert_eq!(next_changes(&mut w), changes(&[], &["c.wgsl"]), "the new folder's shaders");
        settle(&mut w);
        std::fs::write(dir.join("c.wgsl"), "fn c() { }").unwrap();
        assert_eq!(next_changes(&mut w), changes(&[], &["c.wgsl"]), "and its edits");
        let _ = std::fs::remove_dir_all(&dir);
        let _ = std::fs::remove_dir_all(&moved);
    }
}
