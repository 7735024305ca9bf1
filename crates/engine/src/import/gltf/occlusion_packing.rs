//! Occlusion packed into the red channel of the metallic-roughness texture, at import.
//!
//! glTF reads metallic from blue and roughness from green, and occlusion from red, so many
//! exporters write one "ORM" texture; others (DamagedHelmet among them) keep occlusion in an
//! image of its own. Where a material's two textures are separate images of the same size,
//! sampled alike (same sampler, UV set and transform), read as linear data only and by nothing
//! else, import replaces them with one image holding occlusion's red and metallic-roughness's
//! other channels, and points both slots at it. The renderer then compiles the variant that
//! reads one texel for both (`OCCLUSION_IN_METALLIC_ROUGHNESS`): one texture read fewer per
//! fragment on every adapter, and on a CPU rasteriser less fragment shader to compile on every
//! hot reload of the lit shader (docs/shaders.md, "Reload latency"). One texture instead of two
//! on the GPU.
//!
//! The pixels do not change: the texels and every level of the mip chains are copied channel
//! by channel (import's chains average each channel on its own, so the packed chain is the
//! chain of the packed image), and a sampler filters each channel on its own.
//!
//! Data flow: `load_inner` decodes the images, calls [`pack_occlusion`] with the materials
//! (still naming glTF image indices) and the decoded images; packed images are appended after
//! the file's own, and the originals they replace are dropped.

use std::collections::{HashMap, HashSet};
use std::sync::Arc;

use super::materials::MaterialDesc;
use crate::image::Image;
use crate::mip_chain::{MipChain, MipLevel};

/// `StandardMaterial::textures()` slots.
const METALLIC_ROUGHNESS_SLOT: usize = 1;
const OCCLUSION_SLOT: usize = 3;

/// A (metallic-roughness, occlusion) pair of decoded images, by identity.
type Pair = (*const Image, *const Image);

/// Packs each material's occlusion into its metallic-roughness image where that keeps every
/// pixel and nothing else reads either image; returns how many packed images were made.
///
/// Only pairs read by nothing but each other are packed: the packed image then replaces both
/// originals, so memory only shrinks (import's image limit, checked on the decoded images,
/// still bounds it) and no original stays on the GPU beside its copy. Images are compared by
/// identity, not index: glTF image entries naming one source share one decoded image.
pub(crate) fn pack_occlusion(materials: &mut [MaterialDesc], images: &mut Vec<Option<Arc<Image>>>) -> usize {
    let id = |index: usize| images.get(index).and_then(Option::as_ref).map(Arc::as_ptr);
    // Each (metallic-roughness, occlusion) pair of distinct images, and whether it can be
    // packed: every material pairing them samples both alike.
    let mut pairs: HashMap<Pair, bool> = HashMap::new();
    for m in materials.iter() {
        let (Some(mr), Some(ao)) = (&m.textures[METALLIC_ROUGHNESS_SLOT], &m.textures[OCCLUSION_SLOT]) else {
            continue;
        };
        let (Some(mr_id), Some(ao_id)) = (id(mr.image), id(ao.image)) else { continue };
        if mr_id == ao_id {
            // Already one image: the renderer samples it once.
            continue;
        }
        let alike = mr.sampler == ao.sampler && mr.uv_set == ao.uv_set && mr.transform == ao.transform;
        *pairs.entry((mr_id, ao_id)).or_insert(true) &= alike;
    }
    // And every read of either image is that pair's own slot. Each image's reader: the pair
    // whose own slot it fills, or `None` once anything else reads it.
    let mut reader: HashMap<*const Image, Option<Pair>> = HashMap::new();
    for m in materials.iter() {
        let pair = match (&m.textures[METALLIC_ROUGHNESS_SLOT], &m.textures[OCCLUSION_SLOT]) {
            (Some(mr), Some(ao)) => id(mr.image).zip(id(ao.image)),
            _ => None,
        };
        for (slot, t) in m.textures.iter().enumerate() {
            let Some(image) = t.as_ref().and_then(|t| id(t.image)) else { continue };
            let own = pair.filter(|&(mr, ao)| {
                slot == METALLIC_ROUGHNESS_SLOT && image == mr || slot == OCCLUSION_SLOT && image == ao
            });
            let r = reader.entry(image).or_insert(own);
            if *r != own {
                *r = None;
            }
        }
    }
    let mut packable: HashSet<Pair> = pairs
        .into_iter()
        .filter(|&(pair, alike)| {
            alike && reader.get(&pair.0) == Some(&Some(pair)) && reader.get(&pair.1) == Some(&Some(pair))
        })
        .map(|(pair, _)| pair)
        .collect();
    let mut packed: HashMap<Pair, usize> = HashMap::new();
    for m in materials.iter_mut() {
        let (Some(mr), Some(ao)) = (&m.textures[METALLIC_ROUGHNESS_SLOT], &m.textures[OCCLUSION_SLOT]) else {
            continue;
        };
        let (Some(mr_image), Some(ao_image)) =
            (images.get(mr.image).and_then(Option::clone), images.get(ao.image).and_then(Option::clone))
        else {
            continue;
        };
        let key = (Arc::as_ptr(&mr_image), Arc::as_ptr(&ao_image));
        let index = match packed.get(&key) {
            Some(&i) => i,
            None if packable.contains(&key) => {
                let Some(image) = packed_image(&mr_image, &ao_image) else {
                    packable.remove(&key);
                    continue;
                };
                images.push(Some(Arc::new(image)));
                packed.insert(key, images.len() - 1);
                images.len() - 1
            }
            None => continue,
        };
        for slot in [METALLIC_ROUGHNESS_SLOT, OCCLUSION_SLOT] {
            if let Some(t) = &mut m.textures[slot] {
                t.image = index;
            }
        }
    }
    // Nothing reads the originals now: their memory goes with them.
    let replaced: HashSet<*const Image> = packed.keys().flat_map(|&(mr, ao)| [mr, ao]).collect();
    for image in images.iter_mut() {
        if image.as_ref().is_some_and(|i| replaced.contains(&Arc::as_ptr(i))) {
            *image = None;
        }
    }
    packed.len()
}

