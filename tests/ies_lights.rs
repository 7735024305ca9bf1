//! IES-profiled lights: a profile written by the test, with a different intensity in every
//! plane, hangs over a white, fully rough floor seen from straight above. The floor's radiance,
//! read back from the HDR target, must follow the profile's candela in each direction (which
//! also pins its orientation: nadir along the light's −Z, C = 0° along its +X, C = 90° along
//! its +Y); a light whose profile is removed goes dark without failing.

use penumbra::prelude::*;
use penumbra::render::{RenderSettings, Renderer};

mod common;
use common::{add_ies_profile, floor_radiance, hdr_of, render_app, scene_app, top_down};

const SIZE: u32 = 64;

fn settings() -> RenderSettings {
    // The tests read HDR colour.
    RenderSettings { msaa: 1, keep_hdr: true, ..Default::default() }
}

/// Vertical angles 0–90° by 15°, planes at 0, 90, 180, 270 and 360°: a different brightness in
/// each plane, falling off toward the horizon.
fn asymmetric_profile(app: &mut App) -> Handle<IesProfile> {
    let vertical: Vec<f32> = (0..=6).map(|i| i as f32 * 15.0).collect();
    let horizontal = [0.0, 90.0, 180.0, 270.0, 360.0];
    let planes = [1000.0, 250.0, 500.0, 100.0, 1000.0];
    let falloff = [1.0, 0.9, 0.8, 0.6, 0.4, 0.2, 0.0];
    let candela: Vec<f32> = planes.iter().flat_map(|p| falloff.iter().map(move |f| p * f)).collect();
    add_ies_profile(app, &vertical, &horizontal, &candela)
}

/// Pointing straight down, local +X along world +X (so local +Y is world −Z).
fn hanging(height: f32) -> Transform {
    Transform::from_xyz(0.0, height, 0.0).with_rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2))
}

#[test]
fn the_floor_follows_the_profile_in_every_direction() {
    let mut app = scene_app();
    let pixel_world = top_down(&mut app, 1.0);
    let profile = asymmetric_profile(&mut app);
    let height = 0.5;
    let scale = 0.01;
    app.world.spawn((IesLight { scale, ..IesLight::new(profile) }, hanging(height)));
    render_app(&mut app, (SIZE, SIZE), settings());
    let hdr = hdr_of(&app);
    let ies = app.world.resource::<Assets<IesProfile>>().get(profile).unwrap().clone();
    let light = Vec3::Y * height;
    let (mut checked, mut brightest_plane) = (0, [0.0f32; 4]);
    for y in (2..SIZE).step_by(5) {
        for x in (2..SIZE).step_by(5) {
            let p = pixel_world(x, y, SIZE);
            let d = p - light;
            let dist2 = d.length_squared();
            let dir = d / dist2.sqrt();
            let gamma = dir.dot(Vec3::NEG_Y).clamp(-1.0, 1.0).acos().to_degrees();
            // C = 0° along +X, C = 90° along the light's +Y, world −Z.
            let c = dir.dot(Vec3::NEG_Z).atan2(dir.x).to_degrees();
            if gamma > 80.0 {
                continue;
            }
            let candela = scale * ies.candela_at(gamma, c);
            let want = floor_radiance(-dir, candela / dist2);
            let got = hdr[(y * SIZE + x) as usize][1];
            assert!(
                (got - want).abs() <= 0.02 * want + 1e-4,
                "pixel ({x}, {y}), γ {gamma:.1}° C {c:.1}°: radiance {got}, the profile gives {want}"
            );
            checked += 1;
            let plane = ((c.rem_euclid(360.0) + 45.0) / 90.0) as usize % 4;
            brightest_plane[plane] = brightest_plane[plane].max(got);
        }
    }
    assert!(checked > 100, "{checked} pixels checked");
    // The orientation, plainly: brightest toward +X (C = 0), then C = 180, 90 (toward −Z, the
    // top of the image), 270.
    let [c0, c90, c180, c270] = brightest_plane;
    assert!(c0 > c180 && c180 > c90 && c90 > c270, "per-plane peaks {brightest_plane:?}");
}

#[test]
fn a_light_whose_profile_is_removed_goes_dark() {
    let mut app = scene_app();
    let _ = top_down(&mut app, 1.0);
    let profile = asymmetric_profile(&mut app);
    app.world.spawn((IesLight { scale: 0.01, ..IesLight::new(profile) }, hanging(0.5)));
    render_app(&mut app, (16, 16), settings());
    assert!(hdr_of(&app).iter().any(|p| p[1] > 0.01), "lit while the profile is there");
    app.world.resource_mut::<Assets<IesProfile>>().remove(profile).unwrap();
    render_app(&mut app, (16, 16), settings());
    let hdr = hdr_of(&app);
    assert!(hdr.iter().all(|p| p[1] == 0.0), "dark once its profile is gone");
    // The shading code stays while an IES light exists; the light itself is not binned.
    let store = app.world.resource::<Renderer>().light_store();
    assert!(store.shapes().ies);
    assert_eq!(store.local_lights()[0].range, 0.0);
}
