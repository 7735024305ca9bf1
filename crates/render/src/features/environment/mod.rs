//! Environment lighting: the one owner of the maps image-based lighting reads, and of the
//! compute passes that make them.
//!
//! Data flow: extraction copies the main world's `Environment` resource into
//! `RenderScene::environment`. [`EnvironmentLighting::prepare`] resolves its source (the sky
//! needs the scene's brightest directional light) into a `MapsKey`; only when the key changes
//! (a new image, the sun turning, another cube size) does [`EnvironmentLighting::encode`] run
//! the prefilter chain on the GPU:
//!
//! 1. source cube, level 0 (`env_source.wgsl`): the sky, the studio gradient, or the
//!    equirectangular image (reduced on the CPU by box filtering to 4 × the face size, so
//!    bright small sources keep their energy);
//! 2. the source's mip chain (2 × 2 box);
//! 3. the specular cube: level 0 copied from the source, levels 1..[`SPECULAR_LEVELS`] GGX-
//!    prefiltered at perceptual roughness `level / (SPECULAR_LEVELS − 1)` with filtered
//!    importance sampling;
//! 4. nine irradiance harmonics from the source level whose faces are at most 32²;
//! 5. once per renderer, the split-sum table (64², `brdf_lut.wgsl`). Every lit surface reads
//!    its directional albedo there (`split_sum.wgsl`), with or without an environment, so the
//!    renderer asks for it ([`EnvironmentLighting::require_table`]) whenever a frame has lit
//!    draws; the table then stays. Without an environment only this step is compiled and run.
//!
//! Intensity, rotation and the background change only the uniform (`GpuEnvironment`), never
//! the maps. Sources are stored divided by a scale (the sky's zenith luminance, an image's
//! peak over f16's range) that the uniform multiplies back, so no source clamps in the f16
//! cubes. Without an environment the forward shaders are compiled without IBL, the maps are
//! released, and the bindings hold 1 × 1 stand-ins.
//!
//! On GL a six-layer square texture is a cube map for good (wgpu-hal fixes the target from the
//! shape; see `array_layers`), so it cannot also be written as a storage array: there the steps
//! write 2D arrays (`WorkArrays`, one per source level) that are copied face by face into the
//! cubes before the specular step samples them. Elsewhere the steps write the cubes directly.

mod maps;
mod pipelines;
pub mod sky;

pub use pipelines::{BackgroundFamily, BackgroundMode, EnvStep, EnvStepFamily};

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use penumbra_engine::environment::{Background, Environment, EnvironmentImage, EnvironmentSource, Sky};

use crate::bindings::{GroupBuilder, GroupResources};
use crate::frame_context::FrameContext;
use crate::gpu::array_layers::ArrayLayers;
use crate::gpu::formats::{ENVIRONMENT_FORMAT, EQUIRECT_FORMAT};
use crate::pipelines::PipelineCache;
use crate::pipelines::shader_library::ShaderError;
use maps::Maps;

/// Roughness levels of the specular cube (perceptual roughness 0, 0.2, … 1).
pub const SPECULAR_LEVELS: u32 = 6;
/// Side of the split-sum table.
pub const LUT_SIZE: u32 = 64;
/// The irradiance harmonics are projected from the first source level at most this wide.
const SH_FACE_MAX: u32 = 32;
/// Stand-in radiance scale of the studio gradient: straight up, at the horizon, straight down
/// (cd/m²). With the default exposure (EV100 0) the sky above reads 0.83 before tonemapping.
pub const STUDIO_RADIANCE: [f32; 3] = [1.0, 0.6, 0.25];
/// The studio gradient's radiance towards world direction `d` (unit), as `env_source.wgsl`
/// draws it (grey: one value for R, G and B).
pub fn studio_radiance(d: Vec3) -> f32 {
    let smooth = |x: f32| x * x * (3.0 - 2.0 * x);
    let [up_l, horizon, down_l] = STUDIO_RADIANCE;
    let (up, down) = (smooth(d.y.clamp(0.0, 1.0)), smooth((-d.y).clamp(0.0, 1.0)));
    horizon + (up_l - horizon) * up.sqrt() + (down_l - horizon) * down.sqrt()
}

