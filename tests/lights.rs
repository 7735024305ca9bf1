//! Lights and cluster binning on the GPU: the GPU's cluster lists against the CPU reference
//! binner, clustered renders against brute-force renders, analytic irradiance of point and spot
//! lights read back from the HDR target, change-only uploads, and the frame plan leaving binning
//! out when there is nothing to bin.

use penumbra::engine::scenes::{SplitMix64, spawn_many_lights};
use penumbra::prelude::*;
use penumbra::render::LightWalk;
use penumbra::render::features::clusters::grid::ClusterConfig;
use penumbra::render::features::clusters::reference;
use penumbra::render::frame::Pass;
use penumbra::render::{DebugView, LocalLights};
use penumbra::render::{RenderSettings, Renderer};

mod common;
use common::{flip_mean, floor_radiance, hdr_of, render_app, scene_app, spawn_mesh, top_down};

fn settings(walk: LightWalk) -> RenderSettings {
    // The tests read HDR colour.
    RenderSettings { msaa: 1, light_walk: walk, keep_hdr: true, ..Default::default() }
}

/// The GPU's lists of the last frame against the CPU reference. Rounding may legitimately
/// differ between the two for a light within rounding of a cluster boundary, so the reference
/// is run with every range 0.01% smaller and larger: the GPU's lists must lie between the two,
/// and on scenes where the two agree (no light that close to a boundary) equal them exactly.
/// Returns (clusters holding a light, total list entries).
fn assert_lists_match_reference(app: &App, what: &str) -> (usize, usize) {
    let renderer = app.world.resource::<Renderer>();
    let ctx = renderer.context();
    let gpu = renderer.cluster_binner().read_lists(&ctx.device, &ctx.queue).unwrap();
    let grid = renderer.cluster_binner().grid().expect("binning ran");
    let store = renderer.light_store();
    let first = store.global_count();
    let inner = reference::bin_scaled(grid, store.local_lights(), first, 0.9999);
    let outer = reference::bin_scaled(grid, store.local_lights(), first, 1.0001);
    let exact = reference::bin(grid, store.local_lights(), first);
    assert_eq!(gpu.len(), exact.len(), "{what}: cluster count");
    let mut borderline = 0;
    for (c, list) in gpu.iter().enumerate() {
        let mut sorted = list.clone();
        sorted.sort_unstable();
        assert_eq!(&sorted, list, "{what}: cluster {c}'s list is not sorted");
        if inner[c] == outer[c] {
            assert_eq!(list, &exact[c], "{what}: cluster {c} differs from the CPU reference");
        } else {
            borderline += 1;
            assert!(inner[c].iter().all(|l| list.contains(l)), "{what}: cluster {c} misses a light");
            assert!(list.iter().all(|l| outer[c].contains(l)), "{what}: cluster {c} has a stray light");
        }
    }
    // A handful at most: many more would mean the GPU and CPU walks differ systematically.
    assert!(borderline * 20 <= gpu.len(), "{what}: {borderline} borderline clusters");
    (gpu.iter().filter(|l| !l.is_empty()).count(), gpu.iter().map(Vec::len).sum())
}

fn floor(app: &mut App, size: f32) {
    spawn_mesh(app, Mesh::plane(size), StandardMaterial::from_color(Vec4::splat(0.8), 0.6), Transform::default());
}

fn camera(app: &mut App, eye: Vec3, target: Vec3, projection: Projection) {
    app.world.spawn((
        Camera { projection, ..Default::default() },
        Transform::from_translation(eye).looking_at(target, Vec3::Y),
    ));
}

fn perspective() -> Projection {
    Projection::Perspective { yfov: 50f32.to_radians(), znear: 0.1, aspect_ratio: None }
}

#[test]
fn gpu_lists_equal_the_cpu_reference_in_a_stadium_of_1000_lights() {
    let mut app = scene_app();
    spawn_many_lights(&mut app.world, 1000, Some(3.0));
    render_app(&mut app, (160, 90), settings(LightWalk::Clustered));
    let (occupied, entries) = assert_lists_match_reference(&app, "stadium");
    assert!(occupied > 50 && entries >= occupied, "{occupied} clusters hold {entries} entries");
}

