//! What tests, tools and headless runs read back from the GPU: the headless output and its
//! pixels, HDR colour, culling's counts and automatic exposure's state. Each waits for the GPU;
//! none is on a frame's path.

use super::{FrameError, Renderer, RendererError};
use crate::gpu::readback::{self, ReadbackError};
use crate::scene::world::RenderScene;
use crate::targets::MsaaResolve;

impl Renderer {
    /// Instances each opaque batch drew in the last frame after GPU culling, in batch order;
    /// `None` when the last frame was not culled. Reads back (waits for the GPU): for tests and
    /// tools, not for frames.
    pub fn visible_instance_counts(&self) -> Result<Option<Vec<u32>>, ReadbackError> {
        if !self.culling_active {
            return Ok(None);
        }
        self.culling.read_visible_counts(&self.ctx.device, &self.ctx.queue).map(Some)
    }

    /// Triangles each opaque batch drew in the last frame, for batches the cull pass culled
    /// triangle by triangle (`None` where a batch drew instances; `Ok(None)`: the frame culled
    /// no triangles). Reads back (waits for the GPU): for tests and tools.
    pub fn triangle_culled_counts(&self) -> Result<Option<Vec<Option<u32>>>, ReadbackError> {
        if !self.culling_active {
            return Ok(None);
        }
        self.culling.read_triangle_counts(&self.ctx.device, &self.ctx.queue)
    }

    /// Instances each opaque batch drew into each shadow map of the last frame's last shadow
    /// cull pass (map by map, in drawing order: cascade layers, then local maps); `None` when the
    /// maps were not culled on the GPU. Reads back (waits for the GPU): for tests and tools.
    pub fn shadow_caster_counts(&self) -> Result<Option<Vec<Vec<u32>>>, ReadbackError> {
        self.shadows.read_culled_counts(&self.ctx.device, &self.ctx.queue)
    }

    /// The window cascade layer `layer` of the last frame stores (width, height) and its depths
    /// from the light (reverse-Z), row by row; `None` where it stores none. Reads back (waits
    /// for the GPU): for tests and tools.
    pub fn shadow_cascade_depths(&self, layer: usize) -> Result<Option<((u32, u32), Vec<f32>)>, ReadbackError> {
        self.shadows.read_cascade_layer(&self.ctx.device, &self.ctx.queue, layer)
    }

    /// Automatic exposure's state after the last frame: (the correction the tonemap pass
    /// applied on top of the camera's exposure, the adapted EV100). Reads back (waits for the
    /// GPU): for tests and tools.
    pub fn auto_exposure_state(&self) -> Result<(f32, f32), ReadbackError> {
        let bytes = readback::read_buffer(&self.ctx.device, &self.ctx.queue, self.post.params_buffer(), 8)?;
        let f = |i: usize| f32::from_le_bytes(bytes[4 * i..4 * i + 4].try_into().expect("4 bytes"));
        Ok((f(0), f(1)))
    }

    /// Renders into the renderer's own offscreen output of `size`: `Rgba8Unorm`, sRGB-encoded by
    /// the shaders (display.wgsl's exact curve, so a screenshot does not depend on a driver's
    /// sRGB encoder; NVIDIA's and lavapipe's round differently, which alone put FLIP 0.016
    /// between the two on TextureCoordinateTest's flat colours). With MSAA resolving display
    /// colours (`MsaaResolve::Display`) it is `Rgba8UnormSrgb` instead, encoded by the driver:
    /// that resolve averages in linear light through sRGB targets.
    pub fn render_headless(&mut self, scene: &RenderScene, size: (u32, u32)) {
        if self.is_device_lost() && !self.recover_headless() {
            return;
        }
        // A 0×0 request draws into a 1×1 texture: compare with what was made, or it is made again
        // every frame.
        let size = (size.0.max(1), size.1.max(1));
        let max = self.ctx.device.limits().max_texture_dimension_2d;
        if size.0 > max || size.1 > max {
            // A validation error (a panic) if asked of wgpu: the frame fails with the reason.
            self.frame_error = Some(FrameError::Size { size, max });
            return;
        }
        // Resolving display colours averages them in linear light, through an sRGB target (the
        // driver then encodes); otherwise the shaders encode into a unorm target.
        let format = if self.settings.msaa > 1 && self.settings.msaa_resolve == MsaaResolve::Display {
            wgpu::TextureFormat::Rgba8UnormSrgb
        } else {
            wgpu::TextureFormat::Rgba8Unorm
        };
        let needs_new =
            self.headless.as_ref().is_none_or(|(t, _)| (t.width(), t.height()) != size || t.format() != format);
        if needs_new {
            let texture = self.ctx.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("headless output"),
                size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                // Copied into by the visibility buffer's shading pass, which writes through a
                // storage texture (passes::visibility).
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            let view = texture.create_view(&Default::default());
            self.headless = Some((texture, view));
        }
        let view = self.headless.as_ref().expect("just made").1.clone();
        self.render(scene, &view, format, size);
    }

    /// The last headless frame as tightly packed sRGB-encoded RGBA8 rows, whatever drew it (see
    /// [`Renderer::read_frame`]).
    pub fn read_headless(&self) -> Result<Vec<u8>, ReadbackError> {
        let (texture, _) = self.headless.as_ref().ok_or_else(|| ReadbackError::Map("nothing rendered yet".into()))?;
        readback::read_texture(&self.ctx.device, &self.ctx.queue, texture, 4)
    }

    /// The last headless frame, as [`Renderer::read_headless`], or the shader error that kept it
    /// from being the frame the shaders describe: a draw whose pipeline did not compile is left
    /// out, and after a failed reload older shaders drew. Headless renders read this, so a
    /// screenshot with a part missing is an error rather than an image; the viewer draws on
    /// and shows the error beside the frame. The error stands until a reload succeeds, so with
    /// the embedded shaders (nothing to reload) every later read fails too.
    pub fn read_frame(&self) -> Result<Vec<u8>, RendererError> {
        if let Some(e) = &self.shader_error {
            return Err(RendererError::Shader(e.clone()));
        }
        if let Some(e) = &self.frame_error {
            return Err(RendererError::Frame(e.clone()));
        }
        Ok(self.read_headless()?)
    }

    /// The last frame's linear HDR colour (exposed, before tonemapping) as RGBA f32. Alpha is
    /// not opacity: with deferred local lights it held surface roughness (see gbuffer.wgsl).
    pub fn read_hdr(&self) -> Result<Vec<[f32; 4]>, ReadbackError> {
        let targets = self.targets.as_ref().ok_or_else(|| ReadbackError::Map("nothing rendered yet".into()))?;
        let hdr = targets.hdr.as_ref().ok_or_else(|| {
            ReadbackError::Map(
                "the last frame had no HDR target (it drew straight into the output); set \
                 RenderSettings::keep_hdr to read HDR colour"
                    .into(),
            )
        })?;
        let bytes = readback::read_texture(&self.ctx.device, &self.ctx.queue, &hdr.texture, 8)?;
        Ok(bytes
            .chunks_exact(8)
            .map(|px| std::array::from_fn(|c| readback::f16_to_f32(u16::from_le_bytes([px[2 * c], px[2 * c + 1]]))))
            .collect())
    }
}
