//! KHR_materials_clearcoat, read from the material's raw extension JSON (the gltf crate has no
//! typed support for it): the coat's strength, roughness and their textures, and its normal map.
//! Values are checked against the extension's schema (a factor outside 0..=1 is clamped, a
//! texture index past the file's textures is dropped) with a warning naming the material.

use super::materials::{MaterialDesc, TextureDesc, texture, transform_from_json};

/// `StandardMaterial::textures()` slots.
const CLEARCOAT_SLOT: usize = 7;
const CLEARCOAT_ROUGHNESS_SLOT: usize = 8;
const CLEARCOAT_NORMAL_SLOT: usize = 9;

/// Fills `desc`'s coat from `m`'s KHR_materials_clearcoat, if it has one.
pub(crate) fn read(
    m: &gltf::Material,
    document: &gltf::Document,
    desc: &mut MaterialDesc,
    label: &str,
    warnings: &mut Vec<String>,
) {
    let Some(ext) = m.extension_value("KHR_materials_clearcoat") else { return };
    let mut factor = |key: &str| {
        let Some(v) = ext.get(key) else { return 0.0 };
        match v.as_f64().map(|f| f as f32) {
            Some(f) if f.is_finite() && (0.0..=1.0).contains(&f) => f,
            Some(f) if f.is_finite() => {
                warnings.push(format!("{label}: KHR_materials_clearcoat {key} {f} is outside 0..=1; clamped"));
                f.clamp(0.0, 1.0)
            }
            _ => {
                warnings.push(format!("{label}: KHR_materials_clearcoat {key} {v} is not a number; using 0"));
                0.0
            }
        }
    };
    desc.material.clearcoat = factor("clearcoatFactor");
    desc.material.clearcoat_roughness = factor("clearcoatRoughnessFactor");
    let mut texture_info = |key: &str| -> Option<(TextureDesc, Option<f32>)> {
        let info = ext.get(key)?;
        let index = info.get("index").and_then(|i| i.as_u64());
        let Some(tex) = index.and_then(|i| document.textures().nth(i as usize)) else {
            warnings.push(format!(
                "{label}: KHR_materials_clearcoat {key} names no texture of the file ({}); ignored",
                info.get("index").map_or("no index".to_owned(), |i| i.to_string())
            ));
            return None;
        };
        let tex_coord = info.get("texCoord").and_then(|c| c.as_u64()).unwrap_or(0) as u32;
        let transform = info.pointer("/extensions/KHR_texture_transform").map(transform_from_json);
        let scale = info.get("scale").and_then(|s| s.as_f64()).map(|s| s as f32);
        Some((texture(tex, tex_coord, transform), scale))
    };
    desc.textures[CLEARCOAT_SLOT] = texture_info("clearcoatTexture").map(|(t, _)| t);
    desc.textures[CLEARCOAT_ROUGHNESS_SLOT] = texture_info("clearcoatRoughnessTexture").map(|(t, _)| t);
    if let Some((t, scale)) = texture_info("clearcoatNormalTexture") {
        desc.textures[CLEARCOAT_NORMAL_SLOT] = Some(t);
        desc.material.clearcoat_normal_scale = scale.filter(|s| s.is_finite()).unwrap_or(1.0);
    }
}
