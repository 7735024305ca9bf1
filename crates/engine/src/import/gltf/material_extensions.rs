//! The glTF material extensions the gltf crate has no typed support for, read from each
//! material's raw extension JSON: KHR_materials_clearcoat, _sheen, _transmission, _volume,
//! _dispersion, _anisotropy and _iridescence. Values are
//! checked against each extension's schema (a factor outside its range is clamped, a value that
//! is not a number falls back to the extension's default, a texture index past the file's
//! textures is dropped), each with a warning naming the material and the extension.

use glam::Vec3;

use super::materials::{
    ANISOTROPY_SLOT, CLEARCOAT_NORMAL_SLOT, CLEARCOAT_ROUGHNESS_SLOT, CLEARCOAT_SLOT, IRIDESCENCE_SLOT,
    IRIDESCENCE_THICKNESS_SLOT, MaterialDesc, SHEEN_COLOR_SLOT, SHEEN_ROUGHNESS_SLOT, THICKNESS_SLOT,
    TRANSMISSION_SLOT, TextureDesc, texture, transform_from_json,
};

/// Fills `desc` from the extensions of `m` this module reads.
pub(crate) fn read(
    m: &gltf::Material,
    document: &gltf::Document,
    desc: &mut MaterialDesc,
    label: &str,
    warnings: &mut Vec<String>,
) {
    if let Some(ext) = Reader::new(m, "KHR_materials_clearcoat", document, label, warnings) {
        clearcoat(ext, desc);
    }
    if let Some(ext) = Reader::new(m, "KHR_materials_sheen", document, label, warnings) {
        sheen(ext, desc);
    }
    if let Some(mut ext) = Reader::new(m, "KHR_materials_transmission", document, label, warnings) {
        desc.material.transmission = ext.factor("transmissionFactor", 0.0);
        desc.textures[TRANSMISSION_SLOT] = ext.texture("transmissionTexture").map(|(t, _)| t);
    }
    if let Some(ext) = Reader::new(m, "KHR_materials_volume", document, label, warnings) {
        volume(ext, desc);
    }
    if let Some(mut ext) = Reader::new(m, "KHR_materials_dispersion", document, label, warnings) {
        desc.material.dispersion = ext.non_negative("dispersion", 0.0);
    }
    if let Some(mut ext) = Reader::new(m, "KHR_materials_anisotropy", document, label, warnings) {
        desc.material.anisotropy_strength = ext.factor("anisotropyStrength", 0.0);
        desc.material.anisotropy_rotation = ext.finite("anisotropyRotation", 0.0);
        desc.textures[ANISOTROPY_SLOT] = ext.texture("anisotropyTexture").map(|(t, _)| t);
    }
    if let Some(ext) = Reader::new(m, "KHR_materials_iridescence", document, label, warnings) {
        iridescence(ext, desc);
    }
}

fn iridescence(mut ext: Reader, desc: &mut MaterialDesc) {
    let m = &mut desc.material;
    m.iridescence = ext.factor("iridescenceFactor", 0.0);
    desc.textures[IRIDESCENCE_SLOT] = ext.texture("iridescenceTexture").map(|(t, _)| t);
    m.iridescence_ior = match ext.non_negative("iridescenceIor", 1.3) {
        ior if ior >= 1.0 => ior,
        ior => {
            ext.warn(format!("iridescenceIor {ior} is below 1; using 1.3"));
            1.3
        }
    };
    m.iridescence_thickness_min = ext.non_negative("iridescenceThicknessMinimum", 100.0);
    m.iridescence_thickness_max = ext.non_negative("iridescenceThicknessMaximum", 400.0);
    desc.textures[IRIDESCENCE_THICKNESS_SLOT] = ext.texture("iridescenceThicknessTexture").map(|(t, _)| t);
}

fn volume(mut ext: Reader, desc: &mut MaterialDesc) {
    let m = &mut desc.material;
    m.thickness = ext.non_negative("thicknessFactor", 0.0);
    desc.textures[THICKNESS_SLOT] = ext.texture("thicknessTexture").map(|(t, _)| t);
    m.attenuation_color = ext.color("attenuationColor", Vec3::ONE);
    // The schema: a positive distance; infinity (the default) when absent.
    m.attenuation_distance = match ext.ext.get("attenuationDistance") {
        None => f32::INFINITY,
        Some(v) => match v.as_f64().map(|f| f as f32) {
            Some(d) if d > 0.0 => d,
            _ => {
                ext.warn(format!("attenuationDistance {v} is not a positive number; no attenuation"));
                f32::INFINITY
            }
        },
    };
}

