//! Lights with a size: sphere and tube lights (representative point), rect and disk lights
//! (linearly transformed cosines). A white, fully rough floor is rendered from straight above
//! and its radiance read back from the HDR target, against closed forms on the light's axis and
//! against numerical integrals of glTF's BRDF over the emitter elsewhere, including emitters
//! cut by the floor's horizon. And every light kind packs its own type and lights the floor.

use penumbra::prelude::*;
use penumbra::render::RenderSettings;
use penumbra::render::Renderer;
use penumbra::render::resources::light_store::{
    KIND_AMBIENT, KIND_DIRECTIONAL, KIND_DISK, KIND_IES, KIND_POINT, KIND_RECT, KIND_SPHERE, KIND_SPOT, KIND_TUBE,
};

mod common;
use common::{floor_radiance, hdr_of, render_app, scene_app, top_down};

const SIZE: u32 = 64;

fn settings() -> RenderSettings {
    // The tests read HDR colour.
    RenderSettings { msaa: 1, keep_hdr: true, ..Default::default() }
}

/// The floor's radiance at `p` from an emitter given as samples (point, direction it emits
/// along, luminance · area): glTF's BRDF summed over the samples, each a tiny Lambertian patch.
/// Samples below the floor's horizon or facing away contribute nothing.
fn integrate(p: Vec3, samples: &[(Vec3, Vec3, f32)]) -> f32 {
    samples
        .iter()
        .map(|&(q, normal, l_da)| {
            let d = q - p;
            let dist2 = d.length_squared();
            let l = d / dist2.sqrt();
            let cos_emit = normal.dot(-l);
            if cos_emit <= 0.0 { 0.0 } else { floor_radiance(l, l_da * cos_emit / dist2) }
        })
        .sum()
}

/// Midpoint samples of a `width` × `height` rectangle centred at `c` with axes `x`, `y`,
/// emitting along `normal` with `luminance`.
fn rect_samples(c: Vec3, x: Vec3, y: Vec3, normal: Vec3, size: (f32, f32), luminance: f32) -> Vec<(Vec3, Vec3, f32)> {
    let n = 240;
    let da = size.0 * size.1 / (n * n) as f32;
    let mut out = Vec::with_capacity(n * n);
    for i in 0..n {
        for j in 0..n {
            let u = ((i as f32 + 0.5) / n as f32 - 0.5) * size.0;
            let v = ((j as f32 + 0.5) / n as f32 - 0.5) * size.1;
            out.push((c + x * u + y * v, normal, luminance * da));
        }
    }
    out
}

/// Irradiance at distance `h` on the axis of a `w` × `h_` rectangle of luminance `lum` facing
/// the point: four times the corner form factor of a parallel rectangle (Howell's catalogue,
/// configuration B-3).
fn rect_axis_irradiance(lum: f32, w: f32, height: f32, h: f32) -> f32 {
    let (x, y) = (w / (2.0 * h), height / (2.0 * h));
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    2.0 * lum * (x / sx * (y / sx).atan() + y / sy * (x / sy).atan())
}

/// The floor's radiance at `p` from `points` sharing `intensity` candela, each isotropic: a
/// line light's reference when the points lie along it.
fn points_radiance(p: Vec3, points: &[Vec3], intensity: f32) -> f32 {
    let each = intensity / points.len() as f32;
    points
        .iter()
        .map(|&q| {
            let d = q - p;
            floor_radiance(d.normalize(), each / d.length_squared())
        })
        .sum()
}

fn assert_close(got: f32, want: f32, tol: f32, what: &str) {
    assert!(want > 0.0, "{what}: the reference is dark");
    assert!(
        (got - want).abs() <= tol * want,
        "{what}: radiance {got}, expected {want} ({:+.2}%)",
        100.0 * (got / want - 1.0)
    );
}