/// The scan takes the run counts in blocks of 1024 (one run per cluster at 1 000 lights): grids
/// of one partial block, of a few blocks with a partial last one, and of tens of blocks.
#[test]
fn gpu_lists_equal_the_cpu_reference_on_grids_of_any_size() {
    for (tiles_x, tiles_y, slices) in [(5, 3, 7), (13, 7, 31), (64, 36, 40)] {
        let mut app = scene_app();
        spawn_many_lights(&mut app.world, 1000, Some(3.0));
        let clusters = ClusterConfig { tiles_x, tiles_y, slices };
        render_app(&mut app, (160, 90), RenderSettings { clusters, ..settings(LightWalk::Clustered) });
        let what = format!("{tiles_x}x{tiles_y}x{slices} grid");
        let (occupied, _) = assert_lists_match_reference(&app, &what);
        assert!(occupied > 10, "{what}: {occupied} clusters hold lights");
    }
}

#[test]
fn gpu_lists_equal_the_cpu_reference_for_awkward_lights() {
    let mut app = scene_app();
    floor(&mut app, 40.0);
    let eye = Vec3::new(0.0, 2.0, 8.0);
    let mut rng = SplitMix64(7);
    let spawn_point = |app: &mut App, at: Vec3, range: f32| {
        app.world.spawn((
            PointLight { intensity: 5.0, range: Some(range), ..Default::default() },
            Transform::from_translation(at),
        ));
    };
    // Containing the camera, just in front of the near plane, behind the camera, and far.
    spawn_point(&mut app, eye + Vec3::new(0.1, 0.0, -0.05), 1.5);
    spawn_point(&mut app, eye + Vec3::new(0.0, 0.0, -0.2), 0.15);
    spawn_point(&mut app, eye + Vec3::new(0.0, 0.0, 3.0), 1.0);
    spawn_point(&mut app, Vec3::new(3.0, 0.5, -30.0), 4.0);
    // A crowd of small lights straddling many cluster boundaries.
    for _ in 0..300 {
        let at = Vec3::new(rng.uniform(-10.0, 10.0), rng.uniform(0.0, 3.0), rng.uniform(-20.0, 6.0));
        spawn_point(&mut app, at, rng.uniform(0.05, 2.0));
    }
    // Spots aimed every way, some at the camera.
    for i in 0..60 {
        let at = Vec3::new(rng.uniform(-8.0, 8.0), rng.uniform(0.5, 3.0), rng.uniform(-15.0, 4.0));
        let target =
            if i % 5 == 0 { eye } else { at + Vec3::new(rng.uniform(-1.0, 1.0), -1.0, rng.uniform(-1.0, 1.0)) };
        app.world.spawn((
            SpotLight {
                intensity: 20.0,
                range: Some(rng.uniform(1.0, 6.0)),
                inner_cone_angle: 0.1,
                outer_cone_angle: rng.uniform(0.15, 1.5),
                ..Default::default()
            },
            Transform::from_translation(at).looking_at(target, Vec3::Y),
        ));
    }
    // Lights with a size, facing every way (rects and disks only light their front side), one
    // rect containing the camera.
    for i in 0..40 {
        let at = Vec3::new(rng.uniform(-8.0, 8.0), rng.uniform(0.2, 3.0), rng.uniform(-15.0, 4.0));
        let target = at + Vec3::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
        let t = Transform::from_translation(at).looking_at(target, Vec3::Y);
        let range = Some(rng.uniform(0.5, 4.0));
        let size = rng.uniform(0.1, 2.0);
        match i % 4 {
            0 => app.world.spawn((SphereLight { radius: size, range, ..Default::default() }, t)),
            1 => app.world.spawn((TubeLight { length: 2.0 * size, radius: 0.05, range, ..Default::default() }, t)),
            2 => app.world.spawn((RectLight { width: size, height: 0.5 * size, range, ..Default::default() }, t)),
            _ => app.world.spawn((DiskLight { radius: size, range, ..Default::default() }, t)),
        };
    }
    app.world.spawn((
        RectLight { width: 3.0, height: 2.0, range: Some(2.0), ..Default::default() },
        Transform::from_translation(eye + Vec3::new(0.0, 0.0, 0.5)),
    ));
    camera(&mut app, eye, Vec3::new(0.0, 0.5, 0.0), perspective());
    render_app(&mut app, (128, 96), settings(LightWalk::Clustered));
    assert_lists_match_reference(&app, "perspective");

    // The same lights through an orthographic camera (linear slices, box-shaped froxels).
    let mut cams = app.world.query::<&mut Camera>();
    for mut c in cams.iter_mut(&mut app.world) {
        c.projection = Projection::Orthographic { xmag: None, ymag: 6.0, znear: 0.1, zfar: 60.0 };
    }
    render_app(&mut app, (128, 96), settings(LightWalk::Clustered));
    assert_lists_match_reference(&app, "orthographic");
}

