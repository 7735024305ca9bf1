//! The GPU context: instance, adapter, device and queue, shared by every render-world owner.
//!
//! Adapter choice: `WGPU_BACKEND` limits the backends (wgpu's own variable), `WGPU_ADAPTER_NAME`
//! picks by substring; otherwise Vulkan is preferred over other backends, and a discrete GPU over
//! an integrated one over a CPU (software) one. Headless rendering and window surfaces use the
//! same context; a window passes its surface so that only adapters able to present are chosen.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::gpu::array_layers::ArrayLayers;
use crate::pipelines::PipelineCacheDir;

/// How a CPU rasteriser compiles shaders: Mesa's llvmpipe (lavapipe) reads the choice once, when
/// the process's first device is made. Other drivers ignore it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CpuShaderCompiles {
    /// LLVM's optimisation passes and optimising code generation (Mesa's default).
    #[default]
    Optimized,
    /// Without them (`GALLIVM_PERF=nopt`): on lavapipe a hot reload takes markedly less time and
    /// frames take longer, with the same pixels (docs/shaders.md, "Compile mode while
    /// watching"). Pays off where compile latency matters more than frame time:
    /// editing shaders on a machine without a GPU (the viewer's choice while it watches them).
    Fast,
}

impl CpuShaderCompiles {
    /// Applies the choice for the rest of the process. A `GALLIVM_PERF` already in the
    /// environment is the user's and is left alone. Returns what was applied, for the log.
    ///
    /// # Safety
    /// Call before any GPU instance exists (Mesa reads the variable when it makes its first
    /// device) and while no other thread reads or writes the environment, as
    /// `std::env::set_var` requires: first thing in `main`.
    pub unsafe fn apply(self) -> Option<&'static str> {
        if self != CpuShaderCompiles::Fast || std::env::var_os("GALLIVM_PERF").is_some() {
            return None;
        }
        // SAFETY: the caller guarantees no other thread touches the environment.
        unsafe { std::env::set_var("GALLIVM_PERF", "nopt") };
        Some("GALLIVM_PERF=nopt")
    }

    /// The choice this process runs with (Mesa's variable, however it was set), for display.
    /// Read on the first call and kept, as Mesa reads the variable once: call it once the first
    /// device exists (the Stats panel asks every frame it shows).
    pub fn in_effect() -> Self {
        static IN_EFFECT: std::sync::OnceLock<CpuShaderCompiles> = std::sync::OnceLock::new();
        *IN_EFFECT.get_or_init(|| Self::from_gallivm_perf(std::env::var("GALLIVM_PERF").ok().as_deref()))
    }

    /// What Mesa makes of a `GALLIVM_PERF` value: flags separated by anything but letters,
    /// digits and `_`, with `all` for every flag; `nopt` among them or not.
    fn from_gallivm_perf(value: Option<&str>) -> Self {
        let nopt = value.is_some_and(|v| {
            v.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).any(|f| f == "nopt" || f == "all")
        });
        if nopt { CpuShaderCompiles::Fast } else { CpuShaderCompiles::Optimized }
    }
}

/// What to install when no adapter is found: the message every caller (CLI, tests) prints.
pub const INSTALL_HINT: &str = "no GPU adapter found. Penumbra needs a Vulkan driver (or GL through EGL). \
On Debian/Ubuntu without a GPU install the software Vulkan driver: `apt-get install -y mesa-vulkan-drivers`";

#[derive(Debug, thiserror::Error)]
pub enum ContextError {
    #[error("{INSTALL_HINT} (backends searched: {backends:?}{filter})")]
    NoAdapter { backends: wgpu::Backends, filter: String },
    #[error("cannot create the GPU device on {adapter}: {source}")]
    Device {
        adapter: String,
        #[source]
        source: wgpu::RequestDeviceError,
    },
}

