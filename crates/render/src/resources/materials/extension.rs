//! The material extension group: group 3 of the forward and visibility-shading pipelines of a
//! material that uses a glTF material extension (KHR_materials_specular, _clearcoat, ...). It
//! holds the extensions' parameters (one uniform) and the textures of the extensions the
//! material uses, and nothing for the others: a material without extensions binds no group 3,
//! and its pipelines' layouts have none.
//!
//! Every shader stage can sample only so many textures (16 on wgpu's GL backend); the view and
//! core material groups take some of them. A material whose extensions' textures would pass the
//! limit keeps its extensions' factors, but the textures of the extensions that do not fit are
//! left out of its group and its shader variant, with a warning naming the material
//! (`MaterialTable::prepare`).
//!
//! Layouts are made once per set of extensions ([`ExtensionLayouts::layout`]) and shared by the
//! material table, which makes each material's group with its set's layout, and the pipeline
//! families, which make a pipeline layout per set.

use std::collections::HashMap;
use std::sync::Mutex;

use bytemuck::{Pod, Zeroable};
use penumbra_engine::material::{StandardMaterial, TEXTURE_SLOTS};

use super::{CORE_SLOTS, MaterialFeatures, uv_rows};
use crate::pipelines::parts;

/// The group index of the extension group in every pipeline that binds it.
pub const EXTENSION_GROUP: u32 = 3;
/// The group index of the opaque colour's copy in transmissive materials' pipelines.
pub const TRANSMISSION_GROUP: u32 = 2;

/// Which `StandardMaterial::textures()` slots each extension reads, in the order the texture
/// budget is spent (an extension earlier in the list keeps its textures first).
const FEATURE_SLOTS: &[(u8, &[usize])] = &[
    (MaterialFeatures::SPECULAR, &[5, 6]),
    (MaterialFeatures::CLEARCOAT, &[7, 8, 9]),
    (MaterialFeatures::SHEEN, &[10, 11]),
    (MaterialFeatures::TRANSMISSION, &[12, 13]),
    (MaterialFeatures::ANISOTROPY, &[14]),
    (MaterialFeatures::IRIDESCENCE, &[15, 16]),
];

/// The binding of extension slot `slot`'s texture (its sampler follows): after the uniform at 0,
/// two per extension slot in slot order, whether or not the layout holds them.
pub fn texture_binding(slot: usize) -> u32 {
    debug_assert!(slot >= CORE_SLOTS);
    1 + 2 * (slot - CORE_SLOTS) as u32
}

/// Mirrors `struct MaterialExtension` in `shaders/draw_data.wgsl`: the parameters of a
/// material's extensions.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuMaterialExtension {
    /// The dielectric's F0 before its texture: the IOR's reflectance times the specular colour
    /// (the shader clamps the product with the texture to 1).
    pub dielectric_f0_color: [f32; 3],
    /// KHR_materials_specular's strength (its texture's alpha multiplies it).
    pub specular: f32,
    /// KHR_materials_clearcoat: the coat's strength and perceptual roughness (their textures'
    /// red and green multiply them) and its normal map's scale.
    pub clearcoat: f32,
    pub clearcoat_roughness: f32,
    pub clearcoat_normal_scale: f32,
    /// KHR_materials_sheen: the sheen's perceptual roughness and linear colour (their textures'
    /// alpha and RGB multiply them).
    pub sheen_roughness: f32,
    pub sheen_color: [f32; 3],
    /// KHR_materials_transmission's share (its texture's red multiplies it).
    pub transmission: f32,
    /// KHR_materials_volume: what white light becomes after `attenuation_distance` (infinite:
    /// no attenuation) and the volume's thickness in the mesh's units (its texture's green
    /// multiplies it).
    pub attenuation_color: [f32; 3],
    pub thickness: f32,
    pub attenuation_distance: f32,
    /// The IOR refraction bends by, and KHR_materials_dispersion's spread of it.
    pub ior: f32,
    pub dispersion: f32,
    /// KHR_materials_anisotropy: the strength (its texture's blue multiplies it) and the
    /// rotation's (cos, sin), which turns the texture's direction (or the tangent).
    pub anisotropy_strength: f32,
    pub anisotropy_direction: [f32; 2],
    /// KHR_materials_iridescence: the film's strength (its texture's red multiplies it), its
    /// IOR, and its thickness range in nanometres (the thickness texture's green picks).
    pub iridescence: f32,
    pub iridescence_ior: f32,
    pub iridescence_thickness: [f32; 2],
    pub _pad: [f32; 2],
    pub uv: [[f32; 4]; 2 * (TEXTURE_SLOTS - CORE_SLOTS)],
}

/// `m`'s extension parameters.
pub fn pack(m: &StandardMaterial) -> GpuMaterialExtension {
    let rows = uv_rows(m);
    let mut uv = [[0.0; 4]; 2 * (TEXTURE_SLOTS - CORE_SLOTS)];
    for (i, r) in rows[CORE_SLOTS..].iter().enumerate() {
        uv[2 * i..2 * i + 2].copy_from_slice(r);
    }
    GpuMaterialExtension {
        dielectric_f0_color: (m.specular_color * m.ior_reflectance()).to_array(),
        specular: m.specular,
        clearcoat: m.clearcoat,
        clearcoat_roughness: m.clearcoat_roughness,
        clearcoat_normal_scale: m.clearcoat_normal_scale,
        sheen_roughness: m.sheen_roughness,
        sheen_color: m.sheen_color.to_array(),
        transmission: m.transmission,
        attenuation_color: m.attenuation_color.to_array(),
        thickness: m.thickness,
        // f32::MAX rather than infinity: WGSL may assume values are finite.
        attenuation_distance: m.attenuation_distance.min(f32::MAX),
        ior: m.ior,
        dispersion: m.dispersion,
        anisotropy_strength: m.anisotropy_strength,
        anisotropy_direction: [m.anisotropy_rotation.cos(), m.anisotropy_rotation.sin()],
        iridescence: m.iridescence,
        iridescence_ior: m.iridescence_ior,
        iridescence_thickness: [m.iridescence_thickness_min, m.iridescence_thickness_max],
        _pad: [0.0; 2],
        uv,
    }
}

