//! What the overlay and its panels share: the [`Action`]s they hand the viewer, the panel state
//! that persists across frames ([`UiState`]), what the viewer knows this frame ([`FrameInfo`]),
//! and the colour of error text.

use penumbra_engine::variants::SceneVariants;
use std::path::PathBuf;

use bevy_ecs::entity::Entity;
use egui::{Color32, RichText};
use penumbra_engine::import::ProgressSnapshot;
use penumbra_render::{RenderSettings, Renderer};

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
    pub open_dialog: bool,
    pub open_path: String,
    pub env_path: String,
    pub env_status: Option<Result<String, String>>,
    /// The last outcome worth telling: a failed load stays until dismissed.
    pub load_error: Option<String>,
    /// A passing message (screenshot saved, …) and when it was posted; shown for a few seconds.
    pub status: Option<(String, std::time::Instant)>,
    pub vsync: bool,
}

impl UiState {
    pub fn set_status(&mut self, message: impl Into<String>) {
        self.status = Some((message.into(), std::time::Instant::now()));
    }

    pub fn new(vsync: bool) -> UiState {
        UiState {
            show_stats: false,
            // Only the menu bar at first: the scene gets the whole window until a panel is asked for.
            show_tree: false,
            show_inspector: false,
            show_settings: false,
            show_environment: false,
            world_axes: false,
            local_axes: false,
            selected: None,
            open_dialog: false,
            open_path: String::new(),
            env_path: String::new(),
            env_status: None,
            load_error: None,
            status: None,
            vsync,
        }
    }
}

/// What the viewer knows this frame that the panels show.
pub struct FrameInfo<'a> {
    pub renderer: Option<&'a Renderer>,
    pub fps: f32,
    pub frame_ms: f32,
    /// A load in flight: its name, progress and seconds so far.
    pub loading: Option<(String, ProgressSnapshot, f32)>,
    pub recent: &'a [PathBuf],
    /// The file's cameras (glTF index, name) and the one looked through.
    pub cameras: Vec<(usize, String)>,
    pub through: Option<usize>,
    /// The file's material variants (KHR_materials_variants) and the one shown.
    pub variants: SceneVariants,
    pub scene_name: &'a str,
}

/// Red text for errors, used by every panel.
pub fn error_text(text: impl Into<String>) -> RichText {
    RichText::new(text).color(Color32::from_rgb(255, 110, 110))
}
