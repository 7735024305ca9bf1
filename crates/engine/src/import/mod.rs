//! Scene import: files in, entities out.
//!
//! Import runs in two phases so that a bad file never leaves half a scene behind: `load` reads,
//! validates and decodes everything into plain data (a [`gltf::GltfScene`]) and is the only
//! fallible part; `spawn` then inserts assets and entities into the world and cannot fail.

pub mod error;
pub mod gltf;
pub mod obj;

use std::path::Path;

use bevy_ecs::entity::Entity;
use bevy_ecs::world::World;

pub use error::{ImportError, ImportErrorKind};
pub use gltf::{GltfCamera, GltfScene, ImportOptions, SceneRoot};
pub use obj::ObjScene;

/// A decoded scene file of any supported format: what phase one of an import produces.
#[derive(Debug, Clone)]
pub enum SceneFile {
    Gltf(GltfScene),
    Obj(ObjScene),
}

impl SceneFile {
    /// Reads and decodes `path`, choosing the importer by extension (`.gltf`/`.glb`, `.obj`).
    pub fn load(path: &Path, options: &ImportOptions) -> Result<SceneFile, ImportError> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("gltf" | "glb") => Ok(SceneFile::Gltf(GltfScene::load(path, options)?)),
            Some("obj") => Ok(SceneFile::Obj(ObjScene::load(path, options)?)),
            _ => Err(ImportError::new(path, ImportErrorKind::UnknownFormat)),
        }
    }

    pub fn path(&self) -> &Path {
        match self {
            SceneFile::Gltf(s) => &s.path,
            SceneFile::Obj(s) => &s.path,
        }
    }
}

/// Phase two of an import: a decoded scene spawns (infallibly) under a new root entity.
pub trait SpawnScene {
    fn spawn(&self, world: &mut World) -> Entity;
}

impl SpawnScene for GltfScene {
    fn spawn(&self, world: &mut World) -> Entity {
        GltfScene::spawn(self, world)
    }
}

impl SpawnScene for ObjScene {
    fn spawn(&self, world: &mut World) -> Entity {
        ObjScene::spawn(self, world)
    }
}

impl SpawnScene for SceneFile {
    fn spawn(&self, world: &mut World) -> Entity {
        match self {
            SceneFile::Gltf(s) => s.spawn(world),
            SceneFile::Obj(s) => s.spawn(world),
        }
    }
}

/// Loads a scene file (`.gltf`, `.glb` or `.obj`) and spawns it under a new root entity.
pub fn load_scene(world: &mut World, path: &Path, options: &ImportOptions) -> Result<Entity, ImportError> {
    Ok(SceneFile::load(path, options)?.spawn(world))
}
