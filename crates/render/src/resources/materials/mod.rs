//! The material table: every material in use packed into one storage buffer (indexed per
//! instance), plus one bind group per material holding its core textures and samplers (one pair
//! per glTF core slot of `StandardMaterial::textures`), and for a material that uses glTF
//! material extensions a second group with their parameters and textures ([`extension`]).
//!
//! Each frame, prepare visits the materials that draws use; a material is re-packed and its bind
//! groups rebuilt only when its version changed or one of its images was (re)uploaded. Missing
//! textures bind the null texture, so every draw has a complete bind group.

pub mod extension;

use std::sync::Arc;

use std::collections::{HashMap, HashSet};

use bytemuck::{Pod, Zeroable};
use penumbra_engine::Handle;
use penumbra_engine::material::{AlphaMode, StandardMaterial, TEXTURE_SLOTS, UvTransform};

use self::extension::{ExtensionLayouts, texture_binding};
use super::textures::TextureCache;
use crate::gpu::buffer::GrowableBuffer;
use crate::pipelines::parts;
use crate::scene::world::RenderScene;

/// Which material textures a draw samples (bits in `StandardMaterial::textures()` order), and
/// whether any of them maps its coordinate (`TRANSFORMED_UVS`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct TextureSet(pub u32);

impl TextureSet {
    pub const BASE_COLOR: u32 = 1;
    pub const METALLIC_ROUGHNESS: u32 = 1 << 1;
    pub const NORMAL: u32 = 1 << 2;
    pub const OCCLUSION: u32 = 1 << 3;
    pub const EMISSIVE: u32 = 1 << 4;
    pub const SPECULAR: u32 = 1 << 5;
    pub const SPECULAR_COLOR: u32 = 1 << 6;
    pub const CLEARCOAT: u32 = 1 << 7;
    pub const CLEARCOAT_ROUGHNESS: u32 = 1 << 8;
    pub const CLEARCOAT_NORMAL: u32 = 1 << 9;
    pub const SHEEN_COLOR: u32 = 1 << 10;
    pub const SHEEN_ROUGHNESS: u32 = 1 << 11;
    pub const TRANSMISSION: u32 = 1 << 12;
    pub const THICKNESS: u32 = 1 << 13;
    pub const ANISOTROPY: u32 = 1 << 14;
    pub const IRIDESCENCE: u32 = 1 << 15;
    pub const IRIDESCENCE_THICKNESS: u32 = 1 << 16;
    /// Some texture reads TEXCOORD_1 or has a KHR_texture_transform. Without this bit every
    /// texture samples TEXCOORD_0 as it is, with the sampler's own derivatives.
    pub const TRANSFORMED_UVS: u32 = 1 << 30;
    /// The occlusion texture is the metallic-roughness texture (same image, sampler and
    /// coordinates: glTF's ORM packing, occlusion in red), so one sample serves both.
    pub const OCCLUSION_IN_METALLIC_ROUGHNESS: u32 = 1 << 31;

    pub fn has(self, bit: u32) -> bool {
        self.0 & bit != 0
    }
}

/// The material extensions a draw's shading reads (each a shader feature, compiled only into
/// the variants of materials that use it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct MaterialFeatures(pub u8);

impl MaterialFeatures {
    /// KHR_materials_ior / KHR_materials_specular other than glTF's defaults: the dielectric's
    /// reflectance and specular strength come from the material.
    pub const SPECULAR: u8 = 1;
    /// KHR_materials_clearcoat with a strength above 0: a clear coat over the material.
    pub const CLEARCOAT: u8 = 2;
    /// KHR_materials_sheen with a colour other than black: a layer of fibres over the material.
    pub const SHEEN: u8 = 4;
    /// KHR_materials_transmission above 0 (with KHR_materials_volume and _dispersion): light
    /// passes through; drawn after the opaque colour is copied (`features::transmission`).
    pub const TRANSMISSION: u8 = 8;
    /// KHR_materials_anisotropy above 0: the specular lobe stretches along a direction.
    pub const ANISOTROPY: u8 = 16;
    /// KHR_materials_iridescence above 0: a thin film's interference colours the reflection.
    pub const IRIDESCENCE: u8 = 32;

    pub fn has(self, bit: u8) -> bool {
        self.0 & bit != 0
    }

