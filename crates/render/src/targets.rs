//! Frame targets: the linear HDR colour target (`Rgba16Float`), its MSAA twin when multisampling,
//! and the reverse-Z depth target (`Depth32Float`, cleared to 0); with deferred local lights also
//! the surface targets opaque fragments write, and the local light the compute pass writes (see
//! `features/deferred_lights/mod.rs`). A frame whose HDR colour nothing reads has no HDR target
//! at all (the forward pass tonemaps and draws into the output), and a frame whose draws cannot
//! cover a pixel twice has no depth target; [`TargetNeeds`] decides both. With MSAA and
//! [`MsaaResolve::Display`], such a frame draws tonemapped samples into a multisampled target
//! of the output's (sRGB) format instead, resolved into the output. Recreated only when the
//! size, the sample count, whether lights are deferred or whether there is an HDR, a
//! display-space multisampled or a depth target changes.

use penumbra_engine::mesh::SelfOverlap;

use crate::gpu::formats::{DEPTH_FORMAT, HDR_FORMAT, LOCAL_LIGHT_FORMAT, SURFACE_SHAPE_FORMAT};

/// A 2D target of `size` (at least 1×1) with one mip level: the shape of every frame target.
pub fn render_target(
    device: &wgpu::Device,
    label: &str,
    size: (u32, u32),
    samples: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: size.0.max(1), height: size.1.max(1), depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: samples,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// Where multisampled frames average their samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MsaaResolve {
    /// Average the samples' HDR radiance, then tonemap: an edge pixel is the display transform
    /// of the mean radiance, as a path tracer's pixel filter makes it (the references).
    #[default]
    Radiance,
    /// Tonemap each sample and average the display colours (in linear, through an sRGB
    /// target): a frame that nothing else needs HDR colour for then has neither an HDR target
    /// nor a tonemap pass, and half the bytes per sample (what Bevy draws without an HDR
    /// camera). Edges against bright surfaces keep their coverage gradient instead of
    /// saturating. Needs an sRGB output (a headless one is; a window surface without an sRGB
    /// format resolves radiance).
    Display,
}

/// What decides whether a frame has an HDR colour target and a depth target.
#[derive(Debug, Clone, Copy)]
pub struct TargetNeeds {
    pub msaa: u32,
    /// Multisampled frames may resolve display colours ([`MsaaResolve::Display`], sRGB output).
    pub display_resolve: bool,
    /// `RenderSettings::keep_hdr`: HDR colour is read back.
    pub keep_hdr: bool,
    pub deferred_lights: bool,
    pub blended_draws: bool,
    /// The environment is shown behind the scene.
    pub background: bool,
    pub gizmos: bool,
    /// Bloom, automatic exposure or FXAA.
    pub post_processing: bool,
    pub occlusion_culling: bool,
    pub opaque: OpaqueDraws,
}

/// The frame's opaque and masked draws, as far as depth is concerned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OpaqueDraws {
    None,
    /// One instance: whether its mesh's front faces can overlap, and whether back faces are
    /// culled.
    One {
        overlap: SelfOverlap,
        cull_back_faces: bool,
    },
    Many,
}

impl TargetNeeds {
    /// Whether anything but the tonemap pass reads the HDR colour. Without, the forward shader
    /// tonemaps and draws straight into the output (no HDR target, no tonemap pass). With MSAA
    /// only when display colours may be resolved: a resolve of tonemapped samples differs from
    /// the tonemap of resolved radiance at every edge.
    pub fn hdr(&self) -> bool {
        (self.msaa != 1 && !self.display_resolve)
            || self.keep_hdr
            || self.deferred_lights
            || self.blended_draws
            || self.background
            || self.gizmos
            || self.post_processing
    }

    /// Whether anything drawn can cover a pixel twice, or reads depth. Not when the only opaque
    /// instance's front faces cannot overlap (a single triangle; a convex surface with back
    /// faces culled) and nothing else is drawn.
    pub fn depth(&self) -> bool {
        let opaque_overlaps = match self.opaque {
            OpaqueDraws::None => false,
            OpaqueDraws::One { overlap: SelfOverlap::Never, .. } => false,
            OpaqueDraws::One { overlap: SelfOverlap::WhenBackFacesCulled, cull_back_faces } => !cull_back_faces,
            OpaqueDraws::One { overlap: SelfOverlap::Possible, .. } | OpaqueDraws::Many => true,
        };
        opaque_overlaps || self.blended_draws || self.occlusion_culling || self.deferred_lights || self.gizmos
    }
}

