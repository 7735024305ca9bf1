//! What the overlay and its panels share: the [`Action`]s they hand the viewer, the panel state
//! that persists across frames ([`UiState`]), what the viewer knows this frame ([`FrameInfo`]),
//! and the colour of error text.

use penumbra_engine::variants::SceneVariants;
use std::path::PathBuf;

use bevy_ecs::entity::Entity;
use egui::{Color32, RichText};
use penumbra_engine::import::ProgressSnapshot;
use penumbra_render::{RenderSettings, Renderer};

/// How long a passing status message stays on screen.
pub const STATUS_SHOWN: std::time::Duration = std::time::Duration::from_secs(6);

/// What the user asked for that the viewer carries out after the frame.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    Open(PathBuf),
    Screenshot,
    Settings(RenderSettings),
    /// Look through the file's camera of this glTF index (`None`: the orbit camera).
    LookThrough(Option<usize>),
    /// Show the file's material variant of this name (`None`: each primitive's own material).
    Variant(Option<String>),
    FrameScene,
    Focus(Entity),
    Vsync(bool),
    Quit,
}

/// Panel state that persists across frames.
pub struct UiState {
    pub show_stats: bool,
    pub show_tree: bool,
    pub show_inspector: bool,
    pub show_settings: bool,
    pub show_environment: bool,
    /// F2: the world's axes at the origin; F3: every object's local axes.
    pub world_axes: bool,
    pub local_axes: bool,
    pub selected: Option<Entity>,
    /// The file browser (Ctrl+O), while open.
    pub file_dialog: Option<egui_file::FileDialog>,
    /// The location field (Ctrl+L): a path typed in full.
    pub open_dialog: bool,
    pub open_path: String,
    pub env_path: String,
    pub env_status: Option<Result<String, String>>,
    /// The last outcome worth telling: a failed load stays until dismissed.
    pub load_error: Option<String>,
    /// A passing message (screenshot saved, …) and when it was posted; shown for a few seconds.
    pub status: Option<(String, std::time::Instant)>,
    pub vsync: bool,
    /// Where the scene is shown (points): the window less the menu bar and the docked panels,
    /// as laid out last.
    pub viewport: Option<egui::Rect>,
}

impl UiState {
    /// Opens the file browser on `folder` (the last opened file's, else the working folder),
    /// listing folders and the files Penumbra opens.
    pub fn browse(&mut self, folder: Option<PathBuf>) {
        let filter: egui_file::Filter<PathBuf> =
            Box::new(|p: &std::path::Path| penumbra_engine::import::SceneFile::is_scene_path(p));
        let mut dialog = egui_file::FileDialog::open_file()
            .title("Open a scene (.gltf, .glb, .obj)")
            .show_files_filter(filter)
            .anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0])
            .default_size([480.0, 320.0])
            .show_rename(false)
            .show_new_folder(false);
        if let Some(folder) = folder {
            dialog = dialog.initial_path(folder);
        }
        dialog.open();
        self.file_dialog = Some(dialog);
    }

    /// Whether a dialog (the file browser, the location field, a load error) is open.
    pub fn dialog_open(&self) -> bool {
        self.file_dialog.is_some() || self.open_dialog || self.load_error.is_some()
    }

    /// Closes the dialog in front (the open dialog, then a load error); whether one was open.
    pub fn close_dialog(&mut self) -> bool {
        if self.file_dialog.is_some() {
            self.file_dialog = None;
        } else if self.open_dialog {
            self.open_dialog = false;
        } else if self.load_error.is_some() {
            self.load_error = None;
        } else {
            return false;
        }
        true
    }

    pub fn set_status(&mut self, message: impl Into<String>) {
        self.status = Some((message.into(), std::time::Instant::now()));
    }

    /// Only the menu bar at first, unless `panels` asks for some: the scene gets the window.
    pub fn new(vsync: bool, panels: &[crate::cli::PanelArg]) -> UiState {
        use crate::cli::PanelArg;
        UiState {
            show_stats: panels.contains(&PanelArg::Stats),
            show_tree: panels.contains(&PanelArg::Tree),
            show_inspector: panels.contains(&PanelArg::Inspector),
            show_settings: panels.contains(&PanelArg::Settings),
            show_environment: panels.contains(&PanelArg::Environment),
            world_axes: false,
            local_axes: false,
            selected: None,
            file_dialog: None,
            open_dialog: false,
            open_path: String::new(),
            env_path: String::new(),
            env_status: None,
            load_error: None,
            status: None,
            vsync,
            viewport: None,
        }
    }
}

/// What the viewer knows this frame that the panels show.
pub struct FrameInfo<'a> {
    pub renderer: Option<&'a Renderer>,
    pub fps: f32,
    pub frame_ms: f32,
    /// A load in flight: its name, progress, seconds so far, and whether the import is done
    /// and the scene is being prepared for its first frame.
    pub loading: Option<(String, ProgressSnapshot, f32, bool)>,
    pub recent: &'a [PathBuf],
    /// The file's cameras (glTF index, name) and the one looked through.
    pub cameras: Vec<(usize, String)>,
    pub through: Option<usize>,
    /// The file's material variants (KHR_materials_variants) and the one shown.
    pub variants: SceneVariants,
    /// The active camera's EV100 and how the staged one was chosen.
    pub exposure: Option<String>,
    pub scene_name: &'a str,
    /// The scene's image, for the viewport (`None`: nothing to show yet).
    pub viewport: Option<egui::TextureId>,
}

/// Red text for errors, used by every panel.
pub fn error_text(text: impl Into<String>) -> RichText {
    RichText::new(text).color(Color32::from_rgb(255, 110, 110))
}
