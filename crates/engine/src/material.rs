//! `StandardMaterial`: glTF 2.0 metallic-roughness, with the material extensions Penumbra
//! supports (emissive strength, unlit, IOR, specular, clearcoat, sheen, transmission, volume,
//! dispersion, anisotropy, iridescence; KHR_texture_transform;
//! specular-glossiness converts to it at import).
//! Colours are linear; textures say which image, sampler, UV set and UV transform they use.

use glam::{Mat3, Vec2, Vec3, Vec4};

use crate::assets::Handle;
use crate::image::Image;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum FilterMode {
    Nearest,
    #[default]
    Linear,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum WrapMode {
    #[default]
    Repeat,
    MirroredRepeat,
    ClampToEdge,
}

/// Texture sampling state (glTF `sampler`). Mipmaps are always generated; `mipmap: None`
/// samples only the top level, as glTF's NEAREST/LINEAR minification filters ask.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Sampler {
    pub mag_filter: FilterMode,
    pub min_filter: FilterMode,
    pub mipmap_filter: Option<FilterMode>,
    pub wrap_u: WrapMode,
    pub wrap_v: WrapMode,
}

impl Default for Sampler {
    /// glTF leaves unspecified filters to the implementation; trilinear is the quality choice.
    fn default() -> Self {
        Self {
            mag_filter: FilterMode::Linear,
            min_filter: FilterMode::Linear,
            mipmap_filter: Some(FilterMode::Linear),
            wrap_u: WrapMode::Repeat,
            wrap_v: WrapMode::Repeat,
        }
    }
}

/// KHR_texture_transform: `uv' = T · R · S · uv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UvTransform {
    pub offset: Vec2,
    /// Radians, counter-clockwise in UV space.
    pub rotation: f32,
    pub scale: Vec2,
}

impl Default for UvTransform {
    fn default() -> Self {
        Self { offset: Vec2::ZERO, rotation: 0.0, scale: Vec2::ONE }
    }
}

