//! Shadows of directional lights (cascaded shadow maps): the pixel tests of issue #4 — no acne
//! on a lit plane, no gap under a box (no peter-panning), no seam where cascades meet, PCSS
//! penumbrae that widen with the occluder's height — and what the frame plan leaves out when
//! nothing casts.

use penumbra::prelude::*;
use penumbra::render::features::shadows::{ShadowFilter, ShadowSettings};
use penumbra::render::frame::Pass;
use penumbra::render::{OcclusionCulling, Raster, RenderSettings, Renderer};

mod common;
use common::golden_scenes::{grey, sun};
use common::{brightness, render_app, scene_app, scratch_dir, spawn_mesh, top_down};

fn settings(shadows: ShadowSettings) -> RenderSettings {
    RenderSettings { msaa: 1, shadows, ..Default::default() }
}

fn atlas(size: u32) -> ShadowSettings {
    ShadowSettings { atlas_size: size, ..Default::default() }
}

/// Renders a fresh frame with a fresh renderer (settings apply from the first frame).
fn render(app: &mut App, size: (u32, u32), shadows: ShadowSettings) -> Vec<u8> {
    app.world.remove_resource::<Renderer>();
    let px = render_app(app, size, settings(shadows));
    assert_eq!(app.world.resource::<Renderer>().shader_error(), None);
    px
}

/// Saves a frame under the target folder, for a person looking into a failure.
fn save(name: &str, px: &[u8], size: (u32, u32)) {
    let dir = scratch_dir(&format!("shadows-{name}"));
    image::save_buffer(dir.join("frame.png"), px, size.0, size.1, image::ColorType::Rgba8).unwrap();
}

fn set_shadows(app: &mut App, on: bool) {
    let mut q = app.world.query::<&mut DirectionalLight>();
    for mut l in q.iter_mut(&mut app.world) {
        l.shadows = on;
    }
}

fn stats(app: &App) -> penumbra::render::FrameStats {
    app.world.resource::<Renderer>().stats().clone()
}

/// Test 3 of the issue: a plane alone (caster and receiver of its own shadow map) under a light
/// at 30° to 80° elevation, seen in perspective across several cascades, also 100 km from the
/// origin. Against the same frame without shadows: mean darkening below 4/255, standard
/// deviation below 2/255, and no pixel darker by more than 8/255 (an acne speck or stripe is a
/// texel's worth of pixels gone dark, tens of levels).
#[test]
fn a_lit_plane_shows_no_acne() {
    let size = (256, 160);
    for origin in [Vec3::ZERO, Vec3::new(1.0e5, 0.0, -1.0e5)] {
        for elevation in [30.0, 45.0, 60.0, 80.0] {
            let mut app = scene_app();
            spawn_mesh(&mut app, Mesh::plane(400.0), grey(0.8), Transform::from_translation(origin));
            app.world.spawn((DirectionalLight { illuminance: 2.0, ..Default::default() }, sun(elevation, 35.0)));
            let eye = origin + Vec3::new(0.0, 2.0, 6.0);
            app.world.spawn((Camera::default(), Transform::from_translation(eye).looking_at(origin, Vec3::Y)));
            let shadowed = render(&mut app, size, atlas(1024));
            let s = stats(&app);
            assert!(s.plan.runs(Pass::SHADOWS), "the plane casts, so its cascades render");
            set_shadows(&mut app, false);
            let plain = render(&mut app, size, atlas(1024));
            assert!(!stats(&app).plan.runs(Pass::SHADOWS));
            let mut darkening = Vec::new();
            for y in 0..size.1 {
                for x in 0..size.0 {
                    let p = brightness(&plain, size.0, x, y);
                    // The plane (the background is the clear colour).
                    if p > 20.0 {
                        darkening.push(p - brightness(&shadowed, size.0, x, y));
                    }
                }
            }
            let n = darkening.len() as f32;
            assert!(n > 0.4 * (size.0 * size.1) as f32, "the plane fills the lower frame");
            let mean = darkening.iter().sum::<f32>() / n;
            let sd = (darkening.iter().map(|d| (d - mean).powi(2)).sum::<f32>() / n).sqrt();
            let worst = darkening.iter().copied().fold(f32::MIN, f32::max);
            eprintln!("elevation {elevation}°, origin {origin}: mean {mean:.3}, sd {sd:.3}, worst {worst:.1} levels");
            if !(mean < 4.0 && sd < 2.0 && worst <= 8.0) {
                save(&format!("acne-{elevation}"), &shadowed, size);
            }
            assert!(mean < 4.0, "elevation {elevation}°: mean darkening {mean} of 255");
            assert!(sd < 2.0, "elevation {elevation}°: darkening deviates by {sd} of 255");
            assert!(worst <= 8.0, "elevation {elevation}°: a pixel darkened by {worst} of 255");
        }
    }
}

/// Test 4: a 1 m box on the floor under a grazing light (12° elevation, from +X), seen from
/// straight above (orthographic, 64 pixels per metre). Walking away from the box's shadowed
/// side along its centre line, the floor must be in shadow within 4 pixels of the box's base.
#[test]
fn a_box_on_the_floor_casts_a_shadow_from_its_base() {
    let size = 256;
    let mut app = scene_app();
    let world_at = top_down(&mut app, 2.0);
    spawn_mesh(&mut app, Mesh::cuboid(Vec3::ONE), grey(0.5), Transform::from_xyz(0.0, 0.5, 0.0));
    app.world.spawn((DirectionalLight { illuminance: 3.0, ..Default::default() }, sun(12.0, 90.0)));
    let px = render(&mut app, (size, size), atlas(2048));
    set_shadows(&mut app, false);
    let plain = render(&mut app, (size, size), atlas(2048));
    let y = size / 2;
    save("peter-pan-plain", &plain, (size, size));
    save("peter-pan-shadowed", &px, (size, size));
    let lit = brightness(&plain, size, 8, y);
    let dark = brightness(&px, size, 8, y);
    assert!(lit - dark > 40.0, "the floor far in the shadow is dark: {dark} vs {lit} lit");
    // Pixels whose centre lies on the floor beside the box, walking in −X from its base.
    let mut gap = 0;
    let mut found = false;
    for x in (0..size).rev() {
        let p = world_at(x, y, size);
        if p.x >= -0.5 {
            continue;
        }
        let b = brightness(&px, size, x, y);
        if b < 0.5 * (lit + dark) {
            found = true;
            break;
        }
        gap += 1;
    }
    if !found || gap > 4 {
        save("peter-pan", &px, (size, size));
    }
    assert!(found, "no shadow beside the box");
    assert!(gap <= 4, "{gap} lit pixels between the box's base and its shadow");
}