/// Which of the optional targets to make (see [`TargetNeeds`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TargetsMade {
    /// The HDR colour target (else the frame draws straight into the output).
    pub hdr: bool,
    pub depth: bool,
    /// Depth bound for sampling too (occlusion culling's depth pyramid).
    pub depth_sampled: bool,
    /// The output's format: that of the display-space multisampled target (see
    /// [`FrameTargets::display_msaa`]).
    pub output_format: wgpu::TextureFormat,
    /// `Capabilities::shader_msaa_resolve`: multisampled colour is bound for the resolve pass.
    pub shader_resolve: bool,
    /// The HDR colour is written by a compute pass (the visibility buffer's shading).
    pub hdr_storage: bool,
}

pub struct FrameTargets {
    /// Unique among the targets of this process: a pass that binds them keeps its bind groups
    /// while the id stays.
    pub id: u64,
    pub size: (u32, u32),
    pub samples: u32,
    /// `None`: the frame draws straight into the output.
    pub hdr: Option<HdrTargets>,
    /// Without an HDR target but with MSAA: tonemapped samples, in the output's (sRGB) format,
    /// resolved into the output.
    pub display_msaa: Option<wgpu::TextureView>,
    /// `None`: nothing drawn this frame can cover a pixel twice (see `Renderer::render`).
    pub depth_view: Option<wgpu::TextureView>,
    /// The depth target can be bound for sampling (occlusion culling, deferred lights).
    pub depth_sampled: bool,
    pub deferred: Option<DeferredTargets>,
    /// Multisampled colour is resolved by `features::resolve`, not by the render pass
    /// (`Capabilities::shader_msaa_resolve`).
    pub shader_resolve: bool,
    /// The HDR colour can be written by compute (`TargetsMade::hdr_storage`).
    pub hdr_storage: bool,
}

/// Where a pass that ends the frame's drawing draws its colour and how it is resolved.
pub struct ColorAttachment<'a> {
    pub draw: &'a wgpu::TextureView,
    /// The render pass's resolve target.
    pub pass_resolve: Option<&'a wgpu::TextureView>,
    /// Resolved by `features::resolve` after the pass instead (`draw` is then stored).
    pub shader_resolve: Option<&'a wgpu::TextureView>,
}

pub struct HdrTargets {
    /// Single-sampled HDR colour: rendered directly (MSAA 1) or resolved into (MSAA 4).
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    pub msaa_view: Option<wgpu::TextureView>,
}

/// What deferred local lights add: the surface each opaque sample holds (with roughness in the
/// colour's alpha), and the local light per pixel that the compute pass writes and the
/// composite adds (`features::deferred_lights` binds both).
pub struct DeferredTargets {
    pub surface_shape_view: wgpu::TextureView,
    pub local_light_view: wgpu::TextureView,
}

