//! The texture cache: images uploaded once per colour space with a full mip chain, samplers
//! deduplicated by their state, and the 1×1 null texture bound to every empty material slot.
//!
//! An `Image` is colour-space agnostic; the material slot decides (base colour and emissive are
//! sRGB, the rest linear), so the cache is keyed by (image, sRGB). Mips are built on the CPU
//! with a 2×2 box filter, in linear light for sRGB images (averaging encoded values darkens
//! mips). Textures are created once per image; they never sit on the per-frame path.

use std::collections::HashMap;
use std::sync::OnceLock;

use penumbra_engine::Handle;
use penumbra_engine::image::Image;
use penumbra_engine::material::{FilterMode, Sampler, WrapMode};

pub struct GpuTexture {
    pub view: wgpu::TextureView,
    pub version: u64,
    pub bytes: u64,
}

pub struct TextureCache {
    textures: HashMap<(Handle<Image>, bool), GpuTexture>,
    samplers: HashMap<Sampler, wgpu::Sampler>,
    null_view: wgpu::TextureView,
    max_anisotropy: u16,
}

impl TextureCache {
    /// `max_anisotropy` applies to trilinear samplers (1 disables anisotropic filtering).
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, max_anisotropy: u16) -> Self {
        let null = Image::solid([255, 255, 255, 255], "null texture");
        let null_view = create_texture(device, queue, &null, false).0;
        Self {
            textures: HashMap::new(),
            samplers: HashMap::new(),
            null_view,
            max_anisotropy: max_anisotropy.clamp(1, 16),
        }
    }

    /// White 1×1: multiplies by one in every slot that the shader samples unconditionally.
    pub fn null_view(&self) -> &wgpu::TextureView {
        &self.null_view
    }

    pub fn gpu_bytes(&self) -> u64 {
        self.textures.values().map(|t| t.bytes).sum()
    }

    /// The view for `image` in the given colour space, uploading it if it is new or changed.
    /// Returns whether an upload happened (materials using it must rebuild their bind groups).
    pub fn get_or_upload(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        handle: Handle<Image>,
        srgb: bool,
        version: u64,
        image: &Image,
    ) -> (&wgpu::TextureView, bool) {
        let key = (handle, srgb);
        let stale = self.textures.get(&key).is_none_or(|t| t.version != version);
        if stale {
            let (view, bytes) = create_texture(device, queue, image, srgb);
            self.textures.insert(
                key,
                GpuTexture {
                    view,
                    version,
                    bytes,
                },
            );
        }
        (&self.textures[&key].view, stale)
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
}

fn create_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    image: &Image,
    srgb: bool,
) -> (wgpu::TextureView, u64) {
    let levels = mip_chain(image, srgb);
    let format = if srgb {
        wgpu::TextureFormat::Rgba8UnormSrgb
    } else {
        wgpu::TextureFormat::Rgba8Unorm
    };
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some(&image.label),
        size: wgpu::Extent3d {
            width: image.width,
            height: image.height,
            depth_or_array_layers: 1,
        },
        mip_level_count: levels.len() as u32,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    let mut bytes = 0;
    for (level, (w, h, data)) in levels.iter().enumerate() {
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: level as u32,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            data,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * w),
                rows_per_image: Some(*h),
            },
            wgpu::Extent3d {
                width: *w,
                height: *h,
                depth_or_array_layers: 1,
            },
        );
        bytes += data.len() as u64;
    }
    (
        texture.create_view(&wgpu::TextureViewDescriptor::default()),
        bytes,
    )
}

fn srgb_to_linear_table() -> &'static [f32; 256] {
    static T: OnceLock<[f32; 256]> = OnceLock::new();
    T.get_or_init(|| {
        std::array::from_fn(|i| {
            let c = i as f32 / 255.0;
            if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        })
    })
}

/// Linear [0, 1] → sRGB byte, through a 4096-entry table (12 bits of linear input resolve every
/// sRGB code above the toe; below it the table is exact to ±1 code).
fn linear_to_srgb_byte(x: f32) -> u8 {
    static T: OnceLock<Vec<u8>> = OnceLock::new();
    let t = T.get_or_init(|| {
        (0..4096)
            .map(|i| {
                let c = i as f32 / 4095.0;
                let s = if c <= 0.0031308 {
                    c * 12.92
                } else {
                    1.055 * c.powf(1.0 / 2.4) - 0.055
                };
                (s * 255.0).round() as u8
            })
            .collect()
    });
    t[(x.clamp(0.0, 1.0) * 4095.0).round() as usize]
}

/// Every mip level, top first, each as (width, height, RGBA8 bytes).
fn mip_chain(image: &Image, srgb: bool) -> Vec<(u32, u32, Vec<u8>)> {
    let mut levels = vec![(image.width, image.height, image.rgba8.clone())];
    let to_lin = srgb_to_linear_table();
    while let Some((w, h, src)) = levels.last().filter(|(w, h, _)| *w > 1 || *h > 1) {
        let (w, h) = (*w as usize, *h as usize);
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let mut dst = vec![0u8; nw * nh * 4];
        for y in 0..nh {
            // Odd sizes: the last row/column folds into its neighbour (clamped), a common
            // approximation whose error is under one texel of the parent level.
            let (y0, y1) = ((2 * y).min(h - 1), (2 * y + 1).min(h - 1));
            for x in 0..nw {
                let (x0, x1) = ((2 * x).min(w - 1), (2 * x + 1).min(w - 1));
                let px = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)].map(|(px, py)| (py * w + px) * 4);
                let o = (y * nw + x) * 4;
                for c in 0..4 {
                    if srgb && c < 3 {
                        let sum: f32 = px.iter().map(|&p| to_lin[src[p + c] as usize]).sum();
                        dst[o + c] = linear_to_srgb_byte(sum * 0.25);
                    } else {
                        let sum: u32 = px.iter().map(|&p| src[p + c] as u32).sum();
                        dst[o + c] = ((sum + 2) / 4) as u8;
                    }
                }
            }
        }
        levels.push((nw as u32, nh as u32, dst));
    }
    levels
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mip_chain_reaches_one_by_one_for_odd_sizes() {
        let img = Image {
            width: 5,
            height: 3,
            rgba8: vec![128; 5 * 3 * 4],
            label: "t".into(),
        };
        let chain = mip_chain(&img, false);
        let dims: Vec<_> = chain.iter().map(|(w, h, _)| (*w, *h)).collect();
        assert_eq!(dims, [(5, 3), (2, 1), (1, 1)]);
        assert!(
            chain
                .iter()
                .all(|(w, h, d)| d.len() == (*w * *h * 4) as usize)
        );
    }

    #[test]
    fn srgb_mips_average_in_linear_light() {
        // Black and white checker: the linear average is 0.5, which sRGB-encodes to 188, not 128.
        let mut rgba = Vec::new();
        for i in 0..4 {
            let v = if i % 3 == 0 { 0 } else { 255 };
            rgba.extend_from_slice(&[v, v, v, 255]);
        }
        let img = Image {
            width: 2,
            height: 2,
            rgba8: rgba,
            label: "t".into(),
        };
        let chain = mip_chain(&img, true);
        assert_eq!(chain[1].2[0], 188);
        assert_eq!(mip_chain(&img, false)[1].2[0], 128);
    }
}