#[test]
fn rect_light_irradiance_on_its_axis_matches_the_closed_form() {
    let mut app = scene_app();
    let pixel_world = top_down(&mut app, 1.0);
    let axis_at = pixel_world(32, 32, SIZE);
    let (w, h, height, lum) = (1.0, 0.6, 0.8, 2.0);
    let center = axis_at + Vec3::Y * height;
    app.world.spawn((
        RectLight { luminance: lum, width: w, height: h, ..Default::default() },
        Transform::from_translation(center).looking_at(axis_at, Vec3::NEG_Z),
    ));
    render_app(&mut app, (SIZE, SIZE), settings());
    let hdr = hdr_of(&app);
    let e = rect_axis_irradiance(lum, w, h, height);
    // The closed form itself against the numerical integral, so that the reference is right.
    let samples = rect_samples(center, Vec3::X, Vec3::Z, Vec3::NEG_Y, (w, h), lum);
    assert_close(integrate(axis_at, &samples), floor_radiance(Vec3::Y, e), 0.002, "closed form vs integral");
    assert_close(hdr[(32 * SIZE + 32) as usize][1], floor_radiance(Vec3::Y, e), 0.02, "on the axis");
    for (x, y) in [(10, 12), (50, 40), (5, 60), (40, 30)] {
        let p = pixel_world(x, y, SIZE);
        assert_close(hdr[(y * SIZE + x) as usize][1], integrate(p, &samples), 0.02, &format!("pixel ({x}, {y})"));
    }
}

#[test]
fn rect_light_cut_by_the_horizon_matches_the_integral_and_is_dark_behind() {
    let mut app = scene_app();
    let pixel_world = top_down(&mut app, 1.0);
    // Nearly upright, half below the floor's plane, facing +Z.
    let center = Vec3::new(0.1, 0.2, -0.7);
    let transform = Transform::from_translation(center).looking_at(center + Vec3::new(0.0, -0.2, 1.0), Vec3::Y);
    let (w, h, lum) = (1.2, 1.0, 1.5);
    app.world.spawn((RectLight { luminance: lum, width: w, height: h, ..Default::default() }, transform));
    render_app(&mut app, (SIZE, SIZE), settings());
    let hdr = hdr_of(&app);
    let r = transform.rotation;
    let samples = rect_samples(center, r * Vec3::X, r * Vec3::Y, r * Vec3::NEG_Z, (w, h), lum);
    let mut behind = 0;
    for (x, y) in [(32, 32), (20, 40), (50, 28), (32, 60), (8, 50)] {
        let p = pixel_world(x, y, SIZE);
        assert_close(hdr[(y * SIZE + x) as usize][1], integrate(p, &samples), 0.02, &format!("pixel ({x}, {y})"));
    }
    for y in 0..SIZE {
        for x in 0..SIZE {
            let p = pixel_world(x, y, SIZE);
            if (p - center).dot(r * Vec3::NEG_Z) < -0.02 {
                assert_eq!(hdr[(y * SIZE + x) as usize][1], 0.0, "behind the light at {p}");
                behind += 1;
            }
        }
    }
    assert!(behind > 100, "{behind} pixels behind the light");
}

#[test]
fn disk_light_irradiance_on_its_axis_matches_the_closed_form() {
    let mut app = scene_app();
    let pixel_world = top_down(&mut app, 1.0);
    let axis_at = pixel_world(32, 32, SIZE);
    let (radius, height, lum) = (0.4f32, 0.6f32, 3.0f32);
    let center = axis_at + Vec3::Y * height;
    app.world.spawn((
        DiskLight { luminance: lum, radius, ..Default::default() },
        Transform::from_translation(center).looking_at(axis_at, Vec3::NEG_Z),
    ));
    render_app(&mut app, (SIZE, SIZE), settings());
    let hdr = hdr_of(&app);
    // A disk subtending half-angle σ on the axis: E = π·L·sin²σ.
    let e = std::f32::consts::PI * lum * radius * radius / (radius * radius + height * height);
    assert_close(hdr[(32 * SIZE + 32) as usize][1], floor_radiance(Vec3::Y, e), 0.02, "on the axis");
    // Off the axis against the integral over the disk (polar midpoint samples).
    let (nr, na) = (120, 240);
    let mut samples = Vec::new();
    for i in 0..nr {
        let (r0, r1) = (radius * i as f32 / nr as f32, radius * (i + 1) as f32 / nr as f32);
        let da = std::f32::consts::PI * (r1 * r1 - r0 * r0) / na as f32;
        for j in 0..na {
            let a = (j as f32 + 0.5) / na as f32 * std::f32::consts::TAU;
            let q = center + Vec3::new(a.cos(), 0.0, a.sin()) * (0.5 * (r0 + r1));
            samples.push((q, Vec3::NEG_Y, lum * da));
        }
    }
    for (x, y) in [(12, 20), (50, 45), (2, 2)] {
        let p = pixel_world(x, y, SIZE);
        assert_close(hdr[(y * SIZE + x) as usize][1], integrate(p, &samples), 0.02, &format!("pixel ({x}, {y})"));
    }
}