/// sRGB 8-bit to CIELAB (D65).
fn lab(rgb: [u8; 3]) -> [f32; 3] {
    let lin = |c: u8| {
        let c = c as f32 / 255.0;
        if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
    };
    let (r, g, b) = (lin(rgb[0]), lin(rgb[1]), lin(rgb[2]));
    let x = (0.4124 * r + 0.3576 * g + 0.1805 * b) / 0.95047;
    let y = 0.2126 * r + 0.7152 * g + 0.0722 * b;
    let z = (0.0193 * r + 0.1192 * g + 0.9505 * b) / 1.08883;
    let f = |t: f32| if t > 0.008856 { t.cbrt() } else { 7.787 * t + 16.0 / 116.0 };
    [116.0 * f(y) - 16.0, 500.0 * (f(x) - f(y)), 200.0 * (f(y) - f(z))]
}

/// Test 1: 16 pixels along the screen's centre column whose floor points straddle the boundary
/// between the first two cascades (from 20% before it to 5% past it, through the blend zone)
/// differ pairwise by ΔE76 < 2, with the floor lit but also crossed by a shadow's edge region
/// nowhere near (the samples are all lit).
#[test]
fn no_seam_where_cascades_meet() {
    let size = (160u32, 400u32);
    let (height, pitch) = (1.5f32, 12f32.to_radians());
    let mut app = scene_app();
    spawn_mesh(&mut app, Mesh::plane(400.0), grey(0.8), Transform::default());
    // A caster off to the side, so the cascades hold something besides the floor.
    spawn_mesh(&mut app, Mesh::cuboid(Vec3::ONE), grey(0.5), Transform::from_xyz(-6.0, 0.5, -8.0));
    app.world.spawn((DirectionalLight { illuminance: 2.0, ..Default::default() }, sun(50.0, 300.0)));
    let yfov = 45f32.to_radians();
    let rotation = Quat::from_rotation_x(-pitch);
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, height, 0.0).with_rotation(rotation)));
    let px = render(&mut app, size, atlas(1024));
    let frame = app.world.resource::<Renderer>().shadow_frame().clone();
    assert!(frame.rendered.iter().take(2).all(|r| *r), "both cascades render: {:?}", frame.rendered);
    let boundary = frame.cascades[0].far;
    // View depth of the floor seen through the centre column's pixel row `y`.
    let depth_at = |y: u32| {
        let ndc = 1.0 - 2.0 * (y as f32 + 0.5) / size.1 as f32;
        let dir_y = ndc * (0.5 * yfov).tan() * pitch.cos() - pitch.sin();
        if dir_y < 0.0 { height / -dir_y } else { f32::INFINITY }
    };
    let rows: Vec<u32> = (0..size.1).filter(|&y| (0.8 * boundary..1.05 * boundary).contains(&depth_at(y))).collect();
    assert!(rows.len() >= 16, "{} rows cover the blend zone", rows.len());
    let x = size.0 / 2;
    let samples: Vec<[f32; 3]> = (0..16)
        .map(|i| {
            let y = rows[i * (rows.len() - 1) / 15];
            let k = ((y * size.0 + x) * 4) as usize;
            lab([px[k], px[k + 1], px[k + 2]])
        })
        .collect();
    let mut worst = 0f32;
    for a in &samples {
        for b in &samples {
            worst = worst.max(((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt());
        }
    }
    eprintln!("boundary at {boundary:.2} m over {} rows: worst pairwise ΔE76 {worst:.3}", rows.len());
    if worst >= 2.0 {
        save("seam", &px, size);
    }
    assert!(samples[0][0] > 50.0, "the samples are lit floor (L* {})", samples[0][0]);
    assert!(worst < 2.0, "ΔE76 {worst} across the cascade boundary");
}

/// Test 2: PCSS penumbrae widen with the occluder's height. A 1 m slab at five heights over the
/// floor under a light of 3° angular radius; the width of its shadow's edge (10% to 90% of the
/// way from shadow to light, along the floor, interpolated between pixels) grows with every
/// step and the widest is at least 1.5 times the narrowest. One cascade reaching 20 m (texels of
/// 1 cm), so the floor, 10 m below the camera, is read from one cascade only.
#[test]
fn pcss_penumbrae_widen_with_the_occluders_height() {
    let size = 256;
    let mut widths = Vec::new();
    for height in [0.4f32, 0.8, 1.2, 1.6, 2.0] {
        let mut app = scene_app();
        let world_at = top_down(&mut app, 2.0);
        let slab = Mesh::cuboid(Vec3::new(1.0, 0.02, 3.0));
        spawn_mesh(&mut app, slab, grey(0.5), Transform::from_xyz(0.5, height, 0.0));
        let light = DirectionalLight { illuminance: 3.0, angular_radius: 3f32.to_radians(), ..Default::default() };
        app.world.spawn((light, sun(60.0, 90.0)));
        let pcss = ShadowSettings {
            atlas_size: 2048,
            filter: ShadowFilter::Pcss,
            cascades: 1,
            max_distance: 20.0,
            ..Default::default()
        };
        let px = render(&mut app, (size, size), pcss);
        let y = size / 2;
        // The floor from the left edge of the frame to the slab's left edge (x = 0): the
        // shadow's left edge lies at x = −height / tan 60°.
        let row: Vec<(f32, f32)> = (0..size)
            .map(|x| (world_at(x, y, size).x, brightness(&px, size, x, y)))
            .filter(|(wx, _)| *wx < -0.02)
            .collect();
        let lit = row.first().unwrap().1;
        let dark = row.iter().map(|r| r.1).fold(f32::MAX, f32::min);
        assert!(lit - dark > 40.0, "height {height}: a shadow on the floor ({dark} vs {lit})");
        // Where the brightness first falls to `share` of the way from lit to dark, between
        // pixel centres.
        let at = |share: f32| {
            let level = lit - share * (lit - dark);
            let i = row.iter().position(|(_, b)| *b <= level).expect("crosses");
            let (x0, b0) = row[i.saturating_sub(1)];
            let (x1, b1) = row[i];
            if b0 == b1 { x1 } else { x0 + (x1 - x0) * (b0 - level) / (b0 - b1) }
        };
        let width = at(0.9) - at(0.1);
        eprintln!("height {height} m: penumbra {width:.4} m ({:.1} px)", width * size as f32 / 4.0);
        if height == 2.0 {
            save("pcss", &px, (size, size));
        }
        widths.push(width);
    }
    assert!(widths.windows(2).all(|w| w[1] > w[0]), "penumbra widths {widths:?} do not grow with height");
    let ratio = widths[4] / widths[0];
    assert!(ratio >= 1.5, "widest/narrowest penumbra {ratio} (widths {widths:?})");
}

/// What a scene does not need is left out: no shadow pass, atlas or shadow shader code without
/// a shadowed light and a caster, and cascades beyond everything visible are not rendered.
#[test]
fn shadows_cost_nothing_without_casters_and_follow_what_the_camera_sees() {
    let size = (96, 64);
    let mut app = scene_app();
    let floor = spawn_mesh(&mut app, Mesh::plane(3.0), grey(0.8), Transform::default());
    spawn_mesh(&mut app, Mesh::cuboid(Vec3::splat(0.5)), grey(0.5), Transform::from_xyz(0.0, 0.25, 0.0));
    let light = app.world.spawn((DirectionalLight { illuminance: 2.0, ..Default::default() }, sun(50.0, 30.0))).id();
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 2.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y)));

    // The forward pass's pipeline keys say which shader variants ran: the hardware rasteriser
    // (the default on lavapipe; on GPUs with few graphics units compute shading would run).
    let hardware = RenderSettings { raster: Raster::Hardware, ..settings(ShadowSettings::default()) };
    render_app(&mut app, size, hardware);
    let renderer = app.world.resource::<Renderer>();
    let frame = renderer.shadow_frame();
    assert!(renderer.stats().plan.runs(Pass::SHADOWS));
    assert_eq!(frame.cascades.len(), 4);
    // Everything lies within 5 m of the camera; the default cascades reach 100 m.
    assert!(frame.rendered[0] && !frame.rendered[3], "rendered layers {:?}", frame.rendered);
    // The atlas holds layers up to the farthest cascade that renders, not all four, each as
    // large as the largest window of its cascade's map that receivers read.
    let rendered_to = frame.rendered.iter().rposition(|r| *r).unwrap() + 1;
    let (w, h) = frame.layer_extent;
    let layer = 4 * w as u64 * h as u64;
    assert_eq!(renderer.memory().shadows, rendered_to as u64 * layer, "rendered layers {:?}", frame.rendered);
    assert!(layer < 4 * (ShadowSettings::default().atlas_size as u64).pow(2), "{w}×{h} layers");
    assert!(renderer.forward_pipeline_keys().iter().all(|k| k.shadows));

    // The light stops casting: no pass, no atlas, shaders without shadow code.
    app.world.get_mut::<DirectionalLight>(light).unwrap().shadows = false;
    let px = {
        app.update();
        app.world.resource::<Renderer>().read_frame().unwrap()
    };
    let renderer = app.world.resource::<Renderer>();
    assert!(!renderer.stats().plan.runs(Pass::SHADOWS));
    assert_eq!(renderer.memory().shadows, 0, "the atlas is released");
    assert!(px.chunks_exact(4).any(|p| p[0] > 100), "still lit");
    assert!(renderer.stats().pipelines > 0);

    // Casting again, but nothing opaque is drawn (the floor turns transparent, the box hidden).
    app.world.get_mut::<DirectionalLight>(light).unwrap().shadows = true;
    let glass = app
        .world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial { alpha_mode: AlphaMode::Blend, ..grey(0.8) });
    app.world.entity_mut(floor).insert(MeshMaterial3d(glass));
    let mut q = app.world.query_filtered::<&mut Visibility, Without<Camera>>();
    for mut v in q.iter_mut(&mut app.world) {
        *v = Visibility::Hidden;
    }
    app.world.entity_mut(floor).insert(Visibility::Visible);
    app.update();
    let renderer = app.world.resource::<Renderer>();
    assert!(!renderer.stats().plan.runs(Pass::SHADOWS), "{}", renderer.stats().plan);
    assert_eq!(renderer.memory().shadows, 0);
}