/// The extension group's layouts, one per set of extensions, made when first asked for.
pub struct ExtensionLayouts {
    /// How many extension textures a stage may sample beside the other groups' textures.
    texture_budget: usize,
    layouts: Mutex<HashMap<MaterialFeatures, wgpu::BindGroupLayout>>,
}

impl ExtensionLayouts {
    /// `other_textures`: how many textures the other groups of a lit pipeline sample at most.
    pub fn new(device: &wgpu::Device, other_textures: u32) -> Self {
        let limit = device.limits().max_sampled_textures_per_shader_stage;
        Self { texture_budget: limit.saturating_sub(other_textures) as usize, layouts: Default::default() }
    }

    /// The extension slots `features`' group binds (bit `slot` set): each extension's slots, as
    /// long as the texture budget lasts.
    pub fn bound_slots(&self, features: MaterialFeatures) -> u32 {
        let mut mask = 0u32;
        let mut used = 0;
        for &(feature, slots) in FEATURE_SLOTS {
            if features.has(feature) && used + slots.len() <= self.texture_budget {
                used += slots.len();
                for &s in slots {
                    mask |= 1 << s;
                }
            }
        }
        mask
    }

    /// The layout of the group of materials with `features` (not empty).
    pub fn layout(&self, device: &wgpu::Device, features: MaterialFeatures) -> wgpu::BindGroupLayout {
        let mut layouts = self.layouts.lock().unwrap_or_else(|e| e.into_inner());
        layouts
            .entry(features)
            .or_insert_with(|| {
                let lit = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
                let mask = self.bound_slots(features);
                let mut entries = vec![parts::uniform(0, lit)];
                for slot in (CORE_SLOTS..TEXTURE_SLOTS).filter(|s| mask & (1 << s) != 0) {
                    let b = texture_binding(slot);
                    entries.push(wgpu::BindGroupLayoutEntry { visibility: lit, ..parts::texture(b, true) });
                    entries.push(wgpu::BindGroupLayoutEntry { visibility: lit, ..parts::sampler(b + 1) });
                }
                parts::bind_group_layout(device, "material extensions", &entries)
            })
            .clone()
    }
}

/// Pipeline layouts per set of material extensions: `groups` (groups 0 to 2) alone for
/// materials without extensions, then the extension group as group 3; for transmissive
/// materials, `transmission` (the opaque colour's copy) as group 2.
pub struct PipelineLayouts {
    label: &'static str,
    groups: Vec<Option<wgpu::BindGroupLayout>>,
    extensions: std::sync::Arc<ExtensionLayouts>,
    transmission: Option<wgpu::BindGroupLayout>,
    made: Mutex<HashMap<MaterialFeatures, wgpu::PipelineLayout>>,
}

impl PipelineLayouts {
    pub fn new(
        label: &'static str,
        groups: &[Option<&wgpu::BindGroupLayout>],
        extensions: std::sync::Arc<ExtensionLayouts>,
    ) -> Self {
        debug_assert!(groups.len() <= EXTENSION_GROUP as usize);
        Self {
            label,
            groups: groups.iter().map(|g| g.cloned()).collect(),
            extensions,
            transmission: None,
            made: Default::default(),
        }
    }

    /// With `layout` as group 2 of transmissive materials' pipelines (in place of the group 2
    /// of the others, if they have one).
    pub fn with_transmission(self, layout: &wgpu::BindGroupLayout) -> Self {
        debug_assert!(self.groups.len() <= TRANSMISSION_GROUP as usize + 1);
        Self { transmission: Some(layout.clone()), ..self }
    }

    /// The pipeline layout of a material with `features`.
    pub fn get(&self, device: &wgpu::Device, features: MaterialFeatures) -> wgpu::PipelineLayout {
        let mut made = self.made.lock().unwrap_or_else(|e| e.into_inner());
        made.entry(features)
            .or_insert_with(|| {
                let mut groups = self.groups.clone();
                if features.0 != 0 {
                    groups.resize(EXTENSION_GROUP as usize, None);
                    if features.has(MaterialFeatures::TRANSMISSION) {
                        groups[TRANSMISSION_GROUP as usize] = self.transmission.clone();
                    }
                    groups.push(Some(self.extensions.layout(device, features)));
                }
                let refs: Vec<Option<&wgpu::BindGroupLayout>> = groups.iter().map(|g| g.as_ref()).collect();
                device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some(self.label),
                    bind_group_layouts: &refs,
                    immediate_size: 0,
                })
            })
            .clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_texture_budget_keeps_whole_extensions_in_order() {
        let layouts = |budget| ExtensionLayouts { texture_budget: budget, layouts: Default::default() };
        let both = MaterialFeatures(MaterialFeatures::SPECULAR | MaterialFeatures::CLEARCOAT);
        let specular = (1 << 5) | (1 << 6);
        let clearcoat = (1 << 7) | (1 << 8) | (1 << 9);
        assert_eq!(layouts(16).bound_slots(both), specular | clearcoat);
        assert_eq!(layouts(4).bound_slots(both), specular);
        assert_eq!(layouts(3).bound_slots(both), specular);
        assert_eq!(layouts(3).bound_slots(MaterialFeatures(MaterialFeatures::CLEARCOAT)), clearcoat);
        assert_eq!(layouts(1).bound_slots(both), 0);
    }
}
