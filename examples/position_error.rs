//! How far a compressed glTF file's vertex positions lie from its plain counterpart's: for each
//! primitive (in file order), every plain vertex against the nearest decoded one (a Draco stream
//! may reorder and merge points). Prints the worst distance in scene units and relative to the
//! primitive's extent, which is what quantisation at encode time sets. docs/coverage.md,
//! "Compressed variants".
//!
//!     cargo run --release --example position_error -- PLAIN.gltf COMPRESSED.gltf

use penumbra::engine::import::{GltfScene, ImportOptions};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let [_, plain, compressed] = &args[..] else {
        eprintln!("usage: position_error PLAIN.gltf COMPRESSED.gltf");
        std::process::exit(2);
    };
    let load = |p: &str| {
        GltfScene::load(std::path::Path::new(p), &ImportOptions::default()).unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(1)
        })
    };
    let (plain, compressed) = (load(plain), load(compressed));
    let (mut worst, mut worst_relative) = (0f32, 0f32);
    for (a, b) in plain.primitives().zip(compressed.primitives()) {
        let extent = a.positions.iter().fold(0f32, |m, v| m.max(v.abs().max_element())).max(f32::MIN_POSITIVE);
        let nearest = |v: glam::Vec3| b.positions.iter().map(|w| (*w - v).length()).fold(f32::MAX, f32::min);
        let here = a.positions.iter().map(|&v| nearest(v)).fold(0f32, f32::max);
        worst = worst.max(here);
        worst_relative = worst_relative.max(here / extent);
    }
    println!(
        "{} and {} primitives; worst position error {worst:.5} ({worst_relative:.6} of the primitive's extent)",
        plain.primitives().count(),
        compressed.primitives().count()
    );
}
