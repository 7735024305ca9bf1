//! The procedural clear sky's parameters, computed on the CPU from the sun: Preetham, Shirley
//! and Smits 1999, "A Practical Analytic Model for Daylight" (the Perez distribution's
//! coefficients as linear functions of turbidity, Appendix A.2; zenith luminance and
//! chromaticity, A.2's fits). `env_source.wgsl` evaluates the distribution per texel.
//!
//! Absolute scale: Preetham's zenith luminance (kcd/m²) is for a clear day's sun; the sky is
//! scaled by the scene's sun illuminance over [`CLEAR_DAY_SUN_LUX`], so that a glTF scene lit by
//! a 3 lux sun gets a sky of the same proportion. The cube stores the sky divided by its zenith
//! luminance (values of order 1 to 50), and [`SkyParams::scale`] multiplies it back at lookup.

use glam::{Vec3, Vec4};
use penumbra_engine::environment::Sky;

/// Illuminance of a high sun on a clear day, at normal incidence (lux).
pub const CLEAR_DAY_SUN_LUX: f32 = 100_000.0;
/// The sun's elevation is clamped to at least this (radians) when shaping the sky: Preetham's
/// fits are for a sun above the horizon.
const MIN_ELEVATION: f32 = 0.017;
/// Below the horizon the sky fades out, reaching black at this depression (radians, −6°:
/// civil twilight's end).
const TWILIGHT_END: f32 = -0.105;

/// What `env_source.wgsl` needs for the sky, and the scale to multiply it by.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkyParams {
    pub perez_lum: Vec4,
    pub perez_x: Vec4,
    pub perez_y: Vec4,
    /// E for Y, x, y.
    pub perez_e: Vec3,
    /// Zenith Y (1: the stored unit), x and y, each over F(0, θs).
    pub zenith: Vec3,
    /// Towards the sun, normalised.
    pub sun: Vec3,
    /// Ground radiance in the stored unit.
    pub ground: f32,
    /// cd/m² per stored unit: the zenith luminance for this sun.
    pub scale: f32,
}

impl SkyParams {
    /// Luminance (cd/m²) arriving from world direction `d` (unit), as `env_source.wgsl` draws
    /// it less the horizon's blend: Preetham's distribution above the horizon, the grey ground
    /// below.
    pub fn luminance(&self, d: Vec3) -> f32 {
        if d.y < 0.0 {
            return self.ground * self.scale;
        }
        let above = Vec3::new(d.x, d.y.max(0.02), d.z).normalize();
        let gamma = above.dot(self.sun).clamp(-1.0, 1.0).acos();
        let c = self.perez_lum;
        let f = (1.0 + c.x * (c.y / above.y.max(0.01)).exp())
            * (1.0 + c.z * (c.w * gamma).exp() + self.perez_e.x * gamma.cos() * gamma.cos());
        (self.zenith.x * f * self.scale).max(0.0)
    }
}

struct Perez {
    a: f32,
    b: f32,
    c: f32,
    d: f32,
    e: f32,
}

impl Perez {
    fn f(&self, cos_theta: f32, gamma: f32) -> f32 {
        (1.0 + self.a * (self.b / cos_theta.max(0.01)).exp())
            * (1.0 + self.c * (self.d * gamma).exp() + self.e * gamma.cos() * gamma.cos())
    }

    fn coefficients(&self) -> Vec4 {
        Vec4::new(self.a, self.b, self.c, self.d)
    }
}