/// A cascade layer stores only the window of its map that the receivers reading it look up: a
/// small floor seen from above takes a fraction of each layer, and the frame is the one whole
/// slices give. (Three tiny transparent boxes outside the view, which no pixel shows and which
/// cast nothing, stretch the receivers' box over every slice of the view, so every window
/// becomes its slice's whole extent on the map.) A camera move that takes the receivers out of
/// the stored windows redraws them (and grows the layers) into the frame a fresh renderer draws.
#[test]
fn cascade_layers_store_only_the_texels_receivers_read() {
    let size = (96, 64);
    let mut app = scene_app();
    spawn_mesh(&mut app, Mesh::plane(3.0), grey(0.8), Transform::default());
    spawn_mesh(&mut app, Mesh::cuboid(Vec3::splat(0.5)), grey(0.5), Transform::from_xyz(0.3, 0.25, -0.2));
    spawn_mesh(&mut app, Mesh::uv_sphere(0.3, 24, 12), grey(0.6), Transform::from_xyz(-0.6, 0.3, 0.5));
    app.world.spawn((DirectionalLight { illuminance: 2.0, ..Default::default() }, sun(50.0, 30.0)));
    let near = Transform::from_xyz(0.0, 2.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y);
    let camera = app.world.spawn((Camera::default(), near)).id();
    let full_map = ShadowSettings::default().atlas_size;
    let hardware = RenderSettings { raster: Raster::Hardware, ..settings(ShadowSettings::default()) };
    let layer_bytes = |frame: &penumbra::render::features::shadows::orchestrator::ShadowFrame| {
        4 * frame.layer_extent.0 as u64 * frame.layer_extent.1 as u64
    };
    // The same shadows, to the rounding of the layers' matrices.
    let same = |a: &[u8], b: &[u8], what: &str| {
        let differing = a.iter().zip(b).filter(|(a, b)| a.abs_diff(**b) > 1).count();
        assert!(differing <= a.len() / 1000, "{what}: {differing} channels differ by more than 1");
    };

    let windowed = render_app(&mut app, size, hardware.clone());
    let renderer = app.world.resource::<Renderer>();
    let small = renderer.shadow_frame().clone();
    let layers = small.stored.len() as u64;
    assert!(small.rendered.iter().filter(|r| **r).count() >= 2, "{:?}", small.rendered);
    assert_eq!(renderer.memory().shadows, layers * layer_bytes(&small));
    assert!(layer_bytes(&small) < 4 * (full_map as u64).pow(2) / 2, "{:?}", small.layer_extent);
    for (i, stored) in small.stored.iter().enumerate() {
        if let Some(stored) = stored {
            assert!(stored.contains(&small.receiver_windows[i].unwrap()), "layer {i}");
            assert!(stored.width <= small.layer_extent.0 && stored.height <= small.layer_extent.1);
        }
    }
    eprintln!("layers {:?} of {full_map}²: {:?}", small.layer_extent, small.stored);

    // Farther back and to the side: the floor projects elsewhere on every cascade's map.
    let far = Transform::from_xyz(2.5, 3.0, 5.0).looking_at(Vec3::ZERO, Vec3::Y);
    *app.world.get_mut::<Transform>(camera).unwrap() = far;
    app.update();
    let renderer = app.world.resource::<Renderer>();
    let moved = renderer.read_frame().unwrap();
    let after = renderer.shadow_frame().clone();
    assert!(after.redraw.iter().any(|r| *r), "the receivers left the stored windows: {:?}", after.stored);
    app.world.remove_resource::<Renderer>();
    let fresh = render_app(&mut app, size, hardware.clone());
    same(&moved, &fresh, "after the move against a fresh renderer");

    *app.world.get_mut::<Transform>(camera).unwrap() = near;
    let glass = StandardMaterial { alpha_mode: AlphaMode::Blend, ..grey(0.8) };
    for at in [Vec3::new(-600.0, -400.0, -400.0), Vec3::new(600.0, -400.0, -400.0), Vec3::new(0.0, 400.0, 13.0)] {
        spawn_mesh(&mut app, Mesh::cuboid(Vec3::splat(0.01)), glass.clone(), Transform::from_translation(at));
    }
    app.world.remove_resource::<Renderer>();
    let whole = render_app(&mut app, size, hardware);
    let renderer = app.world.resource::<Renderer>();
    let large = renderer.shadow_frame().clone();
    eprintln!("with the boxes: layers {:?}: {:?}", large.layer_extent, large.stored);
    // (The boxes lie deeper than the floor: the far cascades render too, for pixels that show none.)
    assert!(small.rendered.iter().zip(&large.rendered).all(|(s, l)| !s || *l), "{:?}", large.rendered);
    for (i, (l, s)) in large.stored.iter().zip(&small.stored).enumerate() {
        if let (Some(l), Some(s)) = (l, s) {
            assert!(l.contains(s) && l.width * l.height > 2 * s.width * s.height, "layer {i}: {l:?} against {s:?}");
        }
    }
    same(&windowed, &whole, "windows against whole slices");
    assert!(windowed.chunks_exact(4).any(|p| p[0] > 100), "lit");
}

