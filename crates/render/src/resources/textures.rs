//! The texture cache: images uploaded once per colour space with a full mip chain, samplers
//! deduplicated by their state, and the 1×1 null texture bound to every empty material slot.
//!
//! An `Image` is colour-space agnostic; the material slot decides (base colour and emissive are
//! sRGB, the rest linear), so the cache is keyed by (image, sRGB). An image that carries its mip
//! chain for that colour space (made where it was decoded: `penumbra_engine::mip_chain`) is
//! uploaded level by level. Otherwise only level 0 is uploaded and the chain is rendered on the
//! GPU (`shaders/mipmap.wgsl`, the same 2×2 means) through unorm views, the shader converting
//! sRGB textures to linear light to average them (and back), so that every driver makes the
//! same chain. Textures are created when an image first appears or changes; they never sit on
//! the per-frame path. Where the device can import host memory (`host_memory`), the large
//! levels of an image are copied from where they were decoded; the rest, and everything on
//! other devices, through `Queue::write_texture`'s staging copy. A frame's uploads go to the
//! driver as soon as they are staged, ahead of the frame, so that it places the texels while the
//! render thread builds pipelines: in one submission, unless more than [`STAGING_SUBMIT_BYTES`]
//! were staged, which bounds the staging memory alive at once (on GPUs every level is staged).
//! Few submissions, not one per texture: wgpu chains submissions with semaphores, and
//! lavapipe's `vkQueueSubmit` then blocks until the previous submission has run (`perf`'s
//! scheduler stacks showed the render thread waiting there through each submission; one
//! submission shortens a headless screenshot, docs/performance.md, "A headless screenshot").
//! With imports lavapipe stages only the small levels, so its uploads stay one submission.
//!
//! A KTX2 image (`penumbra_engine::compressed_image`) goes up level by level in the first of its
//! block formats the device samples: BC7, ASTC 4×4 or ETC2 RGBA for Basis Universal (a quarter
//! of RGBA8's memory), a plain file's own BC, ETC2/EAC or ASTC format. It goes up as RGBA8 where
//! the device samples none of them, where the file's chain is missing or stops before 1×1 (block
//! formats cannot be rendered to, so the chain is made on the GPU from RGBA8), where its size is
//! not whole blocks, for plain 8-bit texels, for one- and two-channel formats in an sRGB slot
//! (they have no sRGB variant), and for BC1 RGB files whose blocks use the transparent index. [`TextureCache::rgba8_bytes`] beside [`TextureCache::gpu_bytes`]
//! says what compression saved.

use std::collections::HashMap;
use std::sync::Arc;

use penumbra_engine::Handle;
use penumbra_engine::color::srgb_to_linear;
use penumbra_engine::compressed_image::{CompressedImage, Family, Format};
use penumbra_engine::image::Image;
use penumbra_engine::material::{FilterMode, Sampler, WrapMode};
use penumbra_engine::mip_chain::{MipChain, MipLevel, chain_bytes, mip_level_count};

use super::mipmap::MipmapFamily;
use crate::pipelines::{PipelineCache, parts};

/// Staged texture bytes after which the uploads so far are submitted: wgpu frees a staging
/// buffer once its submission has run, so this bounds the staging memory a scene's textures
/// hold at once.
const STAGING_SUBMIT_BYTES: u64 = 64 << 20;
/// Levels smaller than this go through a staging copy even where imports exist: an import is a
/// few driver calls and whole pages, not worth it for small images.
const IMPORT_MIN_BYTES: usize = 256 << 10;

pub struct GpuTexture {
    pub view: wgpu::TextureView,
    /// The image version it was made from.
    pub version: u64,
    pub bytes: u64,
    /// What it would take as RGBA8 with a full mip chain.
    pub rgba8_bytes: u64,
}

/// An image that some material needs in one colour space.
pub struct TextureRequest {
    pub image: Handle<Image>,
    pub srgb: bool,
    pub version: u64,
    pub data: Arc<Image>,
}

