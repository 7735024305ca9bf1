//! Scene sources for the subcommands: a file from the command line, or the embedded default
//! scene (DamagedHelmet, CC-BY 4.0; see assets/README.md), compiled into the binary.

use std::path::{Path, PathBuf};

use penumbra_engine::import::{GltfScene, ImportError, ImportOptions, ImportStage, SceneFile};

use crate::cli::SceneArgs;

const DEFAULT_SCENE: &[u8] = include_bytes!("../../../assets/DamagedHelmet.glb");
pub const DEFAULT_SCENE_NAME: &str = "<embedded>/DamagedHelmet.glb";

pub fn options(args: &SceneArgs) -> ImportOptions {
    let mut options = ImportOptions {
        scene: args.scene_index,
        allow_outside_folder: args.allow_outside_folder,
        ..Default::default()
    };
    for setting in &args.limits {
        // Checked when the command line was parsed.
        if let Err(e) = options.limits.apply(setting) {
            tracing::error!("--limit {setting}: {e}");
        }
    }
    options
}

/// Loads `path`, or the embedded default scene when `None`.
pub fn load(path: Option<&Path>, args: &SceneArgs) -> Result<SceneFile, ImportError> {
    load_with(path, &options(args))
}

pub fn load_with(path: Option<&Path>, opts: &ImportOptions) -> Result<SceneFile, ImportError> {
    match path {
        Some(p) => SceneFile::load(p, opts),
        None => {
            let scene = GltfScene::from_bytes(DEFAULT_SCENE, &PathBuf::from(DEFAULT_SCENE_NAME), opts)?;
            if let Some(p) = &opts.progress {
                p.enter(ImportStage::Done, 0);
            }
            Ok(SceneFile::Gltf(scene))
        }
    }
}