/// A cascade shadows only receivers inside its slice of the view: when everything visible lies
/// beyond the shadow distance, casters in the cascades' boxes (which reach toward the light, far
/// outside the view) are not drawn, and the frame is the one without shadows.
#[test]
fn casters_are_not_drawn_for_receivers_beyond_the_shadow_distance() {
    let size = (96, 64);
    let mut app = scene_app();
    spawn_mesh(&mut app, Mesh::plane(3.0), grey(0.8), Transform::default());
    spawn_mesh(&mut app, Mesh::cuboid(Vec3::splat(0.5)), grey(0.5), Transform::from_xyz(0.0, 0.25, 0.0));
    app.world.spawn((DirectionalLight { illuminance: 2.0, ..Default::default() }, sun(50.0, 30.0)));
    // The receivers' box (floor and box: 3 m by 0.5 m by 3 m) is nearest, 2.08 m along the
    // view, at its corners in front of the camera.
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 2.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y)));
    let near = ShadowSettings { max_distance: 2.0, ..Default::default() };
    let px = render(&mut app, size, near);
    let renderer = app.world.resource::<Renderer>();
    assert!(renderer.shadow_frame().rendered.iter().all(|r| !r), "{:?}", renderer.shadow_frame().rendered);
    assert!(!renderer.stats().plan.runs(Pass::SHADOWS), "{}", renderer.stats().plan);
    assert_eq!(renderer.memory().shadows, 0);
    set_shadows(&mut app, false);
    assert_eq!(px, render(&mut app, size, near), "the same frame as without shadows");

    // A little farther and the last cascade reaches the box of receivers: it renders.
    set_shadows(&mut app, true);
    let far = ShadowSettings { max_distance: 2.6, ..Default::default() };
    render(&mut app, size, far);
    let renderer = app.world.resource::<Renderer>();
    assert!(renderer.shadow_frame().rendered[3], "{:?}", renderer.shadow_frame().rendered);
    assert!(renderer.stats().plan.runs(Pass::SHADOWS), "{}", renderer.stats().plan);
}