    /// Whether the deferred local lights can shade this material: their surface buffer holds
    /// glTF's core parameters only.
    pub fn fits_surface_buffer(self) -> bool {
        self.0 == 0
    }
}

/// Which of `StandardMaterial::textures()` hold colour (sRGB): base colour, emissive, specular
/// colour.
pub const SRGB_SLOTS: [bool; TEXTURE_SLOTS] = StandardMaterial::SRGB_SLOTS;

pub const FLAG_HAS_NORMAL_MAP: u32 = 1;
pub const FLAG_DOUBLE_SIDED: u32 = 2;

/// Mirrors `struct Material` in `shaders/forward.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuMaterial {
    pub base_color: [f32; 4],
    pub emissive: [f32; 3],
    pub alpha_cutoff: f32,
    pub metallic: f32,
    pub roughness: f32,
    pub normal_scale: f32,
    pub occlusion_strength: f32,
    pub flags: u32,
    pub _pad: [u32; 3],
    pub uv: [[f32; 4]; 2 * CORE_SLOTS],
}

/// glTF's core texture slots, which the material group binds and whose transforms `GpuMaterial`
/// holds; the extensions' follow in the extension group.
const CORE_SLOTS: usize = 5;

/// Which material a draw uses: `None` is the glTF default material.
pub type MaterialKey = Option<Handle<StandardMaterial>>;

/// What of a material selects the pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum AlphaKey {
    Opaque,
    Mask,
    Blend,
}

pub struct MaterialEntry {
    pub slot: u32,
    version: u64,
    /// Versions of the images bound in each slot (0: null texture).
    texture_versions: [u64; TEXTURE_SLOTS],
    pub bind_group: wgpu::BindGroup,
    /// Its extension group ([`extension`]) and the group's uniform, if it uses an extension.
    pub extension: Option<(wgpu::BindGroup, wgpu::Buffer)>,
    pub alpha: AlphaKey,
    pub unlit: bool,
    pub double_sided: bool,
    /// Which slots have a texture: they select the shader variant.
    pub textures: TextureSet,
    /// Which material extensions its shading reads.
    pub features: MaterialFeatures,
}

pub struct MaterialTable {
    /// The material group: a (texture, sampler) pair per core slot, in
    /// `StandardMaterial::textures()` order, read by fragment shaders and by the visibility
    /// buffer's shading pass.
    layout: wgpu::BindGroupLayout,
    extension_layouts: Arc<ExtensionLayouts>,
    cpu: Vec<GpuMaterial>,
    buffer: GrowableBuffer,
    entries: HashMap<MaterialKey, MaterialEntry>,
    free_slots: Vec<u32>,
    /// The default material's "asset" (it has none; version 0 forever).
    default_material: StandardMaterial,
    dirty: bool,
    /// (material, slot) pairs already warned about a missing image, so the log says it once.
    warned_missing: HashSet<(MaterialKey, usize)>,
    /// Materials already warned about extension textures past the texture budget.
    warned_budget: HashSet<MaterialKey>,
}

impl MaterialTable {
    /// `view_textures`: how many textures the view group samples in a stage (the extension
    /// group's texture budget is what the device allows beyond it and the core slots).
    pub fn new(device: &wgpu::Device, view_textures: u32) -> Self {
        let lit = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
        let entries: Vec<_> = (0..CORE_SLOTS as u32)
            .flat_map(|i| [parts::texture(2 * i, true), parts::sampler(2 * i + 1)])
            .map(|e| wgpu::BindGroupLayoutEntry { visibility: lit, ..e })
            .collect();
        Self {
            layout: parts::bind_group_layout(device, "material", &entries),
            extension_layouts: Arc::new(ExtensionLayouts::new(device, view_textures + CORE_SLOTS as u32)),
            cpu: Vec::new(),
            buffer: GrowableBuffer::new(
                device,
                "material table",
                wgpu::BufferUsages::STORAGE,
                64 * std::mem::size_of::<GpuMaterial>() as u64,
            ),
            entries: HashMap::new(),
            free_slots: Vec::new(),
            default_material: StandardMaterial::default(),
            dirty: false,
            warned_missing: Default::default(),
            warned_budget: Default::default(),
        }
    }

