//! glTF cameras to `Projection`s, checked against the specification: what the schema forbids
//! (a field of view, near plane or aspect ratio of 0 or below, a far plane not beyond the near
//! one, a magnification of 0, a non-finite number) refuses the file naming the camera; what it
//! only advises against (a field of view of π or more, a negative magnification) is made
//! sensible with a warning. A camera node's scale never reaches the view (extraction keeps only
//! rotation and translation), so a zero-scaled camera node is only warned about.

use crate::components::Projection;
use crate::import::{ImportErrorKind, num};

/// The widest vertical field of view kept: glTF says yfov SHOULD be below π, where the
/// projection's tan(yfov / 2) goes to infinity and then changes sign.
const MAX_YFOV: f32 = 179.0 * std::f32::consts::PI / 180.0;

/// A camera as the importer keeps it: its name, projection and the file's aspect ratio.
pub(crate) type CameraDesc = (String, Projection, Option<f32>);

/// Every camera of the file, or the first that the specification forbids.
pub(crate) fn convert(
    document: &gltf::Document,
    warnings: &mut Vec<String>,
) -> Result<Vec<CameraDesc>, ImportErrorKind> {
    document.cameras().map(|c| camera(&c, warnings)).collect()
}

fn camera(c: &gltf::Camera, warnings: &mut Vec<String>) -> Result<CameraDesc, ImportErrorKind> {
    let name = c.name().map_or_else(|| format!("camera{}", c.index()), str::to_owned);
    let fail = |reason: String| ImportErrorKind::Camera { index: c.index(), name: name.clone(), reason };
    let positive = |key: &str, v: f32| {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(fail(format!("{key} {} must be a finite number above 0", num(v))))
        }
    };
    // The file's aspect ratio is kept aside (it sizes default screenshots) rather than baked into
    // the projection: forced onto a viewport of another shape it would stretch the image.
    // Vertical field of view (or ymag) is what the camera keeps.
    match c.projection() {
        gltf::camera::Projection::Perspective(p) => {
            let mut yfov = positive("yfov", p.yfov())?;
            let znear = positive("znear", p.znear())?;
            if let Some(zfar) = p.zfar()
                && !(zfar.is_finite() && zfar > znear)
            {
                return Err(fail(format!("zfar {} must be a finite number above znear {}", num(zfar), num(znear))));
            }
            let aspect_ratio = p.aspect_ratio().map(|a| positive("aspectRatio", a)).transpose()?;
            if yfov > MAX_YFOV {
                warnings.push(format!(
                    "camera {} (\"{name}\"): yfov {} is not below π, as glTF asks; using {MAX_YFOV} (179°)",
                    c.index(),
                    num(yfov)
                ));
                yfov = MAX_YFOV;
            }
            // Penumbra's perspective has no far plane (reverse-Z to infinity): zfar only checked.
            Ok((name.clone(), Projection::Perspective { yfov, znear, aspect_ratio: None }, aspect_ratio))
        }
        gltf::camera::Projection::Orthographic(o) => {
            let mut magnification = |key: &str, v: f32| {
                if !v.is_finite() || v == 0.0 {
                    return Err(fail(format!("{key} {} must be a finite number other than 0", num(v))));
                }
                if v < 0.0 {
                    warnings.push(format!(
                        "camera {} (\"{name}\"): {key} {} is negative, which glTF advises against (it mirrors \
                         the image); using {}",
                        c.index(),
                        num(v),
                        num(-v)
                    ));
                }
                Ok(v.abs())
            };
            let xmag = magnification("xmag", o.xmag())?;
            let ymag = magnification("ymag", o.ymag())?;
            let (znear, zfar) = (o.znear(), o.zfar());
            if !(znear.is_finite() && znear >= 0.0) {
                return Err(fail(format!("znear {} must be a finite number of at least 0", num(znear))));
            }
            if !(zfar.is_finite() && zfar > znear) {
                return Err(fail(format!("zfar {} must be a finite number above znear {}", num(zfar), num(znear))));
            }
            Ok((name.clone(), Projection::Orthographic { xmag: None, ymag, znear, zfar }, Some(xmag / ymag)))
        }
    }
}

/// A warning for each camera node whose own scale has a zero or non-finite component: such a
/// node's transform has no inverse, so its view uses the node's rotation and translation only.
pub(crate) fn check_nodes(document: &gltf::Document, warnings: &mut Vec<String>) {
    for node in document.nodes().filter(|n| n.camera().is_some()) {
        let (_, _, scale) = node.transform().decomposed();
        if scale.iter().any(|s| !s.is_finite() || *s == 0.0) {
            warnings.push(format!(
                "node {} (camera {}) has scale {scale:?}; a camera's view ignores scale",
                node.index(),
                node.camera().map_or(0, |c| c.index())
            ));
        }
    }
}
