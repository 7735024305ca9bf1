//! KHR_lights_punctual lights to Penumbra's light components, sanitised: what the shading math
//! cannot carry, or the extension forbids, is replaced with a warning naming the light.
//!
//! Intensities above [`MAX_INTENSITY`] are clamped to it: shading multiplies the intensity by the
//! BRDF's peak and the inverse square of the distance, and far above this an f32 overflows to
//! infinity and then to NaN, which shows as a light that vanishes. Every light is already white
//! on screen long before the clamp at any exposure Penumbra accepts. Colours must be finite and
//! not negative; a range must be above 0; cone angles must satisfy 0 ≤ inner < outer ≤ π/2.

use glam::Vec3;

use crate::components::{DirectionalLight, PointLight, SpotLight};
use crate::import::num;

/// The largest intensity (candela) or illuminance (lux) kept; see the module doc.
pub const MAX_INTENSITY: f32 = 1e15;

#[derive(Debug, Clone)]
pub(crate) enum LightDesc {
    Directional(DirectionalLight),
    Point(PointLight),
    Spot(SpotLight),
}

pub(crate) fn convert(document: &gltf::Document, warnings: &mut Vec<String>) -> Vec<LightDesc> {
    document.lights().into_iter().flatten().map(|l| light(&l, warnings)).collect()
}

fn light(l: &gltf::khr_lights_punctual::Light, warnings: &mut Vec<String>) -> LightDesc {
    let label = match l.name() {
        Some(name) => format!("light {} (\"{name}\")", l.index()),
        None => format!("light {}", l.index()),
    };
    let mut warn = |what: String| warnings.push(format!("{label}: {what}"));
    let raw = Vec3::from(l.color());
    let color = if raw.is_finite() && raw.min_element() >= 0.0 {
        raw
    } else {
        let fixed =
            Vec3::from_array(raw.to_array().map(|c| if c.is_nan() { 0.0 } else { c.clamp(0.0, MAX_INTENSITY) }));
        warn(format!("color {raw} must be finite and not negative; using {fixed}"));
        fixed
    };
    if color.max_element() > 1.0 {
        // The extension's colour is 0..=1; a larger one still means what it says (brighter).
        warn(format!("color {color} is outside 0..=1 (the extension's range); kept"));
    }
    let unit = match l.kind() {
        gltf::khr_lights_punctual::Kind::Directional => "lux",
        _ => "cd",
    };
    let raw = l.intensity();
    // What shading multiplies is colour × intensity: a colour above 1 takes from the headroom.
    let headroom = MAX_INTENSITY / color.max_element().max(1.0);
    let intensity = if raw.is_nan() || raw < 0.0 {
        warn(format!("intensity {} must be a number of at least 0; using 0", num(raw)));
        0.0
    } else if raw > headroom {
        warn(format!(
            "intensity {} {unit} is beyond what shading carries (colour × intensity up to {MAX_INTENSITY:e}); \
             clamped to {}",
            num(raw),
            num(headroom)
        ));
        headroom
    } else {
        raw
    };
    let range = l.range().and_then(|r| {
        if r.is_finite() && r > 0.0 {
            Some(r)
        } else {
            // +inf is as good as no range at all, and says the same thing.
            if r != f32::INFINITY {
                warn(format!("range {} must be above 0; ignored (no range)", num(r)));
            }
            None
        }
    });
    match l.kind() {
        gltf::khr_lights_punctual::Kind::Directional => {
            LightDesc::Directional(DirectionalLight { color, illuminance: intensity, ..Default::default() })
        }
        gltf::khr_lights_punctual::Kind::Point => {
            LightDesc::Point(PointLight { color, intensity, range, shadows: true })
        }
        gltf::khr_lights_punctual::Kind::Spot { inner_cone_angle, outer_cone_angle } => {
            let (inner, outer) = cone(inner_cone_angle, outer_cone_angle);
            if (inner, outer) != (inner_cone_angle, outer_cone_angle) {
                warn(format!(
                    "spot cone angles inner {inner_cone_angle}, outer {outer_cone_angle} must satisfy \
                     0 <= inner < outer <= π/2; using {inner}, {outer}"
                ));
            }
            LightDesc::Spot(SpotLight {
                color,
                intensity,
                range,
                inner_cone_angle: inner,
                outer_cone_angle: outer,
                shadows: true,
            })
        }
    }
}

/// The nearest cone pair the extension allows: outer in (0, π/2], inner in [0, outer).
fn cone(inner: f32, outer: f32) -> (f32, f32) {
    let half_pi = std::f32::consts::FRAC_PI_2;
    let outer = if outer.is_finite() && outer > 0.0 { outer.min(half_pi) } else { std::f32::consts::FRAC_PI_4 };
    let inner = if inner.is_finite() && inner >= 0.0 && inner < outer { inner } else { 0.0 };
    (inner, outer)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cone_angles_are_kept_when_valid_and_made_valid_otherwise() {
        assert_eq!(cone(0.1, 0.5), (0.1, 0.5));
        assert_eq!(cone(0.5, 0.5), (0.0, 0.5));
        assert_eq!(cone(0.1, 3.0), (0.1, std::f32::consts::FRAC_PI_2));
        assert_eq!(cone(-1.0, f32::NAN), (0.0, std::f32::consts::FRAC_PI_4));
    }
}
