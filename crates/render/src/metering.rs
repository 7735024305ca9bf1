//! The default exposure: a scene's own lights metered where the camera is framed, as a
//! photographer's handheld incident-light meter would be.
//!
//! [`meter`] reads the main world's light entities and the [`Environment`] resource (nothing
//! GPU-side: it runs at staging, before any frame) and returns the illuminance at the framed
//! objects and the EV100 that exposes it. Headless staging ([`crate::headless::stage_camera`])
//! calls it when no exposure is given and writes the result into the cameras it sets up.
//!
//! Calibration: EV100 = log2(E / 2.5), E in lux, the incident-meter equation
//! EV = log2(E·S / C) with S = 100 and ISO 2720's flat-receptor constant C = 250. A white
//! Lambertian surface facing a light of illuminance E then shows 2.5/(1.2π) ≈ 0.66 before
//! tonemapping, whatever E is: a 6,830 lux sun and a 5 lux lamp both expose to the same grey.
//!
//! Where: the median of the illuminance at nine points, the framed bounds' centre and the
//! midpoints towards its eight corners, so that one light touching the centre does not decide
//! the exposure. Each light counts at full strength (a meter pointed at it), without shadows;
//! the environment counts as the mean of the illuminance it gives an upward- and a
//! downward-facing surface.
//!
//! A scene without light entities is not metered: it keeps EV100 0, the exposure at which
//! environment-lit glTF models (authored for viewers that show radiance unscaled) look as
//! their authors saw them, and at which the default key light is calibrated.

use bevy_ecs::prelude::*;
use glam::Vec3;
use penumbra_engine::assets::Assets;
use penumbra_engine::bounds::Aabb;
use penumbra_engine::components::{
    AmbientLight, DirectionalLight, DiskLight, GlobalTransform, IesLight, InheritedVisibility, PointLight, RectLight,
    SphereLight, SpotLight, TubeLight,
};
use penumbra_engine::environment::{Environment, EnvironmentImage, EnvironmentSource};
use penumbra_engine::ies::IesProfile;

use crate::features::environment::{sky_for, studio_radiance};

/// Illuminance (lux) that EV100 0 exposes correctly (ISO 2720, C = 250).
pub const CALIBRATION_LUX: f32 = 2.5;

/// EV100 far outside any real scene (a moonless night is about −3, noon sun 15): exposures
/// given or metered stay inside it.
pub const EV100_RANGE: std::ops::RangeInclusive<f32> = -30.0..=40.0;

/// What the meter read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Metering {
    /// The exposure chosen, EV100.
    pub ev100: f32,
    /// Illuminance at the framed objects from the light entities (median of the points).
    pub lights_lux: f32,
    /// Illuminance from the environment.
    pub environment_lux: f32,
    /// Light entities counted.
    pub lights: usize,
}

impl Metering {
    /// The total illuminance metered.
    pub fn lux(&self) -> f32 {
        self.lights_lux + self.environment_lux
    }
}

/// How a staged camera's exposure was chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ExposureChoice {
    /// Given by the caller (`--exposure`, a look).
    Given { ev100: f32 },
    /// The scene has no light entities: EV100 0.
    Unlit,
    /// Metered from the scene's lights.
    Metered(Metering),
}

impl ExposureChoice {
    pub fn ev100(&self) -> f32 {
        match self {
            ExposureChoice::Given { ev100 } => *ev100,
            ExposureChoice::Unlit => 0.0,
            ExposureChoice::Metered(m) => m.ev100,
        }
    }
}

impl std::fmt::Display for ExposureChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ExposureChoice::Given { ev100 } => write!(f, "EV100 {ev100:.2}, given"),
            ExposureChoice::Unlit => write!(f, "EV100 0 (the scene has no lights: environment-lit, as authored)"),
            ExposureChoice::Metered(m) => write!(
                f,
                "EV100 {:.2}, metered: {} lux at the framed objects ({} from {} light(s), {} from the environment)",
                m.ev100,
                lux(m.lux()),
                lux(m.lights_lux),
                m.lights,
                lux(m.environment_lux)
            ),
        }
    }
}

/// Lux with as many digits as a reader needs.
fn lux(v: f32) -> String {
    if v >= 100.0 { format!("{v:.0}") } else { format!("{v:.3}") }
}

