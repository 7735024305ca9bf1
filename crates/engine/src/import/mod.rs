//! Scene import: files in, entities out.
//!
//! Import runs in two phases so that a bad file never leaves half a scene behind: `load` reads,
//! validates and decodes everything into plain data (a [`gltf::GltfScene`]) and is the only
//! fallible part; `spawn` then inserts assets and entities into the world and cannot fail.

pub mod error;
pub mod gltf;
pub mod limits;
pub mod obj;
pub mod progress;
mod report;

use std::path::Path;
use std::sync::Arc;

use bevy_ecs::entity::Entity;
use bevy_ecs::world::World;

pub use error::{ImportError, ImportErrorKind};
pub use gltf::{GltfCamera, GltfScene, ImportOptions, SceneRoot};
pub use limits::{ImportLimits, Limit};
pub use obj::ObjScene;
pub use progress::{ImportProgress, ImportStage, ProgressSnapshot};

/// Decodes one texture image (PNG, JPEG, WebP; a KTX2 file, Basis Universal or plain, is checked and kept
/// compressed, see [`crate::compressed_image`]) as the importers do, under `options.limits`: the
/// entry point of the image fuzz target, and for tools that load textures outside a scene.
pub fn decode_texture(
    bytes: &[u8],
    label: &str,
    options: &ImportOptions,
) -> Result<crate::image::Image, ImportErrorKind> {
    gltf::images::decode(bytes, 0, label, label.to_owned(), options)
}

/// A number from a file as messages print it: plainly where that is short (`0.5`, `-1`, `1e-5`
/// as `0.00001`), in exponent form where plain digits would run on (`1e30`, `-1e-30`).
pub(crate) fn num(v: f32) -> String {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() || (1e-4..1e7).contains(&a) { format!("{v}") } else { format!("{v:e}") }
}

/// Reads a scene file whole. Only a regular file: reading a FIFO, a socket or a device would
/// block forever or never end (image and buffer URIs get the same check in `gltf::source`).
pub(crate) fn read_scene_file(path: &Path) -> Result<Vec<u8>, ImportError> {
    let fail = |kind| ImportError::new(path, kind);
    let meta = std::fs::metadata(path).map_err(|e| fail(ImportErrorKind::Io(e)))?;
    if !meta.is_file() {
        return Err(fail(ImportErrorKind::NotAFile { what: file_kind(&meta.file_type()) }));
    }
    std::fs::read(path).map_err(|e| fail(ImportErrorKind::Io(e)))
}

fn file_kind(t: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
    }
    if t.is_dir() { "a folder" } else { "not a regular file" }
}

/// A decoded scene file of any supported format: what phase one of an import produces.
#[derive(Debug, Clone)]
pub enum SceneFile {
    Gltf(GltfScene),
    Obj(ObjScene),
}

/// The scene formats, by file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Gltf,
    Obj,
}

impl Format {
    fn of(path: &Path) -> Option<Format> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("gltf" | "glb") => Some(Format::Gltf),
            Some("obj") => Some(Format::Obj),
            _ => None,
        }
    }
}

impl SceneFile {
    /// Whether `path`'s extension names a format [`SceneFile::load`] reads.
    pub fn is_scene_path(path: &Path) -> bool {
        Format::of(path).is_some()
    }