/// Each cascade draws only the casters that can shadow what reads it, culled on the GPU: a row
/// of cubes running 80 m away from the camera under a sun behind it, four cascades. Each
/// cascade's count of cubes is at most those its box may touch (the box's corners in light clip
/// space, with a margin), and all together fewer than the boxes certainly hold: a cube beyond a
/// cascade's slice of the view, away from the light, casts nothing that the slice shows. The
/// frames, with PCF and with PCSS (whose lookups reach farthest), are the ones the full list
/// draws (GPU culling off), also after the camera moved a millimetre and the cascades drawn
/// with the earlier pose's culling were kept.
#[test]
fn each_cascade_draws_only_the_casters_that_can_shadow_what_it_covers() {
    let size = (96, 64);
    let mut app = scene_app();
    spawn_mesh(&mut app, Mesh::plane(200.0), grey(0.8), Transform::default());
    let cubes: Vec<Vec3> = (0..40).map(|k| Vec3::new(0.0, 0.25, 1.0 - 2.0 * k as f32)).collect();
    for &c in &cubes {
        spawn_mesh(&mut app, Mesh::cuboid(Vec3::splat(0.5)), grey(0.5), Transform::from_translation(c));
    }
    app.world
        .spawn((DirectionalLight { illuminance: 2.0, angular_radius: 0.02, ..Default::default() }, sun(50.0, 30.0)));
    let pose = |x: f32| Transform::from_xyz(x, 2.0, 3.0).looking_at(Vec3::new(x, 0.0, -10.0), Vec3::Y);
    let camera = app.world.spawn((Camera::default(), pose(0.0))).id();
    for filter in [ShadowFilter::Pcf, ShadowFilter::Pcss] {
        // The hardware rasteriser for the view in both frames: without GPU culling the view
        // could not be rasterised in compute, and only the shadow maps' lists are compared here.
        let hardware =
            RenderSettings { raster: Raster::Hardware, ..settings(ShadowSettings { filter, ..Default::default() }) };
        *app.world.get_mut::<Transform>(camera).unwrap() = pose(0.0);
        app.world.remove_resource::<Renderer>();
        let culled = render_app(&mut app, size, hardware.clone());
        let renderer = app.world.resource::<Renderer>();
        let frame = renderer.shadow_frame().clone();
        let counts = renderer.shadow_caster_counts().unwrap().expect("the maps were culled");
        let drawn: Vec<usize> = (0..frame.redraw.len()).filter(|&l| frame.redraw[l]).collect();
        assert_eq!(counts.len(), drawn.len(), "one list per map drawn: {counts:?}");
        assert!(drawn.len() >= 3, "cascades drawn: {:?}", frame.redraw);
        let (mut all_drawn, mut all_certain) = (0, 0);
        for (map, &layer) in counts.iter().zip(&drawn) {
            let m = frame.cascades[layer].clip_from_world;
            let (mut certain, mut possible) = (0, 0);
            for c in &cubes {
                let (mut lo, mut hi) = (glam::DVec3::splat(f64::MAX), glam::DVec3::splat(f64::MIN));
                for i in 0..8 {
                    let corner = c.as_dvec3()
                        + 0.25 * glam::DVec3::new([-1.0, 1.0][i & 1], [-1.0, 1.0][(i >> 1) & 1], [-1.0, 1.0][i >> 2]);
                    let p = m.project_point3(corner);
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
                let overlaps = |e: f64| {
                    lo.x <= 1.0 + e
                        && hi.x >= -1.0 - e
                        && lo.y <= 1.0 + e
                        && hi.y >= -1.0 - e
                        && lo.z <= 1.0 + e
                        && hi.z >= -e
                };
                certain += overlaps(-1e-3) as u32;
                possible += overlaps(1e-3) as u32;
            }
            // Each mesh is its own batch of one instance; the floor, under every cascade, is
            // one of them in every map.
            let total: u32 = map.iter().sum();
            assert!(total >= 1 && map.iter().all(|&n| n <= 1), "layer {layer}: {map:?}");
            let cubes_drawn = total - 1;
            assert!(
                cubes_drawn <= possible,
                "layer {layer}: {cubes_drawn} cubes drawn, {possible} possibly in its box"
            );
            all_drawn += cubes_drawn;
            all_certain += certain;
        }
        assert!(all_drawn < all_certain, "{filter:?}: {all_drawn} cubes drawn, {all_certain} certainly in the boxes");

        // A millimetre sideways: the cascades keep what they hold (their planes reach past
        // the move), and the frame is still the full list's.
        *app.world.get_mut::<Transform>(camera).unwrap() = pose(0.001);
        app.update();
        let renderer = app.world.resource::<Renderer>();
        let kept = renderer.shadow_frame().rendered_layers();
        let moved = renderer.read_frame().unwrap();

        let unculled = RenderSettings { gpu_culling: false, ..hardware };
        app.world.remove_resource::<Renderer>();
        let full_moved = render_app(&mut app, size, unculled.clone());
        *app.world.get_mut::<Transform>(camera).unwrap() = pose(0.0);
        app.world.remove_resource::<Renderer>();
        let full = render_app(&mut app, size, unculled);
        assert!(app.world.resource::<Renderer>().shadow_caster_counts().unwrap().is_none());
        assert_eq!(culled, full, "{filter:?}: the frame the full list draws");
        assert_eq!(moved, full_moved, "{filter:?}: after the move ({kept} layers drawn again)");
    }
}

/// Where a point light at `light` throws the shadow of the box `min..max` onto the floor (y = 0):
/// whether the floor point `p` lies inside the projected box (the hull of its corners' shadows),
/// and how far from the hull's edge (positive inside), in metres.
fn shadow_depth_inside(light: Vec3, min: Vec3, max: Vec3, p: Vec3) -> f32 {
    let mut pts: Vec<Vec2> = Vec::new();
    for i in 0..8 {
        let c = Vec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        );
        let k = light.y / (light.y - c.y);
        let f = light + (c - light) * k;
        pts.push(Vec2::new(f.x, f.z));
    }
    // Convex hull (gift wrapping), counter-clockwise.
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    let cross = |o: Vec2, a: Vec2, b: Vec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<Vec2> = Vec::new();
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &Vec2>> =
            if pass == 0 { Box::new(pts.iter()) } else { Box::new(pts.iter().rev()) };
        for &q in iter {
            while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0 {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    let q = Vec2::new(p.x, p.z);
    let mut depth = f32::MAX;
    for i in 0..hull.len() {
        let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
        let edge = (b - a).normalize();
        // Signed distance to the edge's line, positive on the inner (left) side.
        depth = depth.min(edge.perp_dot(q - a));
    }
    depth
}

/// Test 5: a 1 m slab at 1.5 m between a local light at 3 m and the floor darkens the region
/// the slab's silhouette projects to, and nothing else. Seen from straight above at 64 px/m;
/// pixels within 3 px (4.7 cm) of the silhouette's edge are not judged: the 3×3 bilinear filter
/// reaches 2 texels (about 1.4 cm at this distance with 1024² maps), the receiver's normal
/// offset shifts up to 1.5 texels (1 cm), and a pixel spans 1.6 cm. Pixels where the slab itself
/// is seen are skipped too. For a point light the shadow crosses cube faces (−Y and −X).
#[test]
fn spot_and_point_lights_shadow_exactly_their_silhouette() {
    let size = 256;
    let light_at = Vec3::new(1.2, 3.0, 0.4);
    let (min, max) = (Vec3::new(-0.5, 1.49, -0.5), Vec3::new(0.5, 1.51, 0.5));
    for spot in [true, false] {
        let mut app = scene_app();
        let world_at = top_down(&mut app, 2.0);
        spawn_mesh(&mut app, Mesh::cuboid(max - min), grey(0.5), Transform::from_translation(0.5 * (min + max)));
        let place = Transform::from_translation(light_at).looking_at(light_at + Vec3::NEG_Y, Vec3::Z);
        let light = if spot {
            app.world
                .spawn((
                    SpotLight {
                        intensity: 20.0,
                        range: Some(20.0),
                        inner_cone_angle: 55f32.to_radians(),
                        outer_cone_angle: 60f32.to_radians(),
                        ..Default::default()
                    },
                    place,
                ))
                .id()
        } else {
            app.world.spawn((PointLight { intensity: 20.0, range: Some(20.0), ..Default::default() }, place)).id()
        };
        let what = if spot { "spot light" } else { "point light" };
        let px = render(&mut app, (size, size), atlas(512));
        let frame = app.world.resource::<Renderer>().shadow_frame().clone();
        assert_eq!(frame.local.first_layers.len(), 1, "{what}: one shadowed light");
        assert_eq!(frame.local.render.len(), if spot { 1 } else { 6 }, "{what}: its layers render");
        assert!(app.world.resource::<Renderer>().stats().plan.runs(Pass::SHADOWS));
        // The local atlas holds one cube's layers (whole cubes), not the settings' 24.
        let local_map = ShadowSettings::default().local_map_size as u64;
        let layer = local_map * local_map * 4;
        let held = app.world.resource::<Renderer>().memory().shadows;
        assert!((6 * layer..7 * layer).contains(&held), "{what}: {held} bytes of shadow maps");
        // The same frame without the light's shadows.
        if spot {
            app.world.get_mut::<SpotLight>(light).unwrap().shadows = false;
        } else {
            app.world.get_mut::<PointLight>(light).unwrap().shadows = false;
        }
        let plain = render(&mut app, (size, size), atlas(512));
        assert!(!app.world.resource::<Renderer>().stats().plan.runs(Pass::SHADOWS));
        let tolerance = 3.0 * 4.0 / size as f32;
        let (mut wrong, mut judged_dark, mut judged_lit) = (0, 0, 0);
        for y in 0..size {
            for x in 0..size {
                let p = world_at(x, y, size);
                let on_slab = p.x.abs() < 0.5 + tolerance && p.z.abs() < 0.5 + tolerance;
                let depth = shadow_depth_inside(light_at, min, max, p);
                if on_slab || depth.abs() < tolerance {
                    continue;
                }
                let (s, l) = (brightness(&px, size, x, y), brightness(&plain, size, x, y));
                if depth > 0.0 {
                    judged_dark += 1;
                    wrong += (s > 0.1 * l + 1.0) as u32;
                } else {
                    judged_lit += 1;
                    wrong += ((s - l).abs() > 1.0) as u32;
                }
            }
        }
        eprintln!("{what}: {judged_dark} pixels in shadow, {judged_lit} lit, {wrong} wrong");
        save(if spot { "spot" } else { "point" }, &px, (size, size));
        assert!(judged_dark > 5000 && judged_lit > 20000, "{what}: {judged_dark} dark, {judged_lit} lit judged");
        assert_eq!(wrong, 0, "{what}: pixels shadowed where they should not be, or lit in the shadow");
    }
}

fn check_shadow_golden(make: fn() -> common::golden_scenes::GoldenFrame) -> common::golden_scenes::GoldenFrame {
    common::golden_scenes::check_golden_frame(&make, common::Tolerance::default())
}

/// Golden: a "night club" — 200 coloured point lights over a floor with pillars and balls, four
/// of them casting cube shadows, under a dim moon with cascades.
#[test]
fn golden_night_club() {
    let frame = check_shadow_golden(common::golden_scenes::night_club);
    let frame = frame.app.world.resource::<Renderer>().shadow_frame().clone();
    assert_eq!(frame.local.first_layers.len(), 4, "four cube-shadowed lights");
    assert!(frame.rendered.iter().any(|r| *r), "the moon's cascades");
}

/// Golden: DamagedHelmet on a ground plane under a shadowed sun (PCSS).
#[test]
fn golden_damaged_helmet_under_the_sun() {
    check_shadow_golden(common::golden_scenes::helmet_under_the_sun);
}

/// A still camera over a still scene draws its shadow maps once: later frames skip the shadow
/// passes and show the same image; moving a caster or the camera draws them again.
#[test]
fn shadow_maps_are_drawn_again_only_when_something_moves() {
    let size = (96, 64);
    let mut app = scene_app();
    spawn_mesh(&mut app, Mesh::plane(20.0), grey(0.8), Transform::default());
    let cube = spawn_mesh(&mut app, Mesh::cuboid(Vec3::ONE), grey(0.5), Transform::from_xyz(0.0, 0.5, 0.0));
    app.world.spawn((DirectionalLight { illuminance: 2.0, ..Default::default() }, sun(45.0, 30.0)));
    app.world.spawn((
        PointLight { intensity: 5.0, range: Some(6.0), ..Default::default() },
        Transform::from_xyz(1.5, 2.0, 1.0),
    ));
    let camera =
        app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 3.0, 5.0).looking_at(Vec3::ZERO, Vec3::Y))).id();
    let first = render(&mut app, size, atlas(512));
    let drawn = |app: &App| app.world.resource::<Renderer>().shadow_frame().rendered_layers();
    assert!(drawn(&app) > 6, "cascades and the cube map drawn on the first frame");
    app.update();
    let second = app.world.resource::<Renderer>().read_frame().unwrap();
    assert_eq!(drawn(&app), 0, "nothing moved: no shadow pass");
    assert!(!app.world.resource::<Renderer>().stats().plan.runs(Pass::SHADOWS));
    assert_eq!(first, second, "the kept maps give the same image");
    app.world.get_mut::<Transform>(cube).unwrap().translation.x += 0.3;
    app.update();
    let frame = app.world.resource::<Renderer>().shadow_frame().clone();
    assert!(
        frame.redraw.iter().any(|r| *r) && frame.local.render.len() == 6,
        "a caster moved: the maps it reaches redrawn"
    );
    app.world.get_mut::<Transform>(camera).unwrap().translation.x += 1.0;
    app.update();
    let frame = app.world.resource::<Renderer>().shadow_frame().clone();
    assert!(frame.redraw.iter().any(|r| *r), "the camera moved: its cascades follow");
    assert!(frame.local.render.is_empty(), "a point light's map does not depend on the camera");
}