/// The sky for a sun in direction `towards_sun` (unit, world) of illuminance `sun_lux`.
pub fn sky_params(sky: &Sky, towards_sun: Vec3, sun_lux: f32) -> SkyParams {
    let t = sky.turbidity;
    let sun = towards_sun.normalize_or(Vec3::Y);
    let elevation = sun.y.clamp(-1.0, 1.0).asin();
    let theta_s = std::f32::consts::FRAC_PI_2 - elevation.max(MIN_ELEVATION);
    let lum = Perez {
        a: 0.1787 * t - 1.4630,
        b: -0.3554 * t + 0.4275,
        c: -0.0227 * t + 5.3251,
        d: 0.1206 * t - 2.5771,
        e: -0.0670 * t + 0.3703,
    };
    let px = Perez {
        a: -0.0193 * t - 0.2592,
        b: -0.0665 * t + 0.0008,
        c: -0.0004 * t + 0.2125,
        d: -0.0641 * t - 0.8989,
        e: -0.0033 * t + 0.0452,
    };
    let py = Perez {
        a: -0.0167 * t - 0.2608,
        b: -0.0950 * t + 0.0092,
        c: -0.0079 * t + 0.2102,
        d: -0.0441 * t - 1.6537,
        e: -0.0109 * t + 0.0529,
    };
    let chi = (4.0 / 9.0 - t / 120.0) * (std::f32::consts::PI - 2.0 * theta_s);
    let zenith_kcd = ((4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192).max(0.0);
    let (s1, s2, s3) = (theta_s, theta_s * theta_s, theta_s * theta_s * theta_s);
    let t2 = t * t;
    let zenith_x = (0.00166 * s3 - 0.00375 * s2 + 0.00209 * s1) * t2
        + (-0.02903 * s3 + 0.06377 * s2 - 0.03202 * s1 + 0.00394) * t
        + (0.11693 * s3 - 0.21196 * s2 + 0.06052 * s1 + 0.25886);
    let zenith_y = (0.00275 * s3 - 0.00610 * s2 + 0.00317 * s1) * t2
        + (-0.04214 * s3 + 0.08970 * s2 - 0.04153 * s1 + 0.00516) * t
        + (0.15346 * s3 - 0.26756 * s2 + 0.06670 * s1 + 0.26688);
    // F(0, θs): the distribution at the zenith, whose value the zenith terms fix.
    let zenith = Vec3::new(1.0 / lum.f(1.0, theta_s), zenith_x / px.f(1.0, theta_s), zenith_y / py.f(1.0, theta_s));
    // The sky shaped by a sun at least MIN_ELEVATION high, then faded below the horizon.
    let shape_sun = Vec3::new(sun.x, 0.0, sun.z).normalize_or(Vec3::X) * theta_s.sin() + Vec3::Y * theta_s.cos();
    let twilight = ((elevation - TWILIGHT_END) / (MIN_ELEVATION - TWILIGHT_END)).clamp(0.0, 1.0);
    let scale = zenith_kcd * 1000.0 * (sun_lux.max(0.0) / CLEAR_DAY_SUN_LUX) * twilight;

    // Ground: Lambertian, lit by the sun and the sky's horizontal illuminance (numerically, in
    // the stored unit).
    let mut sky_e = 0.0f64;
    let (n_theta, n_phi) = (32, 64);
    for i in 0..n_theta {
        let theta = (i as f32 + 0.5) / n_theta as f32 * std::f32::consts::FRAC_PI_2;
        for j in 0..n_phi {
            let phi = (j as f32 + 0.5) / n_phi as f32 * std::f32::consts::TAU;
            let d = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            let gamma = d.dot(shape_sun).clamp(-1.0, 1.0).acos();
            let l = zenith.x * lum.f(theta.cos(), gamma);
            let d_omega =
                theta.sin() * (std::f32::consts::FRAC_PI_2 / n_theta as f32) * (std::f32::consts::TAU / n_phi as f32);
            sky_e += (l * theta.cos() * d_omega) as f64;
        }
    }
    // The sun's horizontal illuminance in the stored unit (lux / scale), written without the
    // sun's lux, which cancels: rounding must not make the shape depend on the brightness.
    let unit = zenith_kcd * 1000.0 * twilight / CLEAR_DAY_SUN_LUX;
    let sun_e = if unit > 0.0 { elevation.sin().max(0.0) / unit } else { 0.0 };
    let ground = sky.ground_albedo / std::f32::consts::PI * (sky_e as f32 + sun_e);
    SkyParams {
        perez_lum: lum.coefficients(),
        perez_x: px.coefficients(),
        perez_y: py.coefficients(),
        perez_e: Vec3::new(lum.e, px.e, py.e),
        zenith,
        sun: shape_sun,
        ground,
        scale,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zenith_luminance_matches_preetham_for_a_high_sun() {
        // θs = 30°, T = 2.5: χ = (4/9 − 2.5/120)(π − π/3), Yz = (4.0453·2.5 − 4.971) tan χ −
        // 0.2155·2.5 + 2.4192 = 8.18 kcd/m².
        let sun = Vec3::new(0.0, 60f32.to_radians().sin(), 60f32.to_radians().cos());
        let p = sky_params(&Sky { turbidity: 2.5, ground_albedo: 0.3 }, sun, CLEAR_DAY_SUN_LUX);
        assert!((p.scale - 8180.0).abs() < 30.0, "{}", p.scale);
        // Zenith chromaticity of a clear sky is bluish white: x, y near 0.25-0.30.
        let lz = Perez { a: p.perez_lum.x, b: p.perez_lum.y, c: p.perez_lum.z, d: p.perez_lum.w, e: p.perez_e.x };
        assert!((p.zenith.x * lz.f(1.0, 30f32.to_radians()) - 1.0).abs() < 1e-5);
    }

    #[test]
    fn sky_follows_the_sun_illuminance_and_fades_below_the_horizon() {
        let sky = Sky::default();
        let high = Vec3::new(0.3, 0.8, 0.2).normalize();
        let bright = sky_params(&sky, high, 100_000.0);
        let dim = sky_params(&sky, high, 3.0);
        assert!((bright.scale / dim.scale - 100_000.0 / 3.0).abs() < 1.0);
        let set = sky_params(&sky, Vec3::new(1.0, -0.2, 0.0).normalize(), 100_000.0);
        assert_eq!(set.scale, 0.0);
        assert!(set.ground.is_finite() && set.ground >= 0.0);
        for p in [bright, dim] {
            assert!(p.ground > 0.0 && p.ground.is_finite());
            assert!(p.zenith.is_finite() && p.perez_lum.is_finite());
        }
    }
}