    /// Reads and decodes `path`, choosing the importer by extension (`.gltf`/`.glb`, `.obj`).
    pub fn load(path: &Path, options: &ImportOptions) -> Result<SceneFile, ImportError> {
        if let Some(p) = &options.progress {
            p.enter(ImportStage::Reading, 0);
        }
        let file = match Format::of(path) {
            Some(Format::Gltf) => SceneFile::Gltf(GltfScene::load(path, options)?),
            Some(Format::Obj) => SceneFile::Obj(ObjScene::load(path, options)?),
            None => return Err(ImportError::new(path, ImportErrorKind::UnknownFormat)),
        };
        if let Some(p) = &options.progress {
            p.enter(ImportStage::Done, 0);
        }
        Ok(file)
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

/// The decoded file a scene instance was spawned from, on its root: what [`clone_scene`] spawns
/// again. Shared, not copied, by every instance.
#[derive(bevy_ecs::component::Component, Debug, Clone)]
pub struct SceneSource(pub Arc<SceneFile>);

/// Spawns `scene` under a new root that remembers it ([`SceneSource`]), so the instance can be
/// cloned.
pub fn spawn_instance(world: &mut World, scene: &Arc<SceneFile>) -> Entity {
    let root = scene.spawn(world);
    world.entity_mut(root).insert(SceneSource(scene.clone()));
    root
}

/// The assets one spawned scene instance added (every spawn adds its own handles, sharing the
/// decoded data by `Arc`), on the instance's root: what [`unload_scene`] removes.
#[derive(bevy_ecs::component::Component, Debug, Clone, Default)]
pub struct SceneAssets {
    pub meshes: Vec<crate::assets::Handle<crate::mesh::Mesh>>,
    pub materials: Vec<crate::assets::Handle<crate::material::StandardMaterial>>,
    pub images: Vec<crate::assets::Handle<crate::image::Image>>,
    pub ies_profiles: Vec<crate::assets::Handle<crate::ies::IesProfile>>,
}

/// Despawns a scene instance (its root and every descendant) and removes the assets it added,
/// so that loading and unloading scenes for hours keeps memory flat. A handle taken from the
/// scene and used elsewhere goes stale with it (drawing skips a stale mesh or material); clone
/// the asset first to keep it. Returns whether `root` was a scene root.
pub fn unload_scene(world: &mut World, root: Entity) -> bool {
    let Some(assets) = world.get::<SceneAssets>(root).cloned() else { return false };
    world.despawn(root);
    fn remove_all<T: Send + Sync + 'static>(world: &mut World, handles: &[crate::assets::Handle<T>]) {
        if let Some(mut store) = world.get_resource_mut::<crate::assets::Assets<T>>() {
            for &h in handles {
                let _ = store.remove(h);
            }
        }
    }
    remove_all(world, &assets.meshes);
    remove_all(world, &assets.materials);
    remove_all(world, &assets.images);
    remove_all(world, &assets.ies_profiles);
    true
}

/// Loads a scene file (`.gltf`, `.glb` or `.obj`) and spawns it under a new root entity. The
/// instance moves with the root's `Transform`, despawns with the root (`World::despawn` takes
/// its descendants along), and [`clone_scene`] makes more of it.
pub fn load_scene(world: &mut World, path: &Path, options: &ImportOptions) -> Result<Entity, ImportError> {
    Ok(spawn_instance(world, &Arc::new(SceneFile::load(path, options)?)))
}

/// Spawns another instance of the scene under `root` (which must carry a [`SceneSource`], as
/// instances from [`load_scene`] and [`spawn_instance`] do): same file, same root placement and
/// visibility, and its animation player (if any) at the same clip, time, speed and pause state.
/// The instances share the decoded mesh and image data (by `Arc`); each has its own entities and
/// its own asset handles, so [`unload_scene`] on one leaves the other whole. `None` if `root` is
/// not such a root.
pub fn clone_scene(world: &mut World, root: Entity) -> Option<Entity> {
    let source = world.get::<SceneSource>(root)?.0.clone();
    let transform = world.get::<crate::components::Transform>(root).copied();
    let visibility = world.get::<crate::components::Visibility>(root).copied();
    let player = world.get::<crate::animation::AnimationPlayer>(root).cloned();
    let variants = world.get::<crate::variants::SceneVariants>(root).cloned();
    let copy = spawn_instance(world, &source);
    let mut e = world.entity_mut(copy);
    if let Some(v) = variants {
        e.insert(v);
    }
    if let Some(t) = transform {
        e.insert(t);
    }
    if let Some(v) = visibility {
        e.insert(v);
    }
    if let (Some(from), Some(mut to)) = (player, e.get_mut::<crate::animation::AnimationPlayer>()) {
        to.copy_playback(&from);
    }
    Some(copy)
}