pub struct TextureCache {
    textures: HashMap<(Handle<Image>, bool), GpuTexture>,
    samplers: HashMap<Sampler, wgpu::Sampler>,
    null_view: wgpu::TextureView,
    max_anisotropy: u16,
    /// The device can view an sRGB texture as unorm (not GL): mip generation then converts the
    /// sRGB curve in its shader rather than through the texture unit and render target.
    unorm_views: bool,
    /// The linear value of each stored sRGB byte, for mip generation (shaders/mipmap.wgsl).
    srgb_to_linear: wgpu::Buffer,
    /// `Capabilities::host_import_alignment`.
    host_import_alignment: Option<u64>,
}

impl TextureCache {
    /// `max_anisotropy` applies to trilinear samplers (1 disables anisotropic filtering).
    /// `unorm_views`: `Capabilities::srgb_unorm_views`; `host_import_alignment`: the
    /// capability of that name. Registers the mip generation pipeline family.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        max_anisotropy: u16,
        unorm_views: bool,
        host_import_alignment: Option<u64>,
        pipelines: &mut PipelineCache,
    ) -> Self {
        pipelines.register(MipmapFamily::new(device));
        let null = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("null texture"),
            size: wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        write_level(queue, &null, 0, 1, 1, &[255; 4]);
        Self {
            textures: HashMap::new(),
            samplers: HashMap::new(),
            null_view: null.create_view(&Default::default()),
            max_anisotropy: max_anisotropy.clamp(1, 16),
            unorm_views,
            srgb_to_linear: srgb_table(device, queue),
            host_import_alignment,
        }
    }

    /// Changes the anisotropy of trilinear samplers: the cached samplers go (bind groups holding
    /// them must be made again: `MaterialTable::forget_bind_groups`).
    pub fn set_max_anisotropy(&mut self, max_anisotropy: u16) {
        self.max_anisotropy = max_anisotropy.clamp(1, 16);
        self.samplers.clear();
    }

    /// White 1×1: multiplies by one in every slot that the shader samples unconditionally.
    pub fn null_view(&self) -> &wgpu::TextureView {
        &self.null_view
    }

    pub fn gpu_bytes(&self) -> u64 {
        self.textures.values().map(|t| t.bytes).sum()
    }

    /// What the uploaded textures would take as RGBA8 with full mip chains: `gpu_bytes` less
    /// this is what block compression saved.
    pub fn rgba8_bytes(&self) -> u64 {
        self.textures.values().map(|t| t.rgba8_bytes).sum()
    }

    /// Whether `image` in this colour space must be (re)uploaded for `version`.
    pub fn is_stale(&self, image: Handle<Image>, srgb: bool, version: u64) -> bool {
        self.textures.get(&(image, srgb)).is_none_or(|t| t.version != version)
    }

    /// The view and the image version it holds, if uploaded.
    pub fn get(&self, image: Handle<Image>, srgb: bool) -> Option<(&wgpu::TextureView, u64)> {
        self.textures.get(&(image, srgb)).map(|t| (&t.view, t.version))
    }

    /// Uploads every stale request: level 0 and the chain the image brought, or level 0 and a
    /// GPU mip generation encoded into `encoder` (to be submitted after the uploads, which this
    /// submits: staged writes, and copies from imported memory in an encoder of their own; in
    /// one submission unless more than [`STAGING_SUBMIT_BYTES`] were staged).
    pub fn upload_many(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        pipelines: &mut PipelineCache,
        requests: &[TextureRequest],
    ) {
        // Copies from imported memory, submitted with the staged writes.
        let mut copies = None;
        let mut uploaded = false;
        let mut staged = 0;
        for r in requests {
            if !self.is_stale(r.image, r.srgb, r.version) {
                continue;
            }
            let upload = match &r.data.compressed {
                Some(c) => self.create_compressed(device, queue, encoder, &mut copies, pipelines, &r.data, c, r.srgb),
                None => self.create_texture(device, queue, encoder, &mut copies, pipelines, &r.data, r.srgb),
            };
            let rgba8_bytes = upload.rgba8_bytes.unwrap_or(upload.bytes);
            let texture = GpuTexture { view: upload.view, version: r.version, bytes: upload.bytes, rgba8_bytes };
            self.textures.insert((r.image, r.srgb), texture);
            uploaded = true;
            staged += upload.staged;
            if staged >= STAGING_SUBMIT_BYTES {
                queue.submit(copies.take().map(wgpu::CommandEncoder::finish));
                (staged, uploaded) = (0, false);
            }
        }
        // Handed to the driver now rather than with the frame: it copies the texels into place
        // while this thread prepares the rest of the frame (on a CPU rasteriser the two then
        // take two cores, not one after the other).
        if uploaded {
            queue.submit(copies.map(wgpu::CommandEncoder::finish));
        }
    }

    /// Drops textures whose image is gone.
    pub fn retain(&mut self, live: impl Fn(Handle<Image>) -> bool) {
        self.textures.retain(|(h, _), _| live(*h));
    }

    pub fn sampler(&mut self, device: &wgpu::Device, s: &Sampler) -> &wgpu::Sampler {
        let max_anisotropy = self.max_anisotropy;
        self.samplers.entry(*s).or_insert_with(|| {
            let filter = |f: FilterMode| match f {
                FilterMode::Nearest => wgpu::FilterMode::Nearest,
                FilterMode::Linear => wgpu::FilterMode::Linear,
            };
            let mip = |f: FilterMode| match f {
                FilterMode::Nearest => wgpu::MipmapFilterMode::Nearest,
                FilterMode::Linear => wgpu::MipmapFilterMode::Linear,
            };
            let wrap = |w: WrapMode| match w {
                WrapMode::Repeat => wgpu::AddressMode::Repeat,
                WrapMode::MirroredRepeat => wgpu::AddressMode::MirrorRepeat,
                WrapMode::ClampToEdge => wgpu::AddressMode::ClampToEdge,
            };
            let all_linear = s.mag_filter == FilterMode::Linear
                && s.min_filter == FilterMode::Linear
                && s.mipmap_filter == Some(FilterMode::Linear);
            device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("material sampler"),
                address_mode_u: wrap(s.wrap_u),
                address_mode_v: wrap(s.wrap_v),
                address_mode_w: wgpu::AddressMode::Repeat,
                mag_filter: filter(s.mag_filter),
                min_filter: filter(s.min_filter),
                mipmap_filter: s.mipmap_filter.map_or(wgpu::MipmapFilterMode::Nearest, mip),
                // No mipmap filter in glTF means "sample the top level only".
                lod_max_clamp: if s.mipmap_filter.is_some() { 32.0 } else { 0.0 },
                // Anisotropy only where trilinear is asked for (wgpu allows it only with
                // all-linear filtering).
                anisotropy_clamp: if all_linear { max_anisotropy } else { 1 },
                ..Default::default()
            })
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn create_texture(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        copies: &mut Option<wgpu::CommandEncoder>,
        pipelines: &mut PipelineCache,
        owner: &Arc<Image>,
        srgb: bool,
    ) -> Upload {
        let image: &Image = owner;
        let max = device.limits().max_texture_dimension_2d;
        let fitted;
        let image = if image.width > max || image.height > max {
            fitted = fit_within(image, max, srgb);
            tracing::warn!(
                "{}: {}×{} exceeds this GPU's texture limit of {max}; uploading it at {}×{}",
                image.label,
                image.width,
                image.height,
                fitted.width,
                fitted.height
            );
            &fitted
        } else {
            image
        };
        let format = if srgb { wgpu::TextureFormat::Rgba8UnormSrgb } else { wgpu::TextureFormat::Rgba8Unorm };
        // Where unorm views of sRGB textures exist, mips are made through them with the curve
        // applied in the shader; elsewhere (GL) through sRGB views, the driver converting.
        let shader_srgb = srgb && self.unorm_views;
        let view_format = if shader_srgb { wgpu::TextureFormat::Rgba8Unorm } else { format };
        let levels = mip_level_count(image.width, image.height);
        // The chain decoding made, if it is for this colour space (a fitted image has none).
        let made = image.mips.as_ref().filter(|m| m.srgb == srgb && image.fits(m));
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some(&image.label),
            size: wgpu::Extent3d { width: image.width, height: image.height, depth_or_array_layers: 1 },
            mip_level_count: levels,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: if made.is_some() {
                wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST
            } else {
                wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_DST
                    | wgpu::TextureUsages::RENDER_ATTACHMENT
            },
            // Mip generation reads and writes sRGB textures as unorm and converts itself.
            view_formats: if shader_srgb && made.is_none() { &[wgpu::TextureFormat::Rgba8Unorm] } else { &[] },
        });
        // Texels from where they lie where the device imports host memory, for the image as
        // decoded (not one fitted to the device here).
        let import = self.host_import_alignment.filter(|_| std::ptr::eq(image, &**owner));
        let mut staged = 0;
        let mut upload = |copies: &mut Option<wgpu::CommandEncoder>, level: u32, w: u32, h: u32, texels: &[u8]| {
            let level = Level { texture: &texture, level, width: w, height: h, texels };
            staged += upload_level(device, queue, copies, import.map(|a| (a, owner)), level);
        };
        upload(copies, 0, image.width, image.height, &image.rgba8);
        // A full chain adds a third to level 0.
        let bytes = image.rgba8.len() as u64 * 4 / 3;
        match made {
            Some(chain) => {
                for (level, m) in (1..).zip(&chain.levels) {
                    upload(copies, level, m.width, m.height, &m.rgba8);
                }
            }
            None => self.render_mip_chain(device, encoder, pipelines, &texture, view_format, shader_srgb, &image.label),
        }
        Upload { view: texture.create_view(&wgpu::TextureViewDescriptor::default()), bytes, staged, rgba8_bytes: None }
    }

    /// A KTX2 image: its levels in the first of its block formats the device samples, or RGBA8
    /// (see the module doc). A level that does not transcode (corrupt data the import's checks
    /// did not reach) is logged, naming the image, and the texture is left white.
    #[allow(clippy::too_many_arguments)]
    fn create_compressed(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        copies: &mut Option<wgpu::CommandEncoder>,
        pipelines: &mut PipelineCache,
        owner: &Arc<Image>,
        c: &CompressedImage,
        srgb: bool,
    ) -> Upload {
        let max = device.limits().max_texture_dimension_2d;
        // The first level the device can hold; past the file's chain, its last level (it then
        // goes the RGBA8 path, whose fitting halves it further).
        let first =
            (0..c.levels).find(|&l| c.level_size(l).0 <= max && c.level_size(l).1 <= max).unwrap_or(c.levels - 1);
        let (width, height) = c.level_size(first);
        // What the same texels would take as RGBA8 with a full chain, from the level uploaded.
        let rgba8_bytes = Format::Rgba8.level_bytes(width, height) + chain_bytes(width, height);
        // Block formats cannot be rendered to, so the file must bring the whole chain below the
        // level uploaded; and the level must be whole blocks.
        let full_chain = c.levels - first == mip_level_count(width, height);
        let chosen = c.block_formats().into_iter().find_map(|f| {
            let (bw, bh) = f.block();
            let fits = full_chain && width.is_multiple_of(bw) && height.is_multiple_of(bh);
            fits.then(|| device_format(f, srgb, device.features())).flatten().map(|format| (f, format))
        });
        let Some((block, format)) = chosen else {
            return self.create_rgba8(device, queue, encoder, copies, pipelines, owner, c, first, srgb);
        };
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some(&owner.label),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: c.levels - first,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let levels = match c.levels_as(first..c.levels, block) {
            Ok(levels) => levels,
            Err(e) => {
                let image = white(owner, &e);
                return self.create_texture(device, queue, encoder, copies, pipelines, &Arc::new(image), srgb);
            }
        };
        let (bw, bh) = block.block();
        let mut bytes = 0;
        for (level, blocks) in (0..).zip(&levels) {
            let (w, h) = c.level_size(first + level);
            let (across, down) = (w.div_ceil(bw), h.div_ceil(bh));
            queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &texture,
                    mip_level: level,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                blocks,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(across * block.block_bytes()),
                    rows_per_image: Some(down),
                },
                // Copies of block formats cover whole blocks: the level's physical size.
                wgpu::Extent3d { width: across * bw, height: down * bh, depth_or_array_layers: 1 },
            );
            bytes += blocks.len() as u64;
        }
        let rgba8_bytes = Some(rgba8_bytes);
        Upload { view: texture.create_view(&wgpu::TextureViewDescriptor::default()), bytes, staged: bytes, rgba8_bytes }
    }

    /// A KTX2 image from level `first` as RGBA8: with the file's chain where it has one, else
    /// the GPU makes it.
    #[allow(clippy::too_many_arguments)]
    fn create_rgba8(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        copies: &mut Option<wgpu::CommandEncoder>,
        pipelines: &mut PipelineCache,
        owner: &Arc<Image>,
        c: &CompressedImage,
        first: u32,
        srgb: bool,
    ) -> Upload {
        let image = c.levels_as(first..c.levels, Format::Rgba8).map(|levels| {
            let mut levels = (first..).zip(levels).map(|(l, rgba8)| {
                let (width, height) = c.level_size(l);
                MipLevel { width, height, rgba8 }
            });
            let top = levels.next().expect("a level");
            let mut image = Image::rgba8(top.width, top.height, top.rgba8, owner.label.clone());
            let chain = MipChain { srgb, levels: levels.collect() };
            if !chain.levels.is_empty() && image.fits(&chain) {
                image.mips = Some(chain);
            }
            image
        });
        let image = image.unwrap_or_else(|e| white(owner, &e));
        let mut up = self.create_texture(device, queue, encoder, copies, pipelines, &Arc::new(image), srgb);
        // As RGBA8 it saves nothing: what it takes is what it would take.
        up.rgba8_bytes = None;
        up
    }

    /// Levels 1.. of `texture` from level 0, on the GPU (`shaders/mipmap.wgsl`), through views of
    /// `view_format`.
    #[allow(clippy::too_many_arguments)]
    fn render_mip_chain(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        pipelines: &mut PipelineCache,
        texture: &wgpu::Texture,
        view_format: wgpu::TextureFormat,
        shader_srgb: bool,
        label: &str,
    ) {
        let level_view = |level: u32| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                format: Some(view_format),
                base_mip_level: level,
                mip_level_count: Some(1),
                ..Default::default()
            })
        };
        for level in 1..texture.mip_level_count() {
            let source = level_view(level - 1);
            let target = level_view(level);
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("mipmap source"),
                layout: &pipelines.family::<MipmapFamily>().layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&source) },
                    wgpu::BindGroupEntry { binding: 1, resource: self.srgb_to_linear.as_entire_binding() },
                ],
            });
            let pipeline = match pipelines.get::<MipmapFamily>(device, (view_format, shader_srgb)) {
                Ok(p) => p,
                Err(e) => {
                    tracing::error!("mip generation skipped for {}: {e}", label);
                    break;
                }
            };
            parts::draw_fullscreen(encoder, "mipmap", &target, pipeline, &bind_group, None);
        }
    }
}

