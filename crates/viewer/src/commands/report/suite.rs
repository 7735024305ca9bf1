//! The reference suite on disk: `suite.txt` names the scenes (`NAME PATH` per line, the path
//! relative to the file; `#` starts a comment), and `refs/NAME.direct.exr` and
//! `refs/NAME.gi.exr` hold each scene's path-traced references (direct light only, and full
//! global illumination), written by `tools/reference.py`. Scenes render through their own
//! glTF camera (the file's first) at the reference's size.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

#[derive(Debug, Clone)]
pub struct SuiteScene {
    pub name: String,
    pub path: PathBuf,
    pub direct: PathBuf,
    /// Absent when no global-illumination reference was rendered.
    pub gi: Option<PathBuf>,
}

pub fn read_suite(dir: &Path) -> Result<Vec<SuiteScene>> {
    let manifest = dir.join("suite.txt");
    let text = std::fs::read_to_string(&manifest).with_context(|| format!("cannot read {}", manifest.display()))?;
    let mut scenes = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let mut parts = line.split_whitespace();
        let (Some(name), Some(path), None) = (parts.next(), parts.next(), parts.next()) else {
            bail!("{}:{}: expected `NAME PATH`, found {line:?}", manifest.display(), n + 1);
        };
        let path = dir.join(path);
        if !path.is_file() {
            bail!("{}:{}: scene {} does not exist", manifest.display(), n + 1, path.display());
        }
        let direct = dir.join("refs").join(format!("{name}.direct.exr"));
        if !direct.is_file() {
            bail!("{}: no reference for {name} (render it with tools/reference.py)", direct.display());
        }
        let gi = Some(dir.join("refs").join(format!("{name}.gi.exr"))).filter(|p| p.is_file());
        scenes.push(SuiteScene { name: name.to_string(), path, direct, gi });
    }
    if scenes.is_empty() {
        bail!("{}: lists no scenes", manifest.display());
    }
    Ok(scenes)
}

/// A reference image: linear RGB, rows from the top, and its size.
pub fn read_reference(path: &Path) -> Result<(Vec<[f32; 3]>, (u32, u32))> {
    let img = image::open(path).with_context(|| format!("cannot read reference {}", path.display()))?.into_rgb32f();
    let size = img.dimensions();
    Ok((img.pixels().map(|p| p.0).collect(), size))
}