/// Meters the scene's lights at `bounds` (the objects the camera frames); `None` where the
/// scene has no light entity (or they give no light at all), which keeps EV100 0.
pub fn meter(world: &mut World, bounds: &Aabb) -> Option<Metering> {
    let lights = scene_lights(world);
    if lights.is_empty() {
        return None;
    }
    let (center, half) = if bounds.is_empty() || !bounds.center().is_finite() {
        (Vec3::ZERO, Vec3::ONE)
    } else {
        (bounds.center(), bounds.half_extents())
    };
    // A light at a metering point would read infinite: closer than this, it reads as here.
    let near = (half.length() * 0.05).max(f32::MIN_POSITIVE.sqrt());
    let mut readings: Vec<f32> = std::iter::once(center)
        .chain((0..8).map(|i| {
            let s = |bit: u32| if i & bit == 0 { -0.5 } else { 0.5 };
            center + half * Vec3::new(s(1), s(2), s(4))
        }))
        .map(|p| lights.iter().map(|l| l.illuminance_at(p, near)).filter(|e| e.is_finite()).sum::<f32>())
        .collect();
    readings.sort_by(f32::total_cmp);
    let lights_lux = readings[readings.len() / 2];
    let environment_lux = world.get_resource::<Environment>().map_or(0.0, |env| environment_illuminance(env, &lights));
    let total = lights_lux + environment_lux;
    if !(total.is_finite() && total > 0.0) {
        return None;
    }
    let ev100 = (total / CALIBRATION_LUX).log2().clamp(*EV100_RANGE.start(), *EV100_RANGE.end());
    Some(Metering { ev100, lights_lux, environment_lux, lights: lights.len() })
}

/// One light entity, in world space, as the meter sees it.
#[derive(Debug, Clone)]
struct MeteredLight {
    kind: Kind,
    /// Luminance of the colour (Rec. 709), which multiplies the intensity.
    tint: f32,
    position: Vec3,
    /// Where it shines (local −Z), unit.
    forward: Vec3,
    right: Vec3,
    range: Option<f32>,
}

#[derive(Debug, Clone)]
enum Kind {
    /// Lux, wherever.
    Directional(f32),
    /// cd/m² from every direction.
    Ambient(f32),
    /// Candela in every direction.
    Point(f32),
    /// Candela on the axis; cosines of the inner and outer cone.
    Spot(f32, f32, f32),
    /// One-sided emitter: cd/m² times its area (candela along its axis, falling with the cosine).
    Panel(f32),
    /// A profile's candela times a scale.
    Ies(Box<IesProfile>, f32),
}

fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722)).max(0.0)
}

impl MeteredLight {
    /// Illuminance on a surface at `p` facing the light.
    fn illuminance_at(&self, p: Vec3, near: f32) -> f32 {
        let intensity = |toward_p: Vec3| -> f32 {
            match &self.kind {
                Kind::Directional(_) | Kind::Ambient(_) => 0.0,
                Kind::Point(i) => *i,
                Kind::Spot(i, cos_inner, cos_outer) => {
                    let cd = toward_p.dot(self.forward);
                    // As the light store shapes it: a 0.001 floor for a hard-edged cone.
                    let t = ((cd - cos_outer) / (cos_inner - cos_outer).max(0.001)).clamp(0.0, 1.0);
                    i * t * t
                }
                Kind::Panel(i) => i * toward_p.dot(self.forward).max(0.0),
                Kind::Ies(profile, scale) => {
                    // Local +Y: C = 90° (ies.wgsl measures C from +X towards +Y).
                    let up = self.right.cross(self.forward);
                    let gamma = toward_p.dot(self.forward).clamp(-1.0, 1.0).acos().to_degrees();
                    let c = toward_p.dot(up).atan2(toward_p.dot(self.right)).to_degrees();
                    profile.candela_at(gamma, c) * scale
                }
            }
        };
        let lux = match &self.kind {
            Kind::Directional(e) => *e,
            Kind::Ambient(l) => std::f32::consts::PI * l,
            _ => {
                let to_p = p - self.position;
                let d = to_p.length();
                let toward_p = if d > 0.0 { to_p / d } else { self.forward };
                // glTF's range window, as the shaders apply it.
                let window = self.range.map_or(1.0, |r| (1.0 - (d / r).powi(4)).clamp(0.0, 1.0).powi(2));
                intensity(toward_p) * window / d.max(near).powi(2)
            }
        };
        lux * self.tint
    }
}

