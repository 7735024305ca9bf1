//! `penumbra bench soak`: `--frames` headless frames (10 000 for the documented run) of
//! continuous churn ([`penumbra_viewer::soak`]), printing host memory (RSS), GPU memory per pool
//! and the live asset counts every `--frames / 10` frames, and the mean frame time in between.
//! Memory must plateau: the row at frame 10 000 should equal the rows before it.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Result, anyhow};
use penumbra_engine::import::SceneFile;
use penumbra_render::{AdapterRequest, GpuContext, RenderSettings};
use penumbra_viewer::soak::{Soak, SoakConfig, SoakSample};

use crate::cli::BenchArgs;
use crate::scene;

/// Test assets cycled through when run from the repository: a textured box, a skinned and
/// animated fox, morph targets, an OBJ with an MTL texture. Elsewhere only the embedded scene.
const REPO_SCENES: [&str; 4] = [
    "tests/assets/BoxTextured/BoxTextured.glb",
    "tests/assets/Fox/Fox.glb",
    "tests/assets/AnimatedMorphCube/AnimatedMorphCube.glb",
    "tests/assets/ObjScene/scene.obj",
];

pub fn run(args: &BenchArgs) -> Result<()> {
    if args.frames == 0 {
        return Err(anyhow!("--frames must be at least 1"));
    }
    if args.scene_args.variant.is_some() {
        return Err(anyhow!("--variant: the soak bench cycles through several scenes; it takes no variant"));
    }
    let mut scenes = vec![Arc::new(scene::load(None, &args.scene_args)?)];
    let options = scene::options(&args.scene_args);
    for p in REPO_SCENES.iter().map(Path::new).filter(|p| p.exists()) {
        scenes.push(Arc::new(SceneFile::load(p, &options)?));
    }
    let (w, h) = args.size;
    let config = SoakConfig {
        sizes: vec![(w, h), ((w / 2).max(1), (h / 2).max(1)), ((w * 3 / 4).max(1), (h / 3).max(1))],
        scenes,
        settings: RenderSettings { ..args.look.render_settings(false, None)? },
    };
    let ctx = GpuContext::new_headless(&AdapterRequest::default())?;
    println!("adapter: {} ({:?})", ctx.info.name, ctx.info.backend);
    println!(
        "soak: {} frames at {w}x{h} (and two smaller sizes), {} scenes in rotation",
        args.frames,
        config.scenes.len()
    );
    let every = (args.frames as u64 / 10).max(1);
    let mut soak = Soak::new(ctx, config)?;
    print_header();
    print_row(&soak.sample(), None);
    let mut since = Instant::now();
    for frame in 1..=args.frames as u64 {
        soak.step();
        if frame.is_multiple_of(every) || frame == args.frames as u64 {
            let ms = since.elapsed().as_secs_f64() * 1e3 / every as f64;
            print_row(&soak.sample(), Some(ms));
            since = Instant::now();
        }
    }
    Ok(())
}

fn print_header() {
    println!(
        "{:>7} {:>9} {:>9} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>7} {:>6} {:>6} {:>6} {:>5} {:>8}",
        "frame",
        "RSS MiB",
        "GPU MiB",
        "meshpool",
        "textures",
        "instance",
        "targets",
        "lights",
        "clusters",
        "shadows",
        "entity",
        "meshes",
        "mats",
        "images",
        "pipes",
        "ms/frame"
    );
}

fn print_row(s: &SoakSample, ms: Option<f64>) {
    let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
    let g = &s.gpu;
    println!(
        "{:>7} {:>9} {:>9.2} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>7} {:>6} {:>6} {:>6} {:>5} {:>8}",
        s.frame,
        s.rss_bytes.map_or("-".into(), |b| format!("{:.1}", mib(b))),
        mib(g.total()),
        mib(g.mesh_pool),
        mib(g.textures),
        mib(g.instances),
        mib(g.targets),
        mib(g.lights),
        mib(g.clusters),
        mib(g.shadows),
        s.entities,
        s.meshes,
        s.materials,
        s.images,
        s.pipelines,
        ms.map_or("-".into(), |m| format!("{m:.2}")),
    );
}