/// A texture made by `create_texture`: its view, its bytes with the full chain, and the bytes
/// of it that went through staging copies.
struct Upload {
    view: wgpu::TextureView,
    bytes: u64,
    staged: u64,
    /// For a compressed image: its size as RGBA8 with a full chain.
    rgba8_bytes: Option<u64>,
}

/// The texture format a level in `format` is uploaded as, where the device samples it (and, for
/// an sRGB slot, has an sRGB variant of it: one- and two-channel formats have none).
fn device_format(format: Format, srgb: bool, features: wgpu::Features) -> Option<wgpu::TextureFormat> {
    use wgpu::TextureFormat as F;
    let needs = match format.family()? {
        Family::Bc => wgpu::Features::TEXTURE_COMPRESSION_BC,
        Family::Etc2 => wgpu::Features::TEXTURE_COMPRESSION_ETC2,
        Family::Astc => wgpu::Features::TEXTURE_COMPRESSION_ASTC,
    };
    if !features.contains(needs) {
        return None;
    }
    let pick = |unorm, srgb_variant: Option<F>| if srgb { srgb_variant } else { Some(unorm) };
    match format {
        Format::Rgba8 => None,
        Format::Bc1 => pick(F::Bc1RgbaUnorm, Some(F::Bc1RgbaUnormSrgb)),
        Format::Bc2 => pick(F::Bc2RgbaUnorm, Some(F::Bc2RgbaUnormSrgb)),
        Format::Bc3 => pick(F::Bc3RgbaUnorm, Some(F::Bc3RgbaUnormSrgb)),
        Format::Bc4 => pick(F::Bc4RUnorm, None),
        Format::Bc5 => pick(F::Bc5RgUnorm, None),
        Format::Bc7 => pick(F::Bc7RgbaUnorm, Some(F::Bc7RgbaUnormSrgb)),
        Format::Etc2Rgb => pick(F::Etc2Rgb8Unorm, Some(F::Etc2Rgb8UnormSrgb)),
        Format::Etc2RgbA1 => pick(F::Etc2Rgb8A1Unorm, Some(F::Etc2Rgb8A1UnormSrgb)),
        Format::Etc2Rgba => pick(F::Etc2Rgba8Unorm, Some(F::Etc2Rgba8UnormSrgb)),
        Format::EacR11 => pick(F::EacR11Unorm, None),
        Format::EacRg11 => pick(F::EacRg11Unorm, None),
        Format::Astc { w, h } => {
            use wgpu::AstcBlock as B;
            let block = match (w, h) {
                (4, 4) => B::B4x4,
                (5, 4) => B::B5x4,
                (5, 5) => B::B5x5,
                (6, 5) => B::B6x5,
                (6, 6) => B::B6x6,
                (8, 5) => B::B8x5,
                (8, 6) => B::B8x6,
                (8, 8) => B::B8x8,
                (10, 5) => B::B10x5,
                (10, 6) => B::B10x6,
                (10, 8) => B::B10x8,
                (10, 10) => B::B10x10,
                (12, 10) => B::B12x10,
                (12, 12) => B::B12x12,
                _ => return None,
            };
            let channel = if srgb { wgpu::AstcChannel::UnormSrgb } else { wgpu::AstcChannel::Unorm };
            Some(F::Astc { block, channel })
        }
    }
}

