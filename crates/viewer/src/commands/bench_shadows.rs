//! `penumbra bench shadows`: the shadows scene (`penumbra_engine::scenes::spawn_shadows_scene`)
//! at each shadow atlas size and filter. Per setting: GPU time of each cascade's caster pass and
//! of the forward pass (timestamp queries), CPU time, the atlas's memory, and the image error
//! (FLIP mean) against the 4096²/PCSS frame of the same scene; a row without shadows gives the
//! baseline cost. The camera steps sideways by 25 cm every frame (back and forth), so that every
//! cascade is redrawn each frame; a row holds it still, where the cascades are drawn once and
//! kept, and one holds it still while one caster 13 m ahead steps 10 cm sideways every frame
//! (only the maps it can reach are redrawn). Then the same scene with four shadowed point lights and four shadowed spot
//! lights (28 local layers), nudged by a millimetre every frame so that every map re-renders
//! each frame (a static light's map is rendered once and kept), at each local map size: GPU
//! time per local shadow layer, against the frame with 2048² local maps.

use anyhow::{Result, anyhow};
use bevy_ecs::prelude::*;
use glam::Vec3;
use penumbra_engine::Update;
use penumbra_engine::components::{PointLight, SpotLight, Transform};
use penumbra_engine::scenes::spawn_shadows_scene;
use penumbra_render::features::shadows::{ShadowFilter, ShadowSettings};
use penumbra_render::frame::Pass;
use penumbra_render::{AdapterRequest, GpuContext, RenderOutput, RenderPlugin, RenderSettings, Renderer};

use super::bench_measure::flip_mean;
use super::bench_measure::{percentile, step_camera, time_frames};
use crate::cli::BenchArgs;

/// Atlas sizes measured, in texels per layer.
const ATLAS_SIZES: [u32; 3] = [1024, 2048, 4096];

struct Row {
    setting: String,
    layers: usize,
    per_local_ms: Option<f64>,
    per_cascade_ms: Option<f64>,
    shadows_ms: Option<f64>,
    forward_ms: Option<f64>,
    gpu_ms: Option<f64>,
    cpu_ms: f64,
    atlas_mib: f64,
    flip: f32,
}

/// What moves every frame.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Motion {
    Still,
    /// The camera steps 25 cm sideways (`step_camera`): every cascade redraws.
    Camera,
    /// The caster nearest the lower middle of the view steps 10 cm sideways.
    NearestBox,
}

/// Marks the box `Motion::NearestBox` moves.
#[derive(Component)]
struct Mover;

fn step_mover(mut movers: Query<&mut Transform, With<Mover>>, mut frame: Local<u64>) {
    *frame += 1;
    let step = if frame.is_multiple_of(2) { 0.1 } else { -0.1 };
    for mut t in &mut movers {
        t.translation.x += step;
    }
}

/// Nudges every local light by a millimetre, up and down on alternate frames.
fn nudge_local_lights(
    mut lights: Query<&mut Transform, Or<(With<PointLight>, With<SpotLight>)>>,
    mut frame: Local<u64>,
) {
    *frame += 1;
    let step = if frame.is_multiple_of(2) { 0.001 } else { -0.001 };
    for mut t in &mut lights {
        t.translation.y += step;
    }
}

fn spawn_local_lights(world: &mut World) {
    for i in 0..4 {
        let a = i as f32 * std::f32::consts::FRAC_PI_2 + 0.4;
        let at = Vec3::new(8.0 * a.cos(), 3.0, 8.0 * a.sin());
        world.spawn((
            PointLight { intensity: 40.0, range: Some(15.0), ..Default::default() },
            Transform::from_translation(at),
        ));
        let spot_at = Vec3::new(12.0 * a.sin(), 5.0, 12.0 * a.cos());
        let spot = SpotLight {
            intensity: 80.0,
            range: Some(20.0),
            inner_cone_angle: 0.4,
            outer_cone_angle: 0.6,
            ..Default::default()
        };
        world.spawn((spot, Transform::from_translation(spot_at).looking_at(Vec3::ZERO, Vec3::Y)));
    }
}

