//! Extraction cost per entity: a world of drawable entities, the render crate's extraction
//! systems run on it, with every entity's transform changed (per changed entity: reading what
//! propagation listed) and with nothing changed (per unchanged entity: nothing to read; the
//! main world's `PostUpdate`, whose propagation scans change ticks, is timed too). Run with
//! `cargo bench -p penumbra-render --bench extraction`; criterion reports time per frame, and
//! the throughput line reads as entities per second.

use std::time::{Duration, Instant};

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::{Quat, Vec3};
use penumbra_engine::components::{Mesh3d, MeshMaterial3d, Transform};
use penumbra_engine::material::StandardMaterial;
use penumbra_engine::mesh::Mesh;
use penumbra_engine::{App, Assets, CorePlugin, PostUpdate};
use penumbra_render::{Extract, RenderPlugin, RenderScene};

fn world_of(count: usize) -> App {
    let mut app = App::new();
    app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
    let material = app.world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial::default());
    app.world.spawn_batch(
        (0..count).map(move |i| (Mesh3d(mesh), MeshMaterial3d(material), Transform::from_xyz(i as f32, 0.0, 0.0))),
    );
    // Derive GlobalTransform and visibility, and extract everything once.
    app.update();
    app
}

/// Turns every entity and derives the new placements (propagation records them for extraction).
fn touch_all(app: &mut App, turn: f32) {
    let mut q = app.world.query::<&mut Transform>();
    for mut t in q.iter_mut(&mut app.world) {
        t.rotation = Quat::from_rotation_y(turn);
    }
    app.world.run_schedule(PostUpdate);
}

fn extraction(c: &mut Criterion) {
    let mut group = c.benchmark_group("extract");
    group.sample_size(20).warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(4));
    for count in [10_000usize, 100_000, 1_000_000] {
        let mut app = world_of(count);
        group.throughput(Throughput::Elements(count as u64));
        group.bench_function(format!("{count} changed"), |b| {
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for i in 0..iters {
                    touch_all(&mut app, i as f32 * 1e-3);
                    let start = Instant::now();
                    app.world.run_schedule(Extract);
                    total += start.elapsed();
                    assert_eq!(app.world.resource::<RenderScene>().changed_draws.len(), count);
                }
                total
            })
        });
        group.bench_function(format!("{count} unchanged"), |b| {
            b.iter(|| {
                app.world.run_schedule(Extract);
            })
        });
        // The main world's share of a still frame: transform and visibility propagation find
        // nothing changed.
        group.bench_function(format!("{count} unchanged, main world PostUpdate"), |b| {
            b.iter(|| {
                app.world.run_schedule(PostUpdate);
            })
        });
        // Holds whichever of the functions above a filter selected.
        app.world.run_schedule(Extract);
        assert!(app.world.resource::<RenderScene>().changed_draws.is_empty());
    }
    group.finish();
}

criterion_group!(benches, extraction);
criterion_main!(benches);