    /// The extension group's layouts, which the pipelines of materials with extensions share.
    pub fn extension_layouts(&self) -> &Arc<ExtensionLayouts> {
        &self.extension_layouts
    }

    pub fn buffer(&self) -> &wgpu::Buffer {
        self.buffer.buffer()
    }

    /// The layout of every material's bind group.
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    pub fn get(&self, key: &MaterialKey) -> Option<&MaterialEntry> {
        self.entries.get(key)
    }

    /// Makes `key` ready to draw. Returns false when its asset is missing (the draw is skipped
    /// with a warning by the caller).
    /// Textures must already be uploaded (`TextureCache::upload_many`).
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        textures: &mut TextureCache,
        scene: &RenderScene,
        key: MaterialKey,
    ) -> bool {
        let (material, version) = match key {
            None => (&self.default_material, 0),
            Some(h) => match scene.materials.get(&h) {
                Some(s) => (s.data.as_ref(), s.version),
                None => return false,
            },
        };
        let material = material.clone();
        // Resolve textures first: an image that changed forces a new bind group even when the
        // material itself did not.
        let srgb_slots = SRGB_SLOTS;
        let mut views = Vec::with_capacity(TEXTURE_SLOTS);
        let mut texture_versions = [0u64; TEXTURE_SLOTS];
        for (slot, tex) in material.textures().into_iter().enumerate() {
            let image = tex.and_then(|t| scene.images.get(&t.image).map(|s| (t, s)));
            let uploaded = image.and_then(|(t, _)| textures.get(t.image, srgb_slots[slot]).map(|v| (t, v)));
            match uploaded {
                Some((t, (view, version))) => {
                    texture_versions[slot] = version;
                    views.push((view.clone(), Some(t.sampler)));
                }
                None => {
                    if let Some(t) = tex {
                        tracing::warn!(
                            "material texture refers to a missing image {:?}; using the null texture",
                            t.image
                        );
                    }
                    views.push((textures.null_view().clone(), None));
                }
            }
        }
        if let Some(e) = self.entries.get(&key)
            && e.version == version
            && e.texture_versions == texture_versions
        {
            return true;
        }

        let slot = match self.entries.get(&key) {
            Some(e) => e.slot,
            None => self.free_slots.pop().unwrap_or_else(|| {
                self.cpu.push(GpuMaterial::zeroed());
                self.cpu.len() as u32 - 1
            }),
        };
        self.cpu[slot as usize] = pack(&material);
        self.dirty = true;
        let samplers: Vec<wgpu::Sampler> =
            views.iter().map(|(_, s)| textures.sampler(device, &s.unwrap_or_default()).clone()).collect();
        let entries: Vec<wgpu::BindGroupEntry> = (0..CORE_SLOTS)
            .flat_map(|i| {
                [
                    wgpu::BindGroupEntry {
                        binding: 2 * i as u32,
                        resource: wgpu::BindingResource::TextureView(&views[i].0),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2 * i as u32 + 1,
                        resource: wgpu::BindingResource::Sampler(&samplers[i]),
                    },
                ]
            })
            .collect();
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("material textures"),
            layout: &self.layout,
            entries: &entries,
        });
        let features = features(&material);
        let mut texture_set = texture_set(&material);
        let mut extension = None;
        if features.0 != 0 {
            let bound = self.extension_layouts.bound_slots(features);
            let left_out: Vec<usize> =
                (CORE_SLOTS..TEXTURE_SLOTS).filter(|&s| texture_set.has(1 << s) && bound & (1 << s) == 0).collect();
            if !left_out.is_empty() {
                texture_set.0 &= !left_out.iter().fold(0, |m, s| m | (1u32 << s));
                if self.warned_budget.insert(key) {
                    tracing::warn!(
                        "material {key:?}: this GPU samples at most {} textures per shader stage; the textures \
                         of its extensions in slots {left_out:?} of StandardMaterial::textures() are left out \
                         (their factors still apply)",
                        device.limits().max_sampled_textures_per_shader_stage
                    );
                }
            }
            let buffer = wgpu::util::DeviceExt::create_buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some("material extension"),
                    contents: bytemuck::bytes_of(&extension::pack(&material)),
                    usage: wgpu::BufferUsages::UNIFORM,
                },
            );
            let mut entries = vec![wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() }];
            for slot in (CORE_SLOTS..TEXTURE_SLOTS).filter(|s| bound & (1 << s) != 0) {
                let b = texture_binding(slot);
                entries.push(wgpu::BindGroupEntry {
                    binding: b,
                    resource: wgpu::BindingResource::TextureView(&views[slot].0),
                });
                entries.push(wgpu::BindGroupEntry {
                    binding: b + 1,
                    resource: wgpu::BindingResource::Sampler(&samplers[slot]),
                });
            }
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("material extensions"),
                layout: &self.extension_layouts.layout(device, features),
                entries: &entries,
            });
            extension = Some((group, buffer));
        }
        let alpha = match material.alpha_mode {
            AlphaMode::Opaque => AlphaKey::Opaque,
            AlphaMode::Mask(_) => AlphaKey::Mask,
            AlphaMode::Blend => AlphaKey::Blend,
        };
        self.entries.insert(
            key,
            MaterialEntry {
                slot,
                version,
                texture_versions,
                bind_group,
                alpha,
                unlit: material.unlit,
                double_sided: material.double_sided,
                textures: texture_set,
                features,
                extension,
            },
        );
        true
    }

    /// Makes every material's bind group again on its next `prepare` (its samplers changed).
    pub fn forget_bind_groups(&mut self) {
        for e in self.entries.values_mut() {
            // No image has this version (0 is the null texture), so the entry reads as stale.
            e.texture_versions = [u64::MAX; TEXTURE_SLOTS];
        }
    }

    /// Frees the slots (and bind groups, which hold textures alive) of materials whose asset is
    /// gone or that no draw uses.
    pub fn retain(&mut self, scene: &RenderScene, used: impl Fn(&MaterialKey) -> bool) {
        let free = &mut self.free_slots;
        self.warned_missing.retain(|(k, _)| k.is_none_or(|h| scene.materials.contains_key(&h)));
        self.entries.retain(|k, e| {
            let live = k.is_none_or(|h| scene.materials.contains_key(&h)) && used(k);
            if !live {
                free.push(e.slot);
            }
            live
        });
    }

    /// Uploads the packed table if anything changed; returns true if the buffer was replaced.
    /// Whether material data changed since the last upload.
    pub fn is_dirty(&self) -> bool {
        self.dirty
    }

    pub fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) -> bool {
        if !self.dirty {
            return false;
        }
        self.dirty = false;
        let bytes: &[u8] = bytemuck::cast_slice(&self.cpu);
        let grew = self.buffer.reserve(device, bytes.len() as u64);
        queue.write_buffer(self.buffer.buffer(), 0, bytes);
        grew
    }
}