/// A white 1×1 stand-in for an image that does not transcode, after saying so.
fn white(owner: &Image, error: &str) -> Image {
    tracing::error!("{}: {error}; drawn untextured", owner.label);
    Image::solid([255; 4], owner.label.clone())
}

/// One texture level's texels.
struct Level<'a> {
    texture: &'a wgpu::Texture,
    level: u32,
    width: u32,
    height: u32,
    texels: &'a [u8],
}

/// Uploads one level: copied by `copies` from where the texels lie when `import` (the
/// alignment, and the image holding them) is given and the level qualifies, else staged by
/// `Queue::write_texture`. Returns the bytes staged.
fn upload_level(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    copies: &mut Option<wgpu::CommandEncoder>,
    import: Option<(u64, &Arc<Image>)>,
    l: Level,
) -> u64 {
    // Copies need rows at the copy alignment and texels at a multiple of 4 bytes into the buffer.
    let importable = l.texels.len() >= IMPORT_MIN_BYTES
        && (4 * l.width).is_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
        && (l.texels.as_ptr() as usize).is_multiple_of(4);
    let imported = import.filter(|_| importable).and_then(|(alignment, owner)| {
        // SAFETY: the device was opened with imports (the capability is set only then); the
        // texels lie in the image `owner` holds, immutable behind its Arc.
        unsafe { crate::gpu::host_memory::import(device, alignment, l.texels, owner.clone() as Arc<dyn Send + Sync>) }
    });
    let Some((buffer, offset)) = imported else {
        write_level(queue, l.texture, l.level, l.width, l.height, l.texels);
        return l.texels.len() as u64;
    };
    let c = copies.get_or_insert_with(|| {
        device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("texture uploads") })
    });
    c.copy_buffer_to_texture(
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset,
                bytes_per_row: Some(4 * l.width),
                rows_per_image: Some(l.height),
            },
        },
        wgpu::TexelCopyTextureInfo {
            texture: l.texture,
            mip_level: l.level,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::Extent3d { width: l.width, height: l.height, depth_or_array_layers: 1 },
    );
    0
}

