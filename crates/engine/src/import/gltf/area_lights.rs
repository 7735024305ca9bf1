//! PENUMBRA_lights_area: area lights on glTF nodes (glTF itself has only punctual lights). A
//! node's `extensions.PENUMBRA_lights_area` makes it one light:
//!
//! ```json
//! { "shape": "rect",   "luminance": 2000, "width": 1, "height": 0.5, "color": [1, 1, 1] }
//! { "shape": "disk",   "luminance": 2000, "radius": 0.25 }
//! { "shape": "sphere", "intensity": 100,  "radius": 0.1 }
//! { "shape": "tube",   "intensity": 100,  "length": 1, "radius": 0.02 }
//! ```
//!
//! Units follow `RectLight`, `DiskLight`, `SphereLight` and `TubeLight`: rectangles and disks
//! give the luminance of their face (cd/m²) and shine down the node's −Z (the rectangle's width
//! along X, height along Y); spheres and tubes give candela, as a point light, the tube lying
//! along X. `color` is linear RGB (default white); `range` (metres) and `shadows` (default
//! true) are optional. `tools/reference.py` reads the same extension to place Blender area
//! lights in path-traced references. A malformed entry fails the import naming the field.

use glam::Vec3;
use gltf::json::Value;

use crate::components::{DiskLight, RectLight, SphereLight, TubeLight};
use crate::import::ImportErrorKind;

pub(crate) const NAME: &str = "PENUMBRA_lights_area";

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum AreaLightDesc {
    Rect(RectLight),
    Disk(DiskLight),
    Sphere(SphereLight),
    Tube(TubeLight),
}

fn invalid(at: &str, field: &str, what: &str) -> ImportErrorKind {
    ImportErrorKind::Invalid(format!("{at}.{field}: {what}"))
}

pub(crate) fn node_light(node: &gltf::Node) -> Result<Option<AreaLightDesc>, ImportErrorKind> {
    let Some(ext) = node.extension_value(NAME) else { return Ok(None) };
    let at = format!("nodes[{}].extensions.{NAME}", node.index());
    // A positive finite number (or zero where `zero_ok`); `default` when absent.
    let number = |field: &str, default: Option<f32>, zero_ok: bool| -> Result<f32, ImportErrorKind> {
        match ext.get(field) {
            None => default.ok_or_else(|| invalid(&at, field, "is missing")),
            Some(v) => match v.as_f64().map(|x| x as f32) {
                Some(x) if x.is_finite() && (x > 0.0 || (zero_ok && x == 0.0)) => Ok(x),
                _ => Err(invalid(
                    &at,
                    field,
                    &format!("must be a number {} 0, found {v}", if zero_ok { "≥" } else { ">" }),
                )),
            },
        }
    };
    let color = match ext.get("color") {
        None => Vec3::ONE,
        Some(v) => match super::ies_lights::json_rgb(v).filter(|c| c.min_element() >= 0.0) {
            Some(c) => c,
            None => return Err(invalid(&at, "color", &format!("must be three numbers ≥ 0, found {v}"))),
        },
    };
    let range = match ext.get("range") {
        None => None,
        Some(_) => Some(number("range", None, false)?),
    };
    let shadows = match ext.get("shadows") {
        None => true,
        Some(v) => v.as_bool().ok_or_else(|| invalid(&at, "shadows", &format!("must be true or false, found {v}")))?,
    };
    let shape = ext.get("shape").and_then(Value::as_str).unwrap_or("");
    Ok(Some(match shape {
        "rect" => AreaLightDesc::Rect(RectLight {
            color,
            luminance: number("luminance", None, true)?,
            width: number("width", None, false)?,
            height: number("height", None, false)?,
            range,
            shadows,
        }),
        "disk" => AreaLightDesc::Disk(DiskLight {
            color,
            luminance: number("luminance", None, true)?,
            radius: number("radius", None, false)?,
            range,
            shadows,
        }),
        "sphere" => AreaLightDesc::Sphere(SphereLight {
            color,
            intensity: number("intensity", None, true)?,
            radius: number("radius", None, false)?,
            range,
            shadows,
        }),
        "tube" => AreaLightDesc::Tube(TubeLight {
            color,
            intensity: number("intensity", None, true)?,
            length: number("length", None, false)?,
            radius: number("radius", Some(TubeLight::default().radius), false)?,
            range,
            shadows,
        }),
        other => {
            return Err(invalid(
                &at,
                "shape",
                &format!("is {other:?}; expected \"rect\", \"disk\", \"sphere\" or \"tube\""),
            ));
        }
    }))
}
