//! glTF materials, textures and samplers to `StandardMaterial` descriptions. Textures still name
//! glTF image indices here; `spawn` swaps them for `Handle<Image>`s.

use glam::{Vec2, Vec3, Vec4};
use gltf::texture::{MagFilter, MinFilter, WrappingMode};

use crate::import::num;
use crate::material::{
    AlphaMode, DEFAULT_IOR, FilterMode, Sampler, StandardMaterial, TEXTURE_SLOTS, UvTransform, WrapMode,
};

#[derive(Debug, Clone)]
pub(crate) struct TextureDesc {
    pub image: usize,
    pub sampler: Sampler,
    pub uv_set: u32,
    pub transform: UvTransform,
}

/// A material with its textures still as glTF image indices, in `StandardMaterial::textures` order.
#[derive(Debug, Clone)]
pub(crate) struct MaterialDesc {
    pub material: StandardMaterial,
    pub textures: [Option<TextureDesc>; TEXTURE_SLOTS],
    /// A specular-glossiness material's glossiness factor, while its metallic-roughness slot
    /// still names the specular-glossiness image its roughness image is made from
    /// (`spec_gloss::derive_roughness`).
    pub glossiness: Option<f32>,
}

pub(crate) const NORMAL_SLOT: usize = 2;
/// The slots of tangent-space normal maps: the base's, then the coat's.
pub(crate) const NORMAL_SLOTS: [usize; 2] = [NORMAL_SLOT, CLEARCOAT_NORMAL_SLOT];
/// The extensions' slots that `material_extensions` fills.
pub(crate) const CLEARCOAT_SLOT: usize = 7;
pub(crate) const CLEARCOAT_ROUGHNESS_SLOT: usize = 8;
pub(crate) const CLEARCOAT_NORMAL_SLOT: usize = 9;
pub(crate) const SHEEN_COLOR_SLOT: usize = 10;
pub(crate) const SHEEN_ROUGHNESS_SLOT: usize = 11;
pub(crate) const TRANSMISSION_SLOT: usize = 12;
pub(crate) const THICKNESS_SLOT: usize = 13;
pub(crate) const ANISOTROPY_SLOT: usize = 14;
pub(crate) const IRIDESCENCE_SLOT: usize = 15;
pub(crate) const IRIDESCENCE_THICKNESS_SLOT: usize = 16;

fn sampler(s: gltf::texture::Sampler) -> Sampler {
    let wrap = |w| match w {
        WrappingMode::ClampToEdge => WrapMode::ClampToEdge,
        WrappingMode::MirroredRepeat => WrapMode::MirroredRepeat,
        WrappingMode::Repeat => WrapMode::Repeat,
    };
    let (min_filter, mipmap_filter) = match s.min_filter() {
        None | Some(MinFilter::LinearMipmapLinear) => (FilterMode::Linear, Some(FilterMode::Linear)),
        Some(MinFilter::Nearest) => (FilterMode::Nearest, None),
        Some(MinFilter::Linear) => (FilterMode::Linear, None),
        Some(MinFilter::NearestMipmapNearest) => (FilterMode::Nearest, Some(FilterMode::Nearest)),
        Some(MinFilter::LinearMipmapNearest) => (FilterMode::Linear, Some(FilterMode::Nearest)),
        Some(MinFilter::NearestMipmapLinear) => (FilterMode::Nearest, Some(FilterMode::Linear)),
    };
    let mag_filter = match s.mag_filter() {
        Some(MagFilter::Nearest) => FilterMode::Nearest,
        _ => FilterMode::Linear,
    };
    Sampler { mag_filter, min_filter, mipmap_filter, wrap_u: wrap(s.wrap_s()), wrap_v: wrap(s.wrap_t()) }
}

/// KHR_texture_transform read from raw extension JSON (normal and occlusion texture infos are
/// not typed by the gltf crate). Returns the transform and the optional texCoord override.
pub(crate) fn transform_from_json(v: &gltf::json::Value) -> (UvTransform, Option<u32>) {
    let pair = |key: &str, default: Vec2| {
        v.get(key)
            .and_then(|a| a.as_array())
            .filter(|a| a.len() == 2)
            .and_then(|a| Some(Vec2::new(a[0].as_f64()? as f32, a[1].as_f64()? as f32)))
            .unwrap_or(default)
    };
    let t = UvTransform {
        offset: pair("offset", Vec2::ZERO),
        rotation: v.get("rotation").and_then(|r| r.as_f64()).unwrap_or(0.0) as f32,
        scale: pair("scale", Vec2::ONE),
    };
    (t, v.get("texCoord").and_then(|c| c.as_u64()).map(|c| c as u32))
}

