//! Tests of `light_store`.

use super::*;
use bevy_ecs::entity::Entity;

fn light(kind: LightKind) -> ExtractedLight {
    ExtractedLight {
        kind,
        color: Vec3::ONE,
        position: Vec3::ZERO,
        direction: Vec3::NEG_Z,
        right: Vec3::X,
        range: None,
        shadows: false,
    }
}

fn test_profile() -> penumbra_engine::ies::IesProfile {
    let text = "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 0\n0 45 90\n0\n400 200 0\n";
    penumbra_engine::ies::IesProfile::parse(text, "test.ies").expect("valid")
}

#[test]
fn every_light_kind_packs_its_own_discriminant() {
    let kinds = [
        (LightKind::Directional { angular_radius: 0.0 }, KIND_DIRECTIONAL),
        (LightKind::Point, KIND_POINT),
        (LightKind::Spot { inner_cone_angle: 0.1, outer_cone_angle: 0.5 }, KIND_SPOT),
        (LightKind::Ambient, KIND_AMBIENT),
        (LightKind::Sphere { radius: 0.1 }, KIND_SPHERE),
        (LightKind::Tube { length: 1.0, radius: 0.1 }, KIND_TUBE),
        (LightKind::Rect { width: 1.0, height: 0.5 }, KIND_RECT),
        (LightKind::Disk { radius: 0.3 }, KIND_DISK),
        (LightKind::Ies { profile: penumbra_engine::Assets::new().add(test_profile()) }, KIND_IES),
    ];
    let mut seen = std::collections::HashSet::new();
    for (k, want) in kinds {
        assert_eq!(pack(&light(k), 1.0, DEFAULT_CUTOFF, &ProfileTable::default()).kind, want, "{k:?}");
        assert!(seen.insert(want), "{k:?} shares a discriminant");
    }
    assert_eq!(seen.len(), KIND_COUNT);
    assert_eq!(std::mem::size_of::<GpuLight>(), 64);
}

#[test]
fn gpu_light_mirrors_the_shaders_light() {
    crate::pipelines::shader_library::assert_mirrors_wgsl!(
        GpuLight,
        "forward.wgsl",
        [],
        "Light",
        [position, kind, direction, range, color, size, shape]
    );
}

#[test]
fn the_uniform_array_of_global_lights_has_the_length_the_binding_gives_it() {
    use crate::pipelines::shader_library::{ShaderDefs, ShaderLibrary};
    let module = ShaderLibrary::embedded().unwrap().compose("forward.wgsl", &ShaderDefs::default()).unwrap();
    let (_, global) = module.global_variables.iter().find(|(_, v)| v.name.as_deref() == Some("global_lights")).unwrap();
    let size = match module.types[global.ty].inner {
        naga::TypeInner::Array { size: naga::ArraySize::Constant(n), stride, .. } => (n.get(), stride),
        ref other => panic!("global_lights is {other:?}"),
    };
    assert_eq!(size, (UNIFORM_GLOBAL_LIGHTS, std::mem::size_of::<GpuLight>() as u32));
    // The variant that walks the storage array binds no uniform array.
    let storage = ShaderDefs::default().with("GLOBAL_LIGHTS_IN_STORAGE", true);
    let module = ShaderLibrary::embedded().unwrap().compose("forward.wgsl", &storage).unwrap();
    assert!(module.global_variables.iter().all(|(_, v)| v.name.as_deref() != Some("global_lights")));
}