/// Device capabilities Penumbra adapts to.
#[derive(Debug, Clone, Copy)]
pub struct Capabilities {
    /// GPU timestamps at pass boundaries (used by stats and `penumbra bench`).
    pub timestamps: bool,
    /// Indirect draws that honour their first instance, which GPU culling's draws need
    /// (Vulkan, Metal, DX12; not GL).
    pub indirect_first_instance: bool,
    /// The deferred-lights compute pass (`LightWalk::ClusteredCompute`): not on GL, where naga
    /// cannot translate its depth loads and wgpu cannot render into a multisampled target that
    /// is also bound for sampling. Local lights are then shaded in the fragment shader.
    pub deferred_lights: bool,
    /// Occlusion culling's depth pyramid: not on GL, where naga cannot translate its loads from
    /// the depth texture. Frustum culling still runs there.
    pub occlusion_culling: bool,
    /// Depth reaches the depth buffer as the vertex shader computed it. Not on GL: wgpu's GL
    /// backend rewrites clip z to z·2 − w (GL's −1..1 depth range), which rounds depth at about
    /// 2⁻²⁴ of 1 instead of 2⁻²⁴ of itself, so reverse-Z's extra precision far away is lost
    /// there and shadow lookups need a small depth tolerance (`ShadowOrchestrator`).
    pub exact_depth: bool,
    /// How many layers array textures need so that the backend binds them as arrays (GL picks a
    /// texture's kind from its shape).
    pub array_layers: ArrayLayers,
    /// An sRGB texture can be viewed as unorm (`DownlevelFlags::VIEW_FORMATS`; not GL): mip
    /// generation then applies the sRGB curve in its shader, the same on every driver.
    pub srgb_unorm_views: bool,
    /// Bits of sub-pixel precision the rasteriser snaps vertices to: how far triangle culling
    /// must allow a vertex to move (`features::culling`). The driver's own figure on Vulkan;
    /// elsewhere 4, the least Vulkan allows (D3D12 requires 8).
    pub subpixel_bits: u32,
    /// Multisampled colour is resolved by a pass of Penumbra's own (`shaders/resolve.wgsl`)
    /// rather than by the render pass. On CPU rasterisers through Vulkan: lavapipe (older
    /// releases at least) resolves through a blit shader it builds anew in every process,
    /// outside its shader cache (docs/performance.md, "A headless screenshot"); the pass's
    /// shader is cached like every other. Not on GL, where wgpu cannot render into a multisampled
    /// texture that is also bound for sampling; GPUs resolve faster themselves.
    pub shader_msaa_resolve: bool,
    /// Fragment shaders can write a sample mask (`@builtin(sample_mask)`), with which masked
    /// materials alpha-test each sample at MSAA 4 (`AlphaTest::SampleMask`). Not on GL, where
    /// naga assigns the mask to GLSL's `int[]` output as a `uint` and the driver rejects the
    /// shader (wgpu issue #6085): masked draws are shaded once per sample there instead
    /// (`AlphaTest::SampleRate`), which tests the same samples at four times the fragment work.
    pub sample_mask_output: bool,
    /// Fragment shaders can run once per sample (`DownlevelFlags::MULTISAMPLED_SHADING`: GL 4.0,
    /// GLES 3.2 or OES_sample_variables on GL). Where neither this nor a sample mask is
    /// available, masked draws test alpha once per pixel at every sample count.
    pub sample_rate_shading: bool,
    /// Texels can be copied from where they were decoded (`host_memory`): the import
    /// alignment, on a CPU rasteriser whose Vulkan driver has VK_EXT_external_memory_host.
    pub host_import_alignment: Option<u64>,
    /// 64-bit integers with atomic min and max in storage buffers
    /// (`Features::SHADER_INT64_ATOMIC_MIN_MAX`: Vulkan with VK_KHR_shader_atomic_int64,
    /// lavapipe included; DX12 SM 6.6; Metal): the visibility buffer (`Raster::Compute`). Where
    /// it is missing (GL), frames rasterise in hardware whatever the setting says.
    pub visibility_raster: bool,
    /// The GPU runs graphics work on a small part of the chip, so rasterising in compute pays
    /// (`Raster::Auto`). NVIDIA's Hopper compute GPUs: "only two TPCs in both the SXM5 and PCIe
    /// H100 GPUs are graphics-capable" of 66 (NVIDIA H100 Tensor Core GPU Architecture); the
    /// H200, H800, H20 and GH200 carry the same GH100 chip. On the H100 a multisampled frame's
    /// fixed-function work alone is dear, and the benchmark frames take several times less GPU
    /// time in compute (docs/performance.md, "Rasterising in compute").
    pub few_graphics_units: bool,
}

