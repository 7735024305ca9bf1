//! Command-line arguments. Values are parsed here and range-checked where they are used, so
//! every out-of-range setting is reported with the flag's name.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};
use penumbra_engine::environment::{Background, Environment, EnvironmentImage, EnvironmentSource, Sky};
use penumbra_render::DebugView;
use penumbra_render::features::clusters::grid::ClusterConfig;
use penumbra_render::features::environment::EnvironmentSettings;
use penumbra_render::features::shadows::{ShadowFilter, ShadowSettings};
use penumbra_render::headless::CameraChoice;
use penumbra_render::{AutoExposure, BloomSettings, PostSettings};
use penumbra_render::{LightWalk, OcclusionCulling, Raster, SettingsError, TriangleCulling};
use penumbra_render::{MsaaResolve, QualityPreset, RenderSettings, ShaderSource, Tonemapper};

#[derive(Parser, Debug)]
#[command(name = "penumbra", version, about = "A real-time glTF renderer and viewer")]
pub struct Cli {
    /// Log progress (info level; RUST_LOG overrides).
    #[arg(short, long, global = true)]
    pub verbose: bool,
    /// CPU rasterisers (lavapipe) only: `fast` or `optimized` shader compiles; `auto` is fast
    /// while shaders are watched for edits (docs/cli.md). GPU drivers ignore it.
    #[arg(long, global = true, value_enum, default_value_t = CpuCompileArg::Auto)]
    pub cpu_shader_compile: CpuCompileArg,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CpuCompileArg {
    Auto,
    Optimized,
    Fast,
}

impl CpuCompileArg {
    /// The mode for a command that does (`watches_shaders`) or does not watch a shader folder.
    /// Watching means someone is editing shaders, and on a CPU rasteriser each edit waits for
    /// LLVM: what `cargo run`'s debug profile is to Rust code, fast compiles are to shaders.
    pub fn mode(self, watches_shaders: bool) -> penumbra_render::gpu::context::CpuShaderCompiles {
        use penumbra_render::gpu::context::CpuShaderCompiles;
        match self {
            CpuCompileArg::Auto if watches_shaders => CpuShaderCompiles::Fast,
            CpuCompileArg::Auto | CpuCompileArg::Optimized => CpuShaderCompiles::Optimized,
            CpuCompileArg::Fast => CpuShaderCompiles::Fast,
        }
    }
}

/// The shader folder of the checkout the binary was built from, while that checkout exists
/// (the path is fixed at build time, whatever the working directory): `penumbra view` watches
/// it so that edits show up live.
pub fn repository_shaders() -> Option<PathBuf> {
    let dir = std::path::Path::new(penumbra_render::pipelines::shader_library::REPOSITORY_SHADER_DIR);
    dir.is_dir().then(|| dir.to_path_buf())
}

impl Command {
    /// Whether the command opens a window (everything but `view` runs headless).
    pub fn opens_window(&self) -> bool {
        matches!(self, Command::View(_))
    }