/// Renders `app` with each light walk and returns the images.
fn walks(app: &mut App, size: (u32, u32)) -> (Vec<u8>, Vec<u8>) {
    app.world.remove_resource::<Renderer>();
    let clustered = render_app(app, size, settings(LightWalk::Clustered));
    app.world.remove_resource::<Renderer>();
    let brute = render_app(app, size, settings(LightWalk::AllLights));
    (clustered, brute)
}

/// Slices start at the lights' near side, and fragments in front of it look up no list; those
/// behind the far side, the last slice. Geometry on both sides, near the camera and far from
/// the origin: clustered and brute-force frames are equal to the bit, since both add the same
/// non-zero terms in the same order (a light past its range adds exactly 0).
#[test]
fn clustered_render_equals_brute_force_in_front_of_and_behind_the_lights() {
    for origin in [Vec3::ZERO, Vec3::new(1e5, 0.0, -1e5)] {
        let mut app = scene_app();
        let ground = StandardMaterial::from_color(Vec4::splat(0.8), 0.5);
        spawn_mesh(&mut app, Mesh::plane(200.0), ground, Transform::from_translation(origin));
        let mut rng = SplitMix64(5);
        // A band of lights 20 to 30 m ahead of the eye; the floor runs from under the eye to
        // 100 m, past the band on both sides.
        for _ in 0..200 {
            let at = origin + Vec3::new(rng.uniform(-8.0, 8.0), rng.uniform(0.2, 1.0), rng.uniform(-30.0, -20.0));
            app.world.spawn((
                PointLight { intensity: 40.0, range: Some(rng.uniform(1.0, 3.0)), ..Default::default() },
                Transform::from_translation(at),
            ));
        }
        camera(&mut app, origin + Vec3::new(0.0, 2.0, 0.0), origin + Vec3::new(0.0, 0.0, -25.0), perspective());
        let size = (128, 96);
        app.world.remove_resource::<Renderer>();
        render_app(&mut app, size, settings(LightWalk::Clustered));
        let grid = *app.world.resource::<Renderer>().cluster_binner().grid().expect("binning ran");
        assert!(grid.near > 15.0, "slices begin at {} m", grid.near);
        let clustered = hdr_of(&app);
        app.world.remove_resource::<Renderer>();
        render_app(&mut app, size, settings(LightWalk::AllLights));
        let brute = hdr_of(&app);
        // No other light: only the band lights anything.
        let lit = brute.iter().filter(|p| p[0] + p[1] + p[2] > 0.0).count();
        assert!(lit > 200 && lit < brute.len() / 2, "{origin}: {lit} pixels lit by the band");
        let differing = clustered.iter().zip(&brute).filter(|(a, b)| a != b).count();
        assert_eq!(differing, 0, "{origin}: {differing} pixels differ between clustered and brute-force");
    }
}

#[test]
fn clustered_render_equals_brute_force_for_1000_lights_in_a_stadium() {
    let mut app = scene_app();
    spawn_many_lights(&mut app.world, 1000, Some(3.0));
    let size = (192, 108);
    let (clustered, brute) = walks(&mut app, size);
    let e = flip_mean(&clustered, &brute, size.0, size.1);
    assert!(e <= 0.01, "FLIP mean {e} between clustered and brute-force renders");
    // And the lights do light the scene: the image is not the unlit floor.
    let lit = clustered.chunks_exact(4).filter(|p| p[0].max(p[1]).max(p[2]) > 60).count();
    assert!(lit > 200, "only {lit} brightly lit pixels");
    // Lists are sorted after the atomic fill, so the sum order, and the image, never vary.
    app.world.remove_resource::<Renderer>();
    let again = render_app(&mut app, size, settings(LightWalk::Clustered));
    assert!(again == clustered, "a second clustered render differs");
}

