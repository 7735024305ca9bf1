//! Many objects from a Rust system: `--count` cubes (default 10 000) sharing one mesh and
//! material, 1 % of them turning every frame. The renderer batches them into one instanced draw,
//! culls them on the GPU and re-uploads only the moved ones. Run with
//! `cargo run --release --example many_cubes [-- --count 100000]` (or `--headless cubes.png`).

use penumbra::engine::scenes::{CubeLayout, spawn_many_cubes, spin_cubes};
use penumbra::prelude::*;

fn build(app: &mut App, count: usize) {
    app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
    spawn_many_cubes(&mut app.world, count, CubeLayout::Grid, 0.01, false);
    app.add_systems(Update, spin_cubes);
}

#[cfg_attr(test, allow(dead_code))]
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let count = args.iter().position(|a| a == "--count").and_then(|i| args.get(i + 1)?.parse().ok()).unwrap_or(10_000);
    let mut app = App::new();
    build(&mut app, count);
    penumbra::run(&mut app);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ten_thousand_cubes_draw_as_one_batch_headless() {
        let mut app = App::new();
        build(&mut app, 10_000);
        let out = std::env::temp_dir().join("many_cubes.png");
        let shots = HeadlessRunner::screenshot(out, (96, 64), 3).run_on(&mut app).unwrap_or_else(|e| panic!("{e}"));
        let stats = app.world.resource::<Renderer>().stats().clone();
        assert_eq!(stats.instances, 10_000);
        assert!(stats.draw_calls <= 2, "{} draw calls", stats.draw_calls);
        // 100 moving cubes: 100 instance records of 64 bytes.
        assert_eq!(stats.instance_bytes_uploaded, 100 * 64);
        assert!(shots[0].chunks_exact(4).any(|p| p[0] > 60), "cubes are visible");
    }
}