/// A cascade keeps its layer while nothing that moved, where it was or where it is, reaches the
/// window it stores, and a point light its cube while nothing that moved lies within its reach:
/// a box moving beside the camera redraws the near cascades only, one moving far ahead (under
/// the point light) the farthest cascade and the cube, and each frame equals a fresh renderer's.
#[test]
fn a_cascade_keeps_its_layer_while_what_moved_cannot_reach_it() {
    let size = (96, 64);
    let mut app = scene_app();
    spawn_mesh(&mut app, Mesh::plane(200.0), grey(0.8), Transform::default());
    let near = spawn_mesh(&mut app, Mesh::cuboid(Vec3::splat(0.5)), grey(0.5), Transform::from_xyz(0.5, 0.25, 0.5));
    let far = spawn_mesh(&mut app, Mesh::cuboid(Vec3::splat(2.0)), grey(0.5), Transform::from_xyz(0.0, 1.0, -60.0));
    app.world.spawn((DirectionalLight { illuminance: 2.0, ..Default::default() }, sun(50.0, 30.0)));
    // A point light over the far box, reaching 5 m.
    app.world.spawn((
        PointLight { intensity: 50.0, range: Some(5.0), ..Default::default() },
        Transform::from_xyz(1.5, 3.0, -58.0),
    ));
    app.world
        .spawn((Camera::default(), Transform::from_xyz(0.0, 2.0, 3.0).looking_at(Vec3::new(0.0, 0.0, -10.0), Vec3::Y)));
    let hardware = RenderSettings { raster: Raster::Hardware, ..settings(ShadowSettings::default()) };
    render_app(&mut app, size, hardware.clone());
    let first = app.world.resource::<Renderer>().shadow_frame().clone();
    assert!(first.rendered.iter().filter(|r| **r).count() >= 3, "{:?}", first.rendered);
    assert_eq!(first.local.render.len(), 6, "the point light's cube");

    let step = |app: &mut App, moved: Entity, by: Vec3| {
        app.world.get_mut::<Transform>(moved).unwrap().translation += by;
        app.update();
        let renderer = app.world.resource::<Renderer>();
        let (frame, px) = (renderer.shadow_frame().clone(), renderer.read_frame().unwrap());
        app.world.remove_resource::<Renderer>();
        let fresh = render_app(app, size, hardware.clone());
        let differing = px.iter().zip(&fresh).filter(|(a, b)| a != b).count();
        assert!(differing == 0, "{differing} channels differ from a fresh renderer's frame");
        // The fresh renderer draws every layer; the next step starts from its maps.
        frame
    };
    let frame = step(&mut app, near, Vec3::new(0.2, 0.0, 0.0));
    let (rendered, redraw) = (&frame.rendered, &frame.redraw);
    assert!(redraw[0], "the near cascade holds the box: {redraw:?}");
    let kept = (1..redraw.len()).filter(|&i| rendered[i] && !redraw[i]).count();
    assert!(kept >= 1, "the far cascades do not reach the box: rendered {rendered:?}, redrawn {redraw:?}");
    assert!(frame.local.render.is_empty(), "the point light's reach does not hold the box");
    eprintln!("near box moved: rendered {rendered:?}, redrawn {redraw:?}");

    let frame = step(&mut app, far, Vec3::new(0.5, 0.0, 0.0));
    let last = frame.rendered.iter().rposition(|r| *r).unwrap();
    assert!(frame.redraw[last] && !frame.redraw[0], "the far box moved: redrawn {:?}", frame.redraw);
    assert_eq!(frame.local.render.len(), 6, "the far box lies in the point light's reach");
    eprintln!("far box moved: rendered {:?}, redrawn {:?}", frame.rendered, frame.redraw);
}