#[test]
fn clustered_render_equals_brute_force_for_10000_lights_in_one_cluster() {
    let mut app = scene_app();
    floor(&mut app, 10.0);
    let mut rng = SplitMix64(11);
    // Ten thousand dim lights within 2 cm of one point on the floor: one cluster's list holds
    // all of them, and every one must be there.
    for _ in 0..10_000 {
        let at = Vec3::new(rng.uniform(-0.02, 0.02), rng.uniform(0.1, 0.14), rng.uniform(-0.02, 0.02));
        let hue = rng.uniform(0.0, 1.0);
        app.world.spawn((
            PointLight {
                color: Vec3::new(hue, 1.0 - hue, 0.5),
                intensity: 0.0004,
                range: Some(0.6),
                ..Default::default()
            },
            Transform::from_translation(at),
        ));
    }
    camera(&mut app, Vec3::new(0.0, 3.0, 3.0), Vec3::ZERO, perspective());
    let size = (96, 96);
    let (clustered, brute) = walks(&mut app, size);
    let e = flip_mean(&clustered, &brute, size.0, size.1);
    assert!(e <= 0.01, "FLIP mean {e} between clustered and brute-force renders");
    app.world.remove_resource::<Renderer>();
    render_app(&mut app, size, settings(LightWalk::Clustered));
    assert_eq!(app.world.resource::<Renderer>().stats().local_lights, 10_000);
    // The list comes out as ten runs, one per block of 1 024 lights, each sorted by a workgroup.
    let blocks = app.world.resource::<Renderer>().cluster_binner().light_blocks();
    assert_eq!((blocks.count, blocks.lights), (10, 1024));
    let (_, entries) = assert_lists_match_reference(&app, "10 000 lights in one cluster");
    assert!(entries >= 10_000, "{entries} entries");
}

/// On the largest grid (2²⁰ clusters) the run counters would outgrow their 16 MiB at 4 blocks of
/// 1 024 lights, so blocks grow instead: 40 000 lights crowded into one cluster make 4 runs of
/// 10 000, which the long-run sort orders through a mask of 10 000 bits.
#[test]
fn lists_stay_exact_when_light_blocks_grow_on_the_largest_grid() {
    let mut app = scene_app();
    floor(&mut app, 10.0);
    let mut rng = SplitMix64(40);
    for _ in 0..40_000 {
        // Lights of 1 cm within 0.2 mm, 4 m away: each spans a few of the 1 024 tiles across,
        // all of them the middle one. (Each light's several clusters are what scramble the
        // order of the atomics on lavapipe, whose workgroups run their 8-lane groups one after
        // another: lights of one cluster each would come out sorted, with no sort to test.)
        let at = Vec3::new(rng.uniform(-2e-4, 2e-4), rng.uniform(0.1, 0.1004), rng.uniform(-2e-4, 2e-4));
        app.world.spawn((
            PointLight { intensity: 1e-6, range: Some(1e-2), shadows: false, ..Default::default() },
            Transform::from_translation(at),
        ));
    }
    camera(&mut app, Vec3::new(0.0, 3.0, 3.0), Vec3::new(0.0, 0.1, 0.0), perspective());
    // As many pixels as tiles: boxes reach a pixel past the lights' bounds (LOOKUP_SLACK), which
    // on a smaller target would be many tiles.
    let clusters = ClusterConfig { tiles_x: 1024, tiles_y: 1024, slices: 1 };
    render_app(&mut app, (1024, 1024), RenderSettings { clusters, ..settings(LightWalk::Clustered) });
    let blocks = app.world.resource::<Renderer>().cluster_binner().light_blocks();
    assert_eq!((blocks.count, blocks.lights), (4, 10_000));
    let (_, entries) = assert_lists_match_reference(&app, "40 000 lights on 2^20 clusters");
    assert!(entries >= 40_000, "{entries} entries");
    let renderer = app.world.resource::<Renderer>();
    let ctx = renderer.context();
    let lists = renderer.cluster_binner().read_lists(&ctx.device, &ctx.queue).unwrap();
    assert_eq!(lists.iter().map(Vec::len).max(), Some(40_000), "one cluster holds every light");
}