/// The largest level of `image`'s mip chain for this colour space that fits `max`, with the
/// levels below it as its own chain: the fallback for images larger than the GPU allows. The
/// chain decoding made serves when it is for this colour space; otherwise one is built here
/// (rare: sides over the device's limit, 8192 or 16384 texels).
fn fit_within(image: &Image, max: u32, srgb: bool) -> Image {
    let built;
    let chain = match image.mips.as_ref().filter(|m| m.srgb == srgb && image.fits(m)) {
        Some(chain) => chain,
        None => {
            built = image.build_mips(srgb);
            &built
        }
    };
    // Every chain ends at 1×1, which fits any device.
    let first = chain.levels.iter().position(|l| l.width <= max && l.height <= max).unwrap_or(chain.levels.len() - 1);
    let level = &chain.levels[first];
    let mut fitted = Image::rgba8(level.width, level.height, level.rgba8.clone(), image.label.clone());
    fitted.mips = Some(MipChain { srgb, levels: chain.levels[first + 1..].to_vec() });
    fitted
}

/// The sRGB curve's inverse at each 8-bit value.
fn srgb_to_linear_values() -> [f32; 256] {
    std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0))
}

fn srgb_table(device: &wgpu::Device, queue: &wgpu::Queue) -> wgpu::Buffer {
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("sRGB decoding table"),
        size: 256 * 4,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    queue.write_buffer(&buffer, 0, bytemuck::cast_slice(&srgb_to_linear_values()));
    buffer
}