/// The cascade debug view colours each fragment by its cascade: along the screen's centre
/// column, every floor pixel (more than two rows from a boundary) shows the tint of the cascade
/// its view depth falls in, and at least three cascades show.
#[test]
fn the_cascade_view_colours_fragments_by_their_cascade() {
    let size = (64u32, 400u32);
    let (height, pitch) = (1.5f32, 12f32.to_radians());
    let mut app = scene_app();
    spawn_mesh(&mut app, Mesh::plane(400.0), grey(0.8), Transform::default());
    spawn_mesh(&mut app, Mesh::cuboid(Vec3::ONE), grey(0.5), Transform::from_xyz(-6.0, 0.5, -8.0));
    app.world.spawn((DirectionalLight { illuminance: 2.0, ..Default::default() }, sun(50.0, 300.0)));
    app.world
        .spawn((Camera::default(), Transform::from_xyz(0.0, height, 0.0).with_rotation(Quat::from_rotation_x(-pitch))));
    app.world.remove_resource::<Renderer>();
    let settings = RenderSettings {
        msaa: 1,
        debug_view: penumbra::render::DebugView::Cascades,
        shadows: atlas(512),
        ..Default::default()
    };
    let px = render_app(&mut app, size, settings);
    let frame = app.world.resource::<Renderer>().shadow_frame().clone();
    let fars: Vec<f32> = frame.cascades.iter().map(|c| c.far).collect();
    let yfov = 45f32.to_radians();
    let depth_at = |y: f32| {
        let ndc = 1.0 - 2.0 * (y + 0.5) / size.1 as f32;
        let dir_y = ndc * (0.5 * yfov).tan() * pitch.cos() - pitch.sin();
        if dir_y < 0.0 { height / -dir_y } else { f32::INFINITY }
    };
    let cascade_of = |d: f32| fars.iter().position(|f| d < *f).unwrap_or(4);
    // Dominant channels of the tints: red, green, blue, red and green (yellow), grey.
    let classify = |p: &[u8]| {
        let (r, g, b) = (p[0] as i32, p[1] as i32, p[2] as i32);
        match () {
            _ if r > 2 * b && g > 2 * b && (r - g).abs() < r / 3 => 3,
            _ if r > 2 * g && r > 2 * b => 0,
            _ if g > 2 * r && g > 2 * b => 1,
            _ if b > r + r / 2 && b > g => 2,
            _ => 4,
        }
    };
    let mut seen = std::collections::BTreeSet::new();
    let x = size.0 / 2;
    for y in 0..size.1 {
        let expected = cascade_of(depth_at(y as f32));
        if expected == 4
            || cascade_of(depth_at(y as f32 - 2.0)) != expected
            || cascade_of(depth_at(y as f32 + 2.0)) != expected
        {
            continue;
        }
        let k = ((y * size.0 + x) * 4) as usize;
        let got = classify(&px[k..k + 3]);
        if got != expected {
            save("cascade-view", &px, size);
        }
        assert_eq!(got, expected, "row {y} at depth {:.2} m: pixel {:?}", depth_at(y as f32), &px[k..k + 3]);
        seen.insert(got);
    }
    assert!(seen.len() >= 3, "cascades seen: {seen:?}");
}