/// Every sorting path of the binning: runs (one per cluster and block of 1 024 lights) of at
/// most 16 lights are sorted by one invocation, longer ones are queued for a workgroup, which
/// ranks up to 256 lights directly and sorts longer runs through a mask of the block's lights.
/// 1 500 lights in one cluster make a list of two runs, 1 024 and 476 long.
#[test]
fn short_and_long_cluster_lists_come_out_sorted_and_exact() {
    for (count, spread) in [(40, 0.02), (300, 0.02), (1500, 0.02), (600, 2.0)] {
        let mut app = scene_app();
        floor(&mut app, 10.0);
        let mut rng = SplitMix64(count as u64);
        for _ in 0..count {
            let at = Vec3::new(rng.uniform(-spread, spread), rng.uniform(0.1, 0.14), rng.uniform(-spread, spread));
            app.world.spawn((
                PointLight { intensity: 0.001, range: Some(0.6), shadows: false, ..Default::default() },
                Transform::from_translation(at),
            ));
        }
        camera(&mut app, Vec3::new(0.0, 3.0, 3.0), Vec3::ZERO, perspective());
        render_app(&mut app, (64, 64), settings(LightWalk::Clustered));
        let what = format!("{count} lights within {spread} m");
        let (_, entries) = assert_lists_match_reference(&app, &what);
        assert!(entries >= count, "{what}: {entries} entries");
        let renderer = app.world.resource::<Renderer>();
        let ctx = renderer.context();
        let longest = renderer.cluster_binner().read_lists(&ctx.device, &ctx.queue).unwrap().iter().map(Vec::len).max();
        let longest = longest.unwrap_or(0);
        // Crowded: one cluster holds them all. Spread: some lists past 64 (and short ones), so
        // runs both past and within 16 lights, and both sorts run.
        let wanted = if spread < 0.1 { count } else { 65 };
        assert!(longest >= wanted, "{what}: longest list {longest}");
    }
}

#[test]
fn point_light_irradiance_follows_the_inverse_square_law() {
    let mut app = scene_app();
    let pixel_world = top_down(&mut app, 2.0);
    let light_at = Vec3::new(0.3, 1.0, -0.2);
    let intensity = 2.0;
    app.world.spawn((PointLight { intensity, ..Default::default() }, Transform::from_translation(light_at)));
    let size = 64;
    render_app(&mut app, (size, size), settings(LightWalk::Clustered));
    let hdr = hdr_of(&app);
    let mut checked = 0;
    for (x, y) in [(32, 32), (40, 20), (10, 50), (60, 5), (5, 60), (20, 36)] {
        let p = pixel_world(x, y, size);
        let to_light = light_at - p;
        let d2 = to_light.length_squared();
        let l = to_light / d2.sqrt();
        // E = I / d² perpendicular to the light; the BRDF applies cos θ = N·L.
        let expected = floor_radiance(l, intensity / d2);
        let got = hdr[(y * size + x) as usize][1];
        assert!(
            (got - expected).abs() <= 0.02 * expected,
            "pixel ({x}, {y}) at {p}: radiance {got}, expected {expected} (I cos θ / d² with d² = {d2})"
        );
        checked += 1;
    }
    assert_eq!(checked, 6);
}

#[test]
fn spot_light_is_full_inside_its_inner_cone_and_dark_outside_its_outer_cone() {
    let mut app = scene_app();
    let pixel_world = top_down(&mut app, 1.0);
    let light_at = Vec3::new(0.0, 1.0, 0.0);
    let (inner, outer) = (0.3f32, 0.6f32);
    app.world.spawn((
        SpotLight { intensity: 3.0, inner_cone_angle: inner, outer_cone_angle: outer, ..Default::default() },
        Transform::from_translation(light_at).looking_at(Vec3::ZERO, Vec3::NEG_Z),
    ));
    let size = 64;
    render_app(&mut app, (size, size), settings(LightWalk::Clustered));
    let hdr = hdr_of(&app);
    let (mut inside, mut outside) = (0, 0);
    for y in 0..size {
        for x in 0..size {
            let p = pixel_world(x, y, size);
            let to_light = light_at - p;
            let angle = (-to_light).normalize().dot(Vec3::NEG_Y).clamp(-1.0, 1.0).acos();
            let got = hdr[(y * size + x) as usize][1];
            if angle < inner - 0.02 {
                let d2 = to_light.length_squared();
                let expected = floor_radiance(to_light / d2.sqrt(), 3.0 / d2);
                assert!((got - expected).abs() <= 0.02 * expected, "inside the inner cone at {p}: {got} vs {expected}");
                inside += 1;
            } else if angle > outer + 0.02 {
                assert_eq!(got, 0.0, "outside the outer cone at {p}");
                outside += 1;
            }
        }
    }
    assert!(inside > 100 && outside > 100, "{inside} pixels inside, {outside} outside");
}

