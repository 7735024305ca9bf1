//! The soak: thousands of headless frames of continuous churn, sampling host and GPU memory, to
//! show that a viewer left running for hours keeps memory flat. Used by `penumbra bench soak`
//! and by the CI test that runs a short version (`tests/long_runs.rs`).
//!
//! Every frame spawns new meshes (new content, so the mesh pool takes new ranges), materials
//! and point or spot lights, and despawns the oldest beyond a fixed window, removing their
//! assets; every `TEXTURE_EVERY` frames a new image replaces the oldest; every `SCENE_EVERY`
//! frames the next glTF scene of the rotation is loaded and the previous one unloaded
//! ([`unload_scene`]); every `RESIZE_EVERY` frames the target changes size. All choices come from
//! a fixed-seed generator, so two runs churn identically. Memory is sampled with
//! [`Soak::sample`]: resident set size, [`MemoryStats`] per pool and the live asset counts.

use std::collections::VecDeque;
use std::sync::Arc;

use anyhow::Result;
use bevy_ecs::entity::Entity;
use glam::{Quat, Vec3, Vec4};
use penumbra_engine::App;
use penumbra_engine::assets::{Assets, Handle};
use penumbra_engine::components::{Mesh3d, MeshMaterial3d, PointLight, SpotLight, Transform};
use penumbra_engine::image::Image;
use penumbra_engine::import::{SceneFile, spawn_instance, unload_scene};
use penumbra_engine::material::{StandardMaterial, TextureRef};
use penumbra_engine::mesh::Mesh;
use penumbra_render::{GpuContext, MemoryStats, RenderOutput, RenderPlugin, RenderSettings, Renderer};

/// Objects alive at once; each frame adds `SPAWN_PER_FRAME` and the oldest go.
const WINDOW: usize = 48;
const SPAWN_PER_FRAME: usize = 3;
const TEXTURE_EVERY: u64 = 5;
const TEXTURES_ALIVE: usize = 8;
const SCENE_EVERY: u64 = 40;
const RESIZE_EVERY: u64 = 25;

/// What the soak renders into and loads.
#[derive(Debug, Clone)]
pub struct SoakConfig {
    /// Target sizes the soak cycles through.
    pub sizes: Vec<(u32, u32)>,
    /// Decoded scene files spawned and unloaded in turn (none: no scene churn).
    pub scenes: Vec<Arc<SceneFile>>,
    pub settings: RenderSettings,
}

/// One memory sample.
#[derive(Debug, Clone, Copy)]
pub struct SoakSample {
    pub frame: u64,
    /// Resident set size of the process (host memory; on a CPU rasteriser it holds the "GPU"
    /// memory too). `None` where /proc is missing.
    pub rss_bytes: Option<u64>,
    pub gpu: MemoryStats,
    pub entities: u32,
    pub meshes: usize,
    pub materials: usize,
    pub images: usize,
    pub pipelines: usize,
}

/// The churning app and where it is in its cycle.
pub struct Soak {
    app: App,
    config: SoakConfig,
    scenes: Vec<Arc<SceneFile>>,
    objects: VecDeque<(Entity, Option<Handle<Mesh>>, Option<Handle<StandardMaterial>>)>,
    textures: VecDeque<Handle<Image>>,
    scene: Option<Entity>,
    frame: u64,
    rng: u64,
}

impl Soak {
    /// Attaches a renderer on `context`. Scenes are decoded once by the caller; each turn spawns
    /// one anew (new handles, shared data), as loading it again would.
    pub fn new(context: GpuContext, config: SoakConfig) -> Result<Self> {
        let scenes = config.scenes.clone();
        let mut app = App::new();
        app.add_plugins(penumbra_engine::CorePlugin).add_plugins(RenderPlugin);
        app.insert_resource(Renderer::new(context, config.settings.clone())?);
        anyhow::ensure!(!config.sizes.is_empty(), "the soak needs at least one target size");
        Ok(Self {
            app,
            config,
            scenes,
            objects: VecDeque::new(),
            textures: VecDeque::new(),
            scene: None,
            frame: 0,
            rng: 0x5eed,
        })
    }

    pub fn frame(&self) -> u64 {
        self.frame
    }

    pub fn app(&self) -> &App {
        &self.app
    }

    /// Churns, renders one frame, and waits for the GPU (a bounded queue, as a paced viewer has).
    pub fn step(&mut self) {
        self.churn();
        let (w, h) = self.config.sizes[(self.frame / RESIZE_EVERY) as usize % self.config.sizes.len()];
        self.app.insert_resource(RenderOutput::Headless { width: w, height: h });
        self.app.update();
        self.app.world.resource_mut::<Renderer>().finish();
        self.frame += 1;
    }

    fn next(&mut self) -> f32 {
        // splitmix64: fast, fixed-seed, good enough to place objects.
        self.rng = self.rng.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.rng;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }

    fn churn(&mut self) {
        if self.frame.is_multiple_of(TEXTURE_EVERY) {
            self.churn_texture();
        }
        for _ in 0..SPAWN_PER_FRAME {
            self.spawn_object();
        }
        while self.objects.len() > WINDOW {
            let (entity, mesh, material) = self.objects.pop_front().expect("non-empty");
            let world = &mut self.app.world;
            world.despawn(entity);
            if let Some(m) = mesh {
                let _ = world.resource_mut::<Assets<Mesh>>().remove(m);
            }
            if let Some(m) = material {
                let _ = world.resource_mut::<Assets<StandardMaterial>>().remove(m);
            }
        }
        if self.frame.is_multiple_of(SCENE_EVERY) && !self.scenes.is_empty() {
            if let Some(old) = self.scene.take() {
                unload_scene(&mut self.app.world, old);
            }
            let file = self.scenes[(self.frame / SCENE_EVERY) as usize % self.scenes.len()].clone();
            let root = spawn_instance(&mut self.app.world, &file);
            self.app.world.entity_mut(root).insert(Transform::from_translation(Vec3::new(0.0, 0.0, -3.0)));
            self.scene = Some(root);
        }
    }

    fn churn_texture(&mut self) {
        let (a, b) = ((self.next() * 255.0) as u8, (self.next() * 255.0) as u8);
        let side = 16 + 16 * (self.frame / TEXTURE_EVERY % 3) as u32;
        let rgba8 = (0..side * side)
            .flat_map(
                |i| if (i / 4 + i / side / 4).is_multiple_of(2) { [a, b, 255 - a, 255] } else { [b, a, 128, 255] },
            )
            .collect();
        let image = Image::rgba8(side, side, rgba8, format!("soak texture {}", self.frame));
        let handle = self.app.world.resource_mut::<Assets<Image>>().add(image);
        self.textures.push_back(handle);
        if self.textures.len() > TEXTURES_ALIVE {
            let old = self.textures.pop_front().expect("non-empty");
            // Materials still naming it draw with a stand-in until they churn out.
            let _ = self.app.world.resource_mut::<Assets<Image>>().remove(old);
        }
    }

    fn spawn_object(&mut self) {
        let position = Vec3::new(self.next() * 8.0 - 4.0, self.next() * 4.0 - 2.0, -4.0 - self.next() * 6.0);
        let kind = (self.next() * 5.0) as u32;
        let world = &mut self.app.world;
        let entity = match kind {
            0 => {
                let light =
                    PointLight { intensity: 20.0 + self.rng as f32 % 50.0, range: Some(3.0), ..Default::default() };
                world.spawn((light, Transform::from_translation(position))).id()
            }
            1 => {
                let light = SpotLight { intensity: 40.0, range: Some(4.0), ..Default::default() };
                let t = Transform::from_translation(position).with_rotation(Quat::from_rotation_x(-1.2));
                world.spawn((light, t)).id()
            }
            _ => {
                let mesh = if kind == 2 {
                    Mesh::uv_sphere(0.2 + self.next() * 0.3, 8 + (self.frame % 8) as u32, 6)
                } else {
                    Mesh::cuboid(Vec3::new(0.2 + self.next() * 0.4, 0.2 + self.next() * 0.4, 0.3))
                };
                let mut material =
                    StandardMaterial::from_color(Vec4::new(self.next(), self.next(), self.next(), 1.0), 0.5);
                if let Some(&image) = self.textures.back() {
                    material.base_color_texture = Some(TextureRef::new(image));
                }
                let world = &mut self.app.world;
                let mesh = world.resource_mut::<Assets<Mesh>>().add(mesh);
                let material = world.resource_mut::<Assets<StandardMaterial>>().add(material);
                let t = Transform::from_translation(position);
                let e = world.spawn((Mesh3d(mesh), MeshMaterial3d(material), t)).id();
                self.objects.push_back((e, Some(mesh), Some(material)));
                return;
            }
        };
        self.objects.push_back((entity, None, None));
    }

    pub fn sample(&self) -> SoakSample {
        let world = &self.app.world;
        let renderer = world.resource::<Renderer>();
        SoakSample {
            frame: self.frame,
            rss_bytes: resident_bytes(),
            gpu: renderer.memory(),
            entities: world.entities().count_spawned(),
            meshes: world.resource::<Assets<Mesh>>().len(),
            materials: world.resource::<Assets<StandardMaterial>>().len(),
            images: world.resource::<Assets<Image>>().len(),
            pipelines: renderer.stats().pipelines_compiled,
        }
    }
}

/// The process's resident set size, from /proc/self/status (`VmRSS`).
pub fn resident_bytes() -> Option<u64> {
    status_kib("VmRSS:").map(|kib| kib * 1024)
}

/// Starts a new peak of resident memory ([`peak_resident_bytes`]); `false` where the system
/// cannot (not Linux, or /proc/self/clear_refs not writable): the peak is then the process's.
pub fn reset_peak_resident() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// The most memory the process has held resident since [`reset_peak_resident`] (or its start),
/// from /proc/self/status (`VmHWM`).
pub fn peak_resident_bytes() -> Option<u64> {
    status_kib("VmHWM:").map(|kib| kib * 1024)
}

fn status_kib(field: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(field))?;
    line.split_whitespace().nth(1)?.parse().ok()
}