/// The extension naming a WebP image for a texture.
pub(crate) const WEBP: &str = "EXT_texture_webp";
pub(crate) const BASISU: &str = "KHR_texture_basisu";

/// The image a texture samples: the one KHR_texture_basisu or EXT_texture_webp names (checked
/// against the file's images at validation; KTX2 first, it is what the GPU samples compressed),
/// else its `source`; `None` when it has none.
pub(crate) fn texture_image(texture: &gltf::Texture) -> Option<usize> {
    let named = |ext| texture.extension_value(ext).and_then(|e| e.get("source")).and_then(|s| s.as_u64());
    named(BASISU).or_else(|| named(WEBP)).map(|i| i as usize).or_else(|| texture.source().map(|s| s.index()))
}

pub(crate) fn texture(
    texture: gltf::Texture,
    tex_coord: u32,
    transform: Option<(UvTransform, Option<u32>)>,
) -> TextureDesc {
    let (transform, uv_override) = transform.unwrap_or_default();
    TextureDesc {
        // A texture without an image points past the images: resolved to none, untextured.
        image: texture_image(&texture).unwrap_or(usize::MAX),
        sampler: sampler(texture.sampler()),
        uv_set: uv_override.unwrap_or(tex_coord),
        transform,
    }
}

pub(crate) fn info(i: gltf::texture::Info) -> TextureDesc {
    let tt = i.texture_transform().map(|t| {
        (UvTransform { offset: t.offset().into(), rotation: t.rotation(), scale: t.scale().into() }, t.tex_coord())
    });
    texture(i.texture(), i.tex_coord(), tt)
}

/// The material's name for messages: its name, or its index.
pub(crate) fn label(m: &gltf::Material) -> String {
    match (m.name(), m.index()) {
        (Some(name), _) => format!("material \"{name}\""),
        (None, Some(i)) => format!("material {i}"),
        (None, None) => "the default material".to_owned(),
    }
}

/// KHR_materials_ior and KHR_materials_specular, checked against their schemas: a value out of
/// range is replaced by the nearest allowed one (or the default), with a warning naming it.
fn dielectric(m: &gltf::Material, material: &mut StandardMaterial, warnings: &mut Vec<String>) {
    if let Some(ior) = m.ior() {
        material.ior = if ior.is_finite() && (ior == 0.0 || ior >= 1.0) {
            ior
        } else {
            warnings.push(format!(
                "{}: KHR_materials_ior ior {ior} is neither 0 nor at least 1; using {DEFAULT_IOR}",
                label(m)
            ));
            DEFAULT_IOR
        };
    }
    let Some(specular) = m.specular() else { return };
    let factor = specular.specular_factor();
    material.specular = if factor.is_finite() {
        if !(0.0..=1.0).contains(&factor) {
            warnings.push(format!(
                "{}: KHR_materials_specular specularFactor {factor} is outside 0..=1; clamped",
                label(m)
            ));
        }
        factor.clamp(0.0, 1.0)
    } else {
        warnings.push(format!("{}: KHR_materials_specular specularFactor {factor} is not finite; using 1", label(m)));
        1.0
    };
    let color = Vec3::from(specular.specular_color_factor());
    material.specular_color = if color.is_finite() && color.min_element() >= 0.0 {
        color
    } else {
        warnings.push(format!(
            "{}: KHR_materials_specular specularColorFactor {color} must be finite and not negative; using white",
            label(m)
        ));
        Vec3::ONE
    };
}

