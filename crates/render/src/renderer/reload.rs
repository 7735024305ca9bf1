//! Shader hot reload as the renderer sees it: a reload asked for by name or found by the folder
//! watcher goes to the pipeline cache; a success clears the shader error and tells the features
//! whose results came from the old code (shadow maps, environment maps) to make them again.

use std::time::Instant;

use super::Renderer;
use crate::features::environment::EnvStepFamily;
use crate::pipelines::shader_watcher::ShaderWatcher;
use crate::pipelines::{ReloadReport, ShaderError};

impl Renderer {
    /// Re-reads the shader folder because `files` changed, rebuilding the pipelines that use them.
    pub fn reload_shaders(&mut self, files: &[String]) -> Result<ReloadReport, ShaderError> {
        let start = Instant::now();
        let result = self.pipelines.reload(&self.ctx.device, files);
        self.report_reload(&result, start);
        result
    }

    /// Logs a reload's outcome and shows its error, or applies what it changed.
    fn report_reload(&mut self, result: &Result<ReloadReport, ShaderError>, start: Instant) {
        match result {
            Ok(report) => self.reloaded(report, start),
            Err(e) => {
                tracing::error!("{e} (keeping the last good shaders)");
                self.shader_error = Some(e.clone());
            }
        }
    }

    /// What a successful reload changes beyond the pipelines.
    fn reloaded(&mut self, report: &ReloadReport, start: Instant) {
        if report.rebuilt > 0 {
            // A changed caster shader may draw other depths: every shadow map is redrawn.
            self.shadows.invalidate();
        }
        if report.rebuilt_of::<EnvStepFamily>() > 0 {
            self.environment.remake();
        }
        if report.files.is_empty() {
            tracing::debug!("shaders unchanged (a save of the same text)");
        } else {
            let families: Vec<String> = report.families.iter().map(|(family, n)| format!("{family} {n}")).collect();
            tracing::info!(
                "shaders reloaded ({}): {} pipeline{} rebuilt{} in {:.1} ms",
                report.files.join(", "),
                report.rebuilt,
                if report.rebuilt == 1 { "" } else { "s" },
                if families.is_empty() { String::new() } else { format!(" ({})", families.join(", ")) },
                start.elapsed().as_secs_f64() * 1e3
            );
        }
        // The library in use now holds the folder's sources, every changed one of them checked.
        self.shader_error = None;
    }

    /// Applies the watcher's changes, if any; returns the outcome of a reload that changed
    /// something or reported an error. A file is tried as soon as its event arrives and kept if
    /// it compiles; one that does not is left alone until its events settle (a save may still be
    /// under way), then reloaded again and its error reported (see `shader_watcher.rs`).
    pub fn poll_shader_changes(&mut self) -> Option<Result<ReloadReport, ShaderError>> {
        let changes = self.shader_watcher.as_mut()?.poll();
        if !changes.settled.is_empty() {
            let start = Instant::now();
            let result = self.pipelines.reload(&self.ctx.device, &changes.settled);
            // A reload reads the whole folder: the error may be in another file whose save is
            // still under way. That one is reported when it settles, as it would be alone.
            if let Err(e) = &result
                && self.shader_watcher.as_ref().is_some_and(|w| w.is_pending(&e.file))
            {
                tracing::debug!("{e} (not reported yet: the save of {} may still be under way)", e.file);
                return None;
            }
            self.report_reload(&result, start);
            return Some(result);
        }
        if changes.fresh.is_empty() {
            return None;
        }
        let start = Instant::now();
        match self.pipelines.reload(&self.ctx.device, &changes.fresh) {
            Ok(report) => {
                if let Some(w) = self.shader_watcher.as_mut() {
                    w.accept(&changes.fresh);
                }
                self.reloaded(&report, start);
                Some(Ok(report))
            }
            Err(e) => {
                tracing::debug!("{e} (not reported yet: the save may still be under way)");
                None
            }
        }
    }

    /// Whether file events are waiting to settle into a reload.
    pub fn shader_changes_pending(&self) -> bool {
        self.shader_watcher.as_ref().is_some_and(ShaderWatcher::busy)
    }
}