#[test]
fn binning_runs_only_with_local_lights() {
    let mut app = scene_app();
    floor(&mut app, 10.0);
    app.world.spawn((DirectionalLight::default(), Transform::default().looking_at(Vec3::NEG_Y, Vec3::Z)));
    camera(&mut app, Vec3::new(0.0, 3.0, 3.0), Vec3::ZERO, perspective());
    render_app(&mut app, (32, 32), settings(LightWalk::Clustered));
    let r = app.world.resource::<Renderer>();
    assert!(!r.stats().plan.runs(Pass::CLUSTER_BIN), "plan:\n{}", r.stats().plan);
    assert!(r.forward_pipeline_keys().iter().all(|k| k.local_lights == LocalLights::None));

    app.world.spawn((PointLight::default(), Transform::from_xyz(0.0, 1.0, 0.0)));
    render_app(&mut app, (32, 32), settings(LightWalk::Clustered));
    let r = app.world.resource::<Renderer>();
    assert!(r.stats().plan.runs(Pass::CLUSTER_BIN), "plan:\n{}", r.stats().plan);
}

#[test]
fn only_changed_lights_are_uploaded() {
    let mut app = scene_app();
    let lights = spawn_many_lights(&mut app.world, 500, Some(3.0));
    let size = (64, 36);
    render_app(&mut app, size, settings(LightWalk::Clustered));
    let stats = |app: &App| app.world.resource::<Renderer>().stats().clone();
    assert_eq!(stats(&app).light_bytes_uploaded, 501 * 64, "first frame uploads every light");
    render_app(&mut app, size, settings(LightWalk::Clustered));
    assert_eq!(stats(&app).light_bytes_uploaded, 0, "nothing changed");
    app.world.get_mut::<Transform>(lights[123]).unwrap().translation.y += 0.5;
    render_app(&mut app, size, settings(LightWalk::Clustered));
    assert_eq!(stats(&app).light_bytes_uploaded, 64, "one light moved");
    app.world.despawn(lights[7]);
    render_app(&mut app, size, settings(LightWalk::Clustered));
    assert_eq!(stats(&app).local_lights, 499);
    assert_eq!(stats(&app).light_bytes_uploaded, 64, "the last light moved into the hole");
    assert_lists_match_reference(&app, "after a removal");
}

#[test]
fn a_light_with_nan_is_refused_and_the_others_keep_lighting() {
    let mut app = scene_app();
    let _ = top_down(&mut app, 2.0);
    app.world.spawn((PointLight { intensity: 2.0, ..Default::default() }, Transform::from_xyz(0.0, 1.0, 0.0)));
    let bad = app
        .world
        .spawn((PointLight { intensity: f32::NAN, ..Default::default() }, Transform::from_xyz(0.5, 1.0, 0.0)))
        .id();
    render_app(&mut app, (32, 32), settings(LightWalk::Clustered));
    let r = app.world.resource::<Renderer>();
    assert_eq!(r.stats().local_lights, 1, "the NaN light is not stored");
    let hdr = hdr_of(&app);
    assert!(hdr.iter().all(|p| p.iter().all(|c| c.is_finite())));
    assert!(hdr[16 * 32 + 16][1] > 0.0, "the good light still lights the floor");
    app.world.get_mut::<PointLight>(bad).unwrap().intensity = 1.0;
    render_app(&mut app, (32, 32), settings(LightWalk::Clustered));
    assert_eq!(app.world.resource::<Renderer>().stats().local_lights, 2, "fixed, it comes back");
}

fn golden_shot(app: &mut App, size: (u32, u32), settings: RenderSettings) -> common::Shot {
    let rgba8 = render_app(app, size, settings);
    common::Shot { width: size.0, height: size.1, rgba8 }
}

#[test]
fn golden_1000_point_lights() {
    let mut app = scene_app();
    spawn_many_lights(&mut app.world, 1000, Some(3.0));
    let shot = golden_shot(&mut app, (256, 144), RenderSettings { msaa: 4, ..Default::default() });
    common::check_golden("lights_1000_points", &shot, common::Tolerance::default());
}

#[test]
fn golden_cluster_heat_view() {
    let mut app = scene_app();
    spawn_many_lights(&mut app.world, 1000, Some(3.0));
    let settings = RenderSettings { msaa: 1, debug_view: DebugView::ClusterHeat, ..Default::default() };
    let shot = golden_shot(&mut app, (256, 144), settings);
    // Lights are scattered over the whole ground, so nearly every cluster it passes through has
    // some (black is none): a heat map of many levels, not one flat colour.
    let pixels: Vec<[u8; 3]> = shot.rgba8.chunks_exact(4).map(|p| [p[0], p[1], p[2]]).collect();
    let black = pixels.iter().filter(|p| **p == [0, 0, 0]).count();
    assert!(black < pixels.len() / 10, "{black} of {} pixels black", pixels.len());
    let levels: std::collections::HashSet<[u8; 3]> = pixels.into_iter().collect();
    assert!(levels.len() >= 16, "{} colours in the heat view", levels.len());
    common::check_golden("lights_cluster_heat", &shot, common::Tolerance::default());
}