/// Every visible light entity.
fn scene_lights(world: &mut World) -> Vec<MeteredLight> {
    let mut out = Vec::new();
    let visible = |v: Option<&InheritedVisibility>| v.is_none_or(|v| v.0);
    let placed = |g: Option<&GlobalTransform>, kind: Kind, color: Vec3, range: Option<f32>| {
        let g = g.copied().unwrap_or_default();
        MeteredLight {
            kind,
            tint: luminance(color),
            position: g.translation(),
            forward: g.forward(),
            right: g.right(),
            range,
        }
    };
    macro_rules! collect {
        ($component:ty, |$l:ident| $kind:expr, $range:expr) => {
            let mut q = world.query::<(&$component, Option<&GlobalTransform>, Option<&InheritedVisibility>)>();
            for ($l, g, v) in q.iter(world) {
                // The renderer places lights by their GlobalTransform and leaves out one without.
                let kind = $kind;
                if visible(v) && (g.is_some() || matches!(kind, Kind::Ambient(_))) {
                    out.push(placed(g, kind, $l.color, $range));
                }
            }
        };
    }
    collect!(DirectionalLight, |l| Kind::Directional(l.illuminance), None);
    collect!(AmbientLight, |l| Kind::Ambient(l.intensity), None);
    collect!(PointLight, |l| Kind::Point(l.intensity), l.range);
    collect!(SphereLight, |l| Kind::Point(l.intensity), l.range);
    collect!(TubeLight, |l| Kind::Point(l.intensity), l.range);
    // Cones clamped as the light store clamps them (outer at most π/2, inner within it).
    collect!(
        SpotLight,
        |l| {
            let outer = l.outer_cone_angle.clamp(0.0, std::f32::consts::FRAC_PI_2);
            Kind::Spot(l.intensity, l.inner_cone_angle.clamp(0.0, outer).cos(), outer.cos())
        },
        l.range
    );
    collect!(RectLight, |l| Kind::Panel(l.luminance * l.width * l.height), l.range);
    collect!(DiskLight, |l| Kind::Panel(l.luminance * std::f32::consts::PI * l.radius * l.radius), l.range);
    let mut q = world.query::<(&IesLight, Option<&GlobalTransform>, Option<&InheritedVisibility>)>();
    let profiles = world.get_resource::<Assets<IesProfile>>().map(|a| {
        q.iter(world)
            .filter(|(_, g, v)| visible(*v) && g.is_some())
            .filter_map(|(l, g, _)| {
                Some(placed(g, Kind::Ies(Box::new(a.get(l.profile).ok()?.clone()), l.scale), l.color, l.range))
            })
            .collect::<Vec<_>>()
    });
    out.extend(profiles.into_iter().flatten());
    out
}

/// The environment's illuminance: the mean of what an upward- and a downward-facing surface
/// receive, ½∫L|cos θ|dω (π × the radiance of a uniform environment).
fn environment_illuminance(env: &Environment, lights: &[MeteredLight]) -> f32 {
    if let EnvironmentSource::Image(img) = &env.source {
        return image_illuminance(img) * env.intensity;
    }
    // The sky is made for the brightest directional light, as the renderer makes it.
    let sun = lights
        .iter()
        .filter_map(|l| match l.kind {
            Kind::Directional(lux) => Some((-l.forward, lux * l.tint)),
            _ => None,
        })
        .max_by(|a, b| a.1.total_cmp(&b.1));
    let radiance: Box<dyn Fn(Vec3) -> f32> = match sky_for(env, sun) {
        Some(sky) => Box::new(move |d| sky.luminance(d)),
        None => Box::new(studio_radiance),
    };
    let (rows, columns) = (64, 64);
    let mut sum = 0.0f64;
    for i in 0..rows {
        let theta = (i as f32 + 0.5) / rows as f32 * std::f32::consts::PI;
        let d_omega = theta.sin() * (std::f32::consts::PI / rows as f32) * (std::f32::consts::TAU / columns as f32);
        for j in 0..columns {
            let phi = (j as f32 + 0.5) / columns as f32 * std::f32::consts::TAU;
            let d = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            sum += (radiance(d) * theta.cos().abs() * d_omega) as f64;
        }
    }
    0.5 * sum as f32 * env.intensity
}

