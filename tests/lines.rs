//! Line primitives: drawn as quads a pixel wide (resources/line_quads.rs), they cover exactly the
//! samples a strict hardware line of width 1 covers: the rectangle around the segment. Triangle
//! coverage is fixed by the sample positions, so these frames are the same on every driver
//! (hardware lines were not: the MeshPrimitiveModes golden moved a pixel column between
//! lavapipe and an NVIDIA driver at MSAA 4).

use penumbra::prelude::*;
use penumbra::render::{RenderSettings, Renderer};

mod common;
use common::{assert_finite_hdr, hdr_of, render_app, scene_app, spawn_mesh};

const SIZE: u32 = 64;

/// Vulkan's standard 4-sample positions within a pixel (y down).
const SAMPLES_4: [(f32, f32); 4] = [(0.375, 0.125), (0.875, 0.375), (0.125, 0.625), (0.625, 0.875)];

fn settings(msaa: u32) -> RenderSettings {
    RenderSettings { msaa, keep_hdr: true, clear_color: [0.0; 3], ..Default::default() }
}

fn unlit_white() -> StandardMaterial {
    StandardMaterial { unlit: true, ..StandardMaterial::from_color(Vec4::ONE, 1.0) }
}

fn line_mesh(segments: &[(Vec2, Vec2)]) -> Mesh {
    Mesh {
        topology: Topology::LineList,
        positions: segments.iter().flat_map(|(a, b)| [a.extend(0.0), b.extend(0.0)]).collect(),
        ..Default::default()
    }
}

fn three_points() -> Mesh {
    Mesh { topology: Topology::PointList, positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y], ..Default::default() }
}

/// A world point (x, y, 0) seen by the pixel camera: x right, y down, in pixels.
fn to_pixels(p: Vec2) -> Vec2 {
    Vec2::new(p.x + SIZE as f32 / 2.0, SIZE as f32 / 2.0 - p.y)
}

/// An orthographic camera over z = 0 whose world units are pixels.
fn pixel_camera(app: &mut App) {
    let half = SIZE as f32 / 2.0;
    let projection = Projection::Orthographic { xmag: Some(half), ymag: half, znear: 0.1, zfar: 100.0 };
    app.world.spawn((Camera { projection, ..Default::default() }, Transform::from_xyz(0.0, 0.0, 10.0)));
}

/// Fraction of `samples` (pixel-relative positions) of pixel (x, y) inside the rectangle one
/// pixel wide around segment a-b (pixel coordinates). Panics if a sample lies so close to the
/// rectangle's edge that the test would depend on rounding.
fn covered(a: Vec2, b: Vec2, x: u32, y: u32, samples: &[(f32, f32)]) -> f32 {
    let dir = (b - a).normalize();
    let len = (b - a).length();
    let inside = samples
        .iter()
        .filter(|(sx, sy)| {
            let p = Vec2::new(x as f32 + sx, y as f32 + sy) - a;
            let (along, across) = (p.dot(dir), p.perp_dot(dir).abs());
            let near = |d: f32| d.abs() < 1e-3;
            let on_end = (near(along) || near(len - along)) && across < 0.5 + 1e-3;
            let on_side = near(0.5 - across) && along > -1e-3 && along < len + 1e-3;
            assert!(!on_end && !on_side, "sample ({x}+{sx}, {y}+{sy}) lies on the rectangle's edge");
            along > 0.0 && along < len && across < 0.5
        })
        .count();
    inside as f32 / samples.len() as f32
}

/// Horizontal, vertical and two diagonal segments, placed so that no sample lies within 0.005 px
/// of a rectangle's edge.
fn segments() -> Vec<(Vec2, Vec2)> {
    vec![
        (Vec2::new(-21.8, 11.5), Vec2::new(18.2, 11.5)),
        (Vec2::new(-25.5, -28.3), Vec2::new(-25.5, 3.9)),
        (Vec2::new(-12.59, -19.83), Vec2::new(25.47, -1.71)),
        (Vec2::new(19.86, 25.13), Vec2::new(-4.21, -10.18)),
    ]
}

/// How the segments are drawn: as a line mesh, or as gizmo lines.
#[derive(Clone, Copy, Debug)]
enum Drawn {
    Mesh,
    Gizmos,
}

