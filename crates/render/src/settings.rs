//! The renderer's settings: one facade over the features' own settings (shadows, post,
//! environment, clusters, culling, rasterisation), validated as a whole, and the changes a
//! backend forces on them (with a warning).

use crate::features::bloom::BloomSettings;
use crate::features::clusters::LightWalk;
use crate::features::clusters::grid::ClusterConfig;
use crate::features::culling::{OcclusionCulling, TriangleCulling};
use crate::features::environment::EnvironmentSettings;
use crate::features::exposure::AutoExposure;
use crate::features::shadows::{ShadowSettings, ShadowSettingsError};
use crate::features::visibility::Raster;
use crate::gpu::context::GpuContext;
use crate::resources::draws::{DebugView, Tonemapper};
use crate::resources::light_store::DEFAULT_CUTOFF;
use crate::targets::MsaaResolve;

/// Which post-processes run (the chain is `frame::post_chain`; each process's settings live in
/// its folder). All off by default: each costs GPU time and changes the image, so a scene asks
/// for it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PostSettings {
    pub bloom: Option<BloomSettings>,
    /// FXAA on the tonemapped image (a cheap alternative to MSAA, or on top of it).
    pub fxaa: bool,
    /// Automatic exposure instead of the camera's EV100 alone.
    pub auto_exposure: Option<AutoExposure>,
}

impl PostSettings {
    pub fn validate(&self) -> Result<(), String> {
        self.bloom.as_ref().map_or(Ok(()), BloomSettings::validate)?;
        self.auto_exposure.as_ref().map_or(Ok(()), AutoExposure::validate)
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    /// 1 or 4.
    pub msaa: u32,
    pub tonemapper: Tonemapper,
    /// Linear RGB written behind the scene (after exposure, before tonemapping).
    pub clear_color: [f64; 3],
    /// Collect per-pass GPU times (read back a few frames late, without stalling).
    pub gpu_timing: bool,
    /// Where the shaders come from.
    pub shaders: ShaderSource,
    /// The froxel grid local lights are binned into.
    pub clusters: ClusterConfig,
    /// How fragments find local lights (clusters, or the brute-force references).
    pub light_walk: LightWalk,
    /// Display-referred luminance (after exposure) below which a local light without a glTF
    /// `range` stops: its range is where it would light a facing white surface this bright.
    pub light_cutoff: f32,
    pub debug_view: DebugView,
    /// Shadow maps of directional lights.
    pub shadows: ShadowSettings,
    /// Cull opaque and masked draws against the view frustum on the GPU and draw them
    /// indirectly (see `features::culling`). Adapters without indirect first-instance draws
    /// (GL) draw everything whatever this says.
    pub gpu_culling: bool,
    /// Occlusion culling on top of GPU culling: two-phase, against a hierarchical depth buffer
    /// of what this frame drew (see `features::culling`).
    pub occlusion_culling: OcclusionCulling,
    /// Triangle culling on top of GPU culling (and in occlusion culling's phases): batches of
    /// small meshes draw only the triangles that can cover a sample (see `features::culling`).
    pub triangle_culling: TriangleCulling,
    /// How the scene's `Environment` (if it has one) is prefiltered.
    pub environment: EnvironmentSettings,
    /// Bloom, automatic exposure, FXAA (all off by default).
    pub post: PostSettings,
    /// Always render into the HDR target, so that [`Renderer::read_hdr`] can read it. Without
    /// it a frame that nothing else reads HDR colour for (MSAA 1 or display-colour resolve, no
    /// post-processing, no environment background, no blended draws, no gizmos, no deferred
    /// lights) skips the HDR target and the tonemap pass: the forward shader tonemaps and draws
    /// into the output.
    pub keep_hdr: bool,
    /// Where multisampled frames average their samples: HDR radiance (the default, as the
    /// path-traced references filter it) or display colours, which spares a frame that nothing
    /// else needs HDR colour for its HDR target and tonemap pass (see [`MsaaResolve`]).
    pub msaa_resolve: MsaaResolve,
    /// Anisotropic filtering of trilinear material samplers, 1 (off) to 16. `None`: 8 on a GPU,
    /// 1 on a CPU rasteriser (see `auto_anisotropy`). Frames meant to match across adapters
    /// (the goldens) set it, since the automatic choice differs between them.
    pub max_anisotropy: Option<u16>,
    /// Where opaque surfaces are rasterised: by the GPU's fixed-function rasteriser, or in
    /// compute into a visibility buffer; by default where it is faster (see [`Raster`]).
    pub raster: Raster,
}

/// Where the renderer's WGSL comes from.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum ShaderSource {
    /// The shaders compiled into the binary.
    #[default]
    Embedded,
    /// The `*.wgsl` files of a folder (missing ones from the embedded set); with `watch`, edits
    /// are picked up while running (hot reload).
    Folder { dir: std::path::PathBuf, watch: bool },
}