/// ½∫L|cos θ|dω over an equirectangular image, every texel by its solid angle (rows top to
/// bottom, θ from straight up).
fn image_illuminance(img: &EnvironmentImage) -> f32 {
    let (w, h) = (img.width as usize, img.height as usize);
    if w == 0 || h == 0 || img.texels.len() != w * h {
        return 0.0;
    }
    let mut sum = 0.0f64;
    for (y, row) in img.texels.chunks_exact(w).enumerate() {
        let theta = (y as f64 + 0.5) / h as f64 * std::f64::consts::PI;
        let d_omega = theta.sin() * (std::f64::consts::PI / h as f64) * (std::f64::consts::TAU / w as f64);
        let row_sum: f64 = row.iter().map(|t| luminance(Vec3::from(*t)) as f64).filter(|v| v.is_finite()).sum();
        sum += row_sum * theta.cos().abs() * d_omega;
    }
    (0.5 * sum) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use penumbra_engine::components::Transform;

    fn world_with(env: Option<Environment>) -> World {
        let mut world = World::new();
        if let Some(env) = env {
            world.insert_resource(env);
        }
        world
    }

    fn unit_box() -> Aabb {
        Aabb { min: Vec3::splat(-1.0), max: Vec3::splat(1.0) }
    }

    #[test]
    fn a_sun_is_metered_to_the_incident_meter_equation() {
        let mut world = world_with(None);
        world.spawn((
            DirectionalLight { illuminance: 6830.0, ..Default::default() },
            GlobalTransform(Transform::IDENTITY.looking_at(Vec3::new(0.3, -1.0, 0.2), Vec3::X).to_affine()),
        ));
        let m = meter(&mut world, &unit_box()).unwrap();
        assert!((m.ev100 - (6830.0f32 / 2.5).log2()).abs() < 1e-4, "{m:?}");
        assert_eq!(m.environment_lux, 0.0);
    }

    #[test]
    fn no_lights_no_metering() {
        let mut world = world_with(Some(Environment::default()));
        assert!(meter(&mut world, &unit_box()).is_none());
    }

    #[test]
    fn point_lights_fall_off_with_distance_and_a_light_at_the_centre_does_not_decide() {
        let mut world = world_with(None);
        world.spawn((
            PointLight { intensity: 40.0, ..Default::default() },
            GlobalTransform(Transform::from_xyz(0.0, 0.0, 10.0).to_affine()),
        ));
        let far = meter(&mut world, &unit_box()).unwrap();
        // 40 cd at about 10 m: 0.4 lux (the median point is within half a metre of 10 m).
        assert!((far.lights_lux - 0.4).abs() < 0.05, "{far:?}");
        let mut world = world_with(None);
        world.spawn((PointLight { intensity: 40.0, ..Default::default() }, GlobalTransform::default()));
        let inside = meter(&mut world, &unit_box()).unwrap();
        // Every corner midpoint is √3/2 away: 40 / 0.75 lux, not the centre's clamp.
        assert!((inside.lights_lux - 40.0 / 0.75).abs() < 0.1, "{inside:?}");
    }

    #[test]
    fn spot_lights_count_only_inside_their_cone_and_panels_only_in_front() {
        let aim =
            |from: Vec3| GlobalTransform(Transform::from_translation(from).looking_at(Vec3::ZERO, Vec3::Y).to_affine());
        let away =
            |from: Vec3| GlobalTransform(Transform::from_translation(from).looking_at(from * 2.0, Vec3::Y).to_affine());
        for (toward, lit) in [(true, true), (false, false)] {
            let g = if toward { aim(Vec3::new(0.0, 5.0, 0.0)) } else { away(Vec3::new(0.0, 5.0, 0.0)) };
            let mut world = world_with(None);
            world.spawn((SpotLight { intensity: 100.0, ..Default::default() }, g));
            world.spawn((RectLight { luminance: 100.0, ..Default::default() }, g));
            let m = meter(&mut world, &unit_box()).map_or(0.0, |m| m.lights_lux);
            assert_eq!(m > 1.0, lit, "{m}");
        }
    }

    #[test]
    fn the_environment_counts_by_its_illuminance() {
        // A uniform environment of 1 cd/m² gives π lux.
        let img = EnvironmentImage::from_fn(64, 32, "uniform", |_| Vec3::ONE);
        let env = Environment { intensity: 2.0, ..Environment::image(std::sync::Arc::new(img)) };
        let mut world = world_with(Some(env));
        world.spawn((DirectionalLight { illuminance: 0.0, ..Default::default() }, GlobalTransform::default()));
        let m = meter(&mut world, &unit_box()).unwrap();
        assert!((m.environment_lux / (2.0 * std::f32::consts::PI) - 1.0).abs() < 0.005, "{m:?}");
        // The studio gradient: between its darkest (0.25) and brightest (1) radiance times π.
        let mut world = world_with(Some(Environment { source: EnvironmentSource::Studio, ..Default::default() }));
        world.spawn((DirectionalLight { illuminance: 0.0, ..Default::default() }, GlobalTransform::default()));
        let e = meter(&mut world, &unit_box()).unwrap().environment_lux;
        assert!(e > 0.25 * std::f32::consts::PI && e < std::f32::consts::PI, "{e}");
    }

    #[test]
    fn nan_and_huge_inputs_leave_a_finite_exposure() {
        let mut world = world_with(None);
        world.spawn((PointLight { intensity: f32::NAN, ..Default::default() }, GlobalTransform::default()));
        world.spawn((DirectionalLight { illuminance: 1e30, ..Default::default() }, GlobalTransform::default()));
        let m = meter(&mut world, &Aabb { min: Vec3::splat(7e5), max: Vec3::splat(7e5 + 1e-3) }).unwrap();
        assert!(m.ev100.is_finite() && EV100_RANGE.contains(&m.ev100), "{m:?}");
    }
}