#[test]
fn sphere_light_lights_like_the_point_light_of_its_intensity() {
    let mut app = scene_app();
    let pixel_world = top_down(&mut app, 1.0);
    let center = Vec3::new(0.2, 0.7, -0.1);
    let intensity = 2.0;
    app.world
        .spawn((SphereLight { intensity, radius: 0.15, ..Default::default() }, Transform::from_translation(center)));
    render_app(&mut app, (SIZE, SIZE), settings());
    let hdr = hdr_of(&app);
    // Wholly above the floor's horizon, a uniform sphere's irradiance is exactly a point's.
    for (x, y) in [(32, 32), (10, 12), (50, 40), (5, 60), (60, 3)] {
        let p = pixel_world(x, y, SIZE);
        let d = center - p;
        let expected = floor_radiance(d.normalize(), intensity / d.length_squared());
        assert_close(hdr[(y * SIZE + x) as usize][1], expected, 0.02, &format!("pixel ({x}, {y})"));
    }
}

#[test]
fn tube_light_irradiance_matches_the_line_integral_also_when_cut_by_the_horizon() {
    for (what, tilt) in [("level", 0.0f32), ("one end below the floor", 30f32.to_radians())] {
        let mut app = scene_app();
        let pixel_world = top_down(&mut app, 1.0);
        let center = Vec3::new(0.0, 0.2, 0.1);
        let (length, intensity) = (1.5f32, 2.0f32);
        let rotation = Quat::from_rotation_z(tilt);
        app.world.spawn((
            TubeLight { intensity, length, radius: 0.005, ..Default::default() },
            Transform::from_translation(center).with_rotation(rotation),
        ));
        render_app(&mut app, (SIZE, SIZE), settings());
        let hdr = hdr_of(&app);
        // A line of isotropic points sharing the intensity.
        let n = 4000;
        let axis = rotation * Vec3::X;
        let samples: Vec<Vec3> =
            (0..n).map(|i| center + axis * (((i as f32 + 0.5) / n as f32 - 0.5) * length)).collect();
        for (x, y) in [(32, 10), (12, 50), (50, 44), (60, 20)] {
            let p = pixel_world(x, y, SIZE);
            let expected = points_radiance(p, &samples, intensity);
            // 2% as for the other lights, 3% with the tube cut by the horizon: there the point of
            // the tube nearest a rough surface's reflected ray can sit on the horizon, which
            // loses most of the specular share (about 2% of the light at these angles; the
            // diffuse part is exact, see the shader).
            let tol = if tilt == 0.0 { 0.02 } else { 0.03 };
            assert_close(hdr[(y * SIZE + x) as usize][1], expected, tol, &format!("{what}, pixel ({x}, {y})"));
        }
    }
}

