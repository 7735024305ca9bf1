//! `EXT_mesh_gpu_instancing`: a node's mesh drawn once per instance, each placed by the
//! instance's translation, rotation and scale (accessors of one count, any of the three left
//! out) before the node's own transform.
//!
//! The importer reads each instancing node's accessors here into a list of [`Transform`]s; the
//! spawner makes one child entity per instance that holds the mesh (one grandchild per
//! primitive where the mesh has several), so the retained extraction, culling, bounds and
//! picking see instances as they see any entity, and the renderer's instanced draw lists batch
//! them. Accessors are decoded with the same range checks and import limits as every other
//! (`accessor.rs`); a wrong accessor is an import error naming the attribute, non-finite or
//! non-unit values are replaced or normalised with a warning, as node transforms are.

use std::sync::Arc;

use glam::{Quat, Vec3};
use gltf::json::Value;

use super::accessor::{Buffers, read_f32};
use crate::components::Transform;
use crate::import::ImportErrorKind;

pub(crate) const NAME: &str = "EXT_mesh_gpu_instancing";

/// The instances' transforms of `node`, or `None` where it uses no instancing (or has no mesh:
/// the extension then means nothing, and says so in a warning).
pub(crate) fn node_instances(
    node: &gltf::Node,
    document: &gltf::Document,
    buffers: &Buffers,
    warnings: &mut Vec<String>,
) -> Result<Option<Arc<[Transform]>>, ImportErrorKind> {
    let Some(ext) = node.extension_value(NAME) else { return Ok(None) };
    let at = format!("nodes[{}].extensions.{NAME}", node.index());
    if node.mesh().is_none() {
        warnings.push(format!("{at}: the node has no mesh to instance; ignored"));
        return Ok(None);
    }
    let attributes =
        ext.get("attributes").and_then(Value::as_object).ok_or_else(|| invalid(&at, "has no attributes object"))?;
    let accessor = |name: &str| -> Result<Option<gltf::Accessor<'_>>, ImportErrorKind> {
        let Some(v) = attributes.get(name) else { return Ok(None) };
        let index = v
            .as_u64()
            .ok_or_else(|| invalid(&format!("{at}.attributes.{name}"), &format!("is {v}, not an accessor index")))?;
        let count = document.accessors().len();
        document.accessors().nth(index as usize).map(Some).ok_or_else(|| {
            invalid(&format!("{at}.attributes.{name}"), &format!("is accessor {index}, but the file has {count}"))
        })
    };
    let read3 = |name: &str| -> Result<Option<Vec<[f32; 3]>>, ImportErrorKind> {
        accessor(name)?
            .map(|a| {
                read_f32::<3>(&a, buffers)
                    .map_err(|e| e.context(format!("{at}.attributes.{name}")).into_kind(a.index()))
            })
            .transpose()
    };
    let translations = read3("TRANSLATION")?;
    let scales = read3("SCALE")?;
    let rotations = accessor("ROTATION")?
        .map(|a| {
            read_f32::<4>(&a, buffers).map_err(|e| e.context(format!("{at}.attributes.ROTATION")).into_kind(a.index()))
        })
        .transpose()?;
    let counts: Vec<(&str, usize)> = [
        ("TRANSLATION", translations.as_ref().map(Vec::len)),
        ("ROTATION", rotations.as_ref().map(Vec::len)),
        ("SCALE", scales.as_ref().map(Vec::len)),
    ]
    .into_iter()
    .filter_map(|(name, n)| Some((name, n?)))
    .collect();
    let Some(&(_, count)) = counts.first() else {
        warnings.push(format!("{at}: none of TRANSLATION, ROTATION, SCALE is given; the mesh is drawn once"));
        return Ok(None);
    };
    if let Some((name, n)) = counts.iter().find(|(_, n)| *n != count) {
        return Err(invalid(
            &at,
            &format!(
                "has attributes of different counts ({}: {count}, {name}: {n}); every instance needs one of each",
                counts[0].0
            ),
        ));
    }
    let (mut replaced, mut normalised) = (0usize, 0usize);
    let transforms: Vec<Transform> = (0..count)
        .map(|i| {
            let mut translation = translations.as_ref().map_or(Vec3::ZERO, |t| Vec3::from(t[i]));
            let mut scale = scales.as_ref().map_or(Vec3::ONE, |s| Vec3::from(s[i]));
            let mut rotation = rotations.as_ref().map_or(Quat::IDENTITY, |r| Quat::from_array(r[i]));
            if !translation.is_finite() || !scale.is_finite() || !rotation.is_finite() {
                replaced += 1;
                if !translation.is_finite() {
                    translation = Vec3::ZERO;
                }
                if !scale.is_finite() {
                    scale = Vec3::ONE;
                }
                if !rotation.is_finite() {
                    rotation = Quat::IDENTITY;
                }
            }
            if (rotation.length() - 1.0).abs() > 1e-3 {
                normalised += 1;
                rotation = glam::Vec4::from(rotation).try_normalize().map_or(Quat::IDENTITY, Quat::from_vec4);
            }
            Transform { translation, rotation, scale }
        })
        .collect();
    if replaced > 0 {
        warnings.push(format!("{at}: {replaced} instance(s) with non-finite values; those values were replaced (translation 0, rotation identity, scale 1)"));
    }
    if normalised > 0 {
        warnings.push(format!("{at}: {normalised} instance rotation(s) were not unit quaternions; normalised"));
    }
    Ok(Some(transforms.into()))
}

fn invalid(at: &str, problem: &str) -> ImportErrorKind {
    ImportErrorKind::Malformed(format!("{at} {problem}"))
}