/// Whether the adapter with this PCI vendor and name is a GPU with few graphics units (see
/// `Capabilities::few_graphics_units`).
pub fn few_graphics_units((vendor, name): (u32, &str)) -> bool {
    const NVIDIA: u32 = 0x10de;
    const HOPPER_COMPUTE: [&str; 5] = ["H100", "H200", "H800", "H20", "GH200"];
    vendor == NVIDIA && HOPPER_COMPUTE.iter().any(|n| name.contains(n))
}

/// The rasteriser's sub-pixel precision, as the driver reports it (Vulkan), else a lower bound.
fn subpixel_bits(adapter: &wgpu::Adapter) -> u32 {
    match adapter.get_info().backend {
        wgpu::Backend::Vulkan => {
            // SAFETY: the adapter is Vulkan (checked above); only its properties are read.
            let bits = unsafe {
                adapter.as_hal::<wgpu::hal::api::Vulkan>().map(|a| {
                    let instance = a.shared_instance().raw_instance();
                    instance.get_physical_device_properties(a.raw_physical_device()).limits.sub_pixel_precision_bits
                })
            };
            bits.unwrap_or(4).clamp(4, 16)
        }
        wgpu::Backend::Dx12 => 8,
        _ => 4,
    }
}

#[derive(Clone)]
pub struct GpuContext {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: Arc<wgpu::AdapterInfo>,
    pub caps: Capabilities,
    /// Set by the device-lost callback (a driver reset, a removed GPU, `Device::destroy`).
    lost: Arc<AtomicBool>,
    /// The first out-of-memory error no error scope caught, until the renderer takes it.
    out_of_memory: Arc<std::sync::Mutex<Option<String>>>,
    /// How the adapter was chosen, to choose again after a loss.
    request: AdapterRequest,
}

/// How to pick the adapter.
#[derive(Debug, Clone, Default)]
pub struct AdapterRequest {
    /// Only these backends (default: `WGPU_BACKEND`, else all).
    pub backends: Option<wgpu::Backends>,
    /// Substring of the adapter name (default: `WGPU_ADAPTER_NAME`).
    pub name: Option<String>,
    /// Where the renderer keeps compiled pipelines between runs (`pipelines::store`).
    pub pipeline_cache: PipelineCacheDir,
}

impl GpuContext {
    /// Where the renderer keeps compiled pipelines between runs, as requested.
    pub fn pipeline_cache_dir(&self) -> &PipelineCacheDir {
        &self.request.pipeline_cache
    }

    /// A context for headless rendering.
    pub fn new_headless(request: &AdapterRequest) -> Result<Self, ContextError> {
        let explicit = request.backends.is_some() || std::env::var_os("WGPU_BACKEND").is_some();
        if !explicit {
            // An instance of every backend sets up EGL (loading Mesa's GL driver) even when
            // Vulkan is chosen: a noticeable part of a headless screenshot's CPU time. So Vulkan
            // alone first; the full instance (Vulkan tried again, then the rest) only when it has
            // no adapter, so that the error still names every backend.
            let vulkan = AdapterRequest { backends: Some(wgpu::Backends::VULKAN), ..request.clone() };
            match Self::with_instance(wgpu::Instance::new(Self::instance_descriptor(&vulkan)), &vulkan, None) {
                Err(ContextError::NoAdapter { .. }) => {}
                Ok(mut ctx) => {
                    // Choosing again after a device loss may fall back to other backends.
                    ctx.request = request.clone();
                    return Ok(ctx);
                }
                Err(e) => return Err(e),
            }
        }
        let instance = wgpu::Instance::new(Self::instance_descriptor(request));
        Self::with_instance(instance, request, None)
    }