#[test]
fn every_light_kind_packs_its_own_type_and_lights_the_floor() {
    let above = Transform::from_xyz(0.0, 0.8, 0.0).looking_at(Vec3::ZERO, Vec3::NEG_Z);
    type Spawn = fn(&mut World, Transform);
    let kinds: [(&str, u32, Spawn); 9] = [
        ("directional", KIND_DIRECTIONAL, |w, t| {
            w.spawn((DirectionalLight::default(), t));
        }),
        ("point", KIND_POINT, |w, t| {
            w.spawn((PointLight::default(), t));
        }),
        ("spot", KIND_SPOT, |w, t| {
            w.spawn((SpotLight::default(), t));
        }),
        ("ambient", KIND_AMBIENT, |w, _| {
            w.spawn(AmbientLight::default());
        }),
        ("sphere", KIND_SPHERE, |w, t| {
            w.spawn((SphereLight::default(), t));
        }),
        ("tube", KIND_TUBE, |w, t| {
            w.spawn((TubeLight::default(), t));
        }),
        ("rect", KIND_RECT, |w, t| {
            w.spawn((RectLight::default(), t));
        }),
        ("disk", KIND_DISK, |w, t| {
            w.spawn((DiskLight::default(), t));
        }),
        ("ies", KIND_IES, |w, t| {
            let text = "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 0\n0 45 90\n0\n2 1 0\n";
            let profile = w.resource_mut::<Assets<IesProfile>>().add(IesProfile::parse(text, "t.ies").unwrap());
            w.spawn((IesLight::new(profile), t));
        }),
    ];
    let mut seen = std::collections::HashSet::new();
    for (name, kind, spawn) in kinds {
        let mut app = scene_app();
        let _pixel_world = top_down(&mut app, 1.0);
        spawn(&mut app.world, above);
        render_app(&mut app, (16, 16), settings());
        let renderer = app.world.resource::<Renderer>();
        let packed = renderer.light_store().packed();
        assert_eq!(packed.iter().map(|l| l.kind).collect::<Vec<_>>(), vec![kind], "{name}");
        assert!(seen.insert(kind), "{name} shares type {kind}");
        let hdr = hdr_of(&app);
        let lit = hdr.iter().filter(|p| p[1] > 0.0).count();
        assert!(lit >= 16, "{name}: only {lit} of 256 pixels lit");
        // Shading code for lights with a size is compiled only when the scene has them.
        let shapes = renderer.light_store().shapes();
        assert_eq!(shapes.sphere_tube, matches!(kind, KIND_SPHERE | KIND_TUBE), "{name}");
        assert_eq!(shapes.ltc, matches!(kind, KIND_RECT | KIND_DISK), "{name}");
        assert_eq!(shapes.ies, kind == KIND_IES, "{name}");
        assert!(renderer.forward_pipeline_keys().iter().all(|k| k.light_shapes == shapes), "{name}");
    }
}

/// A tube lying in the floor (its axis in the floor's plane, half of it below) lights the floor
/// beside it as the same tube resting on the floor does: the floor sees the capsule's upper
/// half, not its axis. Away from the tube both match the line integral of isotropic points
/// along the top of the capsule; nothing is dark or speckled where rounding puts the axis a
/// hair above or below the horizon.
#[test]
fn a_tube_lying_in_the_floor_lights_it_like_one_resting_on_it() {
    let (length, radius, intensity) = (1.2f32, 0.02f32, 2.0f32);
    let rotation = Quat::from_rotation_y(0.3);
    let axis = rotation * Vec3::X;
    // Off the pixel grid's symmetry, so that pixels land at uneven distances.
    let center = Vec3::new(0.013, 0.0, 0.0071);
    let mut images = Vec::new();
    let mut pixel_world = None;
    for height in [0.0, radius] {
        let mut app = scene_app();
        pixel_world = Some(top_down(&mut app, 1.0));
        app.world.spawn((
            TubeLight { intensity, length, radius, ..Default::default() },
            Transform::from_translation(center + Vec3::Y * height).with_rotation(rotation),
        ));
        render_app(&mut app, (SIZE, SIZE), settings());
        let hdr = hdr_of(&app);
        common::assert_finite_hdr(&hdr, "tube on the floor");
        images.push(hdr);
    }
    let pixel_world = pixel_world.expect("rendered");
    let n = 2000;
    let top: Vec<Vec3> =
        (0..n).map(|i| center + Vec3::Y * radius + axis * (((i as f32 + 0.5) / n as f32 - 0.5) * length)).collect();
    let mut checked = 0;
    for y in 0..SIZE {
        for x in 0..SIZE {
            let p = pixel_world(x, y, SIZE);
            let along = (p - center).dot(axis);
            let off = ((p - center) - axis * along).length();
            if along.abs() > 0.45 || !(0.04..=0.6).contains(&off) {
                continue;
            }
            let (in_floor, resting) = (images[0][(y * SIZE + x) as usize][1], images[1][(y * SIZE + x) as usize][1]);
            assert!(in_floor > 0.0, "pixel ({x}, {y}) {off:.3} m from the tube is dark");
            assert_close(in_floor, resting, 0.01, &format!("in the floor vs resting, pixel ({x}, {y})"));
            if off > 0.1 {
                let expected = points_radiance(p, &top, intensity);
                assert_close(resting, expected, 0.03, &format!("resting, pixel ({x}, {y}), {off:.2} m off"));
                checked += 1;
            }
        }
    }
    assert!(checked > 300, "{checked} pixels checked");
}