    /// Whether the command reloads shaders from a watched folder while it runs.
    pub fn watches_shaders(&self) -> bool {
        match self {
            Command::View(a) => a.look.shader_dir.is_some() || repository_shaders().is_some(),
            Command::Bench(a) => a.shader_edits > 0,
            Command::Render(_) | Command::Gif(_) | Command::Report(_) => false,
        }
    }
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Open a window on a scene (the embedded default scene without one).
    View(ViewArgs),
    /// Render a scene headless to a PNG.
    Render(RenderArgs),
    /// Measure CPU and GPU frame times and load-to-first-frame.
    Bench(BenchArgs),
    /// Render a turntable (the camera circling the scene once) as an animated GIF.
    Gif(GifArgs),
    /// Image error against path-traced references and GPU cost, for every suite scene at every
    /// quality preset: a table, a CSV and an error-against-time plot.
    Report(ReportArgs),
}

#[derive(Args, Debug, Clone, Default)]
pub struct SceneArgs {
    /// Which scene of the file (default: the file's default scene).
    #[arg(long = "scene", value_name = "INDEX")]
    pub scene_index: Option<usize>,
    /// Let relative URIs in the file reach outside its folder.
    #[arg(long)]
    pub allow_outside_folder: bool,
    /// Show the file's material variant NAME (KHR_materials_variants; default: each
    /// primitive's own material).
    #[arg(long, value_name = "NAME")]
    pub variant: Option<String>,
    /// Raise or lower an import limit (repeatable), e.g. `--limit vertices=1e9 --limit image-bytes=2G`.
    #[arg(long = "limit", value_name = "NAME=N", value_parser = parse_limit, long_help = LIMIT_HELP)]
    pub limits: Vec<String>,
}

/// `--limit`'s long help: every limit with its default (a unit test keeps it complete).
pub const LIMIT_HELP: &str = "Raise or lower an import limit (repeatable). A scene file is untrusted input: \
every count or size it declares is checked against these before memory is allocated.
  data-uri-bytes=256M      decoded size of one base64 data URI
  buffer-bytes=4G          byteLength of one glTF buffer
  read-bytes=8G            bytes read from files and data URIs in one import
  accessor-elements=64M    elements in one accessor
  decoded-bytes=8G         vertex, index, skin and animation data decoded in one import
  vertices=256M            vertices over all primitives of a file
  indices=1G               indices over all primitives of a file
  animation-keys=64M       keyframes over all animation samplers
  node-depth=1024          depth of the node hierarchy
  nodes=4M                 nodes in a file
  image-dimension=16384    width or height of one image
  image-bytes=1G           decoded size of one image, and size of one image file
  total-image-bytes=8G     decoded size of all images of a file, with their mip chains
N may be written 100000, 1e8, 512M or 4G (K, M, G are powers of 1024).";

fn parse_limit(s: &str) -> Result<String, String> {
    penumbra_engine::import::ImportLimits::default().apply(s)?;
    Ok(s.to_owned())
}

#[derive(Args, Debug, Clone)]
pub struct LookArgs {
    /// `reference`: the image a path tracer's raw output is, for comparing against one:
    /// radiance × 1 (EV100 −0.263), no environment, a black background, no tonemapping. Flags
    /// given beside it (`--exposure`, `--env`, `--tonemap`, `--background-color`) win.
    #[arg(long, value_enum, default_value_t = LookArg::Default)]
    pub look: LookArg,
    /// Display transform: `neutral` (the default), `aces`, or `none` (radiance clamped to 1).
    #[arg(long, value_enum)]
    pub tonemap: Option<TonemapArg>,
    /// Quality preset: sets MSAA, shadow atlas size, cascades, shadow filter, cluster grid and
    /// the light cutoff together (`high` is the default); the flags for each override it.
    #[arg(long, default_value = "high", value_parser = parse_quality, value_name = "low|medium|high|ultra")]
    pub quality: QualityPreset,
    /// MSAA samples (1 or 4; default from --quality).
    #[arg(long)]
    pub msaa: Option<u32>,
    /// Where MSAA averages samples: `radiance` (HDR, then tonemapped: as the path-traced
    /// references filter) or `display` (each sample tonemapped, display colours averaged: no
    /// HDR target or tonemap pass where nothing else needs them). Default `radiance`; the
    /// many-cubes and many-lights benchmarks default to `display`, as their recipe draws
    /// without an HDR target.
    #[arg(long, value_enum, value_name = "radiance|display")]
    pub msaa_resolve: Option<MsaaResolveArg>,
    /// Exposure as EV100 (−0.263 maps radiance 1 to 1). Default: metered from the scene's
    /// lights at the framed objects, EV100 = log2(lux / 2.5) (a 6,830 lux sun: 11.4); EV100 0
    /// for a scene without lights. `--explain` says which.
    #[arg(long, allow_negative_numbers = true)]
    pub exposure: Option<f32>,
    /// Read WGSL from this folder instead of the embedded shaders (`view` also watches it and
    /// reloads on change; by default `view` watches the repository's shaders/ when it exists).
    #[arg(long, value_name = "DIR")]
    pub shader_dir: Option<PathBuf>,
    /// Show a debug view instead of the shaded image: `clusters` colours each pixel by the
    /// number of lights in its cluster (black none, blue, green, yellow, red, white ≥ 256);
    /// `cascades` by the sun's shadow cascade (red, green, blue, yellow from near to far);
    /// `normals` shows world-space shading normals (n·0.5+0.5), `uvs` the first UV set.
    #[arg(long, value_enum, default_value_t = DebugViewArg::None)]
    pub debug_view: DebugViewArg,
    /// How fragments find local lights: through their cluster, in the fragment shader
    /// (`clustered`) or in a compute pass over opaque surfaces (`compute`: the same image, faster
    /// with long lists and where fragment shaders run on few units), `auto` choosing by the
    /// lists' length; or every light (`all`, the brute-force reference; `unbounded` also drops
    /// the range window).
    #[arg(long, value_enum, default_value_t = LightWalkArg::Auto)]
    pub light_walk: LightWalkArg,
    /// Cluster grid: tiles across x tiles down x depth slices (default from --quality;
    /// high: 16x16x32).
    #[arg(long, value_parser = parse_clusters, value_name = "XxYxZ")]
    pub clusters: Option<ClusterConfig>,
    /// Display-referred luminance (after exposure) at which a local light without a glTF
    /// range stops reaching (default from --quality; high: 1/4096).
    #[arg(long, value_name = "LUMINANCE")]
    pub light_cutoff: Option<f32>,
    /// Texels across each layer of the shadow atlas (one layer per cascade), 16 to 16384
    /// (default from --quality; high: 4096).
    #[arg(long, value_name = "TEXELS")]
    pub shadow_atlas: Option<u32>,
    /// Cascades per shadowed directional light, 1 to 4 (default from --quality; high: 4).
    #[arg(long)]
    pub cascades: Option<u32>,
    /// Distance from the camera beyond which nothing is shadowed, in metres.
    #[arg(long, default_value_t = ShadowSettings::default().max_distance, value_name = "METRES")]
    pub shadow_distance: f32,
    /// Shadow filtering: `pcf` (fixed soft edge) or `pcss` (penumbrae widen with distance from
    /// the caster, from the light's angular size). Default from --quality (pcss at ultra).
    #[arg(long, value_enum)]
    pub shadow_filter: Option<ShadowFilterArg>,
    /// Shadow casters' depth bias, in multiples of their depth slope across one texel, 0 to 16:
    /// more removes acne from steep surfaces and eats into contact shadows.
    #[arg(long, default_value_t = ShadowSettings::default().slope_bias, value_name = "SLOPES")]
    pub shadow_slope_bias: f32,
    /// Shadow receivers' offset along their normal, in texels of the cascade they read, 0 to 16.
    #[arg(long, default_value_t = ShadowSettings::default().normal_bias, value_name = "TEXELS")]
    pub shadow_normal_bias: f32,
    /// Draw every opaque object instead of culling against the view on the GPU, and every
    /// caster into every shadow map (for comparison; culling never changes the image).
    #[arg(long)]
    pub no_culling: bool,
    /// Anisotropic filtering of material textures, 1 (off) to 16. Default: 8 on a GPU, 1 on a
    /// CPU rasteriser such as lavapipe (where it is very slow).
    #[arg(long, value_name = "1..16")]
    pub anisotropy: Option<u16>,
    /// Occlusion culling (with GPU culling): `auto` runs it with 10 000 opaque instances or
    /// more, on a GPU (not on CPU rasterisers such as lavapipe).
    #[arg(long, value_enum, default_value_t = OcclusionArg::Auto)]
    pub occlusion: OcclusionArg,
    /// Triangle culling (with GPU culling): batches of small meshes draw only the triangles that
    /// can cover a sample. `auto`: on a GPU, not on CPU rasterisers such as lavapipe.
    #[arg(long, value_enum, default_value_t = OcclusionArg::Auto)]
    pub triangle_culling: OcclusionArg,
    /// Where opaque surfaces are rasterised: `auto` (the default): compute on GPUs whose
    /// graphics units are a small part of the chip (NVIDIA H100, H200), else the GPU's
    /// rasteriser; `hardware`; or `compute` (a visibility buffer written and shaded by compute
    /// shaders; blended and transmissive draws, gizmos, line and point meshes are drawn over it
    /// by the GPU's rasteriser). Frames compute cannot draw (no 64-bit atomics, as on GL; GPU
    /// culling off; `--occlusion on`; a visibility buffer too large for one binding; no opaque
    /// triangle mesh) rasterise in hardware; `render --explain` says which ran and why.
    #[arg(long, value_enum)]
    pub raster: Option<RasterArg>,
    /// Environment light and background: `auto` (a clear sky made for the scene's sun, or a
    /// neutral studio gradient when it has none), `sky`, `studio`, `none`, or an
    /// equirectangular Radiance .hdr or OpenEXR file.
    /// (Default `auto`; `none` with `--look reference`.)
    #[arg(long, value_name = "auto|sky|studio|none|FILE")]
    pub env: Option<String>,
    /// Multiplies the environment's radiance (light and background).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true, value_name = "FACTOR")]
    pub env_intensity: f32,
    /// Turns the environment about the vertical axis, degrees.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_name = "DEGREES")]
    pub env_rotation: f32,
    /// Face size of the environment's cube maps (a power of two, 16 to 2048).
    /// (`auto`: 512 on a GPU, 128 on a CPU rasteriser such as lavapipe.)
    #[arg(long, default_value = "auto", value_parser = parse_env_size, value_name = "TEXELS|auto")]
    pub env_size: EnvSize,
    /// Behind the scene: the environment, the environment `blurred` (as a surface of
    /// --background-blur roughness reflects it), or the solid clear `color`.
    #[arg(long, value_enum, default_value_t = BackgroundArg::Environment)]
    pub background: BackgroundArg,
    /// The colour behind the scene where no environment is drawn (`--env none`, or
    /// `--background color`): linear `R,G,B` (each 0 to 65504) or sRGB `#RRGGBB`, radiance like
    /// the scene's (exposed and tonemapped with it; shown as given with `--look reference`).
    /// Default a near-black grey (0.02,0.02,0.025); black with `--look reference`.
    #[arg(long, value_parser = parse_color, value_name = "R,G,B|#RRGGBB")]
    pub background_color: Option<[f32; 3]>,
    /// Perceptual roughness of the blurred background, 0 to 1.
    #[arg(long, default_value_t = 0.5, value_name = "ROUGHNESS")]
    pub background_blur: f32,
    /// Bloom: how much of the image its blur replaces, 0 to 1 (`--bloom` alone: 0.04;
    /// `--bloom=0.1` for more: the `=` keeps a scene path after the flag a path).
    #[arg(long, num_args = 0..=1, require_equals = true, default_missing_value = "0.04", value_name = "STRENGTH")]
    pub bloom: Option<f32>,
    /// FXAA on the tonemapped image (with or instead of MSAA: `--msaa 1 --fxaa`).
    #[arg(long)]
    pub fxaa: bool,
    /// Automatic exposure (histogram-metered, adapting over time) instead of the fixed EV100.
    #[arg(long)]
    pub auto_exposure: bool,
    /// Automatic exposure's limits, EV100.
    #[arg(long, default_value = "-6:18", value_parser = parse_ev_range, value_name = "MIN:MAX", allow_hyphen_values = true)]
    pub ev_range: (f32, f32),
    /// Automatic exposure's compensation, EV (positive: brighter).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_name = "EV")]
    pub exposure_compensation: f32,
}

/// `--env-size`: a face size, or `auto` (`None`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EnvSize(pub Option<u32>);

fn parse_env_size(s: &str) -> Result<EnvSize, String> {
    if s == "auto" {
        return Ok(EnvSize(None));
    }
    s.parse::<u32>().map(|n| EnvSize(Some(n))).map_err(|_| format!("{s:?} is neither a whole number nor auto"))
}

fn parse_ev_range(s: &str) -> Result<(f32, f32), String> {
    let (a, b) = s.split_once(':').ok_or_else(|| format!("{s:?} is not MIN:MAX (for example -6:18)"))?;
    let n = |v: &str| v.trim().parse::<f32>().map_err(|_| format!("{v:?} in {s:?} is not a number"));
    Ok((n(a)?, n(b)?))
}

/// `--look`.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum LookArg {
    Default,
    Reference,
}