/// The sky the renderer makes for a procedural environment (`Auto` or `Sky`) in a scene whose
/// brightest directional light is `sun` (direction towards it, lux); `None` where it draws the
/// studio gradient instead (and for images, which are their own radiance).
pub fn sky_for(env: &Environment, sun: Option<(Vec3, f32)>) -> Option<sky::SkyParams> {
    match resolve(env, sun).0 {
        Source::Sky(p) => Some(p),
        _ => None,
    }
}

/// Most GGX samples per texel of any level.
pub const MAX_SAMPLES: u32 = 4096;
/// Uniform buffer stride between per-level filter parameters.
const PARAMS_STRIDE: u64 = 256;

/// How finely the environment is prefiltered.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EnvironmentSettings {
    /// Face size of the source and of the specular cube's sharpest level; a power of two,
    /// 32..=2048 (32 is the smallest with all six roughness levels). The background shows
    /// this level. `None`: [`AUTO_CUBE_GPU`] on a GPU,
    /// [`AUTO_CUBE_CPU`] on a CPU rasteriser (lavapipe), where prefiltering 512² faces takes
    /// seconds (docs/environment-and-post.md, "How").
    pub cube_size: Option<u32>,
    /// GGX samples per texel of the first prefiltered level (perceptual roughness 0.2); each
    /// rougher level takes twice as many (up to [`MAX_SAMPLES`]). `None`: [`AUTO_SAMPLES`], or
    /// [`AUTO_SAMPLES_STUDIO`] for the studio gradient.
    pub specular_samples: Option<u32>,
}

/// `EnvironmentSettings::cube_size` when not given, on a GPU and on a CPU rasteriser.
pub const AUTO_CUBE_GPU: u32 = 512;
pub const AUTO_CUBE_CPU: u32 = 128;
/// `EnvironmentSettings::specular_samples` when not given. Images and the sky need them: with
/// fewer, a small bright source's highlight at roughness 0.2 strays from a 2048-sample
/// reference by more than the 6 % that tests/ibl.rs allows (docs/environment-and-post.md,
/// "Sample count, and limits").
pub const AUTO_SAMPLES: u32 = 128;
/// The studio gradient varies slowly, and filtered importance sampling reads each sample from
/// the source level its solid angle matches: 16 samples draw the studio-lit MetalRoughSpheres
/// practically as 128 do, and the prefilter, which a screenshot of a scene without a sun pays
/// for on the CPU rasteriser, costs an eighth as much (docs/performance.md, "A headless
/// screenshot").
pub const AUTO_SAMPLES_STUDIO: u32 = 16;

impl EnvironmentSettings {
    /// The face size to use on an adapter of this kind.
    pub fn cube_size_for(&self, cpu_adapter: bool) -> u32 {
        self.cube_size.unwrap_or(if cpu_adapter { AUTO_CUBE_CPU } else { AUTO_CUBE_GPU })
    }

    /// The first prefiltered level's samples per texel, for the studio gradient or another source.
    pub fn specular_samples_for(&self, studio: bool) -> u32 {
        self.specular_samples.unwrap_or(if studio { AUTO_SAMPLES_STUDIO } else { AUTO_SAMPLES })
    }

    pub fn validate(&self) -> Result<(), String> {
        if let Some(size) = self.cube_size
            && !(size.is_power_of_two() && (32..=2048).contains(&size))
        {
            return Err(format!("environment cube size {size} must be a power of two in 32..=2048"));
        }
        if let Some(samples) = self.specular_samples
            && !(1..=MAX_SAMPLES).contains(&samples)
        {
            return Err(format!("environment specular samples {samples} must lie in 1..={MAX_SAMPLES}"));
        }
        Ok(())
    }
}