/// The shadow stress scene: a ground, boxes upright and tilted, a sphere, a fence cut out of a
/// checker of alpha (a masked, textured caster), and a line mesh (drawn over the visibility
/// buffer, casting nothing, but counted among the opaque batches the casters are culled from),
/// under a sun at 40°.
fn caster_scene() -> App {
    let mut app = scene_app();
    spawn_mesh(&mut app, Mesh::plane(40.0), grey(0.8), Transform::default());
    spawn_mesh(&mut app, Mesh::cuboid(Vec3::splat(0.6)), grey(0.6), Transform::from_xyz(-1.0, 0.3, -0.5));
    let tilted = Transform::from_xyz(1.2, 0.7, -1.5)
        .with_rotation(Quat::from_rotation_x(0.5) * Quat::from_rotation_y(0.8) * Quat::from_rotation_z(0.3));
    spawn_mesh(&mut app, Mesh::cuboid(Vec3::new(0.8, 0.3, 0.5)), grey(0.5), tilted);
    spawn_mesh(&mut app, Mesh::uv_sphere(0.45, 32, 16), grey(0.7), Transform::from_xyz(0.2, 0.9, 0.8));
    // Far boxes, for the outer cascades.
    for i in 0..6 {
        let at = Vec3::new(-8.0 + 3.2 * i as f32, 0.75, -9.0 - 2.0 * i as f32);
        spawn_mesh(&mut app, Mesh::cuboid(Vec3::new(0.8, 1.5, 0.8)), grey(0.6), Transform::from_translation(at));
    }
    let fence = common::checker_fence(&mut app);
    let upright = Transform::from_xyz(-2.2, 0.9, 0.6).with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2));
    spawn_mesh(&mut app, Mesh::plane(1.6), fence, upright);
    let zigzag: Vec<Vec3> =
        (0..12).map(|k| Vec3::new(-2.2 + 0.4 * k as f32, 0.4 + 0.5 * (k % 2) as f32, 1.5)).collect();
    let lines = Mesh {
        topology: Topology::LineList,
        positions: zigzag.windows(2).flat_map(|w| [w[0], w[1]]).collect(),
        ..Default::default()
    };
    let yellow = StandardMaterial { unlit: true, ..StandardMaterial::from_color(Vec4::new(1.0, 0.95, 0.2, 1.0), 1.0) };
    spawn_mesh(&mut app, lines, yellow, Transform::IDENTITY);
    app.world.spawn((DirectionalLight { illuminance: 2.0, ..Default::default() }, sun(40.0, 30.0)));
    app.world
        .spawn((Camera::default(), Transform::from_xyz(0.5, 2.5, 5.0).looking_at(Vec3::new(0.0, 0.3, -1.0), Vec3::Y)));
    app
}

/// Cascade layers rasterised in compute (in a frame whose view is) hold what the hardware's
/// caster passes draw: the same windows; the same texels covered, and the same depths within
/// 2·10⁻⁵ of the depth range (the slope-scaled bias's slope measured by the larger axis, as
/// Vulkan allows; vertex rounding), but for fewer than 1 texel in 2000 (samples exactly on an
/// edge, which two rasterisers' vertex rounding may give to different triangles); the masked
/// fence cut out alike; and frames that show the same shadows. A frame that was to be
/// rasterised in compute but goes to the hardware (`--occlusion on` asks for the forward pass's
/// depth) draws its casters through the float atlas's staging: the hardware's very depths.
#[test]
fn cascades_rasterised_in_compute_hold_the_hardwares_depths() {
    let size = (192, 128);
    let shadows = ShadowSettings { atlas_size: 1024, ..Default::default() };
    let mut layers = Vec::new();
    let mut frames = Vec::new();
    let fallback = RenderSettings { occlusion_culling: OcclusionCulling::On, ..settings(shadows) };
    let configs = [
        ("hardware", RenderSettings { raster: Raster::Hardware, ..settings(shadows) }, false),
        ("compute", RenderSettings { raster: Raster::Compute, ..settings(shadows) }, true),
        ("compute, falling back", RenderSettings { raster: Raster::Compute, ..fallback }, false),
    ];
    for (name, settings, computed) in configs {
        let mut app = caster_scene();
        let px = render_app(&mut app, size, settings.clone());
        let renderer = app.world.resource::<Renderer>();
        assert_eq!(renderer.shader_error(), None);
        let plan = &renderer.stats().plan;
        assert_eq!(plan.runs(Pass::VISIBILITY_RASTER), computed, "{name}");
        let (_, why) = plan.passes.iter().find(|(p, _)| *p == Pass::SHADOWS).expect("shadows drawn");
        assert_eq!(why.contains("rasterised in compute"), computed, "{name}: {why}");
        let frame = renderer.shadow_frame().clone();
        // The hardware draws into the layers. A float atlas (the raster setting asks for
        // compute) adds one layer's staging: the buffer compute writes, and the hardware's depth
        // target where the frame falls back.
        let layer = 4 * frame.layer_extent.0 as u64 * frame.layer_extent.1 as u64;
        let staging = match settings.raster {
            Raster::Compute => layer * if computed { 1 } else { 2 },
            _ => 0,
        };
        assert_eq!(renderer.memory().shadows, frame.stored.len() as u64 * layer + staging, "{name}");
        let depths: Vec<_> =
            (0..frame.stored.len()).map(|layer| renderer.shadow_cascade_depths(layer).unwrap()).collect();
        save(&format!("compute-{}", name.replace([' ', ','], "")), &px, size);
        layers.push((frame, depths));
        frames.push(px);
    }
    let (hardware, compute) = (&layers[0], &layers[1]);
    assert_eq!(hardware.0.stored, compute.0.stored, "the same windows");
    assert!(hardware.0.redraw.iter().filter(|r| **r).count() >= 3, "{:?}", hardware.0.redraw);
    for (layer, (h, c)) in hardware.1.iter().zip(&compute.1).enumerate() {
        let (Some((window, h)), Some((_, c))) = (h, c) else { continue };
        let covered = h.iter().filter(|d| **d > 0.0).count();
        let coverage = h.iter().zip(c).filter(|(h, c)| (**h > 0.0) != (**c > 0.0)).count();
        let both = || h.iter().zip(c).filter(|(h, c)| **h > 0.0 && **c > 0.0);
        let worst = both().map(|(h, c)| (h - c).abs()).fold(0.0, f32::max);
        let apart = both().filter(|(h, c)| (*h - *c).abs() > 2e-5).count();
        let mean = both().map(|(h, c)| (h - c).abs() as f64).sum::<f64>() / covered.max(1) as f64;
        eprintln!(
            "layer {layer} {window:?}: {covered} of {} texels covered, {coverage} differ in coverage, depths differ \
             by {worst:e} at most, {mean:e} on average",
            h.len()
        );
        assert!(covered * 4 > h.len() / 10 || layer == 3, "layer {layer}: {covered} texels covered");
        assert!(coverage * 2000 <= covered, "layer {layer}: {coverage} of {covered} texels differ in coverage");
        assert!(apart * 2000 <= covered, "layer {layer}: {apart} of {covered} texels' depths differ by more than 2e-5");
    }
    let flip = common::flip_mean(&frames[0], &frames[1], size.0, size.1);
    eprintln!("FLIP mean {flip}");
    assert!(flip < 0.001, "FLIP mean {flip} between the frames");
    // The fallback's layers hold the hardware's depths exactly.
    assert_eq!(layers[2].0.stored, hardware.0.stored);
    for (layer, (h, f)) in hardware.1.iter().zip(&layers[2].1).enumerate() {
        assert_eq!(h, f, "layer {layer}: the fallback's depths");
    }
}
