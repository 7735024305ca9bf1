//! The environment panel: source (none, auto, sky, studio, an .hdr/.exr file), intensity,
//! rotation and background. Edits a copy of the `Environment` resource, written back on change.

use std::path::Path;
use std::sync::Arc;

use bevy_ecs::world::World;
use penumbra_engine::environment::{Background, Environment, EnvironmentImage, EnvironmentSource, Sky};

use crate::view::ui_state::error_text;

/// Loads `path` as the environment's image; on failure the environment stays as it was and
/// the error (naming the file) is returned.
pub fn load_environment(env: &mut Option<Environment>, path: &Path) -> Result<String, String> {
    let image = EnvironmentImage::load(path).map_err(|e| e.to_string())?;
    let loaded = format!("{} ({}×{})", path.display(), image.width, image.height);
    let current = env.get_or_insert_with(Environment::default);
    current.source = EnvironmentSource::Image(Arc::new(image));
    Ok(loaded)
}

pub fn panel(ui: &mut egui::Ui, world: &mut World, path: &mut String, status: &mut Option<Result<String, String>>) {
    let before = world.get_resource::<Environment>().cloned();
    let mut env = before.clone();
    egui::CollapsingHeader::new("Environment").default_open(true).show(ui, |ui| edit(ui, &mut env, path, status));
    if env != before {
        match env {
            Some(e) => world.insert_resource(e),
            None => {
                world.remove_resource::<Environment>();
            }
        }
    }
}

fn edit(
    ui: &mut egui::Ui,
    env: &mut Option<Environment>,
    path: &mut String,
    status: &mut Option<Result<String, String>>,
) {
    let kind = match env.as_ref().map(|e| &e.source) {
        None => "none",
        Some(EnvironmentSource::Auto) => "auto",
        Some(EnvironmentSource::Sky(_)) => "sky",
        Some(EnvironmentSource::Studio) => "studio",
        Some(EnvironmentSource::Image(_)) => "image",
    };
    ui.horizontal(|ui| {
        for (name, source) in [
            ("none", None),
            ("auto", Some(EnvironmentSource::Auto)),
            ("sky", Some(EnvironmentSource::Sky(Sky::default()))),
            ("studio", Some(EnvironmentSource::Studio)),
        ] {
            if ui.selectable_label(kind == name, name).clicked() && kind != name {
                match source {
                    None => *env = None,
                    Some(s) => env.get_or_insert_with(Environment::default).source = s,
                }
            }
        }
        if kind == "image" {
            let _ = ui.selectable_label(true, "image");
        }
    });
    ui.horizontal(|ui| {
        ui.add(egui::TextEdit::singleline(path).hint_text(".hdr or .exr file (or drop one on the window)"));
        if ui.button("Load").clicked() {
            *status = Some(load_environment(env, Path::new(path.trim())));
        }
    });
    match status {
        Some(Ok(m)) => {
            ui.label(format!("loaded {m}"));
        }
        Some(Err(e)) => {
            ui.label(error_text(e.as_str()));
        }
        None => {}
    }
    let Some(e) = env.as_mut() else { return };
    ui.add(egui::Slider::new(&mut e.intensity, 0.0..=16.0).logarithmic(true).text("intensity"));
    let mut degrees = e.rotation.to_degrees();
    if ui.add(egui::Slider::new(&mut degrees, -180.0..=180.0).text("rotation °")).changed() {
        e.rotation = degrees.to_radians();
    }
    let mut blur = match e.background {
        Background::Blurred(r) => Some(r),
        _ => None,
    };
    ui.horizontal(|ui| {
        ui.label("background");
        if ui.selectable_label(e.background == Background::Environment, "environment").clicked() {
            e.background = Background::Environment;
            blur = None;
        }
        if ui.selectable_label(blur.is_some(), "blurred").clicked() && blur.is_none() {
            blur = Some(0.5);
        }
        if ui.selectable_label(matches!(e.background, Background::Color(_)), "colour").clicked() {
            e.background = Background::Color([0.02, 0.02, 0.025]);
            blur = None;
        }
    });
    if let Some(mut r) = blur {
        ui.add(egui::Slider::new(&mut r, 0.0..=1.0).text("blur (roughness)"));
        e.background = Background::Blurred(r);
    }
}