/// Mirrors `EnvironmentParams` in `shaders/ibl.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
struct GpuEnvironment {
    rotation: [f32; 2],
    intensity: f32,
    max_lod: f32,
    background_lod: f32,
    _pad: [f32; 3],
}

/// Mirrors `SourceParams` in `shaders/env_source.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct GpuSourceParams {
    perez_lum: [f32; 4],
    perez_x: [f32; 4],
    perez_y: [f32; 4],
    perez_e: [f32; 4],
    zenith: [f32; 4],
    sun: [f32; 4],
    studio: [f32; 4],
    mode: u32,
    face_size: u32,
    _pad: [u32; 2],
}

/// Mirrors `FilterParams` in `shaders/env_filter.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct GpuFilterParams {
    roughness: f32,
    sample_count: u32,
    source_size: u32,
    face_size: u32,
    source_levels: u32,
    _pad: [u32; 3],
}

/// What the maps are made from, resolved.
#[derive(Debug, Clone)]
enum Source {
    Sky(sky::SkyParams),
    Studio,
    Image(Arc<EnvironmentImage>),
}

impl PartialEq for Source {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            // The scale goes to the uniform; only the shape is in the maps.
            (Source::Sky(a), Source::Sky(b)) => {
                sky::SkyParams { scale: 0.0, ..*a } == sky::SkyParams { scale: 0.0, ..*b }
            }
            (Source::Studio, Source::Studio) => true,
            (Source::Image(a), Source::Image(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }
}

/// Everything the maps depend on: a change of any part re-runs the prefilter chain.
#[derive(Debug, Clone, PartialEq)]
struct MapsKey {
    source: Source,
    cube_size: u32,
    specular_samples: u32,
}

/// What [`EnvironmentLighting::prepare`] decided.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EnvironmentFrame {
    /// The scene has an environment: forward shaders add its light.
    pub active: bool,
    /// The maps are made this frame.
    pub prefilter: bool,
    /// A view or texture in the view bind group was replaced.
    pub rebind: bool,
    /// A solid background's radiance: the frame is cleared to it (exposed) and no background
    /// pass runs.
    pub solid_background: Option<[f32; 3]>,
}

pub struct EnvironmentLighting {
    uniform: wgpu::Buffer,
    sh: wgpu::Buffer,
    sampler: wgpu::Sampler,
    stand_in_cube: wgpu::TextureView,
    stand_in_2d: wgpu::TextureView,
    lut: Option<(wgpu::Texture, wgpu::TextureView)>,
    lut_made: bool,
    maps: Option<Maps>,
    /// What the maps hold (or are about to, while `pending`).
    key: Option<MapsKey>,
    pending: bool,
    last_uniform: Option<GpuEnvironment>,
    /// Prefilter chains run since start-up.
    pub prefilters: u64,
    /// The last problem with the scene's environment, reported once.
    refused: Option<String>,
    /// An image's storage scale, which needs a pass over every texel: computed once per image.
    image_scale: Option<(Arc<EnvironmentImage>, f32)>,
    array_layers: ArrayLayers,
}

fn texture_bytes(t: &wgpu::Texture) -> u64 {
    let mut total = 0;
    for level in 0..t.mip_level_count() {
        let (w, h) = ((t.width() >> level).max(1) as u64, (t.height() >> level).max(1) as u64);
        total += w * h * t.depth_or_array_layers() as u64 * t.format().block_copy_size(None).unwrap_or(8) as u64;
    }
    total
}

