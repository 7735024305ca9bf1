//! The recent-files list: scenes opened successfully, newest first, kept in
//! `$XDG_CONFIG_HOME/penumbra/recent.txt` (or `~/.config/penumbra/recent.txt`), one path per
//! line. A missing or unreadable list is an empty one; failing to save it is logged, never fatal.

use std::path::{Path, PathBuf};

use penumbra_engine::output;

const KEEP: usize = 10;

pub struct RecentFiles {
    file: Option<PathBuf>,
    pub paths: Vec<PathBuf>,
}

impl RecentFiles {
    pub fn load() -> RecentFiles {
        let file = std::env::var_os("XDG_CONFIG_HOME")
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("HOME").map(|h| Path::new(&h).join(".config")))
            .map(|dir| dir.join("penumbra").join("recent.txt"));
        Self::load_from(file)
    }

    /// The list kept in `file` (`None`: kept nowhere).
    pub fn load_from(file: Option<PathBuf>) -> RecentFiles {
        let paths = file
            .as_ref()
            .and_then(|f| std::fs::read_to_string(f).ok())
            .map(|text| text.lines().filter(|l| !l.trim().is_empty()).map(PathBuf::from).take(KEEP).collect())
            .unwrap_or_default();
        RecentFiles { file, paths }
    }

    /// Puts `path` first (absolute, so the list works from any folder) and saves the list.
    pub fn add(&mut self, path: &Path) {
        let path = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
        self.paths.retain(|p| *p != path);
        self.paths.insert(0, path);
        self.paths.truncate(KEEP);
        let Some(file) = &self.file else { return };
        let text: String = self.paths.iter().map(|p| format!("{}\n", p.display())).collect();
        // Written whole or not at all: a full disk must not empty the list.
        let saved = file
            .parent()
            .map_or(Ok(()), std::fs::create_dir_all)
            .map_err(|e| e.to_string())
            .and_then(|_| output::write_file(file, |out| out.write_all(text.as_bytes())).map_err(|e| e.reason));
        if let Err(e) = saved {
            tracing::warn!("cannot save the recent-files list {}: {e}", file.display());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newest_first_without_repeats_at_most_ten_and_kept_across_runs() {
        let dir = std::env::temp_dir().join(format!("penumbra-recent-{}", std::process::id()));
        let file = dir.join("penumbra").join("recent.txt");
        let _ = std::fs::remove_dir_all(&dir);
        let mut recent = RecentFiles::load_from(Some(file.clone()));
        assert!(recent.paths.is_empty(), "a missing list is an empty one");
        for i in 0..12 {
            recent.add(Path::new(&format!("/scenes/{i}.glb")));
        }
        recent.add(Path::new("/scenes/5.glb"));
        let again = RecentFiles::load_from(Some(file));
        assert_eq!(again.paths.len(), 10);
        assert_eq!(again.paths[0], Path::new("/scenes/5.glb"));
        assert_eq!(again.paths[1], Path::new("/scenes/11.glb"));
        assert_eq!(again.paths.iter().filter(|p| p.ends_with("5.glb")).count(), 1);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
