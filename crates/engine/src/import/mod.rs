//! Scene import: files in, entities out.
//!
//! Import runs in two phases so that a bad file never leaves half a scene behind: `load` reads,
//! validates and decodes everything into plain data (a [`gltf::GltfScene`]) and is the only
//! fallible part; `spawn` then inserts assets and entities into the world and cannot fail.

pub mod error;
pub mod gltf;

use std::path::Path;

use bevy_ecs::entity::Entity;
use bevy_ecs::world::World;

pub use error::{ImportError, ImportErrorKind};
pub use gltf::{GltfCamera, GltfScene, ImportOptions, SceneRoot};

/// Loads a scene file (`.gltf` or `.glb`) and spawns it under a new root entity.
pub fn load_scene(world: &mut World, path: &Path, options: &ImportOptions) -> Result<Entity, ImportError> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("gltf" | "glb") => {
            let scene = GltfScene::load(path, options)?;
            Ok(scene.spawn(world))
        }
        _ => Err(ImportError::new(path, ImportErrorKind::UnknownFormat)),
    }
}