impl EnvironmentLighting {
    /// Registers the environment's pipeline families (`view`: the view group the background
    /// reads).
    pub fn new(
        device: &wgpu::Device,
        array_layers: ArrayLayers,
        pipelines: &mut PipelineCache,
        view: &wgpu::BindGroupLayout,
    ) -> Self {
        let (steps, background) = pipelines::families(device, view);
        pipelines.register(steps);
        pipelines.register(background);
        let stand_in = |label, layers, dimension| {
            let t = device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: layers },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: ENVIRONMENT_FORMAT,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            // Zero-initialised by wgpu: no light, should a shader read it.
            t.create_view(&wgpu::TextureViewDescriptor { dimension: Some(dimension), ..Default::default() })
        };
        Self {
            uniform: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("environment"),
                size: std::mem::size_of::<GpuEnvironment>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            sh: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("environment irradiance"),
                size: 9 * 16,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            sampler: device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("environment"),
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                // ibl.wgsl blends neighbouring mips itself (smaller shaders on llvmpipe).
                mipmap_filter: wgpu::MipmapFilterMode::Nearest,
                ..Default::default()
            }),
            stand_in_cube: stand_in("environment stand-in", 6, wgpu::TextureViewDimension::Cube),
            stand_in_2d: stand_in("split-sum stand-in", 1, wgpu::TextureViewDimension::D2),
            lut: None,
            lut_made: false,
            maps: None,
            key: None,
            pending: false,
            last_uniform: None,
            prefilters: 0,
            refused: None,
            image_scale: None,
            array_layers,
        }
    }

    pub fn uniform(&self) -> &wgpu::Buffer {
        &self.uniform
    }

    pub fn irradiance_buffer(&self) -> &wgpu::Buffer {
        &self.sh
    }

    pub fn sampler(&self) -> &wgpu::Sampler {
        &self.sampler
    }

    pub fn specular_view(&self) -> &wgpu::TextureView {
        self.maps.as_ref().map_or(&self.stand_in_cube, |m| &m.specular_view)
    }

    /// Makes the split-sum table (filled by the next [`Self::encode`]) when it does not exist
    /// yet and the frame has lit draws (asked only then: once the table exists this is one
    /// check per frame). Returns whether it is new: bind groups must then be made again.
    pub fn require_table(&mut self, device: &wgpu::Device, lit_draws: impl FnOnce() -> bool) -> bool {
        if self.lut.is_none() && lit_draws() {
            self.lut = Some(make_lut_texture(device));
            return true;
        }
        false
    }

    /// The steps' shaders changed (hot reload): the maps and the table are made again, with the
    /// new code, on the next frame that has them.
    pub fn remake(&mut self) {
        self.key = None;
        self.lut_made = false;
    }

    /// The table exists but is not filled yet: [`Self::encode`] must run this frame.
    pub fn table_pending(&self) -> bool {
        self.lut.is_some() && !self.lut_made
    }

    pub fn lut_view(&self) -> &wgpu::TextureView {
        self.lut.as_ref().map_or(&self.stand_in_2d, |(_, v)| v)
    }

    /// The environment's share of the view group (`shaders/ibl.wgsl`, `split_sum.wgsl`): its
    /// parameters, irradiance harmonics and specular cube, then the split-sum table every lit
    /// surface reads and the sampler it shares with the cube.
    pub fn declare_view(b: &mut GroupBuilder) {
        let lit = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
        let filtered = |view_dimension| wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: true },
            view_dimension,
            multisampled: false,
        };
        b.buffer("environment", lit, wgpu::BufferBindingType::Uniform)
            .buffer("irradiance_sh", lit, wgpu::BufferBindingType::Storage { read_only: true })
            .add("specular_cube", lit, filtered(wgpu::TextureViewDimension::Cube))
            .add("brdf_lut", lit, filtered(wgpu::TextureViewDimension::D2))
            .add("linear_sampler", lit, wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering));
    }

    pub fn view_resources<'a>(&'a self, r: &mut GroupResources<'a>) {
        r.buffer("environment", self.uniform())
            .buffer("irradiance_sh", self.irradiance_buffer())
            .add("specular_cube", wgpu::BindingResource::TextureView(self.specular_view()))
            .add("brdf_lut", wgpu::BindingResource::TextureView(self.lut_view()))
            .add("linear_sampler", wgpu::BindingResource::Sampler(self.sampler()));
    }

    /// GPU memory held by the maps and the table.
    pub fn bytes(&self) -> u64 {
        let maps = self.maps.as_ref().map_or(0, |m| {
            let work = m
                .work
                .as_ref()
                .map_or(0, |w| w.source.iter().map(texture_bytes).sum::<u64>() + texture_bytes(&w.specular));
            texture_bytes(&m.source) + texture_bytes(&m.specular) + work
        });
        maps + self.lut.as_ref().map_or(0, |(t, _)| texture_bytes(t))
    }

    /// Resolves this frame's environment, (re)allocates maps when the cube size changes, and
    /// uploads what the prefilter chain reads when the source changed. `sun`: the scene's
    /// brightest directional light as (direction towards it, illuminance in lux).
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipelines: &PipelineCache,
        settings: &EnvironmentSettings,
        environment: Option<&Environment>,
        sun: Option<(Vec3, f32)>,
        cpu_adapter: bool,
    ) -> EnvironmentFrame {
        let cube_size = settings.cube_size_for(cpu_adapter);
        let environment = environment.filter(|e| match e.validate() {
            Ok(()) => {
                self.refused = None;
                true
            }
            Err(problem) => {
                if self.refused.as_ref() != Some(&problem) {
                    tracing::error!("environment refused: {problem}; rendering without it");
                    self.refused = Some(problem);
                }
                false
            }
        });
        let Some(env) = environment else {
            // No environment: release the maps; the bindings fall back to stand-ins.
            let rebind = self.maps.take().is_some();
            self.key = None;
            self.pending = false;
            return EnvironmentFrame { active: false, prefilter: false, rebind, solid_background: None };
        };
        let (source, source_scale) = match &env.source {
            EnvironmentSource::Image(img) => {
                let scale = match &self.image_scale {
                    Some((held, s)) if Arc::ptr_eq(held, img) => *s,
                    _ => {
                        let s = image_scale(img);
                        self.image_scale = Some((img.clone(), s));
                        s
                    }
                };
                (Source::Image(img.clone()), scale)
            }
            _ => {
                self.image_scale = None;
                resolve(env, sun)
            }
        };
        let specular_samples = settings.specular_samples_for(source == Source::Studio);
        let key = MapsKey { source, cube_size, specular_samples };
        let mut rebind = false;
        if self.maps.as_ref().is_none_or(|m| m.size != cube_size) {
            self.maps = Some(Maps::new(device, pipelines, &self.sh, cube_size, self.array_layers));
            rebind = true;
            self.key = None;
        }
        if self.key.as_ref() != Some(&key) {
            let maps = self.maps.as_mut().expect("made above");
            maps.upload_source(device, queue, pipelines, &key);
            self.write_filter_params(queue, key.specular_samples);
            self.key = Some(key);
            self.pending = true;
        }
        let max_lod = (SPECULAR_LEVELS - 1) as f32;
        let uniform = GpuEnvironment {
            rotation: [env.rotation.cos(), env.rotation.sin()],
            intensity: env.intensity * source_scale,
            max_lod,
            background_lod: match env.background {
                Background::Blurred(r) => r * max_lod,
                Background::Environment | Background::Color(_) => 0.0,
            },
            _pad: [0.0; 3],
        };
        if self.last_uniform != Some(uniform) {
            queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));
            self.last_uniform = Some(uniform);
        }
        let solid_background = match env.background {
            Background::Color(c) => Some(c),
            _ => None,
        };
        // The split-sum table is the renderer's to ask for (`require_table`), environment or not.
        EnvironmentFrame { active: true, prefilter: self.pending, rebind, solid_background }
    }

    fn write_filter_params(&self, queue: &wgpu::Queue, specular_samples: u32) {
        let Some(maps) = &self.maps else { return };
        let levels = maps.source.mip_level_count();
        let mut bytes = vec![0u8; (PARAMS_STRIDE * (SPECULAR_LEVELS as u64 + 1)) as usize];
        for level in 0..=SPECULAR_LEVELS {
            // Entry SPECULAR_LEVELS is the harmonics' projection.
            let (roughness, face) = if level < SPECULAR_LEVELS {
                (level as f32 / (SPECULAR_LEVELS - 1) as f32, (maps.size >> level).max(1))
            } else {
                (0.0, maps.sh_face)
            };
            let p = GpuFilterParams {
                roughness,
                // Rougher levels converge more slowly and have a quarter of the texels of the
                // level before: twice the samples each costs half as much again in all.
                sample_count: (specular_samples << level.saturating_sub(1).min(5)).min(MAX_SAMPLES),
                source_size: maps.size,
                face_size: face,
                source_levels: levels,
                _pad: [0; 3],
            };
            let at = (level as u64 * PARAMS_STRIDE) as usize;
            bytes[at..at + std::mem::size_of::<GpuFilterParams>()].copy_from_slice(bytemuck::bytes_of(&p));
        }
        queue.write_buffer(&maps.filter_params, 0, &bytes);
    }

    /// Compiles the prefilter steps and the split-sum table's pipeline ahead of the first frame
    /// that has an environment (`Renderer::warm_up`).
    pub fn warm_up(device: &wgpu::Device, pipelines: &mut PipelineCache) -> Result<(), ShaderError> {
        pipelines.prepare::<EnvStepFamily>(device, EnvStep::ALL)
    }

    /// Runs the prefilter chain if the source changed, and the split-sum table once. On a
    /// shader error nothing runs and the work stays pending (a reload may fix it).
    pub fn encode(&mut self, cx: &mut FrameContext) -> Result<(), ShaderError> {
        let (encoder, device, pipelines, timer) =
            (&mut *cx.encoder, cx.device, &mut *cx.pipelines, cx.timer.as_deref_mut());
        if !(self.pending || self.table_pending()) {
            return Ok(());
        }
        let steps: &[EnvStep] = if self.pending { &EnvStep::ALL } else { &[EnvStep::BrdfLut] };
        pipelines.prepare::<EnvStepFamily>(device, steps.iter().copied())?;
        let step = |s| pipelines.cached::<EnvStepFamily>(&s).expect("compiled above");
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("environment prefilter"),
            timestamp_writes: timer.and_then(|t| t.compute_pass("environment")),
        });
        if !self.lut_made
            && let Some((lut, _)) = &self.lut
        {
            let view = lut.create_view(&Default::default());
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("split-sum table"),
                layout: pipelines.family::<EnvStepFamily>().layout(EnvStep::BrdfLut),
                entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) }],
            });
            pass.set_pipeline(step(EnvStep::BrdfLut));
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(LUT_SIZE.div_ceil(8), LUT_SIZE.div_ceil(8), 1);
            self.lut_made = true;
        }
        // The source step's group holds the uploaded image: released once it has run.
        if self.pending
            && let Some(maps) = self.maps.as_mut()
            && let Some(source_group) = maps.source_group.take()
        {
            let groups = |size: u32| (size.div_ceil(8), size.div_ceil(8), 6);
            pass.set_pipeline(step(EnvStep::Source));
            pass.set_bind_group(0, &source_group, &[]);
            let (x, y, z) = groups(maps.size);
            pass.dispatch_workgroups(x, y, z);
            pass.set_pipeline(step(EnvStep::Downsample));
            for (i, group) in maps.downsample_groups.iter().enumerate() {
                pass.set_bind_group(0, group, &[]);
                let (x, y, z) = groups((maps.size >> (i + 1)).max(1));
                pass.dispatch_workgroups(x, y, z);
            }
            if let Some(work) = &maps.work {
                // The specular step samples the source as a cube: the cube must be whole first.
                drop(pass);
                for (level, written) in work.source.iter().enumerate() {
                    copy_faces(encoder, (written, 0), (&maps.source, level as u32), maps.size >> level);
                }
                pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("environment prefilter (specular)"),
                    timestamp_writes: None,
                });
            }
            pass.set_pipeline(step(EnvStep::Specular));
            for (i, group) in maps.specular_groups.iter().enumerate() {
                pass.set_bind_group(0, group, &[]);
                let (x, y, z) = groups((maps.size >> (i + 1)).max(1));
                pass.dispatch_workgroups(x, y, z);
            }
            pass.set_pipeline(step(EnvStep::IrradianceSh));
            pass.set_bind_group(0, &maps.sh_group, &[]);
            pass.dispatch_workgroups(1, 1, 1);
            drop(pass);
            // The sharpest specular level is the source itself.
            copy_faces(encoder, (maps.written_source(), 0), (&maps.specular, 0), maps.size);
            if let Some(work) = &maps.work {
                for level in 1..maps.specular.mip_level_count() {
                    copy_faces(encoder, (&work.specular, level), (&maps.specular, level), maps.size >> level);
                }
            }
            self.pending = false;
            self.prefilters += 1;
        }
        Ok(())
    }
}