impl FrameTargets {
    /// `deferred`: lights are deferred (which needs the HDR target and depth). Without
    /// `made.hdr` and `made.depth` nothing is made but, with MSAA, the display-colour target.
    pub fn new(device: &wgpu::Device, size: (u32, u32), samples: u32, deferred: bool, made: TargetsMade) -> Self {
        static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let id = NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let TargetsMade { hdr, depth, depth_sampled, output_format, shader_resolve, hdr_storage } = made;
        let tex = |label, format, samples, usage| render_target(device, label, size, samples, format, usage);
        let attach = wgpu::TextureUsages::RENDER_ATTACHMENT;
        let sampled = wgpu::TextureUsages::TEXTURE_BINDING;
        let hdr = (hdr || deferred).then(|| {
            let storage = if hdr_storage { wgpu::TextureUsages::STORAGE_BINDING } else { wgpu::TextureUsages::empty() };
            let texture = tex(
                "hdr colour",
                HDR_FORMAT,
                1,
                attach | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC | storage,
            );
            let view = texture.create_view(&Default::default());
            // The deferred-lights pass reads the colour's alpha; a shader resolve all of it.
            let msaa_usage = if deferred || shader_resolve { attach | sampled } else { attach };
            let msaa_view = (samples > 1)
                .then(|| tex("hdr colour msaa", HDR_FORMAT, samples, msaa_usage).create_view(&Default::default()));
            HdrTargets { texture, view, msaa_view }
        });
        let display_usage = if shader_resolve { attach | sampled } else { attach };
        let display_msaa = (hdr.is_none() && samples > 1).then(|| {
            tex("display colour msaa", output_format, samples, display_usage).create_view(&Default::default())
        });
        // Sampled by the deferred-lights pass and by occlusion culling's depth pyramid; otherwise
        // only an attachment, which wgpu's GL backend needs of a multisampled texture (it cannot
        // render into a multisampled texture that is also bound for sampling: the frame is lost).
        let depth_usage = if depth_sampled || deferred { attach | sampled } else { attach };
        let depth_view = (depth || deferred)
            .then(|| tex("depth", DEPTH_FORMAT, samples, depth_usage).create_view(&Default::default()));
        let deferred = (deferred && hdr.is_some() && depth_view.is_some()).then(|| {
            let view = |t: wgpu::Texture| t.create_view(&Default::default());
            DeferredTargets {
                surface_shape_view: view(tex("surface shape", SURFACE_SHAPE_FORMAT, samples, attach | sampled)),
                local_light_view: view(tex(
                    "local light",
                    LOCAL_LIGHT_FORMAT,
                    1,
                    wgpu::TextureUsages::STORAGE_BINDING | sampled,
                )),
            }
        });
        Self { id, size, samples, hdr, display_msaa, depth_view, depth_sampled, deferred, shader_resolve, hdr_storage }
    }

    /// The single-sampled HDR colour, if the frame has one.
    pub fn hdr_view(&self) -> Option<&wgpu::TextureView> {
        self.hdr.as_ref().map(|h| &h.view)
    }

    /// Where the forward pass draws, and what it resolves into: the HDR targets, or else the
    /// output (`direct`), drawn into or (display-space MSAA) resolved into.
    pub fn color_attachment<'a>(&'a self, direct: &'a wgpu::TextureView) -> ColorAttachment<'a> {
        let (draw, resolve) = self.draw_and_resolve(direct);
        let (pass_resolve, shader_resolve) = if self.shader_resolve { (None, resolve) } else { (resolve, None) };
        ColorAttachment { draw, pass_resolve, shader_resolve }
    }

    fn draw_and_resolve<'a>(
        &'a self,
        direct: &'a wgpu::TextureView,
    ) -> (&'a wgpu::TextureView, Option<&'a wgpu::TextureView>) {
        match &self.hdr {
            Some(HdrTargets { view, msaa_view: Some(msaa), .. }) => (msaa, Some(view)),
            Some(HdrTargets { view, msaa_view: None, .. }) => (view, None),
            None => match &self.display_msaa {
                Some(msaa) => (msaa, Some(direct)),
                None => (direct, None),
            },
        }
    }

    pub fn bytes(&self) -> u64 {
        let made = Made {
            hdr: self.hdr.is_some(),
            display_msaa: self.display_msaa.is_some(),
            depth: self.depth_view.is_some(),
            deferred: self.deferred.is_some(),
        };
        made.bytes(self.size, self.samples)
    }

    /// [`FrameTargets::new`] inside error scopes: a device that cannot hold the targets (out of
    /// memory, or a size past its limits) is an error saying what was asked for and what it
    /// needs, with what a single-sampled frame would need, rather than wgpu's panic.
    pub fn try_new(
        device: &wgpu::Device,
        size: (u32, u32),
        samples: u32,
        deferred: bool,
        made: TargetsMade,
    ) -> Result<Self, TargetsError> {
        let memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let targets = Self::new(device, size, samples, deferred, made);
        let invalid = pollster::block_on(validation.pop());
        let out_of_memory = pollster::block_on(memory.pop());
        let Some(error) = out_of_memory.or(invalid) else { return Ok(targets) };
        let planned = |samples| Made::planned(samples, deferred, &made).bytes(size, samples);
        Err(TargetsError {
            size,
            samples,
            bytes: planned(samples),
            single_sampled_bytes: (samples > 1).then(|| planned(1)),
            reason: error.to_string(),
        })
    }
}