impl UvTransform {
    /// `uv' = T · R · S · uv`, with R turning UVs counter-clockwise as the image is seen (v points
    /// down, so in (u, v) coordinates that is u' = c·u + s·v, v' = −s·u + c·v). The extension's
    /// README prints the GLSL transposed; the TextureTransformTest sample's markers (green: right
    /// direction, red: reversed) confirm this orientation, as the Khronos sample viewer uses.
    pub fn matrix(&self) -> Mat3 {
        let (s, c) = self.rotation.sin_cos();
        let translation = Mat3::from_cols(Vec3::X, Vec3::Y, self.offset.extend(1.0));
        let rotation = Mat3::from_cols(Vec3::new(c, -s, 0.0), Vec3::new(s, c, 0.0), Vec3::Z);
        let scale = Mat3::from_diagonal(self.scale.extend(1.0));
        translation * rotation * scale
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextureRef {
    pub image: Handle<Image>,
    pub sampler: Sampler,
    /// Which TEXCOORD set (0 or 1).
    pub uv_set: u32,
    pub transform: UvTransform,
}

impl TextureRef {
    pub fn new(image: Handle<Image>) -> Self {
        Self { image, sampler: Sampler::default(), uv_set: 0, transform: UvTransform::default() }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum AlphaMode {
    #[default]
    Opaque,
    /// Discard below the cutoff (glTF default 0.5).
    Mask(f32),
    /// Blended, drawn after opaque geometry, sorted back to front.
    Blend,
}

#[derive(Debug, Clone, PartialEq)]
pub struct StandardMaterial {
    /// Linear RGBA factor.
    pub base_color: Vec4,
    pub base_color_texture: Option<TextureRef>,
    pub metallic: f32,
    /// Perceptual roughness.
    pub roughness: f32,
    /// Blue: metallic, green: roughness (glTF).
    pub metallic_roughness_texture: Option<TextureRef>,
    pub normal_texture: Option<TextureRef>,
    pub normal_scale: f32,
    pub occlusion_texture: Option<TextureRef>,
    pub occlusion_strength: f32,
    /// Linear RGB factor.
    pub emissive: Vec3,
    /// KHR_materials_emissive_strength multiplier.
    pub emissive_strength: f32,
    pub emissive_texture: Option<TextureRef>,
    pub alpha_mode: AlphaMode,
    pub double_sided: bool,
    /// KHR_materials_unlit: base colour only, no lighting.
    pub unlit: bool,
    /// Index of refraction of the dielectric (KHR_materials_ior): its reflectance at normal
    /// incidence is ((ior − 1) / (ior + 1))², 4 % at the default 1.5. 0 gives a reflectance of 1
    /// scaled by `specular_color` alone, which is how specular-glossiness materials convert.
    pub ior: f32,
    /// KHR_materials_specular: the strength of the dielectric's specular lobe, 0..=1 (what it
    /// does not reflect goes to the diffuse lobe). Metals are unaffected.
    pub specular: f32,
    /// Multiplies `specular`; read from alpha.
    pub specular_texture: Option<TextureRef>,
    /// Linear RGB colour of the dielectric's reflectance at normal incidence (its F0 is this
    /// times the IOR's reflectance, clamped to 1).
    pub specular_color: Vec3,
    /// Multiplies `specular_color`; sRGB-encoded RGB.
    pub specular_color_texture: Option<TextureRef>,
    /// KHR_materials_clearcoat: the strength of a clear dielectric coat (IOR 1.5) over the
    /// material, 0..=1 (0: none).
    pub clearcoat: f32,
    /// Multiplies `clearcoat`; read from red.
    pub clearcoat_texture: Option<TextureRef>,
    /// The coat's perceptual roughness.
    pub clearcoat_roughness: f32,
    /// Multiplies `clearcoat_roughness`; read from green.
    pub clearcoat_roughness_texture: Option<TextureRef>,
    /// The coat's own normal map (tangent space, as `normal_texture`); without it the coat
    /// follows the geometry's normal, not the base's normal map.
    pub clearcoat_normal_texture: Option<TextureRef>,
    pub clearcoat_normal_scale: f32,
    /// KHR_materials_sheen: the linear colour of a layer of fibres over the material (the
    /// velvet's or cloth's rim), black for none.
    pub sheen_color: Vec3,
    /// Multiplies `sheen_color`; sRGB-encoded RGB.
    pub sheen_color_texture: Option<TextureRef>,
    /// The sheen's perceptual roughness (its Charlie distribution's α is the square).
    pub sheen_roughness: f32,
    /// Multiplies `sheen_roughness`; read from alpha.
    pub sheen_roughness_texture: Option<TextureRef>,
    /// KHR_materials_transmission: the share of the dielectric's diffuse lobe that passes
    /// through the surface instead (glass, water, clear plastic), 0..=1. Seen through, what lies
    /// behind is refracted by `ior`, blurred by `roughness` and tinted by the base colour.
    pub transmission: f32,
    /// Multiplies `transmission`; read from red.
    pub transmission_texture: Option<TextureRef>,
    /// KHR_materials_volume: the thickness of the volume beneath the surface, in the mesh's own
    /// units (the node's scale applies). 0 is a thin wall: no refraction, no attenuation.
    pub thickness: f32,
    /// Multiplies `thickness`; read from green.
    pub thickness_texture: Option<TextureRef>,
    /// The distance (world units) light travels in the volume before its colour is reduced to
    /// `attenuation_color` (Beer's law); infinite: no attenuation.
    pub attenuation_distance: f32,
    /// Linear RGB: what white light becomes after `attenuation_distance` in the volume.
    pub attenuation_color: Vec3,
    /// KHR_materials_dispersion: how much the IOR varies with wavelength, as 20 / Abbe number
    /// (0: none). Spreads the refracted colours apart.
    pub dispersion: f32,
    /// KHR_materials_anisotropy: how much the specular highlight stretches along the
    /// anisotropy direction (brushed metal, hair), 0..=1. The roughness along it becomes
    /// mix(α, 1, strength²); across it stays α.
    pub anisotropy_strength: f32,
    /// Radians, counter-clockwise from the tangent (in tangent space): the direction of
    /// stretching, or the rotation of the texture's directions.
    pub anisotropy_rotation: f32,
    /// Red and green: the direction in tangent space ([0, 1] maps to [−1, 1]); blue multiplies
    /// the strength. Linear.
    pub anisotropy_texture: Option<TextureRef>,
    /// KHR_materials_iridescence: the strength of a thin film over the material (soap
    /// bubbles, oil, anodised metal), 0..=1; its colours come from interference.
    pub iridescence: f32,
    /// Multiplies `iridescence`; read from red.
    pub iridescence_texture: Option<TextureRef>,
    /// The film's index of refraction.
    pub iridescence_ior: f32,
    /// The film's thickness in nanometres: the texture's green picks between the two; without
    /// a texture it is the maximum.
    pub iridescence_thickness_min: f32,
    pub iridescence_thickness_max: f32,
    pub iridescence_thickness_texture: Option<TextureRef>,
}

impl Default for StandardMaterial {
    /// glTF's default material: white, fully metallic, fully rough.
    fn default() -> Self {
        Self {
            base_color: Vec4::ONE,
            base_color_texture: None,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            occlusion_texture: None,
            occlusion_strength: 1.0,
            emissive: Vec3::ZERO,
            emissive_strength: 1.0,
            emissive_texture: None,
            alpha_mode: AlphaMode::Opaque,
            double_sided: false,
            unlit: false,
            ior: DEFAULT_IOR,
            specular: 1.0,
            specular_texture: None,
            specular_color: Vec3::ONE,
            specular_color_texture: None,
            clearcoat: 0.0,
            clearcoat_texture: None,
            clearcoat_roughness: 0.0,
            clearcoat_roughness_texture: None,
            clearcoat_normal_texture: None,
            clearcoat_normal_scale: 1.0,
            sheen_color: Vec3::ZERO,
            sheen_color_texture: None,
            sheen_roughness: 0.0,
            sheen_roughness_texture: None,
            transmission: 0.0,
            transmission_texture: None,
            thickness: 0.0,
            thickness_texture: None,
            attenuation_distance: f32::INFINITY,
            attenuation_color: Vec3::ONE,
            dispersion: 0.0,
            anisotropy_strength: 0.0,
            anisotropy_rotation: 0.0,
            anisotropy_texture: None,
            iridescence: 0.0,
            iridescence_texture: None,
            iridescence_ior: 1.3,
            iridescence_thickness_min: 100.0,
            iridescence_thickness_max: 400.0,
            iridescence_thickness_texture: None,
        }
    }
}

impl StandardMaterial {
    /// A plain dielectric of the given linear colour and roughness.
    pub fn from_color(base_color: Vec4, roughness: f32) -> Self {
        Self { base_color, metallic: 0.0, roughness, ..Default::default() }
    }

    /// Which of [`Self::textures`]' slots hold sRGB-encoded colour (base colour, emissive and
    /// specular colour and sheen colour, as glTF defines them); the others are read as stored.
    pub const SRGB_SLOTS: [bool; TEXTURE_SLOTS] = [
        true, false, false, false, true, false, true, false, false, false, true, false, false, false, false, false,
        false,
    ];

    /// Every texture slot in the fixed order the renderer binds them.
    pub fn textures(&self) -> [Option<&TextureRef>; TEXTURE_SLOTS] {
        [
            self.base_color_texture.as_ref(),
            self.metallic_roughness_texture.as_ref(),
            self.normal_texture.as_ref(),
            self.occlusion_texture.as_ref(),
            self.emissive_texture.as_ref(),
            self.specular_texture.as_ref(),
            self.specular_color_texture.as_ref(),
            self.clearcoat_texture.as_ref(),
            self.clearcoat_roughness_texture.as_ref(),
            self.clearcoat_normal_texture.as_ref(),
            self.sheen_color_texture.as_ref(),
            self.sheen_roughness_texture.as_ref(),
            self.transmission_texture.as_ref(),
            self.thickness_texture.as_ref(),
            self.anisotropy_texture.as_ref(),
            self.iridescence_texture.as_ref(),
            self.iridescence_thickness_texture.as_ref(),
        ]
    }

    /// [`Self::textures`], to fill in.
    pub fn textures_mut(&mut self) -> [&mut Option<TextureRef>; TEXTURE_SLOTS] {
        [
            &mut self.base_color_texture,
            &mut self.metallic_roughness_texture,
            &mut self.normal_texture,
            &mut self.occlusion_texture,
            &mut self.emissive_texture,
            &mut self.specular_texture,
            &mut self.specular_color_texture,
            &mut self.clearcoat_texture,
            &mut self.clearcoat_roughness_texture,
            &mut self.clearcoat_normal_texture,
            &mut self.sheen_color_texture,
            &mut self.sheen_roughness_texture,
            &mut self.transmission_texture,
            &mut self.thickness_texture,
            &mut self.anisotropy_texture,
            &mut self.iridescence_texture,
            &mut self.iridescence_thickness_texture,
        ]
    }

    /// The dielectric's reflectance at normal incidence from the IOR alone, ((ior − 1) /
    /// (ior + 1))² (1 for an IOR of 0).
    pub fn ior_reflectance(&self) -> f32 {
        let r = (self.ior - 1.0) / (self.ior + 1.0);
        r * r
    }

    /// Whether the material has a sheen (KHR_materials_sheen with a colour other than black).
    pub fn has_sheen(&self) -> bool {
        self.sheen_color.max_element() > 0.0
    }

    /// Whether a thin film colours the reflection (KHR_materials_iridescence above 0).
    pub fn has_iridescence(&self) -> bool {
        self.iridescence > 0.0
    }

    /// Whether the specular lobe is anisotropic (KHR_materials_anisotropy above 0).
    pub fn has_anisotropy(&self) -> bool {
        self.anisotropy_strength > 0.0
    }

    /// Whether light passes through the material (KHR_materials_transmission above 0).
    pub fn has_transmission(&self) -> bool {
        self.transmission > 0.0
    }

    /// Whether the dielectric reflects other than glTF's default (IOR 1.5, specular 1, white,
    /// no specular textures): the shader then reads its specular parameters.
    pub fn has_custom_specular(&self) -> bool {
        self.ior != DEFAULT_IOR
            || self.specular != 1.0
            || self.specular_color != Vec3::ONE
            || self.specular_texture.is_some()
            || self.specular_color_texture.is_some()
    }
}

/// How many texture slots a material has ([`StandardMaterial::textures`]).
pub const TEXTURE_SLOTS: usize = 17;

/// glTF's IOR when a material gives none.
pub const DEFAULT_IOR: f32 = 1.5;

/// Editing derives nothing else from the asset.
impl crate::assets::AssetEdit for StandardMaterial {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uv_transform_matches_the_extension_example() {
        // uv (1, 0) is scaled to (2, 0), turned by π/2 to (0, −2), then offset by (0.5, 0).
        let t =
            UvTransform { offset: Vec2::new(0.5, 0.0), rotation: std::f32::consts::FRAC_PI_2, scale: Vec2::splat(2.0) };
        let p = t.matrix() * Vec3::new(1.0, 0.0, 1.0);
        assert!((p.truncate() - Vec2::new(0.5, -2.0)).length() < 1e-5, "{p}");
    }
}