/// The shadows scene; `local` adds the eight shadowed local lights (nudged every frame),
/// `motion` says what else moves every frame.
fn app_with(
    ctx: &GpuContext,
    settings: RenderSettings,
    shadows: bool,
    local: bool,
    motion: Motion,
    size: (u32, u32),
) -> Result<penumbra_engine::App> {
    let mut app = penumbra_engine::App::new();
    app.add_plugins(penumbra_engine::CorePlugin).add_plugins(RenderPlugin);
    spawn_shadows_scene(&mut app.world);
    match motion {
        Motion::Still => {}
        Motion::Camera => {
            app.add_systems(Update, step_camera);
        }
        Motion::NearestBox => {
            // The camera looks down −z from z = 28 at 5 m: (0, 0, 16) is on the ground in the
            // lower middle of the view, 13 m away. The ground is the mesh at the origin.
            let mut meshes = app.world.query::<(Entity, &Transform, &penumbra_engine::components::Mesh3d)>();
            let seen = Vec3::new(0.0, 0.0, 16.0);
            let nearest = meshes
                .iter(&app.world)
                .filter(|(_, t, _)| t.translation != Vec3::ZERO)
                .min_by(|a, b| a.1.translation.distance(seen).total_cmp(&b.1.translation.distance(seen)))
                .map(|(e, _, _)| e);
            if let Some(e) = nearest {
                app.world.entity_mut(e).insert(Mover);
            }
            app.add_systems(Update, step_mover);
        }
    }
    if local {
        spawn_local_lights(&mut app.world);
        app.add_systems(Update, nudge_local_lights);
    }
    if !shadows {
        let mut q = app.world.query::<&mut penumbra_engine::components::DirectionalLight>();
        for mut l in q.iter_mut(&mut app.world) {
            l.shadows = false;
        }
    }
    app.insert_resource(Renderer::new(ctx.clone(), settings)?);
    app.insert_resource(RenderOutput::Headless { width: size.0, height: size.1 });
    Ok(app)
}

fn frame(app: &mut penumbra_engine::App) -> Result<Vec<u8>> {
    app.update();
    app.world.resource::<Renderer>().read_frame().map_err(|e| anyhow!("{e}"))
}

