//! EXT_lights_ies: IES light profiles in glTF. The root's `extensions.EXT_lights_ies.lights`
//! lists profiles, each an `.ies` file by `uri` (beside the scene, under the same folder rules
//! as buffers) or embedded by `bufferView` (`mimeType` `application/x-ies-lm-63`); a node's
//! `extensions.EXT_lights_ies` places one (`light`, with an optional `multiplier` and linear
//! `color` in [0, 1]). The extension maps the profile's (0°, 0°) direction to the node's −Z, its
//! C = 0° plane through X, as `IesLight` does.
//!
//! Profiles are parsed at load (phase one), so a malformed one fails the import with the
//! parser's `file:line: problem` inside the import error.

use std::path::Path;
use std::sync::Arc;

use glam::Vec3;
use gltf::json::Value;

use super::ImportOptions;
use super::accessor::Buffers;
use super::source::{ReadBudget, ReadLimit, read_uri};
use crate::ies::IesProfile;
use crate::import::ImportErrorKind;

/// The extension's name, in `extensionsUsed` and as the JSON key.
pub(crate) const NAME: &str = "EXT_lights_ies";

/// A node's light: which profile, and how it is scaled and tinted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct IesLightDesc {
    pub profile: usize,
    pub multiplier: f32,
    pub color: Vec3,
}

fn invalid(at: String, what: &str) -> ImportErrorKind {
    ImportErrorKind::Invalid(format!("{at}: {what}"))
}

/// Parses every profile the file lists.
pub(crate) fn load_profiles(
    document: &gltf::Document,
    buffers: &Buffers,
    base_dir: &Path,
    file: &str,
    options: &ImportOptions,
    reads: &ReadBudget,
) -> Result<Vec<Arc<IesProfile>>, ImportErrorKind> {
    let Some(ext) = document.extension_value(NAME) else { return Ok(Vec::new()) };
    let Some(lights) = ext.get("lights").and_then(Value::as_array) else {
        return Err(invalid(format!("extensions.{NAME}"), "has no \"lights\" array"));
    };
    let mut out = Vec::with_capacity(lights.len());
    for (index, light) in lights.iter().enumerate() {
        let at = format!("extensions.{NAME}.lights[{index}]");
        let name = light.get("name").and_then(Value::as_str).map(str::to_owned);
        let (source, bytes) = match (light.get("uri").and_then(Value::as_str), light.get("bufferView")) {
            (Some(uri), None) => {
                let short = if uri.starts_with("data:") { "data URI".to_owned() } else { uri.to_owned() };
                let bytes = read_uri(base_dir, uri, options, ReadLimit::file(options, "an IES profile's size"), reads)
                    .map_err(|e| {
                        e.into_kind(uri, |reason| ImportErrorKind::IesProfile { index, uri: short.clone(), reason })
                    })?;
                (short, bytes)
            }
            (None, Some(view)) => {
                let view_index = view.as_u64().ok_or_else(|| invalid(format!("{at}.bufferView"), "is not an index"))?;
                let mime = light.get("mimeType").and_then(Value::as_str);
                if mime != Some("application/x-ies-lm-63") {
                    return Err(invalid(
                        format!("{at}.mimeType"),
                        &format!("must be \"application/x-ies-lm-63\" with a bufferView, found {mime:?}"),
                    ));
                }
                let source = format!("bufferView {view_index}");
                let err = |reason: String| ImportErrorKind::IesProfile { index, uri: source.clone(), reason };
                let view = document
                    .views()
                    .nth(view_index as usize)
                    .ok_or_else(|| err(format!("the file has {} buffer views", document.views().len())))?;
                let bytes = buffers.view(&view).map_err(&err)?.to_vec();
                (source, bytes)
            }
            _ => return Err(invalid(at, "needs exactly one of \"uri\" and \"bufferView\"")),
        };
        let label = format!("{file}#{}", name.unwrap_or_else(|| format!("ies{index}")));
        let profile = IesProfile::parse(&String::from_utf8_lossy(&bytes), &label)
            .map_err(|e| ImportErrorKind::IesProfile { index, uri: source.clone(), reason: e.to_string() })?;
        out.push(Arc::new(profile));
    }
    Ok(out)
}

/// The light a node places, if any, checked against the `profiles` the file lists.
pub(crate) fn node_light(node: &gltf::Node, profiles: usize) -> Result<Option<IesLightDesc>, ImportErrorKind> {
    let Some(ext) = node.extension_value(NAME) else { return Ok(None) };
    let at = format!("nodes[{}].extensions.{NAME}", node.index());
    let profile = ext
        .get("light")
        .and_then(Value::as_u64)
        .ok_or_else(|| invalid(format!("{at}.light"), "is missing or not an index"))? as usize;
    if profile >= profiles {
        return Err(invalid(format!("{at}.light"), &format!("is {profile}, but the file lists {profiles} profiles")));
    }
    let multiplier = match ext.get("multiplier") {
        None => 1.0,
        Some(v) => match v.as_f64() {
            Some(m) if m >= 0.0 && m.is_finite() => m as f32,
            _ => return Err(invalid(format!("{at}.multiplier"), &format!("must be a number ≥ 0, found {v}"))),
        },
    };
    let color = match ext.get("color") {
        None => Vec3::ONE,
        Some(v) => {
            match json_rgb(v) {
                // The extension clamps the colour to [0, 1].
                Some(c) => c.clamp(Vec3::ZERO, Vec3::ONE),
                None => return Err(invalid(format!("{at}.color"), &format!("must be three numbers, found {v}"))),
            }
        }
    };
    Ok(Some(IesLightDesc { profile, multiplier, color }))
}

/// Three finite numbers as a colour (the `color` of node light extensions); `None` otherwise.
pub(crate) fn json_rgb(v: &Value) -> Option<Vec3> {
    let c: Vec<f32> = v.as_array()?.iter().map(|x| x.as_f64().map(|x| x as f32)).collect::<Option<_>>()?;
    match c.as_slice() {
        &[r, g, b] if [r, g, b].iter().all(|x| x.is_finite()) => Some(Vec3::new(r, g, b)),
        _ => None,
    }
}