/// One light of every type over a floor with a few spheres.
#[test]
fn golden_every_light_type() {
    let mut app = scene_app();
    floor(&mut app, 12.0);
    for (i, metallic) in [0.0f32, 1.0].into_iter().enumerate() {
        let m = StandardMaterial {
            base_color: Vec4::new(0.8, 0.8, 0.8, 1.0),
            metallic,
            roughness: 0.35,
            ..Default::default()
        };
        spawn_mesh(&mut app, Mesh::uv_sphere(0.6, 32, 16), m, Transform::from_xyz(i as f32 * 2.0 - 1.0, 0.6, 0.0));
    }
    app.world.spawn((
        DirectionalLight { color: Vec3::new(1.0, 0.95, 0.9), illuminance: 0.6, ..Default::default() },
        Transform::default().looking_at(Vec3::new(-0.3, -1.0, -0.4), Vec3::Y),
    ));
    app.world.spawn((
        PointLight { color: Vec3::new(1.0, 0.3, 0.2), intensity: 4.0, ..Default::default() },
        Transform::from_xyz(-2.5, 1.2, 1.0),
    ));
    app.world.spawn((
        SpotLight {
            color: Vec3::new(0.2, 0.5, 1.0),
            intensity: 12.0,
            inner_cone_angle: 0.25,
            outer_cone_angle: 0.45,
            ..Default::default()
        },
        Transform::from_xyz(2.0, 3.0, 2.0).looking_at(Vec3::new(1.0, 0.0, 0.0), Vec3::Y),
    ));
    app.world.spawn(AmbientLight { color: Vec3::ONE, intensity: 0.05 });
    app.world.spawn((
        SphereLight { color: Vec3::new(0.3, 1.0, 0.4), intensity: 2.0, radius: 0.2, ..Default::default() },
        Transform::from_xyz(0.0, 1.7, -1.2),
    ));
    app.world.spawn((
        TubeLight { color: Vec3::new(1.0, 0.8, 0.5), intensity: 1.0, length: 2.5, radius: 0.03, ..Default::default() },
        Transform::from_xyz(0.0, 0.2, 1.5),
    ));
    app.world.spawn((
        RectLight { color: Vec3::new(0.8, 0.4, 1.0), luminance: 2.5, width: 1.2, height: 0.8, ..Default::default() },
        Transform::from_xyz(-3.0, 1.3, -1.2).looking_at(Vec3::new(-1.0, 0.4, 0.0), Vec3::Y),
    ));
    app.world.spawn((
        DiskLight { color: Vec3::new(1.0, 1.0, 0.6), luminance: 3.0, radius: 0.35, ..Default::default() },
        Transform::from_xyz(2.8, 2.0, -1.2).looking_at(Vec3::new(1.0, 0.4, 0.0), Vec3::Y),
    ));
    // A street-light-like profile throwing forward (C = 0°, local +X) from the front right.
    let vertical: Vec<f32> = (0..=9).map(|i| i as f32 * 10.0).collect();
    let horizontal: Vec<f32> = (0..=4).map(|i| i as f32 * 45.0).collect();
    let candela: Vec<f32> = horizontal
        .iter()
        .flat_map(|c| {
            vertical
                .iter()
                .map(move |g| 8.0 * (1.0 + 1.5 * c.to_radians().cos() * g.to_radians().sin()) * g.to_radians().cos())
        })
        .collect();
    let profile = common::add_ies_profile(&mut app, &vertical, &horizontal, &candela);
    app.world.spawn((
        IesLight { color: Vec3::new(1.0, 0.9, 0.7), ..IesLight::new(profile) },
        Transform::from_xyz(2.6, 1.4, 2.4)
            .with_rotation(Quat::from_rotation_y(2.4) * Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2)),
    ));
    camera(&mut app, Vec3::new(0.0, 3.0, 6.0), Vec3::new(0.0, 0.5, 0.0), perspective());
    let shot = golden_shot(&mut app, (256, 160), RenderSettings { msaa: 4, ..Default::default() });
    common::check_golden("lights_every_type", &shot, common::Tolerance::default());
}

