//! `Image`: decoded texel data, always 8-bit RGBA. Whether the bytes are sRGB-encoded or linear
//! is not a property of the image but of the material slot that samples it (base colour and
//! emissive are sRGB, the others linear), so the render side picks the view format per use.

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
}

impl Image {
    /// A 1×1 image of one colour.
    pub fn solid(rgba: [u8; 4], label: impl Into<String>) -> Self {
        Self { width: 1, height: 1, rgba8: rgba.to_vec(), label: label.into(), mips: None }
    }
}

impl crate::assets::AssetEdit for Image {
    /// The chain was made from the texels about to change: the renderer makes it anew.
    fn before_edit(&mut self) {
        self.mips = None;
    }
}