fn check_coverage(msaa: u32, samples: &[(f32, f32)], drawn: Drawn) {
    let mut app = scene_app();
    pixel_camera(&mut app);
    match drawn {
        Drawn::Mesh => {
            // Three points first (behind the camera), so the lines' pool entry cannot start
            // where the pool does by chance (line entries must start at a multiple of four
            // vertices).
            spawn_mesh(&mut app, three_points(), unlit_white(), Transform::from_xyz(0.0, 0.0, 50.0));
            spawn_mesh(&mut app, line_mesh(&segments()), unlit_white(), Transform::IDENTITY);
        }
        Drawn::Gizmos => {
            let mut gizmos = Gizmos::default();
            for (a, b) in segments() {
                gizmos.line(a.extend(0.0), b.extend(0.0), Vec3::ONE);
            }
            app.insert_resource(gizmos);
        }
    }
    render_app(&mut app, (SIZE, SIZE), settings(msaa));
    let hdr = hdr_of(&app);
    assert_finite_hdr(&hdr, "lines");
    let full = hdr.iter().map(|p| p[0]).fold(0.0, f32::max);
    assert!(full > 0.0, "nothing drawn");
    let lines: Vec<(Vec2, Vec2)> = segments().into_iter().map(|(a, b)| (to_pixels(a), to_pixels(b))).collect();
    let mut wrong = Vec::new();
    let mut lit = 0;
    for y in 0..SIZE {
        for x in 0..SIZE {
            // Where segments cross, samples covered by either count once.
            let mut per_sample = vec![false; samples.len()];
            for (a, b) in &lines {
                for (i, s) in samples.iter().enumerate() {
                    per_sample[i] |= covered(*a, *b, x, y, std::slice::from_ref(s)) > 0.0;
                }
            }
            let expected = per_sample.iter().filter(|c| **c).count() as f32 / samples.len() as f32;
            let got = hdr[(y * SIZE + x) as usize][0] / full;
            lit += (expected > 0.0) as u32;
            if (got - expected).abs() > 2e-3 {
                wrong.push(format!("({x}, {y}): {got:.3}, expected {expected:.3}"));
            }
        }
    }
    assert!(lit > 150, "the segments cover {lit} pixels");
    assert!(
        wrong.is_empty(),
        "MSAA {msaa}: {} of {} pixels differ: {:?}",
        wrong.len(),
        SIZE * SIZE,
        &wrong[..wrong.len().min(12)]
    );
}

#[test]
fn a_line_covers_the_pixel_centres_in_the_rectangle_one_pixel_wide_around_it() {
    check_coverage(1, &[(0.5, 0.5)], Drawn::Mesh);
}

#[test]
fn with_four_samples_a_line_covers_the_standard_sample_positions_inside_that_rectangle() {
    check_coverage(4, &SAMPLES_4, Drawn::Mesh);
}

#[test]
fn gizmo_lines_cover_the_same_rectangles() {
    check_coverage(1, &[(0.5, 0.5)], Drawn::Gizmos);
    check_coverage(4, &SAMPLES_4, Drawn::Gizmos);
}

#[test]
fn a_morphed_line_is_drawn_where_its_pose_puts_it() {
    let mut app = scene_app();
    pixel_camera(&mut app);
    spawn_mesh(&mut app, three_points(), unlit_white(), Transform::from_xyz(0.0, 0.0, 50.0));
    let (a, b) = (Vec2::new(-20.41, 0.42), Vec2::new(19.58, 0.43));
    let mut mesh = line_mesh(&[(a, b)]);
    // The target lifts the first endpoint by 10 px and the second by 20: a sloped line.
    mesh.morph_targets = vec![MorphTarget { positions: vec![Vec3::Y * 10.0, Vec3::Y * 20.0], ..Default::default() }];
    let line = spawn_mesh(&mut app, mesh, unlit_white(), Transform::IDENTITY);
    app.world.entity_mut(line).insert(MorphWeights(vec![1.0]));
    render_app(&mut app, (SIZE, SIZE), settings(1));
    let hdr = hdr_of(&app);
    let full = hdr.iter().map(|p| p[0]).fold(0.0, f32::max);
    let (pa, pb) = (to_pixels(a + Vec2::Y * 10.0), to_pixels(b + Vec2::Y * 20.0));
    for y in 0..SIZE {
        for x in 0..SIZE {
            let expected = covered(pa, pb, x, y, &[(0.5, 0.5)]);
            let got = hdr[(y * SIZE + x) as usize][0] / full;
            assert!((got - expected).abs() < 2e-3, "({x}, {y}): {got}, expected {expected}");
        }
    }
}

/// A 90° camera at the origin looking down −Z, its near plane at 0.1.
fn eye_at_origin() -> App {
    let mut app = scene_app();
    let projection = Projection::Perspective { yfov: 90f32.to_radians(), znear: 0.1, aspect_ratio: None };
    app.world.spawn((Camera { projection, ..Default::default() }, Transform::from_xyz(0.0, 0.0, 0.0)));
    app
}