/// `mr` with `ao`'s red channel, level by level; `None` where that would change what a material
/// reads: different sizes, or a chain made in sRGB (the image is also read as colour somewhere,
/// so its linear reads get the renderer's chain) or missing.
fn packed_image(mr: &Image, ao: &Image) -> Option<Image> {
    if (mr.width, mr.height) != (ao.width, ao.height) || mr.rgba8.len() != ao.rgba8.len() {
        return None;
    }
    let (mr_chain, ao_chain) = (mr.mips.as_ref()?, ao.mips.as_ref()?);
    if mr_chain.srgb || ao_chain.srgb || !mr.fits(mr_chain) || !ao.fits(ao_chain) {
        return None;
    }
    let levels = mr_chain
        .levels
        .iter()
        .zip(&ao_chain.levels)
        .map(|(m, a)| MipLevel { width: m.width, height: m.height, rgba8: with_red_of(&m.rgba8, &a.rgba8) })
        .collect();
    Some(Image {
        width: mr.width,
        height: mr.height,
        rgba8: with_red_of(&mr.rgba8, &ao.rgba8),
        label: format!("{} with occlusion from {}", mr.label, ao.label),
        mips: Some(MipChain { srgb: false, levels }),
        compressed: None,
    })
}

/// `rgba` with the red byte of each texel taken from `red`.
fn with_red_of(rgba: &[u8], red: &[u8]) -> Vec<u8> {
    let mut out = rgba.to_vec();
    for (texel, from) in out.chunks_exact_mut(4).zip(red.chunks_exact(4)) {
        texel[0] = from[0];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::gltf::materials::TextureDesc;
    use crate::material::{Sampler, StandardMaterial, UvTransform, WrapMode};

    /// A `w`×`h` image whose texel i is [r + i, g + 3i, b, a] (wrapping), with its linear chain.
    fn image(w: u32, h: u32, rgba: [u8; 4], label: &str) -> Arc<Image> {
        let rgba8 = (0..w * h)
            .flat_map(|i| [rgba[0].wrapping_add(i as u8), rgba[1].wrapping_add(3 * i as u8), rgba[2], rgba[3]])
            .collect();
        let mut img = Image::rgba8(w, h, rgba8, label);
        img.mips = Some(img.build_mips(false));
        Arc::new(img)
    }

    fn texture(image: usize) -> Option<TextureDesc> {
        Some(TextureDesc { image, sampler: Sampler::default(), uv_set: 0, transform: UvTransform::default() })
    }

    fn material(mr: usize, ao: usize) -> MaterialDesc {
        let mut textures: [Option<TextureDesc>; crate::material::TEXTURE_SLOTS] = Default::default();
        textures[METALLIC_ROUGHNESS_SLOT] = texture(mr);
        textures[OCCLUSION_SLOT] = texture(ao);
        MaterialDesc { material: StandardMaterial::default(), textures, glossiness: None }
    }

    #[test]
    fn separate_occlusion_moves_into_the_red_channel_level_by_level() {
        let mr = image(8, 4, [10, 20, 30, 255], "mr");
        let ao = image(8, 4, [200, 7, 7, 7], "ao");
        let mut images = vec![Some(mr.clone()), Some(ao.clone())];
        let mut materials = vec![material(0, 1), material(0, 1)];
        assert_eq!(pack_occlusion(&mut materials, &mut images), 1);
        // Both slots of both materials read the one packed image; the originals are gone.
        for m in &materials {
            assert_eq!(m.textures[METALLIC_ROUGHNESS_SLOT].as_ref().unwrap().image, 2);
            assert_eq!(m.textures[OCCLUSION_SLOT].as_ref().unwrap().image, 2);
        }
        assert!(images[0].is_none() && images[1].is_none());
        let packed = images[2].as_ref().unwrap();
        assert_eq!(packed.label, "mr with occlusion from ao");
        // What each slot reads is unchanged: red from the occlusion image, the rest from
        // metallic-roughness, at level 0 and in every level of the chain (which is the chain of
        // the packed image).
        let expect = |m: &[u8], a: &[u8]| -> Vec<u8> {
            m.chunks(4).zip(a.chunks(4)).flat_map(|(m, a)| [a[0], m[1], m[2], m[3]]).collect()
        };
        assert_eq!(packed.rgba8, expect(&mr.rgba8, &ao.rgba8));
        let chain = packed.mips.as_ref().unwrap();
        let (mr_chain, ao_chain) = (mr.mips.as_ref().unwrap(), ao.mips.as_ref().unwrap());
        assert_eq!(chain.levels.len(), 3);
        for (i, level) in chain.levels.iter().enumerate() {
            assert_eq!(level.rgba8, expect(&mr_chain.levels[i].rgba8, &ao_chain.levels[i].rgba8));
        }
        assert_eq!(*chain, packed.build_mips(false));
    }

    #[test]
    fn textures_read_differently_stay_apart() {
        let cases: [(&str, fn(&mut MaterialDesc, &mut Vec<Option<Arc<Image>>>)); 8] = [
            ("one image already (ORM)", |m, _| m.textures[OCCLUSION_SLOT].as_mut().unwrap().image = 0),
            ("a chain is missing", |_, images| {
                let mut ao = (**images[1].as_ref().unwrap()).clone();
                ao.mips = None;
                images[1] = Some(Arc::new(ao));
            }),
            ("sizes differ", |_, images| images[1] = Some(image(4, 4, [1, 2, 3, 4], "ao"))),
            ("samplers differ", |m, _| {
                m.textures[OCCLUSION_SLOT].as_mut().unwrap().sampler.wrap_u = WrapMode::ClampToEdge
            }),
            ("UV sets differ", |m, _| m.textures[OCCLUSION_SLOT].as_mut().unwrap().uv_set = 1),
            ("transforms differ", |m, _| m.textures[OCCLUSION_SLOT].as_mut().unwrap().transform.rotation = 0.5),
            ("a chain is sRGB (the image is also read as colour)", |_, images| {
                let mut ao = (**images[1].as_ref().unwrap()).clone();
                ao.mips = Some(ao.build_mips(true));
                images[1] = Some(Arc::new(ao));
            }),
            ("an image failed to decode", |_, images| images[1] = None),
        ];
        for (why, change) in cases {
            let mut images = vec![Some(image(8, 8, [1, 2, 3, 4], "mr")), Some(image(8, 8, [5, 6, 7, 8], "ao"))];
            let mut materials = vec![material(0, 1)];
            change(&mut materials[0], &mut images);
            let before = images.clone();
            assert_eq!(pack_occlusion(&mut materials, &mut images), 0, "{why}");
            assert_eq!(materials[0].textures[METALLIC_ROUGHNESS_SLOT].as_ref().unwrap().image, 0, "{why}");
            let ao = if why.starts_with("one image") { 0 } else { 1 };
            assert_eq!(materials[0].textures[OCCLUSION_SLOT].as_ref().unwrap().image, ao, "{why}");
            assert_eq!(images.len(), 2, "{why}");
            assert!(images.iter().zip(&before).all(|(a, b)| a.is_some() == b.is_some()), "{why}");
        }
    }

    #[test]
    fn images_something_else_reads_are_not_packed() {
        // The packed image would sit beside an original that must stay: more memory, not less.
        let cases: [(&str, fn(&mut MaterialDesc)); 3] = [
            ("metallic-roughness read alone", |m| m.textures[OCCLUSION_SLOT] = None),
            ("occlusion read as another slot", |m| {
                m.textures[OCCLUSION_SLOT] = None;
                m.textures[0] = texture(1);
            }),
            ("the pair sampled differently", |m| {
                m.textures[OCCLUSION_SLOT].as_mut().unwrap().sampler.wrap_v = WrapMode::MirroredRepeat
            }),
        ];
        for (why, change) in cases {
            let mut images = vec![Some(image(8, 8, [1, 2, 3, 4], "mr")), Some(image(8, 8, [5, 6, 7, 8], "ao"))];
            let mut other = material(0, 1);
            change(&mut other);
            let mut materials = vec![material(0, 1), other];
            assert_eq!(pack_occlusion(&mut materials, &mut images), 0, "{why}");
            assert_eq!(images.len(), 2, "{why}");
            assert!(images.iter().all(Option::is_some), "{why}");
            assert_eq!(materials[0].textures[OCCLUSION_SLOT].as_ref().unwrap().image, 1, "{why}");
        }
    }

    #[test]
    fn entries_naming_one_decoded_image_pack_once() {
        // glTF images 0 and 2 name one source: import decoded it once.
        let (mr, ao) = (image(8, 8, [1, 2, 3, 4], "mr"), image(8, 8, [5, 6, 7, 8], "ao"));
        let mut images = vec![Some(mr.clone()), Some(ao), Some(mr)];
        let mut materials = vec![material(0, 1), material(2, 1)];
        assert_eq!(pack_occlusion(&mut materials, &mut images), 1);
        assert_eq!(images.len(), 4);
        assert!(images[..3].iter().all(Option::is_none));
        for m in &materials {
            assert_eq!(m.textures[METALLIC_ROUGHNESS_SLOT].as_ref().unwrap().image, 3);
            assert_eq!(m.textures[OCCLUSION_SLOT].as_ref().unwrap().image, 3);
        }
    }

    #[test]
    fn damaged_helmet_reads_occlusion_from_its_metallic_roughness_image() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/DamagedHelmet.glb");
        let scene = crate::import::gltf::GltfScene::load(&path, &Default::default()).unwrap();
        let m = &scene.materials[0];
        let (mr, ao) =
            (m.textures[METALLIC_ROUGHNESS_SLOT].as_ref().unwrap(), m.textures[OCCLUSION_SLOT].as_ref().unwrap());
        assert_eq!(mr.image, ao.image);
        let packed = scene.images[mr.image].as_ref().unwrap();
        assert_eq!(packed.label, "DamagedHelmet.glb#image1 with occlusion from DamagedHelmet.glb#image3");
        // Base colour, emissive, normal map and the packed image: four, not five.
        assert_eq!(scene.images.iter().flatten().count(), 4);
    }
}
