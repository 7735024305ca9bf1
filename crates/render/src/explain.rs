//! The frame plan explained, for `penumbra render --explain`: which passes the last frame ran
//! and why, what each reads, which passes it left out and why, the forward shader variants it
//! compiled (their feature switches), and the GPU memory each pool holds. Everything here is
//! read from the renderer after a frame; nothing is recomputed, so the explanation cannot
//! drift from what ran.

use std::fmt::Write;

use crate::renderer::Renderer;

/// A report of the renderer's last frame (call after at least one frame).
pub fn explain(renderer: &Renderer) -> String {
    let stats = renderer.stats();
    let plan = &stats.plan;
    let mut out = String::new();
    let n = &plan.needs;
    let _ = writeln!(
        out,
        "Frame plan (frame {}: {} draw calls, {} lights of which {} local, {} shadow layers rendered)",
        stats.frame, stats.draw_calls, stats.lights, stats.local_lights, n.shadow_layers
    );
    for (i, (pass, why)) in plan.passes.iter().enumerate() {
        let _ = writeln!(out, "{:>3}. {pass:?}: {why}\n       reads: {}", i + 1, pass.inputs());
    }
    let _ = writeln!(out, "Left out:");
    for (pass, why) in plan.left_out() {
        let _ = writeln!(out, "     - {pass:?}: {why}");
    }
    let keys = renderer.forward_pipeline_keys();
    let _ = writeln!(out, "Forward shader variants compiled ({}), by their feature switches:", keys.len());
    let mut variants: Vec<String> = keys
        .iter()
        .map(|k| {
            let defs: Vec<&str> = k.shader_defs().0.into_iter().collect();
            let defs = if defs.is_empty() { "(none: the base shader)".to_string() } else { defs.join(" ") };
            format!("MSAA {}: {defs}", k.sample_count)
        })
        .collect();
    variants.sort();
    variants.dedup();
    for v in variants {
        let _ = writeln!(out, "     - {v}");
    }
    let compiled = stats.pipelines_compiled;
    match renderer.pipeline_store() {
        Some(store) => {
            let _ = writeln!(
                out,
                "Pipelines: {compiled} created; driver cache {} ({:.1} KiB read at start)",
                store.path().display(),
                store.loaded_bytes() as f64 / 1024.0
            );
        }
        None => {
            let _ = writeln!(out, "Pipelines: {compiled} created; no driver cache kept between runs");
        }
    }
    let m = renderer.memory();
    let _ = writeln!(out, "GPU memory by pool (0: not allocated, the scene does not need it):");
    for (name, bytes) in [
        ("render targets", m.targets),
        ("mesh pool", m.mesh_pool),
        ("textures", m.textures),
        ("instances and culling", m.instances),
        ("light store", m.lights),
        ("cluster lists", m.clusters),
        ("shadow atlas", m.shadows),
        ("environment maps", m.environment),
        ("post-processing", m.post),
        ("skinning and morphs", m.deform),
    ] {
        let _ = writeln!(out, "     {name:<22} {:>10.1} KiB", bytes as f64 / 1024.0);
    }
    if m.textures_rgba8 > m.textures {
        let _ = writeln!(
            out,
            "     (textures as RGBA8 would take {:.1} KiB: block compression saves {:.1} KiB)",
            m.textures_rgba8 as f64 / 1024.0,
            (m.textures_rgba8 - m.textures) as f64 / 1024.0
        );
    }
    out
}