fn clearcoat(mut ext: Reader, desc: &mut MaterialDesc) {
    let m = &mut desc.material;
    m.clearcoat = ext.factor("clearcoatFactor", 0.0);
    m.clearcoat_roughness = ext.factor("clearcoatRoughnessFactor", 0.0);
    desc.textures[CLEARCOAT_SLOT] = ext.texture("clearcoatTexture").map(|(t, _)| t);
    desc.textures[CLEARCOAT_ROUGHNESS_SLOT] = ext.texture("clearcoatRoughnessTexture").map(|(t, _)| t);
    if let Some((t, scale)) = ext.texture("clearcoatNormalTexture") {
        desc.textures[CLEARCOAT_NORMAL_SLOT] = Some(t);
        m.clearcoat_normal_scale = scale.filter(|s| s.is_finite()).unwrap_or(1.0);
    }
}

fn sheen(mut ext: Reader, desc: &mut MaterialDesc) {
    desc.material.sheen_color = ext.color("sheenColorFactor", Vec3::ZERO);
    desc.material.sheen_roughness = ext.factor("sheenRoughnessFactor", 0.0);
    desc.textures[SHEEN_COLOR_SLOT] = ext.texture("sheenColorTexture").map(|(t, _)| t);
    desc.textures[SHEEN_ROUGHNESS_SLOT] = ext.texture("sheenRoughnessTexture").map(|(t, _)| t);
}

/// One material's extension object, with what its warnings name.
struct Reader<'a> {
    ext: &'a gltf::json::Value,
    name: &'static str,
    document: &'a gltf::Document,
    label: &'a str,
    warnings: &'a mut Vec<String>,
}

impl<'a> Reader<'a> {
    fn new(
        m: &'a gltf::Material,
        name: &'static str,
        document: &'a gltf::Document,
        label: &'a str,
        warnings: &'a mut Vec<String>,
    ) -> Option<Self> {
        let ext = m.extension_value(name)?;
        Some(Self { ext, name, document, label, warnings })
    }

    fn warn(&mut self, what: String) {
        self.warnings.push(format!("{}: {} {what}", self.label, self.name));
    }

    /// A factor in 0..=1 (the schema's range for every factor read here).
    fn factor(&mut self, key: &str, default: f32) -> f32 {
        let Some(v) = self.ext.get(key) else { return default };
        match v.as_f64().map(|f| f as f32) {
            Some(f) if f.is_finite() && (0.0..=1.0).contains(&f) => f,
            Some(f) if f.is_finite() => {
                self.warn(format!("{key} {f} is outside 0..=1; clamped"));
                f.clamp(0.0, 1.0)
            }
            _ => {
                self.warn(format!("{key} {v} is not a number; using {default}"));
                default
            }
        }
    }

    /// Any finite number (an angle).
    fn finite(&mut self, key: &str, default: f32) -> f32 {
        let Some(v) = self.ext.get(key) else { return default };
        match v.as_f64().map(|f| f as f32) {
            Some(f) if f.is_finite() => f,
            _ => {
                self.warn(format!("{key} {v} is not a finite number; using {default}"));
                default
            }
        }
    }

    /// A factor of at least 0 (thickness, dispersion).
    fn non_negative(&mut self, key: &str, default: f32) -> f32 {
        let Some(v) = self.ext.get(key) else { return default };
        match v.as_f64().map(|f| f as f32) {
            Some(f) if f.is_finite() && f >= 0.0 => f,
            _ => {
                self.warn(format!("{key} {v} is not a finite number of at least 0; using {default}"));
                default
            }
        }
    }

    /// A linear RGB colour factor, each component in 0..=1.
    fn color(&mut self, key: &str, default: Vec3) -> Vec3 {
        let Some(v) = self.ext.get(key) else { return default };
        let parsed = v.as_array().filter(|a| a.len() == 3).and_then(|a| {
            let c: Option<Vec<f32>> = a.iter().map(|x| x.as_f64().map(|f| f as f32)).collect();
            c.map(|c| Vec3::new(c[0], c[1], c[2])).filter(|c| c.is_finite())
        });
        match parsed {
            Some(c) if c.min_element() >= 0.0 && c.max_element() <= 1.0 => c,
            Some(c) => {
                self.warn(format!("{key} {c} is outside 0..=1; clamped"));
                c.clamp(Vec3::ZERO, Vec3::ONE)
            }
            None => {
                self.warn(format!("{key} {v} is not three finite numbers; using {default}"));
                default
            }
        }
    }

    /// A textureInfo (its texture, coordinates and transform) and its `scale`, if it has one.
    fn texture(&mut self, key: &str) -> Option<(TextureDesc, Option<f32>)> {
        let info = self.ext.get(key)?;
        let index = info.get("index").and_then(|i| i.as_u64());
        let Some(tex) = index.and_then(|i| self.document.textures().nth(i as usize)) else {
            let index = info.get("index").map_or("no index".to_owned(), |i| i.to_string());
            self.warn(format!("{key} names no texture of the file ({index}); ignored"));
            return None;
        };
        let tex_coord = info.get("texCoord").and_then(|c| c.as_u64()).unwrap_or(0) as u32;
        let transform = info.pointer("/extensions/KHR_texture_transform").map(transform_from_json);
        let scale = info.get("scale").and_then(|s| s.as_f64()).map(|s| s as f32);
        Some((texture(tex, tex_coord, transform), scale))
    }
}