/// The frame's targets could not be made.
#[derive(Debug, Clone, thiserror::Error)]
#[error(
    "the frame's targets for {w}x{h} at MSAA {samples} need {need} of GPU memory and the device could not make them \
     ({reason}){hint}",
    w = size.0,
    h = size.1,
    need = mib(*bytes),
    hint = single_sampled_bytes.map_or_else(String::new, |b| format!("; MSAA 1 (--msaa 1) needs {}", mib(b)))
)]
pub struct TargetsError {
    pub size: (u32, u32),
    pub samples: u32,
    pub bytes: u64,
    pub single_sampled_bytes: Option<u64>,
    pub reason: String,
}

fn mib(bytes: u64) -> String {
    if bytes >= 1 << 30 {
        format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
    } else {
        format!("{:.0} MiB", bytes as f64 / (1u64 << 20) as f64)
    }
}

/// Which targets a frame has, for their sizes.
struct Made {
    hdr: bool,
    display_msaa: bool,
    depth: bool,
    deferred: bool,
}

impl Made {
    /// What [`FrameTargets::new`] makes for these arguments.
    fn planned(samples: u32, deferred: bool, made: &TargetsMade) -> Made {
        let hdr = made.hdr || deferred;
        Made { hdr, display_msaa: !hdr && samples > 1, depth: made.depth || deferred, deferred }
    }

    fn bytes(&self, size: (u32, u32), samples: u32) -> u64 {
        let px = size.0 as u64 * size.1 as u64;
        let samples = samples as u64;
        // Depth 4 B per sample; HDR 8 B per sample plus the single-sampled resolve target;
        // deferred lights add 8 B of surface per sample and 8 B of local light per pixel.
        let depth = if self.depth { px * 4 * samples } else { 0 };
        let hdr = if self.hdr { px * 8 * samples + if samples > 1 { px * 8 } else { 0 } } else { 0 };
        let deferred = if self.deferred { px * (8 * samples + 8) } else { 0 };
        let display = if self.display_msaa { px * 4 * samples } else { 0 };
        depth + hdr + deferred + display
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plain() -> TargetNeeds {
        TargetNeeds {
            msaa: 1,
            display_resolve: false,
            keep_hdr: false,
            deferred_lights: false,
            blended_draws: false,
            background: false,
            gizmos: false,
            post_processing: false,
            occlusion_culling: false,
            opaque: OpaqueDraws::Many,
        }
    }

    #[test]
    fn hdr_colour_only_when_something_reads_it() {
        assert!(!plain().hdr());
        for needs in [
            TargetNeeds { msaa: 4, ..plain() },
            TargetNeeds { keep_hdr: true, ..plain() },
            TargetNeeds { deferred_lights: true, ..plain() },
            TargetNeeds { blended_draws: true, ..plain() },
            TargetNeeds { background: true, ..plain() },
            TargetNeeds { gizmos: true, ..plain() },
            TargetNeeds { post_processing: true, ..plain() },
        ] {
            assert!(needs.hdr(), "{needs:?}");
        }
        // Resolving display colours, MSAA alone needs no HDR target; anything else still does.
        let display = TargetNeeds { msaa: 4, display_resolve: true, ..plain() };
        assert!(!display.hdr());
        assert!(TargetNeeds { post_processing: true, ..display }.hdr());
        assert!(TargetNeeds { background: true, ..display }.hdr());
    }

    #[test]
    fn depth_only_when_draws_can_overlap_or_something_reads_it() {
        let one =
            |overlap, cull_back_faces| TargetNeeds { opaque: OpaqueDraws::One { overlap, cull_back_faces }, ..plain() };
        assert!(!TargetNeeds { opaque: OpaqueDraws::None, ..plain() }.depth());
        assert!(!one(SelfOverlap::Never, false).depth());
        assert!(!one(SelfOverlap::WhenBackFacesCulled, true).depth());
        assert!(one(SelfOverlap::WhenBackFacesCulled, false).depth(), "double-sided convex");
        assert!(one(SelfOverlap::Possible, true).depth());
        assert!(plain().depth(), "many instances");
        let convex = one(SelfOverlap::WhenBackFacesCulled, true);
        for needs in [
            TargetNeeds { blended_draws: true, ..convex },
            TargetNeeds { occlusion_culling: true, ..convex },
            TargetNeeds { deferred_lights: true, ..convex },
            TargetNeeds { gizmos: true, ..convex },
        ] {
            assert!(needs.depth(), "{needs:?}");
        }
    }
}
