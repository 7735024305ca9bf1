//! KHR_materials_pbrSpecularGlossiness (archived, still common in older files), converted at
//! import to the metallic-roughness material with the specular parameters of
//! KHR_materials_specular and KHR_materials_ior, as the specular extension's specification
//! documents the conversion:
//!
//! - diffuse → base colour (factor and texture), metallic 0;
//! - specular → the specular colour, with IOR 0 so that the dielectric's F0 is that colour
//!   (factor, and the specular-glossiness texture's RGB as the specular colour texture);
//! - glossiness → roughness = 1 − glossiness: the factor directly, or, with a texture, an image
//!   made here whose green is 1 − factor × the texture's alpha (roughness is read from green).
//!
//! Approximate, and said so in a warning: specular-glossiness adds its diffuse and specular
//! lobes, where glTF's dielectric gives the diffuse lobe only what the specular lobe leaves.
//!
//! Data flow: [`convert`] fills the material and names the specular-glossiness image in the
//! metallic-roughness slot with the glossiness factor beside it; once images are decoded,
//! [`derive_roughness`] makes each (image, factor)'s roughness image once, appends it after the
//! file's own images and points the slot at it.

use std::collections::HashMap;
use std::sync::Arc;

use glam::{Vec3, Vec4};

use super::materials::MaterialDesc;
use crate::image::Image;

/// `StandardMaterial::textures()` slots.
const BASE_COLOR_SLOT: usize = 0;
const METALLIC_ROUGHNESS_SLOT: usize = 1;
const SPECULAR_COLOR_SLOT: usize = 6;

/// Converts `desc` (already read as metallic-roughness, for what both workflows share: normal,
/// occlusion, emissive, alpha) from the material's specular-glossiness parameters.
pub(crate) fn convert(
    sg: &gltf::material::PbrSpecularGlossiness,
    desc: &mut MaterialDesc,
    label: &str,
    info: impl Fn(gltf::texture::Info) -> super::materials::TextureDesc,
    warnings: &mut Vec<String>,
) {
    let m = &mut desc.material;
    m.base_color = Vec4::from(sg.diffuse_factor());
    m.metallic = 0.0;
    m.ior = 0.0;
    m.specular = 1.0;
    m.specular_color = Vec3::from(sg.specular_factor());
    let glossiness = sg.glossiness_factor();
    m.roughness = 1.0;
    desc.textures[BASE_COLOR_SLOT] = sg.diffuse_texture().map(&info);
    desc.textures[SPECULAR_COLOR_SLOT] = None;
    desc.textures[METALLIC_ROUGHNESS_SLOT] = None;
    desc.glossiness = None;
    match sg.specular_glossiness_texture().map(&info) {
        Some(t) => {
            desc.textures[SPECULAR_COLOR_SLOT] = Some(t.clone());
            desc.textures[METALLIC_ROUGHNESS_SLOT] = Some(t);
            desc.glossiness = Some(glossiness);
        }
        None => m.roughness = 1.0 - glossiness,
    }
    let checked = |v: f32| v.is_finite() && (0.0..=1.0).contains(&v);
    if !checked(glossiness) || !m.specular_color.is_finite() || m.specular_color.min_element() < 0.0 {
        warnings.push(format!(
            "{label}: KHR_materials_pbrSpecularGlossiness glossiness {glossiness} or specular {} out of \
             range; clamped",
            m.specular_color
        ));
        m.roughness = m.roughness.clamp(0.0, 1.0);
        m.specular_color = m.specular_color.clamp(Vec3::ZERO, Vec3::ONE);
        if let Some(g) = &mut desc.glossiness {
            *g = if g.is_finite() { g.clamp(0.0, 1.0) } else { 1.0 };
        }
        if !m.roughness.is_finite() {
            m.roughness = 1.0;
        }
    }
    warnings.push(format!(
        "{label}: KHR_materials_pbrSpecularGlossiness (archived) converted to metallic-roughness with \
         KHR_materials_specular at IOR 0; approximate: the diffuse lobe gets only what the specular \
         lobe leaves"
    ));
}

/// Gives each material converted with a glossiness texture its roughness image (made once per
/// source image and factor); returns how many images were made.
pub(crate) fn derive_roughness(
    materials: &mut [MaterialDesc],
    images: &mut Vec<Option<Arc<Image>>>,
) -> Result<usize, (usize, String)> {
    let mut made: HashMap<(*const Image, u32), usize> = HashMap::new();
    for m in materials.iter_mut() {
        let (Some(glossiness), Some(slot)) = (m.glossiness, &mut m.textures[METALLIC_ROUGHNESS_SLOT]) else {
            continue;
        };
        let Some(source) = images.get(slot.image).and_then(Option::clone) else {
            continue;
        };
        let key = (Arc::as_ptr(&source), glossiness.to_bits());
        let index = match made.get(&key) {
            Some(&index) => index,
            None => {
                let image = roughness_image(&source, glossiness).map_err(|e| (slot.image, e))?;
                images.push(Some(Arc::new(image)));
                made.insert(key, images.len() - 1);
                images.len() - 1
            }
        };
        slot.image = index;
        m.glossiness = None;
    }
    Ok(made.len())
}

/// Roughness 1 − `glossiness` × alpha in green, metallic 0 in blue, occlusion 1 in red, with its
/// own mip chain (linear: roughness is data).
fn roughness_image(source: &Image, glossiness: f32) -> Result<Image, String> {
    let texels = source.texels().map_err(|e| format!("{}: {e}", source.label))?;
    let rgba8 = texels
        .chunks_exact(4)
        .flat_map(|p| {
            let rough = 1.0 - glossiness * (p[3] as f32 / 255.0);
            [255, (rough.clamp(0.0, 1.0) * 255.0).round() as u8, 0, 255]
        })
        .collect();
    let label = format!("{} (roughness from glossiness {glossiness})", source.label);
    let mut image = Image::rgba8(source.width, source.height, rgba8, label);
    image.mips = Some(image.build_mips(false));
    Ok(image)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roughness_is_one_minus_glossiness_times_alpha() {
        let source = Image::rgba8(2, 1, vec![10, 20, 30, 255, 10, 20, 30, 0], "sg");
        let r = roughness_image(&source, 0.5).unwrap();
        assert_eq!(r.rgba8, vec![255, 128, 0, 255, 255, 255, 0, 255]);
        assert!(r.mips.as_ref().is_some_and(|c| !c.srgb && r.fits(c)));
    }
}
