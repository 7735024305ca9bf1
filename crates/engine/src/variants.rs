//! KHR_materials_variants at run time: a file's named material sets ("leather", "suede", ...)
//! that a script, the viewer's menu or `--variant NAME` switches between.
//!
//! The importer puts [`SceneVariants`] (the file's variant names and the active one) on the
//! scene's root, and [`VariantMaterials`] (its default material and the material of each
//! variant that maps it) on each drawn primitive that a variant changes. Setting
//! `SceneVariants::active` (directly, or with [`select_variant`]) is all a script does:
//! [`apply_material_variants`] (a `PostUpdate` system of `CorePlugin`) then sets each of the
//! scene's primitives' `MeshMaterial3d` to the active variant's material, or back to its own
//! where the variant does not map it or none is active.

use bevy_ecs::prelude::*;

use crate::assets::Handle;
use crate::components::MeshMaterial3d;
use crate::material::StandardMaterial;

/// On a scene's root: the file's material variants, in the file's order, and the active one
/// (`None`: every primitive draws its own material).
#[derive(Component, Debug, Clone, Default, PartialEq)]
pub struct SceneVariants {
    pub names: Vec<String>,
    pub active: Option<String>,
}

/// On a drawn primitive that some variant maps: its own material and, per variant name, the
/// material it draws with while that variant is active.
#[derive(Component, Debug, Clone, PartialEq)]
pub struct VariantMaterials {
    /// The scene root whose [`SceneVariants`] selects among them.
    pub root: Entity,
    pub default: Handle<StandardMaterial>,
    pub by_variant: Vec<(String, Handle<StandardMaterial>)>,
}

impl VariantMaterials {
    /// The material drawn while `active` is the scene's variant.
    pub fn material(&self, active: Option<&str>) -> Handle<StandardMaterial> {
        active.and_then(|a| self.by_variant.iter().find(|(n, _)| n == a)).map_or(self.default, |(_, h)| *h)
    }
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum VariantError {
    #[error("--variant {name}: the scene has no material variants")]
    NoVariants { name: String },
    #[error("--variant {name}: the scene has no variant of that name (its variants: {})", .available.join(", "))]
    NoSuchVariant { name: String, available: Vec<String> },
}

/// Makes `name` the active variant of the scene under `root` (its primitives switch in the next
/// `PostUpdate`).
pub fn select_variant(world: &mut World, root: Entity, name: &str) -> Result<(), VariantError> {
    let Some(mut variants) = world.get_mut::<SceneVariants>(root) else {
        return Err(VariantError::NoVariants { name: name.to_owned() });
    };
    if !variants.names.iter().any(|n| n == name) {
        return Err(VariantError::NoSuchVariant { name: name.to_owned(), available: variants.names.clone() });
    }
    variants.active = Some(name.to_owned());
    Ok(())
}

/// Sets the material of every primitive whose scene's active variant changed (or that is new)
/// to that variant's.
pub fn apply_material_variants(
    scenes: Query<(Entity, Ref<SceneVariants>)>,
    primitives: Query<(Entity, Ref<VariantMaterials>, &MeshMaterial3d)>,
    mut commands: Commands,
) {
    let changed: Vec<(Entity, Option<String>)> =
        scenes.iter().filter(|(_, v)| v.is_changed()).map(|(e, v)| (e, v.active.clone())).collect();
    for (entity, variants, material) in &primitives {
        let active = match changed.iter().find(|(root, _)| *root == variants.root) {
            Some((_, active)) => active.clone(),
            None if variants.is_added() => scenes.get(variants.root).ok().and_then(|(_, v)| v.active.clone()),
            None => continue,
        };
        let wanted = variants.material(active.as_deref());
        if material.0 != wanted {
            // Immutable: replaced, so the renderer's change tracking sees it.
            commands.entity(entity).insert(MeshMaterial3d(wanted));
        }
    }
}
