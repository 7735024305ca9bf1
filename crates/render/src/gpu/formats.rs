//! Every texture format the renderer chooses, in one place: a pass that writes a target and the
//! pass that reads it, and the pipelines of both, name the same constant.

/// The scene's linear HDR radiance: every value that could overflow f16 (65504) is clamped
/// before it is stored.
pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Reverse-Z depth (cleared to 0, compared with `Greater`): f32 keeps far surfaces apart.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Shadow maps' depth targets (depth from the light, reverse-Z like the camera's): the local
/// lights' atlas, and the hardware's staging target for a cascade layer.
pub const SHADOW_ATLAS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// The cascades' atlas: the same depths as floats, which either rasteriser's result is copied
/// into (`features::shadows::atlas`).
pub const SHADOW_DEPTHS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
/// The surface target opaque fragments write for the deferred-lights pass, beside roughness in
/// the colour's alpha (see `gbuffer.wgsl`).
pub const SURFACE_SHAPE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Uint;
/// What the deferred-lights pass writes and its composite adds.
pub const LOCAL_LIGHT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// What the visibility buffer's shading pass writes the displayed colour into (sRGB-encoded by
/// the shader; storage textures cannot be sRGB), copied into an `Rgba8Unorm` or
/// `Rgba8UnormSrgb` output.
pub const DISPLAY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// The tonemapped frame FXAA reads when it does not write the output itself.
pub const LDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Every environment map (source cube, specular cube, split-sum table).
pub const ENVIRONMENT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// The equirectangular environment image as uploaded (f32: sources brighter than f16 allows
/// keep their energy until the cube is written, scaled).
pub const EQUIRECT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// A texture format usable as a map key with a total order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FormatKey(pub wgpu::TextureFormat);

impl PartialOrd for FormatKey {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for FormatKey {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        // Batch sorting compares a draw's key with its neighbour's: nearly always equal, and
        // then no string is built. Different formats order by name (wgpu gives no other).
        if self.0 == other.0 {
            return std::cmp::Ordering::Equal;
        }
        format!("{:?}", self.0).cmp(&format!("{:?}", other.0))
    }
}