    pub fn instance_descriptor(request: &AdapterRequest) -> wgpu::InstanceDescriptor {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        if let Some(b) = request.backends {
            desc.backends = b;
        }
        desc
    }

    /// A context on an existing instance; with `surface`, only adapters that can present to it.
    pub fn with_instance(
        instance: wgpu::Instance,
        request: &AdapterRequest,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<Self, ContextError> {
        let name = request.name.clone().or_else(|| std::env::var("WGPU_ADAPTER_NAME").ok());
        let explicit =
            request.backends.or_else(|| std::env::var_os("WGPU_BACKEND").map(|_| wgpu::Backends::all().with_env()));
        // Vulkan first, everything else only when Vulkan has nothing: probing GL through EGL is
        // slow at start-up (where lavapipe is installed), a large part of a headless screenshot's
        // budget (docs/performance.md, "A headless screenshot").
        let passes = match explicit {
            Some(b) => vec![b],
            None => vec![wgpu::Backends::VULKAN, wgpu::Backends::all() - wgpu::Backends::VULKAN],
        };
        let mut chosen = None;
        for backends in &passes {
            let adapters = pollster::block_on(instance.enumerate_adapters(*backends));
            chosen = adapters
                .into_iter()
                .filter(|a| surface.is_none_or(|s| a.is_surface_supported(s)))
                .filter(|a| name.as_ref().is_none_or(|n| a.get_info().name.to_lowercase().contains(&n.to_lowercase())))
                .max_by_key(|a| adapter_rank(&a.get_info()));
            if chosen.is_some() {
                break;
            }
        }
        let adapter = chosen.ok_or_else(|| ContextError::NoAdapter {
            backends: passes.iter().fold(wgpu::Backends::empty(), |a, b| a | *b),
            filter: name.map(|n| format!(", name containing {n:?}")).unwrap_or_default(),
        })?;
        let info = adapter.get_info();
        let available = adapter.features();
        let timestamps = available.contains(wgpu::Features::TIMESTAMP_QUERY);
        let indirect_first_instance = available.contains(wgpu::Features::INDIRECT_FIRST_INSTANCE)
            && adapter.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::INDIRECT_EXECUTION);
        let deferred_lights = info.backend != wgpu::Backend::Gl;
        let occlusion_culling = info.backend != wgpu::Backend::Gl;
        let exact_depth = info.backend != wgpu::Backend::Gl;
        let sample_mask_output = info.backend != wgpu::Backend::Gl;
        let sample_rate_shading =
            adapter.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::MULTISAMPLED_SHADING);
        let array_layers = ArrayLayers::for_backend(info.backend);
        let shader_msaa_resolve = info.device_type == wgpu::DeviceType::Cpu && info.backend == wgpu::Backend::Vulkan;
        let srgb_unorm_views = adapter.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::VIEW_FORMATS);
        let subpixel_bits = subpixel_bits(&adapter);
        let int64_atomics = wgpu::Features::SHADER_INT64 | wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX;
        let visibility_raster = available.contains(int64_atomics);
        let few_graphics_units = few_graphics_units((info.vendor, &info.name));
        let mut features = wgpu::Features::empty();
        if visibility_raster {
            features |= int64_atomics;
        }
        if timestamps {
            features |= wgpu::Features::TIMESTAMP_QUERY;
        }
        if indirect_first_instance {
            features |= wgpu::Features::INDIRECT_FIRST_INSTANCE;
        }
        // Compiled pipelines kept between runs (pipelines::store), where the backend can.
        features |= available & wgpu::Features::PIPELINE_CACHE;
        // Block-compressed texture formats the adapter samples: KTX2 textures go up in one of
        // them where they can (resources::textures), else as RGBA8.
        features |= available
            & (wgpu::Features::TEXTURE_COMPRESSION_BC
                | wgpu::Features::TEXTURE_COMPRESSION_ASTC
                | wgpu::Features::TEXTURE_COMPRESSION_ETC2);
        let desc = wgpu::DeviceDescriptor {
            label: Some("penumbra"),
            required_features: features,
            required_limits: adapter.limits(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        };
        // With host-memory imports where the Vulkan driver has them (`host_memory`); a device
        // that cannot be opened so is made the ordinary way, without them.
        let mut host_import_alignment = crate::gpu::host_memory::import_alignment(&adapter);
        // SAFETY: `import_alignment` found a Vulkan adapter with the extension.
        let opened = host_import_alignment.and_then(|_| {
            match unsafe { crate::gpu::host_memory::open_device(&adapter, &desc) } {
                Ok(pair) => Some(pair),
                Err(e) => {
                    tracing::warn!("device with host-memory imports: {e}; uploading textures through staging copies");
                    None
                }
            }
        });
        if opened.is_none() {
            host_import_alignment = None;
        }
        let (device, queue) = match opened {
            Some(pair) => pair,
            None => pollster::block_on(adapter.request_device(&desc))
                .map_err(|source| ContextError::Device { adapter: info.name.clone(), source })?,
        };
        tracing::info!(
            "GPU: {} ({:?}, {:?}, driver {}; {subpixel_bits} sub-pixel bits)",
            info.name,
            info.backend,
            info.device_type,
            info.driver_info
        );
        let lost = Arc::new(AtomicBool::new(false));
        let flag = lost.clone();
        device.set_device_lost_callback(move |reason, message| {
            flag.store(true, Ordering::Release);
            tracing::error!("the GPU device was lost ({reason:?}): {message}");
        });
        // wgpu's default handler panics on any uncaptured error, which is right for Penumbra's
        // own bugs; once the device is lost every call fails, and those failures are expected
        // until the renderer replaces the device. Running out of memory is not a bug: the first
        // such error is kept for the renderer to report (the frame fails with it), and what
        // fails after it, using what could not be made, is its consequence.
        let flag = lost.clone();
        let out_of_memory = Arc::new(std::sync::Mutex::new(None::<String>));
        let oom = out_of_memory.clone();
        let ran_out = AtomicBool::new(false);
        device.on_uncaptured_error(Arc::new(move |error: wgpu::Error| {
            if flag.load(Ordering::Acquire) {
                tracing::debug!("on a lost device: {error}");
            } else if matches!(error, wgpu::Error::OutOfMemory { .. }) {
                ran_out.store(true, Ordering::Release);
                oom.lock().unwrap_or_else(|e| e.into_inner()).get_or_insert_with(|| error.to_string());
            } else if ran_out.load(Ordering::Acquire) {
                tracing::debug!("after running out of GPU memory: {error}");
            } else {
                panic!("wgpu error: {error}");
            }
        }));
        Ok(Self {
            instance,
            adapter,
            device,
            queue,
            info: Arc::new(info),
            caps: Capabilities {
                timestamps,
                indirect_first_instance,
                visibility_raster,
                few_graphics_units,
                deferred_lights,
                occlusion_culling,
                exact_depth,
                array_layers,
                srgb_unorm_views,
                shader_msaa_resolve,
                sample_mask_output,
                sample_rate_shading,
                host_import_alignment,
                subpixel_bits,
            },
            lost,
            out_of_memory,
            request: request.clone(),
        })
    }

    /// The out-of-memory error that no error scope caught since the last call, if any.
    pub fn take_out_of_memory(&self) -> Option<String> {
        self.out_of_memory.lock().unwrap_or_else(|e| e.into_inner()).take()
    }

    /// Whether the device was lost; a lost device never comes back (make a new context).
    pub fn is_lost(&self) -> bool {
        self.lost.load(Ordering::Acquire)
    }

    /// A new headless context chosen as this one was: what a renderer without a window uses to
    /// recover from a lost device.
    pub fn recreate_headless(&self) -> Result<Self, ContextError> {
        Self::new_headless(&self.request)
    }

    /// "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)".
    pub fn describe(&self) -> String {
        format!("{} ({:?})", self.info.name, self.info.backend)
    }
}