#[test]
fn ies_lights_find_their_profile_and_are_repacked_when_it_moves() {
    let mut assets = penumbra_engine::Assets::new();
    let a = assets.add(test_profile());
    let e = |i: u32| Entity::from_raw_u32(i).expect("valid index");
    let mut ies = light(LightKind::Ies { profile: a });
    ies.color = Vec3::splat(0.5);
    ies.range = Some(2.0);
    let mut scene = scene_with(&[(LightKey::Ies(e(1)), ies)]);
    let mut store = LightStore::new();
    // The profile is not extracted yet: the light packs dark and is not binned.
    store.sync(&scene, true, 1.0, DEFAULT_CUTOFF);
    assert_eq!((store.local_lights()[0].range, store.local_lights()[0].color), (0.0, [0.0; 3]));
    let snapshot = |v: u64| crate::scene::world::Snapshot { version: v, data: std::sync::Arc::new(test_profile()) };
    scene.ies_profiles.insert(a, snapshot(1));
    scene.changed_lights.clear();
    store.sync(&scene, true, 1.0, DEFAULT_CUTOFF);
    let g = store.local_lights()[0];
    assert_eq!((g.kind, g.range, g.color), (KIND_IES, 2.0, [200.0; 3]), "peak 400 cd × 0.5");
    let slot = store.profiles.slot(a).expect("in the table");
    assert_eq!((g.size, g.shape[3]), (slot.offset as f32, (slot.rows * 4096 + slot.columns) as f32));
    assert_eq!((slot.rows, slot.columns), (5, 1), "45° steps, one plane");
    // A second profile rebuilds the table; each light finds its own.
    let b = assets.add(test_profile());
    scene.ies_profiles.insert(b, snapshot(2));
    let mut other = ies;
    other.kind = LightKind::Ies { profile: b };
    scene.lights.insert(LightKey::Ies(e(2)), other);
    scene.changed_lights = vec![LightKey::Ies(e(2))];
    store.sync(&scene, true, 1.0, DEFAULT_CUTOFF);
    for (g, h) in store.local_lights().iter().zip([a, b]) {
        assert_eq!(g.size, store.profiles.slot(h).expect("in the table").offset as f32);
    }
    assert_ne!(store.profiles.slot(a), store.profiles.slot(b));
    // Removing the lights releases the profiles.
    scene.changed_lights.clear();
    for k in [LightKey::Ies(e(1)), LightKey::Ies(e(2))] {
        scene.lights.remove(&k);
        scene.removed_lights.push(k);
    }
    store.sync(&scene, true, 1.0, DEFAULT_CUTOFF);
    assert!(store.profiles.slot(a).is_none() && store.profiles.slot(b).is_none());
    assert!(!store.shapes().ies);
}

#[test]
fn spot_falloff_is_one_inside_and_zero_outside() {
    let g = pack(
        &light(LightKind::Spot { inner_cone_angle: 0.2, outer_cone_angle: 0.4 }),
        1.0,
        DEFAULT_CUTOFF,
        &ProfileTable::default(),
    );
    let at = |angle: f32| (angle.cos() * g.size + g.shape[0]).clamp(0.0, 1.0);
    assert!((at(0.1) - 1.0).abs() < 1e-5);
    assert!(at(0.41) == 0.0);
    let g = pack(
        &light(LightKind::Spot { inner_cone_angle: 0.4, outer_cone_angle: 0.4 }),
        1.0,
        DEFAULT_CUTOFF,
        &ProfileTable::default(),
    );
    assert!(g.size.is_finite());
}

#[test]
fn computed_range_is_where_the_light_falls_to_the_cutoff() {
    let mut l = light(LightKind::Point);
    l.color = Vec3::new(100.0, 50.0, 10.0);
    let r = influence_range(&l, 0.5, 0.001);
    // A white surface facing the light at distance r: k·I/(π r²) = cutoff.
    let luminance = 0.5 * 100.0 / (std::f32::consts::PI * r * r);
    assert!((luminance - 0.001).abs() < 1e-6, "{luminance}");
    l.range = Some(3.0);
    assert_eq!(influence_range(&l, 0.5, 0.001), 3.0);
    l.color = Vec3::ZERO;
    assert_eq!(influence_range(&l, 0.5, 0.001), 0.0, "a dark light has no influence");
    l.range = None;
    l.color = Vec3::splat(f32::MAX);
    assert!(influence_range(&l, 1e30, 1e-30).is_finite());
}