/// The textures `m` samples, whether any maps its coordinate, and whether occlusion shares the
/// metallic-roughness texel (the shader variant).
fn texture_set(m: &StandardMaterial) -> TextureSet {
    let mut bits: u32 = 0;
    for (i, tex) in m.textures().iter().enumerate() {
        if let Some(t) = tex {
            bits |= 1 << i;
            if t.uv_set != 0 || t.transform != UvTransform::default() {
                bits |= TextureSet::TRANSFORMED_UVS;
            }
        }
    }
    if m.occlusion_texture.is_some() && m.occlusion_texture == m.metallic_roughness_texture {
        bits |= TextureSet::OCCLUSION_IN_METALLIC_ROUGHNESS;
    }
    TextureSet(bits)
}

/// The material extensions `m`'s shading reads.
fn features(m: &StandardMaterial) -> MaterialFeatures {
    let mut bits = 0;
    if !m.unlit && m.has_custom_specular() {
        bits |= MaterialFeatures::SPECULAR;
    }
    if !m.unlit && m.clearcoat > 0.0 {
        bits |= MaterialFeatures::CLEARCOAT;
    }
    if !m.unlit && m.has_sheen() {
        bits |= MaterialFeatures::SHEEN;
    }
    if !m.unlit && m.has_transmission() {
        bits |= MaterialFeatures::TRANSMISSION;
    }
    if !m.unlit && m.has_anisotropy() {
        bits |= MaterialFeatures::ANISOTROPY;
    }
    if !m.unlit && m.has_iridescence() {
        bits |= MaterialFeatures::IRIDESCENCE;
    }
    MaterialFeatures(bits)
}