#[test]
fn a_line_reaching_behind_the_camera_is_drawn_up_to_the_edge_of_the_view() {
    let mut app = eye_at_origin();
    // Below the eye, from 5 m ahead to 5 m behind: on screen it runs from the far end's image
    // down past the bottom edge.
    let (far, behind) = (Vec3::new(0.3, -1.0, -5.0), Vec3::new(0.3, -1.0, 5.0));
    let mesh = Mesh { topology: Topology::LineList, positions: vec![far, behind], ..Default::default() };
    spawn_mesh(&mut app, mesh, unlit_white(), Transform::IDENTITY);
    render_app(&mut app, (SIZE, SIZE), settings(1));
    let hdr = hdr_of(&app);
    assert_finite_hdr(&hdr, "a line crossing the eye plane");
    // The visible part's image: points of the segment in front of the near plane.
    let project = |p: Vec3| Vec2::new((p.x / -p.z + 1.0) * 32.0, (1.0 - p.y / -p.z) * 32.0);
    let image: Vec<Vec2> =
        (0..=1000).map(|i| far.lerp(Vec3::new(0.3, -1.0, -0.11), i as f32 / 1000.0)).map(project).collect();
    let mut lit_rows = std::collections::BTreeSet::new();
    for y in 0..SIZE {
        for x in 0..SIZE {
            if hdr[(y * SIZE + x) as usize][0] > 0.0 {
                let centre = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                let distance = image.iter().map(|p| p.distance(centre)).fold(f32::MAX, f32::min);
                assert!(distance < 1.0, "pixel ({x}, {y}) is lit {distance} px from the line's image");
                lit_rows.insert(y);
            }
        }
    }
    let first = (project(far).y) as u32;
    assert!(lit_rows.contains(&(first + 1)) && lit_rows.contains(&(SIZE - 1)), "rows lit: {lit_rows:?}");
    assert!(lit_rows.len() as u32 >= SIZE - 1 - first, "a gap in the line: rows {lit_rows:?}");
}

#[test]
fn single_and_double_sided_and_mirrored_lines_share_one_pipeline() {
    let mut app = scene_app();
    pixel_camera(&mut app);
    let line = line_mesh(&[(Vec2::new(-20.41, 0.42), Vec2::new(19.58, 0.43))]);
    let double_sided = StandardMaterial { double_sided: true, ..unlit_white() };
    spawn_mesh(&mut app, line.clone(), unlit_white(), Transform::IDENTITY);
    spawn_mesh(&mut app, line.clone(), double_sided, Transform::from_xyz(0.0, 5.0, 0.0));
    spawn_mesh(
        &mut app,
        line,
        unlit_white(),
        Transform::from_xyz(0.0, -5.0, 0.0).with_scale(Vec3::new(-1.0, 1.0, 1.0)),
    );
    render_app(&mut app, (SIZE, SIZE), settings(1));
    let stats = app.world.resource::<Renderer>().stats();
    assert_eq!(stats.pipelines, 1, "a line has no back to cull and no winding to flip");
}

#[test]
fn where_a_line_is_cut_by_the_near_plane_its_attributes_are_those_of_the_cut() {
    let mut app = eye_at_origin();
    // Red 5 m ahead, blue 5 m behind: along the visible part the colour is their mix at each
    // point's place on the segment (the fraction s of the way from the far end).
    let (far, behind) = (Vec3::new(0.0, -1.0, -5.0), Vec3::new(0.0, -1.0, 5.0));
    let mesh = Mesh {
        topology: Topology::LineList,
        positions: vec![far, behind],
        colors: vec![Vec4::new(1.0, 0.0, 0.0, 1.0), Vec4::new(0.0, 0.0, 1.0, 1.0)],
        ..Default::default()
    };
    spawn_mesh(&mut app, mesh, unlit_white(), Transform::IDENTITY);
    render_app(&mut app, (SIZE, SIZE), settings(1));
    let hdr = hdr_of(&app);
    let mut checked = 0;
    for y in 40..SIZE {
        // The line runs down the column at x = 32, between columns 31 and 32: either may hold it.
        let [r, _, b, _] = hdr[(y * SIZE + 31) as usize];
        let [r2, _, b2, _] = hdr[(y * SIZE + 32) as usize];
        let (r, b) = if r + b > 0.0 { (r, b) } else { (r2, b2) };
        if r + b <= 0.0 {
            continue;
        }
        // Row y sees the line at depth 1 / (y/32 − 1) (image y grows downwards).
        let z = -1.0 / ((y as f32 + 0.5) / 32.0 - 1.0);
        let s = (z - far.z) / (behind.z - far.z);
        assert!(
            (b / (r + b) - s).abs() < 0.03,
            "row {y}: blue share {:.3}, the segment's mix there {s:.3}",
            b / (r + b)
        );
        checked += 1;
    }
    // Down to the bottom edge, where the visible part ends 40 % of the way along.
    assert!(checked >= 20, "{checked} rows of the line checked");
}