/// The core factors, checked against glTF's schema: a factor outside its range is clamped, a
/// non-finite one (which would turn the surface black or NaN) replaced by its default, each with
/// a warning naming the material.
fn core_factors(label: &str, m: &mut StandardMaterial, warnings: &mut Vec<String>) {
    let defaults = StandardMaterial::default();
    let mut check = |key: &str, value: &mut f32, default: f32, range: std::ops::RangeInclusive<f32>| {
        if !value.is_finite() {
            warnings.push(format!("{label}: {key} {} is not a finite number; using {default}", num(*value)));
            *value = default;
        } else if !range.contains(value) {
            let clamped = value.clamp(*range.start(), *range.end());
            let allowed = if *range.end() == f32::MAX {
                format!("below {}", range.start())
            } else {
                format!("outside {}..={}", range.start(), range.end())
            };
            warnings.push(format!("{label}: {key} {} is {allowed}; using {clamped}", num(*value)));
            *value = clamped;
        }
    };
    for (c, name) in ["r", "g", "b", "a"].iter().enumerate() {
        check(&format!("baseColorFactor.{name}"), &mut m.base_color[c], 1.0, 0.0..=1.0);
    }
    check("metallicFactor", &mut m.metallic, defaults.metallic, 0.0..=1.0);
    check("roughnessFactor", &mut m.roughness, defaults.roughness, 0.0..=1.0);
    check("normalTexture.scale", &mut m.normal_scale, 1.0, f32::MIN..=f32::MAX);
    check("occlusionTexture.strength", &mut m.occlusion_strength, 1.0, 0.0..=1.0);
    for (c, name) in ["r", "g", "b"].iter().enumerate() {
        check(&format!("emissiveFactor.{name}"), &mut m.emissive[c], 0.0, 0.0..=1.0);
    }
    check("KHR_materials_emissive_strength emissiveStrength", &mut m.emissive_strength, 1.0, 0.0..=f32::MAX);
    if let AlphaMode::Mask(cutoff) = &mut m.alpha_mode {
        check("alphaCutoff", cutoff, 0.5, 0.0..=f32::MAX);
    }
}

/// KHR_texture_transform's numbers must be finite: a non-finite offset, scale or rotation makes
/// every texel lookup NaN. Such a transform is dropped with a warning.
pub(crate) fn check_transforms(desc: &mut MaterialDesc, label: &str, warnings: &mut Vec<String>) {
    for (slot, t) in desc.textures.iter_mut().enumerate().filter_map(|(i, t)| Some((i, t.as_mut()?))) {
        let UvTransform { offset, rotation, scale } = t.transform;
        if !(offset.is_finite() && rotation.is_finite() && scale.is_finite()) {
            warnings.push(format!(
                "{label}: texture slot {slot}'s KHR_texture_transform (offset {offset}, rotation {rotation},                  scale {scale}) is not finite; ignored"
            ));
            t.transform = UvTransform::default();
        }
    }
}

pub(crate) fn convert(m: &gltf::Material, warnings: &mut Vec<String>) -> MaterialDesc {
    let pbr = m.pbr_metallic_roughness();
    let mut material = StandardMaterial {
        base_color: Vec4::from(pbr.base_color_factor()),
        metallic: pbr.metallic_factor(),
        roughness: pbr.roughness_factor(),
        normal_scale: m.normal_texture().map_or(1.0, |t| t.scale()),
        occlusion_strength: m.occlusion_texture().map_or(1.0, |t| t.strength()),
        emissive: Vec3::from(m.emissive_factor()),
        emissive_strength: m.emissive_strength().unwrap_or(1.0),
        alpha_mode: match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask(m.alpha_cutoff().unwrap_or(0.5)),
            gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        },
        double_sided: m.double_sided(),
        unlit: m.unlit(),
        ..StandardMaterial::default()
    };
    core_factors(&label(m), &mut material, warnings);
    dielectric(m, &mut material, warnings);
    let specular = m.specular();
    let textures = [
        pbr.base_color_texture().map(info),
        pbr.metallic_roughness_texture().map(info),
        m.normal_texture().map(|t| {
            let tt = t.extension_value("KHR_texture_transform").map(transform_from_json);
            texture(t.texture(), t.tex_coord(), tt)
        }),
        m.occlusion_texture().map(|t| {
            let tt = t.extension_value("KHR_texture_transform").map(transform_from_json);
            texture(t.texture(), t.tex_coord(), tt)
        }),
        m.emissive_texture().map(info),
        specular.as_ref().and_then(|s| s.specular_texture()).map(info),
        specular.as_ref().and_then(|s| s.specular_color_texture()).map(info),
        // The coat's, sheen's, transmission's, volume's and anisotropy's slots:
        // `material_extensions::read`.
        None,
        None,
        None,
        None,
        None,
        None,
        None,
        None,
        None,
        None,
    ];
    MaterialDesc { material, textures, glossiness: None }
}