pub fn run(args: &BenchArgs) -> Result<()> {
    if args.frames == 0 {
        return Err(anyhow!("--frames must be at least 1"));
    }
    let base = RenderSettings { gpu_timing: true, ..args.look.render_settings(false, None)? };
    let ctx = GpuContext::new_headless(&AdapterRequest::default())?;
    let limit = ctx.device.limits().max_texture_dimension_2d;
    let reference_settings = ShadowSettings { atlas_size: 4096.min(limit), filter: ShadowFilter::Pcss, ..base.shadows };
    // Images for the error are first frames of a camera that has not moved.
    let reference = frame(&mut app_with(
        &ctx,
        RenderSettings { gpu_timing: false, shadows: reference_settings, ..base.clone() },
        true,
        false,
        Motion::Still,
        args.size,
    )?)?;
    let local_base =
        ShadowSettings { atlas_size: 2048.min(limit), local_layers: 28, local_updates: 28, ..base.shadows };
    let local_reference = frame(&mut app_with(
        &ctx,
        RenderSettings {
            gpu_timing: false,
            shadows: ShadowSettings { local_map_size: 2048.min(limit), ..local_base },
            ..base.clone()
        },
        true,
        true,
        Motion::Still,
        args.size,
    )?)?;
    let mut cases: Vec<(String, bool, bool, Motion, ShadowSettings)> =
        vec![("no shadows".to_owned(), false, false, Motion::Camera, base.shadows)];
    for filter in [ShadowFilter::Pcf, ShadowFilter::Pcss] {
        for atlas_size in ATLAS_SIZES.into_iter().filter(|s| *s <= limit) {
            let name = format!("{atlas_size}², {filter:?}");
            cases.push((name, true, false, Motion::Camera, ShadowSettings { atlas_size, filter, ..base.shadows }));
        }
    }
    for local_map_size in [512, 1024, 2048].into_iter().filter(|s| *s <= limit) {
        let name = format!("2048² Pcf + 8 local lights at {local_map_size}²");
        cases.push((name, true, true, Motion::Camera, ShadowSettings { local_map_size, ..local_base }));
    }
    let still = ShadowSettings { atlas_size: 4096.min(limit), ..base.shadows };
    cases.push((format!("{}², Pcf, still camera", still.atlas_size), true, false, Motion::Still, still));
    let name = format!("{}², Pcf, still camera, one caster moving", still.atlas_size);
    cases.push((name, true, false, Motion::NearestBox, still));
    let mut rows = Vec::new();
    for (setting, on, local, motion, shadows) in cases {
        let mut app = app_with(&ctx, RenderSettings { shadows, ..base.clone() }, on, local, motion, args.size)?;
        let t = time_frames(&mut app, args.warmup, args.frames);
        let renderer = app.world.resource::<Renderer>();
        let layers = renderer.shadow_frame().rendered_layers();
        let median = |v: Option<&[f64]>| v.filter(|v| !v.is_empty()).map(|v| percentile(v, 0.5));
        // The cascades' passes, and the GPU culls of the maps' casters that precede them.
        let shadow_passes: Vec<f64> = t
            .passes
            .iter()
            .filter(|(l, _)| l.starts_with("shadow ") && *l != "shadow local" && *l != "shadow cull")
            .filter_map(|(_, v)| median(Some(v)))
            .collect();
        let cull_ms = median(t.pass("shadow cull")).unwrap_or(0.0);
        // Local passes share one label: the timer keeps each frame's sum of them.
        let local_layers = renderer.shadow_frame().local.render.len();
        let per_local_ms =
            median(t.pass("shadow local")).filter(|_| local_layers > 0).map(|ms| ms / local_layers as f64);
        let cascades_ms = shadow_passes.iter().sum::<f64>();
        let shadows_ms = (!shadow_passes.is_empty()).then_some(cascades_ms + cull_ms);
        let atlas_mib = renderer.memory().shadows as f64 / 1048576.0;
        assert_eq!(renderer.stats().plan.runs(Pass::SHADOWS), layers > 0);
        let settings = RenderSettings { gpu_timing: false, shadows, ..base.clone() };
        let image = frame(&mut app_with(&ctx, settings, on, local, Motion::Still, args.size)?)?;
        let reference = if local { &local_reference } else { &reference };
        rows.push(Row {
            setting,
            layers,
            per_local_ms,
            per_cascade_ms: (!shadow_passes.is_empty()).then(|| cascades_ms / shadow_passes.len() as f64),
            shadows_ms,
            forward_ms: median(t.pass("forward")),
            gpu_ms: median(Some(&t.gpu_total)),
            cpu_ms: percentile(&t.cpu, 0.5),
            atlas_mib,
            flip: flip_mean(reference, &image, args.size),
        });
    }
    let ms = |v: Option<f64>| v.map_or("n/a".to_owned(), |v| format!("{v:.3}"));
    println!("adapter   {}", ctx.describe());
    println!(
        "scene     shadows (scenes.rs): 200 m ground, 400 boxes and spheres, a 4 lux sun at 35° with the sun's angular size"
    );
    println!(
        "settings  {}x{}, MSAA {}, {} cascades to {} m (λ {}), {} warm-up + {} timed frames; FLIP mean against the {}²/PCSS frame",
        args.size.0,
        args.size.1,
        base.msaa,
        base.shadows.cascades,
        base.shadows.max_distance,
        base.shadows.split_lambda,
        args.warmup,
        args.frames,
        reference_settings.atlas_size,
    );
    println!();
    println!(
        "| setting | layers rendered | GPU per cascade (ms) | GPU per local layer (ms) | GPU shadow passes and culls (ms) | GPU forward (ms) | GPU frame (ms) | CPU render (ms) | atlases (MiB) | FLIP mean vs reference |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &rows {
        println!(
            "| {} | {} | {} | {} | {} | {} | {} | {:.3} | {:.1} | {:.4} |",
            r.setting,
            r.layers,
            ms(r.per_cascade_ms),
            ms(r.per_local_ms),
            ms(r.shadows_ms),
            ms(r.forward_ms),
            ms(r.gpu_ms),
            r.cpu_ms,
            r.atlas_mib,
            r.flip
        );
    }
    println!();
    println!(
        "References: the {}²/PCSS frame for the sun alone; for the rows with local lights, their 2048² maps (the sun at 2048² PCF).",
        reference_settings.atlas_size
    );
    Ok(())
}