/// Spaces out retries of something that failed (making a new device after a loss): the first
/// retry at once, then after 0.25 s, doubling to at most 8 s; `reset` after a success.
#[derive(Debug, Clone, Default)]
pub struct RetryBackoff {
    next: Option<std::time::Instant>,
    delay: std::time::Duration,
}

impl RetryBackoff {
    const FIRST: std::time::Duration = std::time::Duration::from_millis(250);
    const MAX: std::time::Duration = std::time::Duration::from_secs(8);

    /// Whether a retry is due now.
    pub fn due(&self) -> bool {
        self.next.is_none_or(|t| std::time::Instant::now() >= t)
    }

    /// Records a failed try: the next one waits longer.
    pub fn failed(&mut self) {
        self.delay = if self.delay.is_zero() { Self::FIRST } else { (self.delay * 2).min(Self::MAX) };
        self.next = Some(std::time::Instant::now() + self.delay);
    }

    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// The wait before the next try.
    pub fn delay(&self) -> std::time::Duration {
        self.delay
    }
}

fn adapter_rank(info: &wgpu::AdapterInfo) -> (u8, u8) {
    let backend = match info.backend {
        wgpu::Backend::Vulkan => 3,
        wgpu::Backend::Metal | wgpu::Backend::Dx12 => 2,
        wgpu::Backend::Gl => 1,
        _ => 0,
    };
    let device = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 4,
        wgpu::DeviceType::IntegratedGpu => 3,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 1,
        wgpu::DeviceType::Other => 0,
    };
    (backend, device)
}