/// `--background-color`: linear `R,G,B` or sRGB `#RRGGBB`, as linear RGB.
fn parse_color(s: &str) -> Result<[f32; 3], String> {
    if let Some(hex) = s.strip_prefix('#') {
        let bytes = (hex.len() == 6 && hex.is_ascii())
            .then(|| (0..3).map(|i| u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).ok()).collect::<Option<Vec<u8>>>())
            .flatten()
            .ok_or_else(|| format!("{s:?} is not #RRGGBB"))?;
        return Ok(std::array::from_fn(|i| penumbra_engine::color::srgb_to_linear(bytes[i] as f32 / 255.0)));
    }
    let parts: Vec<&str> = s.split(',').collect();
    let values: Option<Vec<f32>> = parts.iter().map(|v| v.trim().parse::<f32>().ok()).collect();
    match values {
        Some(v) if v.len() == 3 && v.iter().all(|c| c.is_finite() && (0.0..=65504.0).contains(c)) => {
            Ok([v[0], v[1], v[2]])
        }
        _ => Err(format!("{s:?} is neither R,G,B (three linear values, 0 to 65504) nor #RRGGBB")),
    }
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackgroundArg {
    Environment,
    Blurred,
    Color,
}

impl LookArgs {
    fn reference(&self) -> bool {
        self.look == LookArg::Reference
    }

