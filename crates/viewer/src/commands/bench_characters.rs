//! `penumbra bench characters`: `--count` instances of an animated, skinned model (default the
//! Fox test model, 24 joints, 1 728 vertices) at human scale (1.5 m), 2 m apart on a grid, each playing its clip from its own
//! time, under a sun with cascaded shadows. Per count, medians over the timed frames: the CPU
//! split (main world: animation sampling, transform propagation and joint matrices; extract;
//! prepare), the GPU passes from timestamp queries (deform, shadows, forward), the vertices
//! deformed per frame and the GPU memory of the deformation (source data, joint and weight
//! buffers) and of the mesh pool (which holds each instance's deformed copy).

use std::path::PathBuf;

use anyhow::{Result, anyhow};
use glam::Vec3;
use penumbra_engine::animation::AnimationPlayer;
use penumbra_engine::components::{DirectionalLight, Exposure, Transform};
use penumbra_engine::framing::{framing_camera_from, world_bounds};
use penumbra_engine::import::{SceneFile, spawn_instance};
use penumbra_engine::mesh::Mesh;
use penumbra_engine::{Assets, CorePlugin, Time};
use penumbra_render::{AdapterRequest, GpuContext, RenderOutput, RenderPlugin, RenderSettings, Renderer};

use super::bench_measure::{percentile, time_frames};
use crate::cli::BenchArgs;

/// The model `bench characters` uses without `--model`, relative to the repository root.
pub const DEFAULT_MODEL: &str = "tests/assets/Fox/Fox.glb";

pub fn run(args: &BenchArgs) -> Result<()> {
    if args.frames == 0 || args.count.is_empty() {
        return Err(anyhow!("--frames must be at least 1 and --count needs a value"));
    }
    if args.scene_args.variant.is_some() {
        return Err(anyhow!("--variant: the characters bench spawns its own crowd; it takes no variant"));
    }
    let model = args.model.clone().unwrap_or_else(|| PathBuf::from(DEFAULT_MODEL));
    let scene = std::sync::Arc::new(SceneFile::load(&model, &crate::scene::options(&args.scene_args))?);
    let settings = RenderSettings { gpu_timing: true, ..args.look.render_settings(false, None)? };
    let ctx = GpuContext::new_headless(&AdapterRequest::default())?;
    println!("adapter   {}", ctx.describe());
    println!(
        "scene     {} x N at human scale (1.5 m), 2 m apart on a grid, each playing its first clip from its own time; a 10 000 lux sun with {} cascades",
        model.display(),
        settings.shadows.cascades
    );
    println!(
        "settings  {}x{}, MSAA {}, {} warm-up + {} timed frames, at most 2 in flight",
        args.size.0, args.size.1, settings.msaa, args.warmup, args.frames
    );
    println!();
    println!(
        "| instances | animation | CPU main world (ms) | CPU extract (ms) | CPU prepare (ms) | CPU frame (ms) | GPU deform (ms) | GPU shadows (ms) | GPU forward (ms) | GPU frame (ms) | frame, wall (ms) | vertices skinned | GPU MiB deform data / mesh pool |"
    );
    println!("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (count, playing) in args.count.iter().flat_map(|&c| [(c, true), (c, false)]) {
        let mut app = penumbra_engine::App::new();
        app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
        app.insert_resource(Time::fixed_hz(60.0));
        let first = spawn_instance(&mut app.world, &scene);
        app.update();
        // Every model at human scale (1.5 m at its largest), 2 m apart: within the default
        // shadow distance for a few hundred instances.
        let one = world_bounds(&mut app.world);
        let scale = 1.5 / (one.max - one.min).max_element().max(1e-6);
        let spacing = 2.0;
        let side = (count as f64).sqrt().ceil() as usize;
        let mut roots = vec![first];
        roots.extend((1..count).map(|_| spawn_instance(&mut app.world, &scene)));
        for (i, &root) in roots.iter().enumerate() {
            let at = Vec3::new((i % side) as f32, 0.0, (i / side) as f32) * spacing;
            let mut t = app.world.get_mut::<Transform>(root).expect("scene roots have a Transform");
            t.translation = at;
            t.scale = Vec3::splat(scale);
            if let Some(mut p) = app.world.get_mut::<AnimationPlayer>(root) {
                // Desynchronised, as a crowd is.
                p.seek(0.137 * i as f32)?;
                if !playing {
                    p.pause();
                }
            }
        }
        app.world.spawn((
            DirectionalLight { illuminance: 10_000.0, ..Default::default() },
            Transform::IDENTITY.looking_at(Vec3::new(-0.3, -1.0, -0.6), Vec3::Y),
        ));
        app.update();
        let bounds = world_bounds(&mut app.world);
        let aspect = args.size.0 as f32 / args.size.1 as f32;
        let (mut camera, at) = framing_camera_from(&bounds, Vec3::new(0.0, 0.8, 1.0), 45f32.to_radians(), aspect);
        // Sunny 16: the exposure for a 10 000 lux sun.
        camera.exposure = Exposure { ev100: 15.0 };
        app.world.spawn((camera, at));
        let vertices: usize = {
            use penumbra_engine::components::{Mesh3d, SkinnedMesh};
            let mut q = app.world.query_filtered::<&Mesh3d, bevy_ecs::query::With<SkinnedMesh>>();
            let handles: Vec<_> = q.iter(&app.world).map(|m| m.0).collect();
            let meshes = app.world.resource::<Assets<Mesh>>();
            handles.iter().filter_map(|h| meshes.get(*h).ok()).map(Mesh::vertex_count).sum()
        };
        app.insert_resource(Renderer::new(ctx.clone(), settings.clone())?);
        app.insert_resource(RenderOutput::Headless { width: args.size.0, height: args.size.1 });
        let t = time_frames(&mut app, args.warmup, args.frames);
        let renderer = app.world.resource::<Renderer>();
        let med = |v: &[f64]| percentile(v, 0.5);
        let pass = |label| t.pass(label).map_or(f64::NAN, med);
        // One timed pass per shadow layer drawn: the sum of their medians.
        let shadow_layers: Vec<f64> =
            t.passes.iter().filter(|(l, _)| l.starts_with("shadow")).map(|(_, v)| med(v)).collect();
        let shadows = if shadow_layers.is_empty() { f64::NAN } else { shadow_layers.iter().sum() };
        let cpu: Vec<f64> = (0..t.cpu.len()).map(|i| t.cpu_frame(i)).collect();
        let memory = renderer.memory();
        let ms = |v: f64| if v.is_nan() { "-".to_owned() } else { format!("{v:.3}") };
        println!(
            "| {count} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {} | {} | {} | {} | {:.3} | {vertices} | {:.2} / {:.1} |",
            if playing { "playing" } else { "paused" },
            med(&t.main),
            med(&t.extract),
            med(&t.prepare),
            med(&cpu),
            ms(pass("deform")),
            ms(shadows),
            ms(pass("forward")),
            ms(med(&t.gpu_total)),
            med(&t.wall),
            memory.deform as f64 / 1048576.0,
            memory.mesh_pool as f64 / 1048576.0,
        );
    }
    Ok(())
}