impl Default for RenderSettings {
    fn default() -> Self {
        // A dark neutral grey: silhouettes of dark and light objects both stay visible.
        Self {
            msaa: 4,
            tonemapper: Tonemapper::Neutral,
            clear_color: [0.02, 0.02, 0.025],
            gpu_timing: false,
            shaders: ShaderSource::Embedded,
            clusters: ClusterConfig::default(),
            light_walk: LightWalk::Auto,
            light_cutoff: DEFAULT_CUTOFF,
            debug_view: DebugView::None,
            shadows: ShadowSettings::default(),
            gpu_culling: true,
            occlusion_culling: OcclusionCulling::Auto,
            triangle_culling: TriangleCulling::Auto,
            environment: EnvironmentSettings::default(),
            post: PostSettings::default(),
            keep_hdr: false,
            msaa_resolve: MsaaResolve::Radiance,
            max_anisotropy: None,
            raster: Raster::Auto,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum SettingsError {
    #[error("MSAA sample count {0} is not supported (use 1 or 4)")]
    Msaa(u32),
    #[error("{0}")]
    Clusters(String),
    #[error("light cutoff {0} must be a positive finite luminance")]
    LightCutoff(f32),
    #[error(transparent)]
    Shadows(#[from] ShadowSettingsError),
    #[error("{0}")]
    Environment(String),
    #[error("{0}")]
    Post(String),
    #[error("anisotropy {0} must lie in 1..=16")]
    Anisotropy(u16),
}

impl RenderSettings {
    pub fn validate(&self) -> Result<(), SettingsError> {
        if !matches!(self.msaa, 1 | 4) {
            return Err(SettingsError::Msaa(self.msaa));
        }
        self.clusters.validate().map_err(SettingsError::Clusters)?;
        if !(self.light_cutoff > 0.0 && self.light_cutoff.is_finite()) {
            return Err(SettingsError::LightCutoff(self.light_cutoff));
        }
        self.shadows.validate()?;
        self.environment.validate().map_err(SettingsError::Environment)?;
        self.post.validate().map_err(SettingsError::Post)?;
        if let Some(n) = self.max_anisotropy
            && !(1..=16).contains(&n)
        {
            return Err(SettingsError::Anisotropy(n));
        }
        Ok(())
    }
}

/// 8× anisotropic filtering keeps textures sharp at grazing angles on GPUs, where it is nearly
/// free. On CPU rasterisers it is not: llvmpipe's anisotropic path makes a small DamagedHelmet
/// frame take minutes instead of a fraction of a second, so software adapters get none.
fn auto_anisotropy(ctx: &GpuContext) -> u16 {
    if ctx.info.device_type == wgpu::DeviceType::Cpu { 1 } else { 8 }
}

pub(crate) fn max_anisotropy(ctx: &GpuContext, settings: &RenderSettings) -> u16 {
    settings.max_anisotropy.unwrap_or_else(|| auto_anisotropy(ctx))
}

/// What a backend cannot do as asked, done the way it can, with a warning (never silently):
/// see `Capabilities`. (What the renderer picks on its own, such as `LightWalk::Auto`'s path,
/// it picks among what the backend can do.)
pub(crate) fn degrade_for_backend(mut settings: RenderSettings, ctx: &GpuContext) -> RenderSettings {
    if !ctx.caps.deferred_lights && settings.light_walk == LightWalk::ClusteredCompute {
        tracing::warn!(
            "local lights cannot be shaded in a compute pass on the {:?} backend: shading them in the fragment shader",
            ctx.info.backend
        );
        settings.light_walk = LightWalk::Clustered;
    }
    if !ctx.caps.occlusion_culling && settings.occlusion_culling == OcclusionCulling::On {
        tracing::warn!(
            "occlusion culling's depth pyramid cannot be built on the {:?} backend: culling by the view only",
            ctx.info.backend
        );
        settings.occlusion_culling = OcclusionCulling::Off;
    }
    settings
}