/// The rows of the 2×3 affine part of each slot's UV transform, uv' = (row0 · (u, v, 1),
/// row1 · (u, v, 1)); row 0's last value is the UV set.
fn uv_rows(m: &StandardMaterial) -> [[[f32; 4]; 2]; TEXTURE_SLOTS] {
    m.textures().map(|tex| {
        let (mat, set) = tex.map_or((glam::Mat3::IDENTITY, 0), |t| (t.transform.matrix(), t.uv_set));
        [[mat.x_axis.x, mat.y_axis.x, mat.z_axis.x, set as f32], [mat.x_axis.y, mat.y_axis.y, mat.z_axis.y, 0.0]]
    })
}

fn pack(m: &StandardMaterial) -> GpuMaterial {
    let rows = uv_rows(m);
    let mut uv = [[0.0; 4]; 2 * CORE_SLOTS];
    for (slot, r) in rows[..CORE_SLOTS].iter().enumerate() {
        uv[2 * slot..2 * slot + 2].copy_from_slice(r);
    }
    let mut flags = 0;
    if m.normal_texture.is_some() {
        flags |= FLAG_HAS_NORMAL_MAP;
    }
    if m.double_sided {
        flags |= FLAG_DOUBLE_SIDED;
    }
    let emissive = m.emissive * m.emissive_strength;
    GpuMaterial {
        base_color: m.base_color.to_array(),
        emissive: emissive.to_array(),
        alpha_cutoff: match m.alpha_mode {
            AlphaMode::Mask(c) => c,
            _ => 0.5,
        },
        metallic: m.metallic,
        roughness: m.roughness,
        normal_scale: m.normal_scale,
        occlusion_strength: m.occlusion_strength,
        flags,
        _pad: [0; 3],
        uv,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_texture_set_says_how_textures_are_sampled() {
        use penumbra_engine::image::Image;
        use penumbra_engine::material::TextureRef;
        let mut images = penumbra_engine::Assets::new();
        let orm = TextureRef::new(images.add(Image::solid([255; 4], "orm")));
        let mut m = StandardMaterial {
            base_color_texture: Some(TextureRef::new(images.add(Image::solid([255; 4], "base")))),
            metallic_roughness_texture: Some(orm),
            occlusion_texture: Some(orm),
            ..Default::default()
        };
        let bits = TextureSet::BASE_COLOR
            | TextureSet::METALLIC_ROUGHNESS
            | TextureSet::OCCLUSION
            | TextureSet::OCCLUSION_IN_METALLIC_ROUGHNESS;
        assert_eq!(texture_set(&m), TextureSet(bits));
        // Same image, other coordinates: two samples.
        m.occlusion_texture = Some(TextureRef { uv_set: 1, ..orm });
        let bits = TextureSet::BASE_COLOR
            | TextureSet::METALLIC_ROUGHNESS
            | TextureSet::OCCLUSION
            | TextureSet::TRANSFORMED_UVS;
        assert_eq!(texture_set(&m), TextureSet(bits));
        m.occlusion_texture = None;
        assert_eq!(texture_set(&m), TextureSet(TextureSet::BASE_COLOR | TextureSet::METALLIC_ROUGHNESS));
    }

    #[test]
    fn gpu_material_matches_the_wgsl_layout() {
        // 4 × vec4 of scalars + two vec4 UV rows per core texture slot.
        assert_eq!(std::mem::size_of::<GpuMaterial>(), (4 + 2 * CORE_SLOTS) * 16);
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuMaterial,
            "forward.wgsl",
            [],
            "Material",
            [base_color, emissive, alpha_cutoff, metallic, roughness, normal_scale, occlusion_strength, flags, uv]
        );
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            extension::GpuMaterialExtension,
            "forward.wgsl",
            ["MATERIAL_EXTENSION"],
            "MaterialExtension",
            [
                dielectric_f0_color,
                specular,
                clearcoat,
                clearcoat_roughness,
                clearcoat_normal_scale,
                sheen_roughness,
                sheen_color,
                transmission,
                attenuation_color,
                thickness,
                attenuation_distance,
                ior,
                dispersion,
                anisotropy_strength,
                anisotropy_direction,
                iridescence,
                iridescence_ior,
                iridescence_thickness,
                uv
            ]
        );
    }
}