fn write_level(queue: &wgpu::Queue, texture: &wgpu::Texture, level: u32, w: u32, h: u32, data: &[u8]) {
    queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: level,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        data,
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4 * w), rows_per_image: Some(h) },
        wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_srgb_table_is_the_curve_at_each_byte() {
        let t = srgb_to_linear_values();
        assert_eq!((t[0], t[255]), (0.0, 1.0));
        assert!((t[10] - 10.0 / 255.0 / 12.92).abs() < 1e-9, "linear segment");
        assert!((t[128] - 0.215_860_5).abs() < 1e-6, "0.5 encoded is 0.2159 linear");
        assert!(t.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn block_formats_go_to_the_gpu_only_where_the_device_samples_them() {
        use wgpu::Features as Fe;
        use wgpu::TextureFormat as T;
        assert_eq!(device_format(Format::Bc7, true, Fe::empty()), None, "RGBA8 without the feature");
        assert_eq!(device_format(Format::Bc7, true, Fe::all()), Some(T::Bc7RgbaUnormSrgb));
        assert_eq!(device_format(Format::Etc2Rgba, false, Fe::TEXTURE_COMPRESSION_ETC2), Some(T::Etc2Rgba8Unorm));
        assert_eq!(device_format(Format::Etc2Rgba, false, Fe::TEXTURE_COMPRESSION_BC), None);
        let astc = device_format(Format::Astc { w: 6, h: 6 }, true, Fe::TEXTURE_COMPRESSION_ASTC);
        assert_eq!(astc, Some(T::Astc { block: wgpu::AstcBlock::B6x6, channel: wgpu::AstcChannel::UnormSrgb }));
        // One channel has no sRGB variant: an sRGB slot decodes it to RGBA8.
        assert_eq!(device_format(Format::Bc4, true, Fe::all()), None);
        assert_eq!(device_format(Format::Bc4, false, Fe::all()), Some(T::Bc4RUnorm));
        assert_eq!(device_format(Format::Rgba8, false, Fe::all()), None);
    }

    #[test]
    fn oversized_images_are_halved_until_they_fit() {
        let img = Image::rgba8(10, 3, vec![200; 10 * 3 * 4], "t");
        let fitted = fit_within(&img, 4, false);
        assert_eq!((fitted.width, fitted.height), (2, 1));
        assert!(fitted.rgba8.iter().all(|&b| b == 200));
        // The levels below come along as the fitted image's chain.
        let chain = fitted.mips.as_ref().expect("a chain");
        assert!(fitted.fits(chain) && !chain.srgb);
        // sRGB images average in linear light, as every other chain does: black and white
        // columns meet at 188, not 128.
        let stripes: Vec<u8> = (0..8 * 2).flat_map(|i| if i % 2 == 0 { [0, 0, 0, 255] } else { [255; 4] }).collect();
        let img = Image::rgba8(8, 2, stripes, "s");
        let fitted = fit_within(&img, 4, true);
        assert_eq!((fitted.width, fitted.height), (4, 1));
        assert_eq!(&fitted.rgba8[..4], &[188, 188, 188, 255]);
    }
}
