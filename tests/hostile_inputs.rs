//! The hostile-input generator (`fuzz/hostile/`) run to its end: every structured mutation of
//! its valid scene through the importer and, where it loads, the renderer, with the invariant
//! that a spec violation is never accepted without a word. `PENUMBRA_HOSTILE_TABLE=1` prints
//! every case's outcome (the table docs/reliability.md summarises).

#[path = "../fuzz/hostile/mod.rs"]
mod hostile;

use std::path::Path;

use penumbra::engine::import::{GltfScene, ImportOptions, SceneFile};
use penumbra::render::RenderSettings;
use penumbra::render::Renderer;
use penumbra::render::headless::{CameraChoice, ShotSettings, render_frames, stage_scene};

mod common;
use common::{gpu, scratch_dir};

use hostile::Expect;

#[derive(Debug, Default)]
struct Tally {
    refused: usize,
    warned: usize,
    clean: usize,
    rendered: usize,
}

#[test]
fn every_hostile_case_is_refused_named_or_rendered_finite() {
    let dir = scratch_dir("hostile");
    let table = std::env::var_os("PENUMBRA_HOSTILE_TABLE").is_some();
    let mut renderer =
        Some(Renderer::new(gpu(), RenderSettings { msaa: 1, keep_hdr: true, ..Default::default() }).unwrap());
    let mut tally = Tally::default();
    let mut failures = Vec::new();
    let cases = hostile::cases();
    for (i, case) in cases.iter().enumerate() {
        let path = dir.join(format!("case-{i}.gltf"));
        std::fs::write(&path, serde_json::to_vec(&case.json).unwrap()).unwrap();
        let loaded = std::panic::catch_unwind(|| GltfScene::load(&path, &ImportOptions::default()));
        let outcome = match loaded {
            Err(_) => {
                failures.push(format!("{}: the importer panicked", case.label));
                continue;
            }
            Ok(Err(e)) => {
                let msg = e.to_string();
                if !msg.starts_with(&path.display().to_string()) {
                    failures.push(format!("{}: the error does not name the file: {msg}", case.label));
                }
                if case.expect == Expect::Valid {
                    failures.push(format!("{}: valid glTF refused: {msg}", case.label));
                }
                tally.refused += 1;
                format!("refused: {}", msg.trim_start_matches(&format!("{}: ", path.display())))
            }
            Ok(Ok(scene)) => {
                let named = scene.warnings.iter().any(|w| case.names.iter().any(|n| w.contains(n)));
                match case.expect {
                    Expect::Named if !named => failures.push(format!(
                        "{}: a spec violation was accepted without a warning naming it ({:?})",
                        case.label, scene.warnings
                    )),
                    Expect::Valid if !scene.warnings.is_empty() => {
                        failures.push(format!("{}: valid glTF warned about: {:?}", case.label, scene.warnings))
                    }
                    _ => {}
                }
                if scene.warnings.is_empty() {
                    tally.clean += 1;
                } else {
                    tally.warned += 1;
                }
                match render(&scene, &mut renderer, &path) {
                    Ok(()) => tally.rendered += 1,
                    Err(e) => failures.push(format!("{}: {e}", case.label)),
                }
                if scene.warnings.is_empty() {
                    "loaded".to_owned()
                } else {
                    format!("warned: {}", scene.warnings.join("; "))
                }
            }
        };
        if table {
            println!("{:<70} {outcome}", case.label);
        }
    }
    println!("{} cases: {tally:?}", cases.len());
    assert!(
        failures.is_empty(),
        "{} of {} cases broke the invariant:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
    assert!(tally.refused > 0 && tally.warned > 0 && tally.clean > 0, "{tally:?}");
}

/// Renders the scene through the file's perspective camera at a small size; the frame must be
/// drawn (no frame or shader error) and finite.
fn render(scene: &GltfScene, renderer: &mut Option<Renderer>, path: &Path) -> Result<(), String> {
    let file = SceneFile::Gltf(scene.clone());
    let shot = ShotSettings { size: Some((24, 16)), camera: CameraChoice::Gltf(0), ..Default::default() };
    let (mut app, size) = match stage_scene(&file, &shot) {
        Ok(staged) => staged,
        // The cases that remove the camera or break its node are refused at import; a camera
        // the shot cannot use is an error of its own, not a panic.
        Err(e) => return Err(format!("{}: staging failed: {e}", path.display())),
    };
    let r = renderer.take().expect("the renderer is put back after every case");
    let pixels = render_frames(&mut app, r, size, 1);
    let r = app.world.remove_resource::<Renderer>().expect("rendered");
    let hdr = r.read_hdr();
    *renderer = Some(r);
    pixels.map_err(|e| format!("the frame failed: {e}"))?;
    let hdr = hdr.map_err(|e| format!("no HDR frame: {e}"))?;
    if let Some(p) = hdr.iter().find(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(format!("non-finite HDR pixel {p:?}"));
    }
    Ok(())
}
