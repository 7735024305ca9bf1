//! The pipeline store: the driver's pipeline cache (`wgpu::PipelineCache`) kept in a file between
//! runs, so a process compiles only the pipelines no run on this adapter and driver compiled
//! before.
//!
//! [`PipelineStore::open`] reads `DIR/<adapter key>.bin` (the key from
//! `wgpu::util::pipeline_cache_key`: backend, vendor and device) and hands its data to the driver;
//! every pipeline [`super::PipelineCache`] creates names the cache, so the driver fills it as it
//! compiles. When the store is dropped (the renderer going away), the cache's data is written back
//! if pipelines were compiled since it was read.
//!
//! Safe against what a file on disk can be:
//! - Damaged or cut short: the file carries the BLAKE3 hash and length of its data, checked before
//!   anything reaches the driver (wgpu checks only its own header; a driver's behaviour on
//!   corrupt cache contents is undefined). A bad file is logged and replaced; the run starts with
//!   an empty cache.
//! - Stale or foreign (another driver version, another wgpu, a file copied from another
//!   adapter): wgpu's header names the adapter, the driver's cache UUID and wgpu's cache format.
//!   With `fallback` set wgpu starts an empty cache for a stale file, but reports a file made for
//!   another adapter as a validation error: that is caught, logged, and an empty cache made.
//! - Written by two processes at once: each writes a file of its own in the folder and renames
//!   it over the old one, so a reader sees one whole file or the other.
//! - Not writable, or no cache folder: logged; pipelines compile as they would without a store.
//!
//! Where: [`PipelineCacheDir`] on `AdapterRequest`; by default `PENUMBRA_PIPELINE_CACHE` (a folder,
//! or `off`), else the user's cache folder (`$XDG_CACHE_HOME` or `~/.cache` on Linux,
//! `~/Library/Caches` on macOS, `%LOCALAPPDATA%` on Windows) under `penumbra/pipelines`.

use std::io::Write;
use std::path::{Path, PathBuf};

/// Where compiled pipelines are kept between runs.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub enum PipelineCacheDir {
    /// `PENUMBRA_PIPELINE_CACHE` (a folder, or `off`), else the user's cache folder.
    #[default]
    User,
    /// This folder.
    At(PathBuf),
    /// Nowhere: every run compiles its pipelines.
    Off,
}

impl PipelineCacheDir {
    /// The folder, `None` when off or when the platform has no cache folder.
    pub fn folder(&self) -> Option<PathBuf> {
        match self {
            Self::At(dir) => Some(dir.clone()),
            Self::Off => None,
            Self::User => match std::env::var_os("PENUMBRA_PIPELINE_CACHE") {
                Some(v) if v == "off" || v == "0" => None,
                Some(v) if !v.is_empty() => Some(PathBuf::from(v)),
                _ => dirs::cache_dir().map(|d| d.join("penumbra").join("pipelines")),
            },
        }
    }
}

/// Our envelope around wgpu's data: magic, data length (u64 LE), BLAKE3 of the data, the data.
const MAGIC: &[u8; 8] = b"PNBRPLC1";
const HEADER: usize = 8 + 8 + 32;

/// The driver's pipeline cache and the file it came from and goes back to.
pub struct PipelineStore {
    cache: wgpu::PipelineCache,
    path: PathBuf,
    /// The hash of the data read (or last written), to write only what changed.
    hash: Option<blake3::Hash>,
    /// Bytes of cache data read from the file (0: none, or not usable).
    loaded: usize,
}

impl PipelineStore {
    /// The store for `device` in `dir`; `None` where the device has no pipeline cache (only
    /// Vulkan has one in wgpu) or `dir` is `None`.
    pub fn open(device: &wgpu::Device, info: &wgpu::AdapterInfo, dir: Option<&Path>) -> Option<Self> {
        let dir = dir?;
        if !device.features().contains(wgpu::Features::PIPELINE_CACHE) {
            return None;
        }
        let key = wgpu::util::pipeline_cache_key(info)?;
        let path = dir.join(format!("{key}.bin"));
        let data = match std::fs::read(&path) {
            Ok(bytes) => match unwrap(&bytes) {
                Ok(data) => Some(data.to_vec()),
                Err(why) => {
                    tracing::warn!("pipeline cache {}: {why}; starting an empty one", path.display());
                    None
                }
            },
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => {
                tracing::warn!("pipeline cache {}: {e}; starting an empty one", path.display());
                None
            }
        };
        let create = |data: Option<&[u8]>| {
            // SAFETY: the data is what `PipelineCache::get_data` returned, checked whole against
            // its hash above; wgpu checks its header against this adapter and driver (`fallback`
            // makes a stale one an empty cache; another adapter's is an error, caught below).
            unsafe {
                device.create_pipeline_cache(&wgpu::PipelineCacheDescriptor {
                    label: Some("penumbra pipelines"),
                    data,
                    fallback: true,
                })
            }
        };
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut cache = create(data.as_deref());
        if let Some(e) = pollster::block_on(scope.pop()) {
            tracing::warn!("pipeline cache {}: {e}; starting an empty one", path.display());
            cache = create(None);
        }
        let loaded = data.as_ref().map_or(0, Vec::len);
        tracing::debug!("pipeline cache {}: {loaded} bytes read", path.display());
        Some(Self { cache, path, hash: data.as_deref().map(blake3::hash), loaded })
    }