#[cfg(test)]
mod backoff_tests {
    use super::RetryBackoff;

    #[test]
    fn retries_double_up_to_a_ceiling_and_reset() {
        let mut b = RetryBackoff::default();
        assert!(b.due(), "the first retry is at once");
        let delays: Vec<u128> = (0..8)
            .map(|_| {
                b.failed();
                b.delay().as_millis()
            })
            .collect();
        assert_eq!(delays, [250, 500, 1000, 2000, 4000, 8000, 8000, 8000]);
        assert!(!b.due(), "waits after a failure");
        b.reset();
        assert!(b.due());
    }
}

#[cfg(test)]
mod raster_choice_tests {
    use super::few_graphics_units;

    #[test]
    fn hopper_compute_gpus_rasterise_in_compute_by_default() {
        assert!(few_graphics_units((0x10de, "NVIDIA H100 80GB HBM3")));
        assert!(few_graphics_units((0x10de, "NVIDIA H200")));
        assert!(!few_graphics_units((0x10de, "NVIDIA GeForce RTX 4090")));
        assert!(!few_graphics_units((0x10005, "llvmpipe (LLVM 15.0.6, 256 bits)")));
        // The name alone is not enough.
        assert!(!few_graphics_units((0x1002, "H100")));
    }
}

#[cfg(test)]
mod cpu_compile_tests {
    use super::CpuShaderCompiles;

    #[test]
    fn nopt_among_mesas_flags_means_fast_compiles() {
        assert_eq!(CpuShaderCompiles::from_gallivm_perf(None), CpuShaderCompiles::Optimized);
        assert_eq!(CpuShaderCompiles::from_gallivm_perf(Some("")), CpuShaderCompiles::Optimized);
        assert_eq!(CpuShaderCompiles::from_gallivm_perf(Some("nopt")), CpuShaderCompiles::Fast);
        assert_eq!(CpuShaderCompiles::from_gallivm_perf(Some("brilinear,nopt")), CpuShaderCompiles::Fast);
        assert_eq!(CpuShaderCompiles::from_gallivm_perf(Some("no_quad_lod")), CpuShaderCompiles::Optimized);
        assert_eq!(CpuShaderCompiles::from_gallivm_perf(Some("noptx")), CpuShaderCompiles::Optimized);
        assert_eq!(CpuShaderCompiles::from_gallivm_perf(Some("no_quad_lod|nopt")), CpuShaderCompiles::Fast);
        assert_eq!(CpuShaderCompiles::from_gallivm_perf(Some("all")), CpuShaderCompiles::Fast);
    }
}
