//! White furnace: a white sphere (albedo 1) under uniform unit ambient light must reflect exactly
//! the light it receives, whatever its roughness or metalness; measured in the HDR target before
//! tonemapping, it reads 1.0 ± 2 %. A renderer that loses or invents energy fails here.

use penumbra::prelude::*;
use penumbra::render::{RenderOutput, RenderPlugin, RenderSettings, Renderer};

mod common;
use common::gpu;

const SIZE: u32 = 64;

/// Renders one sphere filling most of the frame and returns the HDR pixels inside 85 % of its
/// projected radius.
fn furnace(metallic: f32, roughness: f32) -> Vec<[f32; 4]> {
    furnace_of(|_| StandardMaterial { base_color: Vec4::ONE, metallic, roughness, ..Default::default() })
}

/// `furnace` with the sphere's material made by `material` (which may add images).
fn furnace_of(material: impl FnOnce(&mut Assets<Image>) -> StandardMaterial) -> Vec<[f32; 4]> {
    lit_sphere(material, |world| {
        world.spawn(AmbientLight { color: Vec3::ONE, intensity: 1.0 });
    })
}

/// `furnace_of` with the light `light` spawns instead of the ambient light.
fn lit_sphere(
    material: impl FnOnce(&mut Assets<Image>) -> StandardMaterial,
    light: impl FnOnce(&mut World),
) -> Vec<[f32; 4]> {
    let mut app = App::new();
    app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::uv_sphere(1.0, 64, 32));
    let material = material(&mut app.world.resource_mut::<Assets<Image>>());
    let material = app.world.resource_mut::<Assets<StandardMaterial>>().add(material);
    app.world.spawn((Mesh3d(mesh), MeshMaterial3d(material)));
    light(&mut app.world);
    // The sphere subtends 2·asin(1/3) ≈ 39° of the 45° field of view.
    app.world.spawn((
        Camera { exposure: Exposure::unit(), ..Default::default() },
        Transform::from_xyz(0.0, 0.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    let settings = RenderSettings { msaa: 1, keep_hdr: true, ..Default::default() };
    app.insert_resource(Renderer::new(gpu(), settings).unwrap());
    app.insert_resource(RenderOutput::Headless { width: SIZE, height: SIZE });
    app.update();
    assert_eq!(app.world.resource::<Renderer>().shader_error(), None);
    let hdr = app.world.resource::<Renderer>().read_hdr().unwrap();
    let disc = (1.0f32 / 3.0).asin().tan() / 22.5f32.to_radians().tan() * SIZE as f32 / 2.0;
    let c = SIZE as f32 / 2.0;
    hdr.iter()
        .enumerate()
        .filter(|(i, _)| {
            let (x, y) = ((i % SIZE as usize) as f32 + 0.5, (i / SIZE as usize) as f32 + 0.5);
            ((x - c).powi(2) + (y - c).powi(2)).sqrt() < 0.85 * disc
        })
        .map(|(_, p)| *p)
        .collect()
}

fn assert_furnace(metallic: f32, roughness: f32) {
    assert_reflects_all(&furnace(metallic, roughness), format_args!("metallic {metallic} roughness {roughness}"));
}

/// Every pixel of a furnace sphere reads the unit ambient light it receives, 1.0 ± 2 %.
fn assert_reflects_all(px: &[[f32; 4]], what: std::fmt::Arguments) {
    assert!(px.len() > 500, "{what}: too few pixels inside the sphere: {}", px.len());
    for p in px {
        for c in &p[..3] {
            assert!(c.is_finite() && (c - 1.0).abs() <= 0.02, "{what}: pixel {p:?}");
        }
    }
}

#[test]
fn rough_dielectric_reflects_all_ambient_light() {
    assert_furnace(0.0, 1.0);
}

#[test]
fn smooth_dielectric_reflects_all_ambient_light() {
    assert_furnace(0.0, 0.0);
}

#[test]
fn rough_metal_reflects_all_ambient_light() {
    assert_furnace(1.0, 1.0);
}

#[test]
fn smooth_metal_reflects_all_ambient_light() {
    assert_furnace(1.0, 0.0);
}

#[test]
fn half_rough_half_metal_reflects_all_ambient_light() {
    assert_furnace(0.5, 0.5);
}

/// KHR_materials_ior and KHR_materials_specular move energy between the dielectric's specular
/// and diffuse lobes and never create or lose it: a white dielectric reflects all ambient light
/// whatever its IOR, specular strength or specular colour.
#[test]
fn white_dielectrics_of_any_ior_and_specular_reflect_all_ambient_light() {
    for (ior, specular, color) in [
        (1.0, 1.0, Vec3::ONE),
        (1.33, 1.0, Vec3::ONE),
        (2.5, 0.5, Vec3::ONE),
        (0.0, 1.0, Vec3::new(1.0, 0.2, 0.0)),
        (1.5, 0.0, Vec3::ONE),
        (1.5, 1.0, Vec3::splat(30.0)),
    ] {
        let px = furnace_of(|_| StandardMaterial {
            base_color: Vec4::ONE,
            metallic: 0.0,
            roughness: 0.5,
            ior,
            specular,
            specular_color: color,
            ..Default::default()
        });
        assert_reflects_all(&px, format_args!("ior {ior} specular {specular} {color}"));
    }
}

/// A point, a directional and a rectangle light, each lighting the sphere from the front
/// right: the kinds whose shading paths differ (punctual, and the LTC integral).
const THREE_LIGHTS: [(&str, fn(&mut World)); 3] = [
    ("point", |w| {
        w.spawn((PointLight { intensity: 20.0, ..Default::default() }, Transform::from_xyz(1.5, 1.0, 2.5)));
    }),
    ("directional", |w| {
        w.spawn((
            DirectionalLight { illuminance: 2.0, ..Default::default() },
            Transform::from_xyz(1.0, 1.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
        ));
    }),
    ("rectangle", |w| {
        w.spawn((
            RectLight { luminance: 2.0, width: 1.5, height: 1.0, ..Default::default() },
            Transform::from_xyz(1.0, 1.5, 2.5).looking_at(Vec3::ZERO, Vec3::Y),
        ));
    }),
];

fn mean(px: &[[f32; 4]]) -> Vec3 {
    px.iter().fold(Vec3::ZERO, |a, p| a + Vec3::new(p[0], p[1], p[2])) / px.len() as f32
}

/// A black dielectric shows only its specular lobe: none at specular strength 0, only Schlick's
/// grazing edge at IOR 1 (glTF keeps F90 = 1 whatever the IOR), more as the IOR rises, coloured
/// by the specular colour; with the textures' defaults (white) the extension's shading equals
/// glTF's core dielectric.
#[test]
fn a_black_dielectric_reflects_what_its_ior_and_specular_say() {
    let black = |ior: f32, specular: f32, color: Vec3| {
        mean(&furnace_of(|_| StandardMaterial {
            base_color: Vec4::new(0.0, 0.0, 0.0, 1.0),
            metallic: 0.0,
            roughness: 0.5,
            ior,
            specular,
            specular_color: color,
            ..Default::default()
        }))
    };
    let core = black(1.5, 1.0, Vec3::ONE);
    assert!(core.min_element() > 0.02 && core.max_element() < 0.2, "{core}");
    let air = black(1.0, 1.0, Vec3::ONE);
    assert!(air.min_element() > 0.0 && air.max_element() < 0.5 * core.min_element(), "IOR 1: {air}, 1.5: {core}");
    assert!(black(1.5, 0.0, Vec3::ONE).max_element() < 1e-4, "specular 0 reflects nothing");
    let (glass, diamond) = (black(1.45, 1.0, Vec3::ONE), black(2.42, 1.0, Vec3::ONE));
    assert!(glass.x < core.x && core.x < diamond.x, "{glass} {core} {diamond}");
    let red = black(0.0, 1.0, Vec3::new(1.0, 0.0, 0.0));
    assert!(red.x > 0.5 && red.y < 0.05 && red.z < 0.05, "IOR 0 takes its F0 from the colour: {red}");
    // White specular textures leave the factors as they are: the extension's shader variant
    // must then give the core dielectric's light.
    let textured = mean(&furnace_of(|images| {
        let white = TextureRef::new(images.add(Image::solid([255; 4], "white")));
        StandardMaterial {
            base_color: Vec4::new(0.0, 0.0, 0.0, 1.0),
            metallic: 0.0,
            roughness: 0.5,
            specular_texture: Some(white),
            specular_color_texture: Some(white),
            ..Default::default()
        }
    }));
    assert!((textured - core).abs().max_element() < 1e-4 * core.max_element().max(1e-3), "{textured} against {core}");
}

/// KHR_materials_clearcoat moves light between the coat and the material beneath it and never
/// creates or loses it: a white material under any coat reflects all ambient light.
#[test]
fn white_materials_under_a_clear_coat_reflect_all_ambient_light() {
    for (metallic, roughness, coat, coat_roughness) in
        [(0.0, 0.5, 1.0, 0.0), (1.0, 0.2, 1.0, 0.5), (0.0, 1.0, 0.5, 1.0), (0.5, 0.5, 1.0, 0.1)]
    {
        let px = furnace_of(|_| StandardMaterial {
            base_color: Vec4::ONE,
            metallic,
            roughness,
            clearcoat: coat,
            clearcoat_roughness: coat_roughness,
            ..Default::default()
        });
        assert_reflects_all(
            &px,
            format_args!("metallic {metallic} roughness {roughness} coat {coat} ({coat_roughness})"),
        );
    }
}

/// Over a black material the coat alone shows: a dielectric's reflection at full strength,
/// half of it at half strength, none at 0.
#[test]
fn a_coat_over_black_reflects_like_a_dielectric_by_its_strength() {
    let coated = |coat: f32| {
        mean(&furnace_of(|_| StandardMaterial {
            base_color: Vec4::new(0.0, 0.0, 0.0, 1.0),
            metallic: 0.0,
            roughness: 1.0,
            specular: 0.0,
            clearcoat: coat,
            clearcoat_roughness: 0.5,
            ..Default::default()
        }))
    };
    let dielectric = mean(&furnace_of(|_| StandardMaterial {
        base_color: Vec4::new(0.0, 0.0, 0.0, 1.0),
        metallic: 0.0,
        roughness: 0.5,
        ..Default::default()
    }));
    let (full, half) = (coated(1.0), coated(0.5));
    assert!((full - dielectric).abs().max_element() < 0.02 * dielectric.max_element(), "{full} against {dielectric}");
    assert!((half * 2.0 - full).abs().max_element() < 0.02 * full.max_element(), "{half} x 2 against {full}");
    assert!(coated(0.0).max_element() < 1e-4);
}

/// The coat's lobe is a dielectric's (F0 0.04) of the coat's roughness, under every kind of
/// light: a full coat over a black material with no specular lobe of its own reflects a point
/// light, a directional light and a rectangle light as a black dielectric of the coat's
/// roughness does.
#[test]
fn a_coat_reflects_lights_as_a_dielectric_of_its_roughness() {
    let lights = THREE_LIGHTS;
    let black = Vec4::new(0.0, 0.0, 0.0, 1.0);
    for (name, light) in lights {
        let coated = mean(&lit_sphere(
            |_| StandardMaterial {
                base_color: black,
                metallic: 0.0,
                roughness: 1.0,
                specular: 0.0,
                clearcoat: 1.0,
                clearcoat_roughness: 0.3,
                ..Default::default()
            },
            light,
        ));
        let dielectric = mean(&lit_sphere(
            |_| StandardMaterial { base_color: black, metallic: 0.0, roughness: 0.3, ..Default::default() },
            light,
        ));
        assert!(dielectric.max_element() > 1e-4, "{name}: the dielectric is lit: {dielectric}");
        assert!(
            (coated - dielectric).abs().max_element() < 0.03 * dielectric.max_element(),
            "{name}: coat {coated} against dielectric {dielectric}"
        );
    }
}

/// KHR_materials_sheen's albedo scaling: the material beneath keeps what the sheen does not
/// reflect, so a white material under a white sheen of any roughness reflects all ambient light.
#[test]
fn white_materials_under_a_white_sheen_reflect_all_ambient_light() {
    for (metallic, roughness, sheen_roughness) in [(0.0, 0.5, 0.0), (0.0, 1.0, 0.3), (1.0, 0.3, 0.7), (0.5, 0.8, 1.0)] {
        let px = furnace_of(|_| StandardMaterial {
            base_color: Vec4::ONE,
            metallic,
            roughness,
            sheen_color: Vec3::ONE,
            sheen_roughness,
            ..Default::default()
        });
        assert_reflects_all(
            &px,
            format_args!("metallic {metallic} roughness {roughness} sheen roughness {sheen_roughness}"),
        );
    }
}

/// Over a black material the sheen alone shows, in proportion to its colour, more as its
/// fibres lean (rougher), and not at all when black.
#[test]
fn a_sheen_over_black_reflects_in_proportion_to_its_colour() {
    let sheen = |color: Vec3, sheen_roughness: f32| {
        mean(&furnace_of(|_| StandardMaterial {
            base_color: Vec4::new(0.0, 0.0, 0.0, 1.0),
            metallic: 0.0,
            roughness: 1.0,
            specular: 0.0,
            sheen_color: color,
            sheen_roughness,
            ..Default::default()
        }))
    };
    let white = sheen(Vec3::ONE, 0.5);
    assert!(white.min_element() > 0.05, "a white sheen reflects: {white}");
    let tinted = sheen(Vec3::new(1.0, 0.5, 0.0), 0.5);
    let expected = white * Vec3::new(1.0, 0.5, 0.0);
    assert!((tinted - expected).abs().max_element() < 0.01 * white.max_element(), "{tinted} against {expected}");
    assert!(sheen(Vec3::ONE, 1.0).x > sheen(Vec3::ONE, 0.2).x, "rougher fibres reflect more");
    assert!(sheen(Vec3::ZERO, 0.5).max_element() < 1e-4);
}

/// The sheen reflects every kind of light, and lights a black material nowhere beyond where the
/// light reaches: a point, a directional and a rectangle light each light a black sphere under a
/// white sheen, and a white sheen over white never returns more than the material alone plus
/// the sheen's own reflection.
#[test]
fn a_sheen_reflects_every_kind_of_light() {
    let lights = THREE_LIGHTS;
    let black = Vec4::new(0.0, 0.0, 0.0, 1.0);
    for (name, light) in lights {
        let material = |base: Vec4, sheen: Vec3| StandardMaterial {
            base_color: base,
            metallic: 0.0,
            roughness: 1.0,
            specular: 0.0,
            sheen_color: sheen,
            sheen_roughness: 0.5,
            ..Default::default()
        };
        let sheen_only = mean(&lit_sphere(|_| material(black, Vec3::ONE), light));
        let base_only = mean(&lit_sphere(|_| material(Vec4::ONE, Vec3::ZERO), light));
        let both = mean(&lit_sphere(|_| material(Vec4::ONE, Vec3::ONE), light));
        assert!(sheen_only.min_element() > 1e-3, "{name}: the sheen reflects: {sheen_only}");
        assert!(
            both.max_element() < base_only.max_element() + sheen_only.max_element(),
            "{name}: the material beneath keeps less under a sheen: {both} against {base_only} + {sheen_only}"
        );
        assert!(both.max_element() > base_only.max_element() * 0.5, "{name}: {both} against {base_only}");
    }
}

/// KHR_materials_anisotropy moves the specular lobe's energy around and never creates or loses
/// it: an anisotropic white metal or dielectric reflects all ambient light.
#[test]
fn white_anisotropic_materials_reflect_all_ambient_light() {
    for (metallic, roughness, strength) in [(1.0, 0.3, 1.0), (0.0, 0.5, 0.6), (1.0, 0.8, 0.3)] {
        let px = furnace_of(|_| StandardMaterial {
            base_color: Vec4::ONE,
            metallic,
            roughness,
            anisotropy_strength: strength,
            ..Default::default()
        });
        assert_reflects_all(&px, format_args!("metallic {metallic} roughness {roughness} anisotropy {strength}"));
    }
}

/// An anisotropic lobe stretches a point light's highlight along the anisotropy's direction: a
/// smooth metal sphere's highlight covers more pixels, the stronger the anisotropy.
#[test]
fn anisotropy_stretches_a_highlight() {
    let highlight = |strength: f32| {
        let px = lit_sphere(
            |_| StandardMaterial {
                base_color: Vec4::ONE,
                metallic: 1.0,
                roughness: 0.2,
                anisotropy_strength: strength,
                ..Default::default()
            },
            |w| {
                w.spawn((PointLight { intensity: 50.0, ..Default::default() }, Transform::from_xyz(0.5, 0.5, 3.0)));
            },
        );
        let peak = px.iter().map(|p| p[0]).fold(0.0, f32::max);
        (px.iter().filter(|p| p[0] > 0.25 * peak).count(), peak)
    };
    let (round, round_peak) = highlight(0.0);
    let (stretched, stretched_peak) = highlight(1.0);
    assert!(round > 0 && round_peak > 0.0);
    assert!(
        stretched as f32 > 2.0 * round as f32,
        "stretched {stretched} pixels (peak {stretched_peak}) against round {round} (peak {round_peak})"
    );
}

/// KHR_materials_iridescence replaces the dielectric's Fresnel and its diffuse base keeps what
/// the film's reflection leaves, so a white dielectric under any film reflects all ambient
/// light; the film's colour changes with its thickness.
#[test]
fn a_thin_film_moves_colour_around_and_keeps_energy() {
    let film = |base: Vec4, thickness: f32| {
        furnace_of(|_| StandardMaterial {
            base_color: base,
            metallic: 0.0,
            roughness: 0.3,
            iridescence: 1.0,
            iridescence_thickness_max: thickness,
            ..Default::default()
        })
    };
    for thickness in [100.0, 300.0, 700.0] {
        assert_reflects_all(&film(Vec4::ONE, thickness), format_args!("thickness {thickness}"));
    }
    let black = Vec4::new(0.0, 0.0, 0.0, 1.0);
    let (thin, thick) = (mean(&film(black, 250.0)), mean(&film(black, 450.0)));
    let hue = |c: Vec3| c / c.max_element().max(1e-6);
    assert!(thin.max_element() > 0.01 && thick.max_element() > 0.01, "{thin} {thick}");
    assert!(
        (hue(thin) - hue(thick)).abs().max_element() > 0.1,
        "the film's colour follows its thickness: {thin} against {thick}"
    );
}
