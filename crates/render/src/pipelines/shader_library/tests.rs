//! Tests of `shader_library`.

use super::super::shader_error::wgpu_error_line;
use super::*;

fn defs(list: &[&'static str]) -> ShaderDefs {
    ShaderDefs(list.iter().copied().collect())
}

#[test]
fn hidden_editor_files_are_not_shaders() {
    let dir = std::env::temp_dir().join(format!("penumbra-hidden-shader-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // Emacs's lock while forward.wgsl has unsaved changes: a link to nowhere.
    #[cfg(unix)]
    std::os::unix::fs::symlink("user@host.1234:1700000000", dir.join(".#forward.wgsl")).unwrap();
    std::fs::write(dir.join(".forward.wgsl"), "not a shader").unwrap();
    let lib = ShaderLibrary::from_dir(&dir).unwrap_or_else(|e| panic!("{e}"));
    assert!(lib.sources.keys().all(|f| !f.starts_with('.')), "{:?}", lib.sources.keys());
    assert_eq!(shader_file_name(Path::new("/s/forward.wgsl")), Some("forward.wgsl"));
    assert_eq!(shader_file_name(Path::new("/s/.#forward.wgsl")), None);
    assert_eq!(shader_file_name(Path::new("/s/forward.wgsl~")), None);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn two_files_declaring_one_module_are_an_error() {
    let dir = std::env::temp_dir().join(format!("penumbra-duplicate-module-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let lib = ShaderLibrary::from_dir(&dir).unwrap_or_else(|e| panic!("{e}"));
    let brdf = EMBEDDED.iter().find(|(f, _)| *f == "brdf.wgsl").unwrap().1;
    let backup = ["brdf_backup.wgsl".to_owned()];
    std::fs::write(dir.join(&backup[0]), brdf).unwrap();
    let err = ShaderLibrary::from_dir(&dir).err().expect("a backup copy declaring penumbra::brdf");
    assert_eq!(err.file, "brdf_backup.wgsl");
    assert!(err.message.contains("penumbra::brdf") && err.message.contains("brdf.wgsl declares too"), "{err}");
    assert_eq!(lib.reloaded(&backup).err(), Some(err), "the same on a reload");
    // Deleting the copy, as the error asks, reloads cleanly: the file gone was never in use.
    std::fs::remove_file(dir.join(&backup[0])).unwrap();
    assert!(lib.reloaded(&backup).is_ok());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_error_without_a_place_names_only_the_file() {
    assert_eq!(ShaderError::whole_file("x.wgsl", "the file is empty").to_string(), "x.wgsl: the file is empty");
    let placed = ShaderError { file: "x.wgsl".into(), line: 3, column: 7, message: "expected `;`".into() };
    assert_eq!(placed.to_string(), "x.wgsl:3:7: expected `;`");
}

#[test]
fn a_wgpu_error_reads_on_one_line_without_its_context() {
    /// One link of a cause chain.
    #[derive(Debug)]
    struct Cause(&'static str, Option<Box<Cause>>);
    impl std::fmt::Display for Cause {
        fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str(self.0)
        }
    }
    impl std::error::Error for Cause {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            self.1.as_deref().map(|c| c as _)
        }
    }
    let leaf = Cause("Binding is missing\n   from the pipeline layout", None);
    let stage = Cause("Error matching ShaderStages(FRAGMENT) shader requirements", Some(Box::new(leaf)));
    for context in
        ["In Device::create_render_pipeline, label = 'forward PipelineKey { .. }'", "In Device::create_shader_module"]
    {
        let e = wgpu::Error::Validation {
            source: Box::new(Cause(context, Some(Box::new(Cause(stage.0, None))))),
            description: "Validation Error\n\nCaused by:\n ...".into(),
        };
        assert_eq!(wgpu_error_line(&e), stage.0, "{context}");
    }
    let e = wgpu::Error::Validation { source: Box::new(stage), description: String::new() };
    assert_eq!(
        wgpu_error_line(&e),
        "Error matching ShaderStages(FRAGMENT) shader requirements: Binding is missing from the pipeline layout"
    );
}

#[test]
fn a_parse_errors_own_reason_is_kept() {
    // naga's parser stops at a nesting depth and says why only in a note naga_oil drops.
    let deep = format!("fn f() -> f32 {{ return {}1.0{}; }}", "(".repeat(500), ")".repeat(500));
    let mut lib = ShaderLibrary::embedded().unwrap();
    lib.sources.insert("deep.wgsl".into(), deep);
    let err = lib.compose("deep.wgsl", &defs(&[])).unwrap_err();
    assert!(err.to_string().starts_with("deep.wgsl") && err.message.contains("recursion limit"), "{err}");
}

#[test]
fn every_entry_composes_in_every_variant_family() {
    let mut lib = ShaderLibrary::embedded().unwrap();
    let all = [
        "ALPHA_MASK",
        "UNLIT",
        "BASE_COLOR_TEXTURE",
        "METALLIC_ROUGHNESS_TEXTURE",
        "NORMAL_MAP",
        "OCCLUSION_TEXTURE",
        "EMISSIVE_TEXTURE",
        "LOCAL_LIGHTS",
    ];
    lib.compose("forward.wgsl", &defs(&[])).unwrap();
    lib.compose("forward.wgsl", &defs(&all)).unwrap();
    lib.compose("forward.wgsl", &defs(&[&all[..], &["TRANSFORMED_UVS"]].concat())).unwrap();
    lib.compose("forward.wgsl", &defs(&["ALPHA_BLEND", "NORMAL_MAP", "LOCAL_LIGHTS"])).unwrap();
    lib.compose("forward.wgsl", &defs(&["ALPHA_MASK", "ALPHA_COVERAGE", "SAMPLE_MASK_OUT", "DEFERRED_LOCAL_LIGHTS"]))
        .unwrap();
    lib.compose("forward.wgsl", &defs(&["ALPHA_MASK", "ALPHA_SAMPLE_RATE", "VERTEX_COLORS"])).unwrap();
    let coverage = ["ALPHA_MASK", "ALPHA_COVERAGE", "SAMPLE_MASK_OUT", "BASE_COLOR_TEXTURE", "VERTEX_COLORS"];
    lib.compose("forward.wgsl", &defs(&coverage)).unwrap();
    lib.compose("forward.wgsl", &defs(&[&coverage[..], &["TRANSFORMED_UVS"]].concat())).unwrap();
    let shadowed = ["LOCAL_LIGHTS", "CLUSTERED_LIGHTS", "SHADOWS", "LOCAL_SHADOWS", "DEBUG_CASCADES"];
    lib.compose("forward.wgsl", &defs(&shadowed)).unwrap();
    for debug in ["DEBUG_NORMALS", "DEBUG_UVS", "DEBUG_CLUSTER_HEAT"] {
        lib.compose("forward.wgsl", &defs(&[debug, "NORMAL_MAP"])).unwrap();
        lib.compose("forward.wgsl", &defs(&[debug, "UNLIT"])).unwrap();
    }
    lib.compose("shadow_caster.wgsl", &defs(&[])).unwrap();
    lib.compose("shadow_caster.wgsl", &defs(&["ALPHA_MASK", "BASE_COLOR_TEXTURE"])).unwrap();
    lib.compose("deferred_lights.wgsl", &defs(&["LOCAL_LIGHTS", "CLUSTERED_LIGHTS", "LOCAL_SHADOWS"])).unwrap();
    for t in [&["TONEMAP_NEUTRAL"][..], &["TONEMAP_ACES", "ENCODE_SRGB"], &[]] {
        lib.compose("tonemap.wgsl", &defs(t)).unwrap();
    }
    lib.compose("mipmap.wgsl", &defs(&[])).unwrap();
    lib.compose("cull.wgsl", &defs(&[])).unwrap();
    lib.compose("deform.wgsl", &defs(&[])).unwrap();
    lib.compose("gizmo.wgsl", &defs(&[])).unwrap();
    // A hybrid frame: the overlay's draws tested against the visibility buffer, masked ones
    // too, and the shading pass compositing the overlay; masked raster bins.
    lib.compose("gizmo.wgsl", &defs(&["VISIBILITY_OCCLUSION"])).unwrap();
    lib.compose("forward.wgsl", &defs(&["ALPHA_BLEND", "VISIBILITY_OCCLUSION", "SAMPLE_MASK_OUT"])).unwrap();
    lib.compose(
        "forward.wgsl",
        &defs(&[&coverage[..], &["VISIBILITY_OCCLUSION", "LINE_QUADS", "POOL_VERTICES"]].concat()),
    )
    .unwrap();
    for overlay in [&["VISIBILITY_OVERLAY"][..], &["VISIBILITY_OVERLAY", "OVERLAY_MULTISAMPLED"]] {
        let shade = [
            &["VISIBILITY_SHADE", "PULLED_VERTICES", "POOL_VERTICES", "VISIBILITY_TONEMAP", "VISIBILITY_DISPLAY"][..],
            overlay,
        ];
        lib.compose("forward.wgsl", &defs(&shade.concat())).unwrap();
    }
    for mask in [&["ALPHA_MASK"][..], &["ALPHA_MASK", "BASE_COLOR_TEXTURE", "TRANSFORMED_UVS", "VERTEX_COLORS"]] {
        lib.compose("visibility_raster.wgsl", &defs(mask)).unwrap();
    }
    lib.compose("cull.wgsl", &defs(&["OCCLUSION_EARLY"])).unwrap();
    lib.compose("cull.wgsl", &defs(&["OCCLUSION_LATE"])).unwrap();
    for d in [&[][..], &["FROM_DEPTH"], &["FROM_DEPTH", "MULTISAMPLED"]] {
        lib.compose("hzb.wgsl", &defs(d)).unwrap();
    }
}

/// Texture samples the fragment entry point makes, each call of a sampling helper counted
/// once per call (helpers that sample return a value, so every call leaves a `CallResult`).
/// `gradients` counts only explicit-gradient samples.
fn fragment_samples(m: &naga::Module, gradients: bool) -> usize {
    fn count(m: &naga::Module, f: &naga::Function, gradients: bool) -> usize {
        f.expressions
            .iter()
            .map(|(_, e)| match e {
                naga::Expression::ImageSample { level, .. } => {
                    usize::from(!gradients || matches!(level, naga::SampleLevel::Gradient { .. }))
                }
                naga::Expression::CallResult(h) => count(m, &m.functions[*h], gradients),
                _ => 0,
            })
            .sum()
    }
    let fs = m.entry_points.iter().find(|ep| ep.stage == naga::ShaderStage::Fragment).expect("fragment entry");
    count(m, &fs.function, gradients)
}

#[test]
fn variants_leave_out_code_they_do_not_use() {
    let mut lib = ShaderLibrary::embedded().unwrap();
    let mut samples = |list: &[&'static str], gradients: bool| {
        fragment_samples(&lib.compose("forward.wgsl", &defs(list)).unwrap(), gradients)
    };
    // Unlit and untextured: nothing. Lit surfaces read the split-sum table once.
    assert_eq!(samples(&["UNLIT"], false), 0);
    assert_eq!(samples(&[], false), 1);
    assert_eq!(samples(&["BASE_COLOR_TEXTURE"], false), 2);
    let all =
        ["BASE_COLOR_TEXTURE", "METALLIC_ROUGHNESS_TEXTURE", "NORMAL_MAP", "OCCLUSION_TEXTURE", "EMISSIVE_TEXTURE"];
    assert_eq!(samples(&all, false), 6);
    // Explicit gradients only where some texture maps its coordinate, and then for every
    // material texture; otherwise none, the normal map included.
    assert_eq!(samples(&all, true), 0);
    let transformed = [&all[..], &["TRANSFORMED_UVS"]].concat();
    assert_eq!(samples(&transformed, true), 5);
    // Occlusion packed in the metallic-roughness texture: one sample for both.
    assert_eq!(samples(&[&all[..], &["OCCLUSION_IN_METALLIC_ROUGHNESS"]].concat(), false), 5);
}

#[test]
fn syntax_errors_report_file_line_and_column() {
    // Columns count characters, as the feature switch check's do: `é` is two bytes, and the
    // `;` where an expression should be is the 22nd character of its line (23rd byte).
    let source = "fn main() {\n  let é = 1; let x = ;\n}";
    let mut lib = ShaderLibrary::embedded_with("broken.wgsl", source).unwrap();
    let err = lib.compose("broken.wgsl", &defs(&[])).unwrap_err();
    assert_eq!((err.file.as_str(), err.line, err.column), ("broken.wgsl", 2, 22), "{err}");
}

#[test]
fn composed_errors_point_into_the_edited_file() {
    let dir = std::env::temp_dir().join(format!("penumbra-shaderlib-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for (f, s) in EMBEDDED {
        std::fs::write(dir.join(f), s).unwrap();
    }
    let brdf = EMBEDDED.iter().find(|(f, _)| *f == "brdf.wgsl").unwrap().1;
    let line = brdf.lines().position(|l| l.starts_with("fn d_ggx")).unwrap() + 2;
    let broken = brdf.replacen("let n_cross_h = cross(n, h);", "let n_cross_h = cross(n, );", 1);
    assert_ne!(broken, brdf, "the test's edit must apply");
    std::fs::write(dir.join("brdf.wgsl"), broken).unwrap();
    // Registering a module defers parsing; composing an entry that imports it fails.
    let err = match ShaderLibrary::from_dir(&dir) {
        Err(e) => e,
        Ok(mut lib) => match lib.compose("forward.wgsl", &defs(&[])) {
            Err(e) => e,
            Ok(_) => panic!("the broken module must not compose"),
        },
    };
    assert_eq!(err.file, "brdf.wgsl", "{err}");
    assert_eq!(err.line as usize, line, "{err}");
    assert!(err.column > 0, "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_variant_uses_only_the_modules_its_switches_bring_in() {
    let lib = ShaderLibrary::embedded().unwrap();
    let f = |s: &str| vec![s.to_owned()];
    // Every forward variant might import ies.wgsl (through lights.wgsl, under IES_LIGHTS).
    assert!(lib.depends_on("forward.wgsl", &f("ies.wgsl")));
    assert!(!lib.variant_uses("forward.wgsl", &defs(&[]), &f("ies.wgsl")));
    assert!(!lib.variant_uses("forward.wgsl", &defs(&["LOCAL_LIGHTS"]), &f("ies.wgsl")));
    assert!(lib.variant_uses("forward.wgsl", &defs(&["LOCAL_LIGHTS", "IES_LIGHTS"]), &f("ies.wgsl")));
    // Imported under a switch, unused without it: shadows, the environment.
    assert!(!lib.variant_uses("forward.wgsl", &defs(&[]), &f("shadows.wgsl")));
    assert!(lib.variant_uses("forward.wgsl", &defs(&["SHADOWS"]), &f("shadows.wgsl")));
    assert!(!lib.variant_uses("forward.wgsl", &defs(&[]), &f("ibl.wgsl")));
    assert!(lib.variant_uses("forward.wgsl", &defs(&["IBL"]), &f("ibl.wgsl")));
    // Always in: the BRDF (directly and through lights.wgsl), and the entry itself.
    assert!(lib.variant_uses("forward.wgsl", &defs(&[]), &f("brdf.wgsl")));
    assert!(lib.variant_uses("forward.wgsl", &defs(&[]), &f("light_data.wgsl")));
    assert!(lib.variant_uses("forward.wgsl", &defs(&["UNLIT"]), &f("forward.wgsl")));
    assert!(!lib.variant_uses("tonemap.wgsl", &defs(&[]), &f("brdf.wgsl")));
    // Whatever the variant composes, composing it parses: its imports agree with naga_oil's,
    // for every entry whose imports depend on switches.
    let lights = ["LOCAL_LIGHTS", "CLUSTERED_LIGHTS"];
    let all_lights = [&lights[..], &["SPHERE_TUBE_LIGHTS", "LTC_LIGHTS", "IES_LIGHTS", "LOCAL_SHADOWS"]].concat();
    let variants: [(&str, &[&'static str]); 9] = [
        ("forward.wgsl", &[]),
        ("forward.wgsl", &["LOCAL_LIGHTS", "IES_LIGHTS"]),
        ("forward.wgsl", &["SHADOWS", "IBL", "CLUSTERED_LIGHTS"]),
        ("deferred_lights.wgsl", &lights),
        ("deferred_lights.wgsl", &all_lights),
        ("shadow_caster.wgsl", &[]),
        ("shadow_caster.wgsl", &["ALPHA_MASK", "BASE_COLOR_TEXTURE"]),
        ("cull.wgsl", &[]),
        ("cull.wgsl", &["OCCLUSION_EARLY", "TRIANGLE_CULLING"]),
    ];
    for (entry, list) in variants {
        // Break every module the variant does not use: it still composes.
        let mut sources = lib.sources.clone();
        let mut used = Vec::new();
        for m in lib.module_files.values() {
            if lib.variant_uses(entry, &defs(list), &f(m)) {
                used.push(m.as_str());
            } else {
                sources.get_mut(m).unwrap().push_str("\nfn broken( {\n");
            }
        }
        let mut broken = ShaderLibrary::from_sources(None, sources).unwrap();
        broken.compose(entry, &defs(list)).unwrap_or_else(|e| panic!("{entry} {list:?} uses {used:?}: {e}"));
    }
}

#[test]
fn every_module_checks_in_its_plain_variant_and_a_broken_one_fails_at_its_line() {
    let mut lib = ShaderLibrary::embedded().unwrap();
    let files: Vec<String> = lib.sources.keys().cloned().collect();
    for file in &files {
        lib.check_plain(file).unwrap_or_else(|e| panic!("{e}"));
    }
    // ies.wgsl: no plain variant of any entry imports it, yet its mistakes show: a syntax
    // error, and a type error in a function nothing calls (the validator's, not the parser's).
    let ies = EMBEDDED.iter().find(|(f, _)| *f == "ies.wgsl").unwrap().1;
    for mistake in ["fn broken( {", "fn unused() -> f32 { return 1u; }"] {
        let broken = format!("{ies}\n{mistake}\n");
        let mut lib = ShaderLibrary::embedded_with("ies.wgsl", &broken).unwrap();
        lib.compose("forward.wgsl", &defs(&[])).expect("the plain forward variant does not import ies.wgsl");
        let err = lib.check_plain("ies.wgsl").expect_err(mistake);
        assert_eq!((err.file.as_str(), err.line as usize), ("ies.wgsl", broken.lines().count()), "{err}");
    }
    // A module may test a value an entry file `#define`s: checked with it.
    let mut sources: BTreeMap<String, String> = EMBEDDED.iter().map(|(f, s)| (f.to_string(), s.to_string())).collect();
    sources.get_mut("tonemap.wgsl").unwrap().insert_str(0, "#define GRADE_STEPS 4\n");
    let tested = "#if GRADE_STEPS == 4\nfn steps() -> f32 { return 4.0; }\n#endif\n";
    sources.get_mut("common.wgsl").unwrap().push_str(tested);
    let mut lib = ShaderLibrary::from_sources(None, sources).unwrap_or_else(|e| panic!("{e}"));
    lib.check_plain("common.wgsl").unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn an_import_cycle_is_reported_at_a_module_on_the_ring() {
    let mut sources: BTreeMap<String, String> = EMBEDDED.iter().map(|(f, s)| (f.to_string(), s.to_string())).collect();
    // a imports b; b and c import each other. a is first in name order but not on the ring.
    let module = |name: &str, import: &str| {
        format!("#define_import_path test::{name}\n#import test::{import}::f\nfn g() -> f32 {{ return f(); }}\n")
    };
    sources.insert("a.wgsl".into(), module("a", "b"));
    sources.insert("b.wgsl".into(), module("b", "c"));
    sources.insert("c.wgsl".into(), module("c", "b"));
    let err = ShaderLibrary::from_sources(None, sources).err().expect("a cycle");
    assert_eq!(err.file, "b.wgsl", "{err}");
    assert!(err.message.ends_with("b.wgsl → c.wgsl → b.wgsl"), "{err}");
}

#[test]
fn changed_files_are_edited_added_and_removed_ones() {
    let lib = ShaderLibrary::embedded().unwrap();
    let mut edited = lib.sources.clone();
    edited.get_mut("brdf.wgsl").unwrap().push_str("\n// edited\n");
    edited.insert("extra.wgsl".into(), "fn f() {}\n".into());
    let other = ShaderLibrary::from_sources(None, edited).unwrap();
    assert_eq!(other.changed_files(&lib), ["brdf.wgsl", "extra.wgsl"]);
    assert_eq!(lib.changed_files(&other), ["brdf.wgsl", "extra.wgsl"]);
    assert!(lib.changed_files(&ShaderLibrary::embedded().unwrap()).is_empty());
}

#[test]
fn dependencies_are_transitive() {
    let lib = ShaderLibrary::embedded().unwrap();
    let f = |s: &str| vec![s.to_owned()];
    assert!(lib.depends_on("forward.wgsl", &f("common.wgsl")));
    assert!(lib.depends_on("forward.wgsl", &f("brdf.wgsl")));
    assert!(lib.depends_on("tonemap.wgsl", &f("common.wgsl")));
    assert!(!lib.depends_on("tonemap.wgsl", &f("brdf.wgsl")));
    assert!(!lib.depends_on("mipmap.wgsl", &f("lights.wgsl")));
}