    /// `--env`, or what `--look` implies.
    pub fn env_name(&self) -> &str {
        self.env.as_deref().unwrap_or(if self.reference() { "none" } else { "auto" })
    }

    /// `--exposure`, or what `--look` implies (`None`: the camera's own).
    pub fn exposure_ev100(&self) -> Option<f32> {
        self.exposure.or(self.reference().then(|| penumbra_engine::components::Exposure::unit().ev100))
    }

    /// The clear colour behind the scene: `--background-color`, or what `--look` implies.
    pub fn clear_color(&self) -> [f32; 3] {
        self.background_color.unwrap_or(if self.reference() {
            [0.0; 3]
        } else {
            RenderSettings::default().clear_color.map(|c| c as f32)
        })
    }

    /// The environment these flags ask for (`None` for `--env none`); reads an image file.
    pub fn environment(&self) -> anyhow::Result<Option<Environment>> {
        let source = match self.env_name() {
            "none" => return Ok(None),
            "auto" => EnvironmentSource::Auto,
            "sky" => EnvironmentSource::Sky(Sky::default()),
            "studio" => EnvironmentSource::Studio,
            path => EnvironmentSource::Image(std::sync::Arc::new(
                EnvironmentImage::load(std::path::Path::new(path)).map_err(|e| anyhow::anyhow!("--env: {e}"))?,
            )),
        };
        let env = Environment {
            source,
            intensity: self.env_intensity,
            rotation: self.env_rotation.to_radians(),
            background: match self.background {
                BackgroundArg::Environment => Background::Environment,
                BackgroundArg::Blurred => Background::Blurred(self.background_blur),
                BackgroundArg::Color => Background::Color(self.clear_color()),
            },
        };
        env.validate().map_err(|e| {
            let flag = if e.contains("intensity") {
                "--env-intensity"
            } else if e.contains("rotation") {
                "--env-rotation"
            } else {
                "--background-blur"
            };
            anyhow::anyhow!("{flag}: {e}")
        })?;
        Ok(Some(env))
    }
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadowFilterArg {
    Pcf,
    Pcss,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum DebugViewArg {
    None,
    Clusters,
    Cascades,
    Normals,
    Uvs,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum RasterArg {
    Auto,
    Hardware,
    Compute,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightWalkArg {
    /// Clusters, in fragments while lists are short and in compute once they grow long.
    Auto,
    Clustered,
    /// Clusters walked by a compute pass for opaque surfaces (deferred local lights).
    Compute,
    All,
    Unbounded,
}

fn parse_quality(s: &str) -> Result<QualityPreset, String> {
    s.parse()
}

fn parse_clusters(s: &str) -> Result<ClusterConfig, String> {
    let parts: Vec<&str> = s.split(['x', 'X']).collect();
    let [x, y, z] = parts.as_slice() else { return Err(format!("{s:?} is not XxYxZ (for example 16x16x32)")) };
    let n = |v: &str| v.trim().parse::<u32>().map_err(|_| format!("{v:?} in {s:?} is not a whole number"));
    let config = ClusterConfig { tiles_x: n(x)?, tiles_y: n(y)?, slices: n(z)? };
    config.validate()?;
    Ok(config)
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// A .gltf, .glb or .obj file; several with --out-dir.
    #[arg(value_name = "SCENE", required = true, num_args = 1..)]
    pub paths: Vec<PathBuf>,
    /// The image to write (.png or .jpg), for one scene.
    #[arg(long, short, required_unless_present = "out_dir", conflicts_with = "out_dir")]
    pub out: Option<PathBuf>,
    /// A folder for the images of many scenes, each named after its scene (SCENE.png); made if
    /// missing. The scenes render one after another on one device and renderer.
    #[arg(long, value_name = "DIR")]
    pub out_dir: Option<PathBuf>,
    /// WIDTHxHEIGHT (default 512 high, camera's aspect).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// `auto`: the file's first camera where it has one that sees the scene, else the scene
    /// framed from a raised three-quarter view (yaw 35°, pitch 25°; animated scenes over their
    /// whole first clip); `front` frames it from +Z; `orbit:YAW:PITCH` from that direction
    /// (degrees); N uses the file's camera N.
    #[arg(long, default_value = "auto", value_parser = parse_camera)]
    pub camera: CameraChoice,
    /// Fixed-step (60 Hz) frames to run before the screenshot.
    #[arg(long, default_value_t = 1)]
    pub frames: u32,
    /// The animation clip to pose (a name or an index; default the first).
    #[arg(long, value_name = "CLIP")]
    pub animation: Option<String>,
    /// Seconds into the clip; the pose is held there (default 0 when --animation is given;
    /// without either, the first clip plays from 0 over --frames).
    #[arg(long, value_name = "SECONDS")]
    pub time: Option<f32>,
    /// Print the last frame's plan: the passes that ran, why, and what each reads; the passes
    /// left out and why; the forward shader variants compiled; GPU memory by pool.
    #[arg(long)]
    pub explain: bool,
    #[command(flatten)]
    pub look: LookArgs,
    #[command(flatten)]
    pub scene_args: SceneArgs,
}

#[derive(Args, Debug)]
pub struct ReportArgs {
    /// The reference suite: a folder holding suite.txt (`NAME PATH` per line) and
    /// refs/NAME.direct.exr (+ NAME.gi.exr) from tools/reference.py.
    #[arg(long, default_value = "tests/reference", value_name = "DIR")]
    pub suite: PathBuf,
    /// Names the run (for example the GPU): the plot's title, OUT/LABEL.csv and OUT/LABEL.png.
    #[arg(long, default_value = "report", value_name = "NAME")]
    pub label: String,
    /// Folder for the CSV and the plot.
    #[arg(long, default_value = ".", value_name = "DIR")]
    pub out: PathBuf,
    /// The presets to measure, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "low,medium,high,ultra", value_parser = parse_quality, value_name = "P,P,...")]
    pub presets: Vec<QualityPreset>,
    /// Only these scenes (names from suite.txt), comma-separated.
    #[arg(long, value_delimiter = ',', value_name = "NAME,...")]
    pub scenes: Vec<String>,
    /// Timed frames per scene and preset (GPU and CPU times are their medians).
    #[arg(long, default_value_t = 30)]
    pub frames: u32,
    #[arg(long, default_value_t = 5)]
    pub warmup: u32,
    /// Size the frame times are measured at (the error is measured at the references' size).
    #[arg(long, value_parser = parse_size, default_value = "1920x1080", value_name = "WxH")]
    pub timing_size: (u32, u32),
    /// Also save every compared image as DIR/SCENE.PRESET.png, its FLIP error map against the
    /// direct-light reference as DIR/SCENE.PRESET.flip.png, and each reference through the same
    /// tonemapper as DIR/SCENE.reference.png.
    #[arg(long, value_name = "DIR")]
    pub images: Option<PathBuf>,
    /// Read WGSL from this folder instead of the embedded shaders (files missing there come from
    /// the embedded set): what a shader edit does to the error and the time.
    #[arg(long, value_name = "DIR")]
    pub shader_dir: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct GifArgs {
    /// A .gltf, .glb or .obj file (default: the embedded default scene).
    #[arg(value_name = "SCENE")]
    pub path: Option<PathBuf>,
    /// Output GIF.
    #[arg(long, short)]
    pub out: PathBuf,
    /// Frames in one turn, 2 to 1000.
    #[arg(long, default_value_t = 36)]
    pub frames: u32,
    /// WIDTHxHEIGHT, each 1 to 4096.
    #[arg(long, value_parser = parse_size, default_value = "320x320")]
    pub size: (u32, u32),
    /// Length of one turn (animations in the scene play along), 0.1 to 600.
    #[arg(long, default_value_t = 4.0)]
    pub seconds: f32,
    /// Camera elevation, degrees (-89 to 89).
    #[arg(long, default_value_t = 15.0, allow_negative_numbers = true)]
    pub pitch: f32,
    #[command(flatten)]
    pub look: LookArgs,
    #[command(flatten)]
    pub scene_args: SceneArgs,
}

impl RenderArgs {
    /// The pose `--animation` and `--time` ask for, if any.
    pub fn animation_shot(&self) -> Option<penumbra_render::headless::AnimationShot> {
        (self.animation.is_some() || self.time.is_some()).then(|| penumbra_render::headless::AnimationShot {
            clip: self.animation.clone(),
            time: self.time.unwrap_or(0.0),
        })
    }
}

#[derive(Args, Debug)]
pub struct ViewArgs {
    /// A .gltf, .glb or .obj file (default: the embedded default scene).
    #[arg(value_name = "SCENE")]
    pub path: Option<PathBuf>,
    /// `auto`: the file's first camera where it has one that sees the scene (the Camera menu
    /// switches), else a raised three-quarter view; `front`, `orbit:YAW:PITCH` or N as for
    /// `render`.
    #[arg(long, default_value = "auto", value_parser = parse_camera)]
    pub camera: CameraChoice,
    #[command(flatten)]
    pub look: LookArgs,
    #[command(flatten)]
    pub scene_args: SceneArgs,
    /// Present without waiting for vertical sync.
    #[arg(long)]
    pub no_vsync: bool,
    /// The window's size in logical pixels.
    #[arg(long, value_parser = parse_size, default_value = "1280x800", value_name = "WxH")]
    pub size: (u32, u32),
    /// Where F12 saves screenshots (penumbra-NNNN.png, the first free number).
    #[arg(long, value_name = "DIR")]
    pub screenshot_dir: Option<PathBuf>,
    /// Panels to open with the window, comma-separated: stats, tree, inspector, settings,
    /// environment (the View menu opens and closes them; none by default: the scene gets the
    /// window).
    #[arg(long, value_enum, value_delimiter = ',', value_name = "PANELS")]
    pub panels: Vec<PanelArg>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PanelArg {
    Stats,
    Tree,
    Inspector,
    Settings,
    Environment,
}

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// A .gltf, .glb or .obj file (default: the embedded default scene).
    #[arg(value_name = "SCENE")]
    pub path: Option<PathBuf>,
    #[arg(long, value_parser = parse_size, default_value = "1920x1080")]
    pub size: (u32, u32),
    /// Timed frames (after warm-up frames that are not counted).
    #[arg(long, default_value_t = 60)]
    pub frames: u32,
    #[arg(long, default_value_t = 5)]
    pub warmup: u32,
    /// Instead of frame times, measure hot-reload latency: make N edits to a copy of
    /// forward.wgsl while rendering and time each from the file write to the first frame
    /// finished with the new shader.
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub shader_edits: u32,
    /// For the built-in `many-lights` scene: the light counts to run, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1000,10000,100000", value_name = "N,N,...")]
    pub lights: Vec<usize>,
    /// For the built-in `many-cubes` scene: the cube counts to run, comma-separated (for
    /// `characters`: the instance counts).
    #[arg(long, value_delimiter = ',', default_value = "10000,100000,1000000", value_name = "N,N,...")]
    pub count: Vec<usize>,
    /// For `many-cubes`: the fractions of cubes that turn every frame, comma-separated (each in
    /// 0..=1; `--moving` alone means 1).
    #[arg(long, value_delimiter = ',', default_value = "0", default_missing_value = "1", num_args = 0..=1, value_parser = parse_fraction, value_name = "F,F,...")]
    pub moving: Vec<f64>,
    /// For `characters`: the animated, skinned model to crowd (default tests/assets/Fox/Fox.glb).
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// For `many-cubes`: where the cubes stand.
    #[arg(long, value_enum, default_value = "grid")]
    pub layout: LayoutArg,
    /// For `many-cubes`: the sun casts shadows (the renderer's shadow settings: four 4096²
    /// cascades at the default preset), and the camera steps 25 cm sideways every frame, so
    /// every cascade redraws.
    #[arg(long)]
    pub shadows: bool,
    /// For `many-lights`: each light's range in metres, or `auto` (from its intensity).
    #[arg(long, default_value = "3", value_parser = parse_range, value_name = "METRES|auto")]
    pub light_range: LightRange,
    /// For `many-lights`: the size at which the range window's image error is measured (the
    /// unbounded reference walks every light for every pixel).
    #[arg(long, value_parser = parse_size, default_value = "480x270")]
    pub error_size: (u32, u32),
    /// With an environment: replace it with a sky whose sun turns 1° a frame, so its maps are
    /// remade every frame (the environment pass's GPU cost).
    #[arg(long)]
    pub env_churn: bool,
    #[command(flatten)]
    pub look: LookArgs,
    #[command(flatten)]
    pub scene_args: SceneArgs,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum MsaaResolveArg {
    Radiance,
    Display,
}

impl From<MsaaResolveArg> for MsaaResolve {
    fn from(r: MsaaResolveArg) -> Self {
        match r {
            MsaaResolveArg::Radiance => MsaaResolve::Radiance,
            MsaaResolveArg::Display => MsaaResolve::Display,
        }
    }
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum TonemapArg {
    Neutral,
    Aces,
    None,
}

impl From<TonemapArg> for Tonemapper {
    fn from(t: TonemapArg) -> Self {
        match t {
            TonemapArg::Neutral => Tonemapper::Neutral,
            TonemapArg::Aces => Tonemapper::Aces,
            TonemapArg::None => Tonemapper::None,
        }
    }
}

/// Off, on, or where it pays (occlusion and triangle culling).
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum OcclusionArg {
    Auto,
    On,
    Off,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum LayoutArg {
    Grid,
    Sphere,
}

fn parse_fraction(s: &str) -> Result<f64, String> {
    s.parse::<f64>()
        .ok()
        .filter(|f| (0.0..=1.0).contains(f))
        .ok_or_else(|| format!("{s:?} is not a fraction between 0 and 1"))
}

/// A light range from the command line: metres, or derived from intensity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightRange(pub Option<f32>);

fn parse_range(s: &str) -> Result<LightRange, String> {
    if s == "auto" {
        return Ok(LightRange(None));
    }
    s.parse::<f32>()
        .ok()
        .filter(|r| r.is_finite() && *r > 0.0)
        .map(|r| LightRange(Some(r)))
        .ok_or_else(|| format!("{s:?} is neither `auto` nor a positive distance in metres"))
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("{s:?} is not WIDTHxHEIGHT"))?;
    let parse = |v: &str| v.trim().parse::<u32>().map_err(|_| format!("{v:?} is not a whole number"));
    Ok((parse(w)?, parse(h)?))
}

fn parse_camera(s: &str) -> Result<CameraChoice, String> {
    if s == "auto" {
        return Ok(CameraChoice::Auto);
    }
    if s == "front" {
        return Ok(CameraChoice::FRONT);
    }
    if let Some(rest) = s.strip_prefix("orbit:") {
        let (yaw, pitch) = rest.split_once(':').ok_or_else(|| format!("{s:?}: expected orbit:YAW:PITCH (degrees)"))?;
        let deg = |v: &str| {
            v.parse::<f32>()
                .ok()
                .filter(|d| d.is_finite() && d.abs() <= 360.0)
                .ok_or_else(|| format!("{v:?} is not an angle in degrees"))
        };
        return Ok(CameraChoice::Orbit { yaw: deg(yaw)?, pitch: deg(pitch)?.clamp(-89.0, 89.0) });
    }
    s.parse()
        .map(CameraChoice::Gltf)
        .map_err(|_| format!("{s:?} is neither `auto`, `front`, `orbit:YAW:PITCH` nor a camera index"))
}

impl LookArgs {
    /// Render settings from the flags, range-checked with the flag named in the error.
    /// `watch_default` is the folder to use (and watch) when `--shader-dir` is not given.
    pub fn render_settings(&self, watch: bool, default_dir: Option<PathBuf>) -> anyhow::Result<RenderSettings> {
        let shaders = match self.shader_dir.clone().or(default_dir) {
            Some(dir) if !dir.is_dir() => anyhow::bail!("--shader-dir {}: not a folder", dir.display()),
            Some(dir) => ShaderSource::Folder { dir, watch },
            None => ShaderSource::Embedded,
        };
        let mut settings = RenderSettings {
            tonemapper: self
                .tonemap
                .unwrap_or(if self.reference() { TonemapArg::None } else { TonemapArg::Neutral })
                .into(),
            clear_color: self.clear_color().map(f64::from),
            shaders,
            light_walk: match self.light_walk {
                LightWalkArg::Auto => LightWalk::Auto,
                LightWalkArg::Clustered => LightWalk::Clustered,
                LightWalkArg::Compute => LightWalk::ClusteredCompute,
                LightWalkArg::All => LightWalk::AllLights,
                LightWalkArg::Unbounded => LightWalk::AllUnbounded,
            },
            debug_view: match self.debug_view {
                DebugViewArg::None => DebugView::None,
                DebugViewArg::Clusters => DebugView::ClusterHeat,
                DebugViewArg::Cascades => DebugView::Cascades,
                DebugViewArg::Normals => DebugView::Normals,
                DebugViewArg::Uvs => DebugView::Uvs,
            },
            shadows: ShadowSettings { max_distance: self.shadow_distance, ..Default::default() },
            gpu_culling: !self.no_culling,
            max_anisotropy: self.anisotropy,
            occlusion_culling: match self.occlusion {
                OcclusionArg::Auto => OcclusionCulling::Auto,
                OcclusionArg::On => OcclusionCulling::On,
                OcclusionArg::Off => OcclusionCulling::Off,
            },
            triangle_culling: match self.triangle_culling {
                OcclusionArg::Auto => TriangleCulling::Auto,
                OcclusionArg::On => TriangleCulling::On,
                OcclusionArg::Off => TriangleCulling::Off,
            },
            raster: match self.raster {
                Some(RasterArg::Auto) | None => Raster::Auto,
                Some(RasterArg::Hardware) => Raster::Hardware,
                Some(RasterArg::Compute) => Raster::Compute,
            },
            environment: EnvironmentSettings { cube_size: self.env_size.0, ..Default::default() },
            post: PostSettings {
                bloom: self.bloom.map(|strength| BloomSettings { strength, ..Default::default() }),
                fxaa: self.fxaa,
                auto_exposure: self.auto_exposure.then(|| AutoExposure {
                    min_ev100: self.ev_range.0,
                    max_ev100: self.ev_range.1,
                    compensation: self.exposure_compensation,
                    ..Default::default()
                }),
            },
            ..Default::default()
        };
        // The preset first, then whichever of its settings were given alone.
        self.quality.apply(&mut settings);
        if let Some(msaa) = self.msaa {
            settings.msaa = msaa;
        }
        if let Some(resolve) = self.msaa_resolve {
            settings.msaa_resolve = resolve.into();
        }
        if let Some(clusters) = self.clusters {
            settings.clusters = clusters;
        }
        if let Some(cutoff) = self.light_cutoff {
            settings.light_cutoff = cutoff;
        }
        if let Some(size) = self.shadow_atlas {
            settings.shadows.atlas_size = size;
        }
        if let Some(cascades) = self.cascades {
            settings.shadows.cascades = cascades;
        }
        settings.shadows.slope_bias = self.shadow_slope_bias;
        settings.shadows.normal_bias = self.shadow_normal_bias;
        if let Some(filter) = self.shadow_filter {
            settings.shadows.filter = match filter {
                ShadowFilterArg::Pcf => ShadowFilter::Pcf,
                ShadowFilterArg::Pcss => ShadowFilter::Pcss,
            };
        }
        settings.validate().map_err(|e| {
            let flag = match &e {
                SettingsError::Msaa(_) => "--msaa",
                SettingsError::Clusters(_) => "--clusters",
                SettingsError::LightCutoff(_) => "--light-cutoff",
                SettingsError::Environment(_) => "--env-size",
                SettingsError::Post(m) if m.contains("bloom") => "--bloom",
                SettingsError::Post(_) => "--auto-exposure / --ev-range / --exposure-compensation",
                SettingsError::Anisotropy(_) => "--anisotropy",
                SettingsError::Shadows(s) => match s.name {
                    "atlas_size" => "--shadow-atlas",
                    "cascades" => "--cascades",
                    "max_distance" => "--shadow-distance",
                    "slope_bias" => "--shadow-slope-bias",
                    "normal_bias" => "--shadow-normal-bias",
                    _ => "shadow settings",
                },
            };
            anyhow::anyhow!("{flag}: {e}")
        })?;
        Ok(settings)
    }
}

#[cfg(test)]
mod limit_help_tests {
    use penumbra_engine::import::{ImportLimits, Limit};

    #[test]
    fn limit_help_lists_every_limit_with_its_true_default() {
        let defaults = ImportLimits::default();
        let mut seen = Vec::new();
        for setting in
            super::LIMIT_HELP.lines().filter_map(|l| l.strip_prefix("  ")).map(|l| l.split(' ').next().unwrap())
        {
            let mut parsed = ImportLimits { vertices: 0, ..defaults };
            parsed.apply(setting).unwrap();
            let name = setting.split('=').next().unwrap();
            let limit = Limit::from_name(name).unwrap();
            assert_eq!(parsed.get(limit), defaults.get(limit), "{setting}");
            seen.push(limit);
        }
        assert_eq!(seen, Limit::ALL, "every limit, in Limit::ALL's order");
    }
}

#[cfg(test)]
mod cpu_compile_tests {
    use clap::Parser;
    use penumbra_render::gpu::context::CpuShaderCompiles;

    use super::Cli;

    fn mode(args: &[&str]) -> CpuShaderCompiles {
        let cli = Cli::try_parse_from(std::iter::once("penumbra").chain(args.iter().copied())).unwrap();
        cli.cpu_shader_compile.mode(cli.command.watches_shaders())
    }

    #[test]
    fn compiles_are_fast_by_default_only_while_shaders_are_watched() {
        // Watching: the reload benchmark, and the viewer with a shader folder (this test runs
        // from the repository, so the viewer would watch its shaders/ too).
        assert_eq!(mode(&["bench", "--shader-edits", "3"]), CpuShaderCompiles::Fast);
        assert_eq!(mode(&["view", "--shader-dir", "shaders"]), CpuShaderCompiles::Fast);
        assert!(super::repository_shaders().is_some());
        assert_eq!(mode(&["view"]), CpuShaderCompiles::Fast);
        // Not watching: frames matter more than compile latency.
        assert_eq!(mode(&["bench"]), CpuShaderCompiles::Optimized);
        assert_eq!(mode(&["render", "scene.glb", "--out", "x.png"]), CpuShaderCompiles::Optimized);
        assert_eq!(
            mode(&["render", "scene.glb", "--out", "x.png", "--shader-dir", "shaders"]),
            CpuShaderCompiles::Optimized
        );
        // An explicit choice wins either way.
        assert_eq!(
            mode(&["--cpu-shader-compile", "optimized", "bench", "--shader-edits", "3"]),
            CpuShaderCompiles::Optimized
        );
        assert_eq!(
            mode(&["--cpu-shader-compile", "fast", "render", "s.glb", "--out", "x.png"]),
            CpuShaderCompiles::Fast
        );
    }
}
