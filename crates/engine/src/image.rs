//! `Image`: texel data, 8-bit RGBA, or a GPU-ready texture (`compressed`: KTX2, Basis Universal
//! or an ordinary GPU format) that the renderer uploads in what the adapter samples. Whether the bytes are
//! sRGB-encoded or linear is not a property of the image but of the material slot that samples it
//! (base colour and emissive are sRGB, the others linear), so the render side picks the view
//! format per use.

use std::borrow::Cow;
use std::sync::Arc;

use crate::compressed_image::CompressedImage;
use crate::mip_chain::MipChain;

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// `width * height * 4` bytes, rows top to bottom.
    pub rgba8: Vec<u8>,
    /// Where it came from, for error messages and debugging (`scene.glb#image3`).
    pub label: String,
    /// Levels 1.. made where the image was decoded, for the colour space its material slots
    /// read it in (`mip_chain`); `None`: the renderer makes the chain on the GPU.
    pub mips: Option<MipChain>,
    /// A texture kept as KTX2 (Basis Universal or a GPU format): `rgba8` is then empty and the
    /// renderer takes each mip level from here; [`Image::texels`] decodes for the CPU.
    pub compressed: Option<Arc<CompressedImage>>,
}

impl Image {
    /// A 1×1 image of one colour.
    pub fn solid(rgba: [u8; 4], label: impl Into<String>) -> Self {
        Self::rgba8(1, 1, rgba.to_vec(), label)
    }

    /// An image of RGBA8 texels (`width * height * 4` bytes, rows top to bottom).
    pub fn rgba8(width: u32, height: u32, rgba8: Vec<u8>, label: impl Into<String>) -> Self {
        Self { width, height, rgba8, label: label.into(), mips: None, compressed: None }
    }

    /// A compressed texture (its base level's size; no texels on the host).
    pub fn compressed(image: CompressedImage, label: impl Into<String>) -> Self {
        Self {
            width: image.width,
            height: image.height,
            rgba8: Vec::new(),
            label: label.into(),
            mips: None,
            compressed: Some(Arc::new(image)),
        }
    }

    /// The base level's RGBA8 texels: borrowed, or decoded from the compressed texture.
    pub fn texels(&self) -> Result<Cow<'_, [u8]>, String> {
        match &self.compressed {
            Some(c) => c.decode_rgba8().map(Cow::Owned),
            None => Ok(Cow::Borrowed(&self.rgba8)),
        }
    }

    /// The mip chain below this image, averaged in linear light when `srgb`.
    pub fn build_mips(&self, srgb: bool) -> MipChain {
        MipChain::build(self.width, self.height, &self.rgba8, srgb)
    }

    /// Whether `chain` belongs below this image.
    pub fn fits(&self, chain: &MipChain) -> bool {
        chain.fits(self.width, self.height)
    }
}

impl crate::assets::AssetEdit for Image {
    /// The chain was made from the texels about to change: the renderer makes it anew.
    fn before_edit(&mut self) {
        self.mips = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assets::Assets;

    #[test]
    fn editing_an_image_drops_the_mip_chain_made_from_its_texels() {
        let mut images = Assets::new();
        let mut image = Image::solid([10, 20, 30, 255], "t");
        image.mips = Some(image.build_mips(true));
        let h = images.add(image);
        assert!(images.get(h).unwrap().mips.is_some());
        images.get_mut(h).unwrap().rgba8[0] = 200;
        assert!(images.get(h).unwrap().mips.is_none(), "a stale chain would show the old texels far away");
    }
}