#[test]
fn area_lights_are_bounded_by_their_reach_plus_their_extent() {
    let mut rect = light(LightKind::Rect { width: 2.0, height: 1.0 });
    rect.range = Some(3.0);
    // A sheared transform's axes: the packed width axis is made perpendicular to the normal.
    rect.right = Vec3::new(1.0, 0.0, 0.5);
    let g = pack(&rect, 1.0, DEFAULT_CUTOFF, &ProfileTable::default());
    assert!((g.range - (3.0 + 0.5 * 5f32.sqrt())).abs() < 1e-5, "{}", g.range);
    // The width axis scaled by the half height; shape.w is left for the shadow layer.
    let axis = Vec3::new(g.shape[0], g.shape[1], g.shape[2]);
    assert!(axis.dot(Vec3::from(g.direction)).abs() < 1e-6 && (axis.length() - 0.5).abs() < 1e-6);
    assert_eq!((g.size, g.shape[3]), (1.0, 0.0));
    // Computed reach: a rect of luminance L and area A reaches as far as a point light of
    // intensity L·A.
    let mut point = light(LightKind::Point);
    point.color = Vec3::splat(2.0);
    rect.range = None;
    assert!((influence_range(&rect, 1.0, 1e-3) - influence_range(&point, 1.0, 1e-3)).abs() < 1e-3);
    let tube =
        pack(&light(LightKind::Tube { length: 4.0, radius: 0.1 }), 1.0, DEFAULT_CUTOFF, &ProfileTable::default());
    let sphere = pack(&light(LightKind::Sphere { radius: 0.1 }), 1.0, DEFAULT_CUTOFF, &ProfileTable::default());
    assert!((tube.range - sphere.range - 2.0).abs() < 1e-4);
    // No area, no light: not binned.
    assert_eq!(
        pack(&light(LightKind::Rect { width: 0.0, height: 1.0 }), 1.0, DEFAULT_CUTOFF, &ProfileTable::default()).range,
        0.0
    );
    assert_eq!(
        pack(&light(LightKind::Disk { radius: -1.0 }), 1.0, DEFAULT_CUTOFF, &ProfileTable::default()).range,
        0.0
    );
}

fn scene_with(lights: &[(LightKey, ExtractedLight)]) -> RenderScene {
    let mut scene = RenderScene::default();
    for (k, l) in lights {
        scene.lights.insert(*k, *l);
        scene.changed_lights.push(*k);
    }
    scene
}

#[test]
fn sections_stay_dense_and_keyed_through_removals() {
    let e = |i: u32| Entity::from_raw_u32(i).expect("valid index");
    let mut store = LightStore::new();
    let mut lights = Vec::new();
    for i in 0..5 {
        let mut l = light(LightKind::Point);
        l.position = Vec3::splat(i as f32);
        lights.push((LightKey::Point(e(i)), l));
    }
    lights.push((LightKey::Directional(e(9)), light(LightKind::Directional { angular_radius: 0.0 })));
    let scene = scene_with(&lights);
    store.sync(&scene, true, 1.0, DEFAULT_CUTOFF);
    assert_eq!((store.global_count(), store.local_count()), (1, 5));
    let mut scene = RenderScene { lights: scene.lights, ..Default::default() };
    scene.lights.remove(&LightKey::Point(e(1)));
    scene.removed_lights.push(LightKey::Point(e(1)));
    store.sync(&scene, true, 1.0, DEFAULT_CUTOFF);
    assert_eq!(store.local_count(), 4);
    // The last light moved into the hole; every key still finds its own light.
    for (key, &(w, i)) in &store.index {
        let s = if w == Which::Global { &store.global } else { &store.local };
        assert_eq!(s.keys[i as usize], *key);
        assert_eq!(s.extracted[i as usize], scene.lights[key]);
    }
}