    pub fn cache(&self) -> &wgpu::PipelineCache {
        &self.cache
    }

    /// The file the store reads and writes.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Bytes of usable data the file held when the store opened.
    pub fn loaded_bytes(&self) -> usize {
        self.loaded
    }

    /// Writes the cache's data to the file if it differs from what the file holds; an error is
    /// returned (and the file left as it was), never a panic.
    pub fn save(&mut self) -> std::io::Result<bool> {
        let Some(data) = self.cache.get_data() else { return Ok(false) };
        let hash = blake3::hash(&data);
        if self.hash == Some(hash) {
            return Ok(false);
        }
        let dir = self.path.parent().unwrap_or(Path::new("."));
        std::fs::create_dir_all(dir)?;
        // A name no other writer uses (this process's id and a count of its saves), renamed over
        // the file only once whole. Two processes saving at once: the last rename wins.
        static SAVES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let nonce = SAVES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let tmp = dir.join(format!(".{}.{}.{nonce}.tmp", file_name(&self.path), std::process::id()));
        let written = (|| {
            let mut file = std::fs::File::create(&tmp)?;
            file.write_all(MAGIC)?;
            file.write_all(&(data.len() as u64).to_le_bytes())?;
            file.write_all(hash.as_bytes())?;
            file.write_all(&data)?;
            file.sync_all()?;
            std::fs::rename(&tmp, &self.path)
        })();
        if let Err(e) = written {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
        self.hash = Some(hash);
        tracing::debug!("pipeline cache {}: {} bytes written", self.path.display(), data.len());
        Ok(true)
    }
}

impl Drop for PipelineStore {
    fn drop(&mut self) {
        if let Err(e) = self.save() {
            tracing::warn!("pipeline cache {} not written: {e}", self.path.display());
        }
    }
}

fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(|| "pipelines".into(), |n| n.to_string_lossy().into_owned())
}

/// The data inside a file's envelope, or why there is none.
fn unwrap(bytes: &[u8]) -> Result<&[u8], &'static str> {
    if bytes.len() < HEADER || &bytes[..8] != MAGIC {
        return Err("not a Penumbra pipeline cache");
    }
    let len = u64::from_le_bytes(bytes[8..16].try_into().expect("8 bytes"));
    let data = &bytes[HEADER..];
    if data.len() as u64 != len {
        return Err("cut short or extended");
    }
    if blake3::hash(data).as_bytes() != &bytes[16..HEADER] {
        return Err("damaged (its data does not match its hash)");
    }
    Ok(data)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wrap(data: &[u8]) -> Vec<u8> {
        let mut v = MAGIC.to_vec();
        v.extend_from_slice(&(data.len() as u64).to_le_bytes());
        v.extend_from_slice(blake3::hash(data).as_bytes());
        v.extend_from_slice(data);
        v
    }

    #[test]
    fn the_envelope_refuses_what_is_not_whole() {
        let data = b"some driver data".to_vec();
        let good = wrap(&data);
        assert_eq!(unwrap(&good).unwrap(), &data[..]);
        assert_eq!(unwrap(&good[..good.len() - 1]).unwrap_err(), "cut short or extended");
        let mut longer = good.clone();
        longer.push(0);
        assert_eq!(unwrap(&longer).unwrap_err(), "cut short or extended");
        let mut flipped = good.clone();
        *flipped.last_mut().unwrap() ^= 1;
        assert!(unwrap(&flipped).unwrap_err().starts_with("damaged"));
        assert_eq!(unwrap(b"").unwrap_err(), "not a Penumbra pipeline cache");
        assert_eq!(unwrap(&[0u8; 100]).unwrap_err(), "not a Penumbra pipeline cache");
        // A length claiming more than a u64's worth of data.
        let mut huge = good.clone();
        huge[8..16].copy_from_slice(&u64::MAX.to_le_bytes());
        assert_eq!(unwrap(&huge).unwrap_err(), "cut short or extended");
    }

    #[test]
    fn off_and_a_folder_are_taken_as_given() {
        assert_eq!(PipelineCacheDir::Off.folder(), None);
        assert_eq!(PipelineCacheDir::At("/x".into()).folder(), Some(PathBuf::from("/x")));
    }
}