/// The source to make maps from, and the scale its stored values are multiplied by.
fn resolve(env: &Environment, sun: Option<(Vec3, f32)>) -> (Source, f32) {
    let sky = match &env.source {
        EnvironmentSource::Auto => Some(Sky::default()),
        EnvironmentSource::Sky(s) => Some(*s),
        EnvironmentSource::Studio => None,
        EnvironmentSource::Image(img) => return (Source::Image(img.clone()), image_scale(img)),
    };
    match (sky, sun) {
        (Some(sky), Some((towards, lux))) => {
            let p = sky::sky_params(&sky, towards, lux);
            (Source::Sky(p), p.scale)
        }
        _ => (Source::Studio, 1.0),
    }
}

/// An image brighter than f16 allows is stored scaled down by this (1 for ordinary images).
fn image_scale(img: &EnvironmentImage) -> f32 {
    let peak = img.texels.iter().flatten().fold(0.0f32, |m, &v| m.max(v));
    (peak / 60_000.0).max(1.0)
}

/// Copies the six faces of (texture, mip level) `from` to `to`, faces `side` texels square, one
/// face per copy: wgpu's GL backend copies only the first layer of a many-layer copy.
fn copy_faces(encoder: &mut wgpu::CommandEncoder, from: (&wgpu::Texture, u32), to: (&wgpu::Texture, u32), side: u32) {
    let side = side.max(1);
    for face in 0..6 {
        let origin = wgpu::Origin3d { x: 0, y: 0, z: face };
        let aspect = wgpu::TextureAspect::All;
        encoder.copy_texture_to_texture(
            wgpu::TexelCopyTextureInfo { texture: from.0, mip_level: from.1, origin, aspect },
            wgpu::TexelCopyTextureInfo { texture: to.0, mip_level: to.1, origin, aspect },
            wgpu::Extent3d { width: side, height: side, depth_or_array_layers: 1 },
        );
    }
}

fn tex(binding: u32, view: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry { binding, resource: wgpu::BindingResource::TextureView(view) }
}

fn make_lut_texture(device: &wgpu::Device) -> (wgpu::Texture, wgpu::TextureView) {
    let t = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("split-sum table"),
        size: wgpu::Extent3d { width: LUT_SIZE, height: LUT_SIZE, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: ENVIRONMENT_FORMAT,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::STORAGE_BINDING,
        view_formats: &[],
    });
    let v = t.create_view(&Default::default());
    (t, v)
}

#[cfg(test)]
mod tests;