/// Lights of zero intensity have no range and must not be binned: the index buffer is sized for
/// binned lights only, so binning them would write past its end.
#[test]
fn dark_lights_are_not_binned() {
    let mut app = scene_app();
    floor(&mut app, 30.0);
    app.world.spawn((
        PointLight { intensity: 3.0, range: Some(5.0), ..Default::default() },
        Transform::from_xyz(0.0, 1.0, -4.0),
    ));
    let mut rng = SplitMix64(3);
    for _ in 0..2000 {
        let at = Vec3::new(rng.uniform(-5.0, 5.0), rng.uniform(0.2, 3.0), rng.uniform(-12.0, 2.0));
        app.world.spawn((PointLight { intensity: 0.0, ..Default::default() }, Transform::from_translation(at)));
    }
    camera(&mut app, Vec3::new(0.0, 2.0, 4.0), Vec3::new(0.0, 0.5, -4.0), perspective());
    render_app(&mut app, (96, 64), settings(LightWalk::Clustered));
    let (_, entries) = assert_lists_match_reference(&app, "dark lights");
    let bound = app.world.resource::<Renderer>().stats().cluster_index_bound;
    assert!(entries as u64 <= bound, "{entries} list entries exceed the bound {bound}");
    assert!(entries > 0, "the bright light is binned");
}

/// A range far beyond the slice range (1e10 m, a common way to write "unbounded") must neither
/// overflow the slice arithmetic nor drop the light, with an orthographic camera's linear slices.
#[test]
fn a_huge_range_is_binned_in_an_orthographic_view() {
    let mut app = scene_app();
    let _ = top_down(&mut app, 2.0);
    app.world.spawn((
        PointLight { intensity: 2.0, range: Some(1e10), ..Default::default() },
        Transform::from_xyz(0.0, 1.0, 0.0),
    ));
    render_app(&mut app, (32, 32), settings(LightWalk::Clustered));
    assert_lists_match_reference(&app, "huge range, orthographic");
    let hdr = hdr_of(&app);
    assert!(hdr[16 * 32 + 16][1] > 0.1, "the light lights the floor: {:?}", hdr[16 * 32 + 16]);
}

/// The forward shader walks the global lights in a uniform array of the light store's first
/// `UNIFORM_GLOBAL_LIGHTS` slots while they fit, and in the storage array beyond (the
/// `GLOBAL_LIGHTS_IN_STORAGE` variant): N directional lights whose illuminances add up to one
/// light's light the floor as that one does, at the array's length and past it. Light i carries
/// a share growing as i², so a walk that lost the lights past the array, or read the array's
/// last one again in their place, would miss by at least 2 %. The keys say which walk drew: on
/// lavapipe a read past the uniform array (shaders are compiled without bounds checks) happens
/// to find the store's next slots, so the radiance alone would not tell.
#[test]
fn global_lights_past_the_uniform_array_are_walked_in_storage() {
    use penumbra::render::resources::light_store::UNIFORM_GLOBAL_LIGHTS;
    let render = |n: u32| {
        let mut app = scene_app();
        let _pixel_world = top_down(&mut app, 2.0);
        let total: f32 = (1..=n).map(|i| (i * i) as f32).sum();
        for i in 1..=n {
            app.world.spawn((
                DirectionalLight { illuminance: 3.0 * (i * i) as f32 / total, shadows: false, ..Default::default() },
                Transform::from_xyz(1.0, 2.0, 1.5).looking_at(Vec3::ZERO, Vec3::Y),
            ));
        }
        render_app(&mut app, (16, 16), settings(LightWalk::Clustered));
        let keys = app.world.resource::<Renderer>().forward_pipeline_keys();
        assert!(!keys.is_empty());
        let in_storage = keys.iter().all(|k| k.global_lights_in_storage);
        assert!(in_storage || keys.iter().all(|k| !k.global_lights_in_storage), "{n} lights: mixed keys");
        (hdr_of(&app)[8 * 16 + 8][1], in_storage)
    };
    let (one, in_storage) = render(1);
    assert!(one > 0.1 && !in_storage, "one light: radiance {one}, in storage {in_storage}");
    for n in [UNIFORM_GLOBAL_LIGHTS, UNIFORM_GLOBAL_LIGHTS + 6] {
        let (split, in_storage) = render(n);
        assert_eq!(in_storage, n > UNIFORM_GLOBAL_LIGHTS, "{n} lights");
        assert!((split - one).abs() <= 1e-3 * one, "{n} lights: radiance {split}, one light: {one}");
    }
}
