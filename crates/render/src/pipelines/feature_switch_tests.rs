//! Tests of the feature-switch check through the shader library that runs it: the switches
//! the embedded shaders test against the list, and the errors a typo gets at its place. Apart
//! from `feature_switches` because they need the library, which itself depends on the check.

use std::collections::BTreeMap;

use super::feature_switches::{FEATURE_SWITCHES, check, directives};
use super::shader_library::{EMBEDDED, ShaderLibrary};

fn embedded(file: &str) -> &'static str {
    EMBEDDED.iter().find(|(f, _)| *f == file).unwrap().1
}

#[test]
fn the_list_is_what_the_shaders_test_and_the_pipelines_set() {
    let tested: std::collections::BTreeSet<String> =
        EMBEDDED.iter().flat_map(|(_, s)| directives(s).tests.into_iter().map(|t| t.name)).collect();
    let listed: std::collections::BTreeSet<String> = FEATURE_SWITCHES.iter().map(|s| s.to_string()).collect();
    assert_eq!(tested, listed, "FEATURE_SWITCHES against the embedded shaders' #ifdef names");
    assert!(FEATURE_SWITCHES.is_sorted_by(|a, b| a < b), "sorted (check searches it), no name twice");
    // The other way: a switch no pipeline sets any more would leave its code out for good.
    // (ShaderDefs::with debug-asserts that whatever is set is listed.)
    // Every source file of the crate, where the pipeline families and the draw key set them.
    let mut pipeline_code = String::new();
    let mut folders = vec![std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/src"))];
    while let Some(folder) = folders.pop() {
        for entry in std::fs::read_dir(&folder).expect("the crate's sources").flatten() {
            let path = entry.path();
            if path.is_dir() {
                folders.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                pipeline_code += &std::fs::read_to_string(&path).expect("a source file");
            }
        }
    }
    for name in FEATURE_SWITCHES {
        assert!(pipeline_code.contains(&format!(".with(\"{name}\"")), "no pipeline sets {name}");
    }
}

#[test]
fn an_unknown_switch_is_an_error_at_its_name() {
    let forward = embedded("forward.wgsl");
    // The error of forward.wgsl with `from` (a whole line) replaced by `to`, checked to sit
    // at `at` in `to`.
    let edit = |from: &str, to: &str, at: &str| {
        let line = forward.lines().position(|l| l.trim() == from).expect("the test's edit must apply") + 1;
        let column = forward.lines().nth(line - 1).unwrap().find(from).unwrap() + to.find(at).unwrap() + 1;
        let err = ShaderLibrary::embedded_with("forward.wgsl", &forward.replacen(from, to, 1))
            .err()
            .unwrap_or_else(|| panic!("{to} must not build"));
        assert_eq!((err.file.as_str(), err.line, err.column as usize), ("forward.wgsl", line as u32, column), "{err}");
        err.message
    };
    let typo = edit("#ifdef NORMAL_MAP", "#ifdef NORMAL_MPA", "NORMAL_MPA");
    assert!(typo.contains("unknown feature switch NORMAL_MPA (did you mean NORMAL_MAP?)"), "{typo}");
    assert!(typo.ends_with("this #ifdef guards would never be compiled"), "{typo}");
    let negated = edit("#ifndef UNLIT", "#ifndef UNLTI", "UNLTI");
    assert!(negated.contains("(did you mean UNLIT?)") && negated.contains("would always be"), "{negated}");
    let far = edit("#ifdef IBL", "#  else   ifdef WIREFRAME", "WIREFRAME");
    assert!(far.starts_with("unknown feature switch WIREFRAME: "), "no suggestion this far off: {far}");
    let compared = edit("#ifdef IBL", "#if SHADOW == true", "SHADOW");
    assert!(compared.contains("(did you mean SHADOWS?)") && compared.contains("fail to compose"), "{compared}");
    // naga_oil's names take `|`: this is one name, and no variant defines it.
    let piped = edit("#ifdef IBL", "#ifdef IBL|SHADOWS", "IBL|");
    assert!(piped.starts_with("unknown feature switch IBL|SHADOWS"), "{piped}");
    // `#else` with anything but a whole branch after it is a plain `#else` to naga_oil.
    for malformed in ["#elseifdef IBL", "#else ifdef", "#else if IBL", "#else define IBL"] {
        let message = edit("#ifdef IBL", malformed, "else");
        assert!(message.starts_with("naga_oil reads this as a plain #else"), "{malformed}: {message}");
    }
    // Switches are defined only where they are on: `#if` on one fails where it is off.
    let listed = edit("#ifdef IBL", "#if SHADOWS == true", "SHADOWS");
    assert!(listed.contains("test it with #ifdef or #ifndef"), "{listed}");
    // Columns count characters, after a block comment on the same line too.
    let source = forward.replacen("#ifdef IBL", "/* é */ #ifdef TYPO\n#endif\n#ifdef IBL", 1);
    let err = ShaderLibrary::embedded_with("forward.wgsl", &source).err().expect("TYPO");
    assert_eq!((err.line as usize, err.column), (forward.lines().position(|l| l == "#ifdef IBL").unwrap() + 1, 16));
}

#[test]
fn comments_and_own_defines_are_not_typos() {
    let forward = embedded("forward.wgsl");
    let with = |insert: &str| {
        let source = forward.replacen("#ifdef IBL", &format!("{insert}\n#ifdef IBL"), 1);
        assert_ne!(source, forward, "the test's edit must apply");
        ShaderLibrary::embedded_with("forward.wgsl", &source).err()
    };
    assert_eq!(with("/* an old path:\n#ifdef OLD_PATH\n#endif\n*/"), None, "inside a block comment");
    assert_eq!(with("#define MY_SWITCH\n#ifdef MY_SWITCH\n#endif"), None, "defined by the file itself");
    assert_eq!(with("#define LEVEL 2\n#if LEVEL == 2\n#endif"), None, "an #if on the file's own value");
    // A #define inside a comment defines nothing.
    assert!(with("// #define MY_SWITCH\n#ifdef MY_SWITCH\n#endif").is_some());
    // Another entry file's #define is out of an entry's reach.
    let tonemap = embedded("tonemap.wgsl").replacen("#ifdef BLOOM", "#define MY_SWITCH\n#ifdef BLOOM", 1);
    let mut sources: BTreeMap<String, String> = EMBEDDED.iter().map(|(f, s)| (f.to_string(), s.to_string())).collect();
    sources.insert("tonemap.wgsl".into(), tonemap);
    sources.insert("forward.wgsl".into(), forward.replacen("#ifdef IBL", "#ifdef MY_SWITCH\n#endif\n#ifdef IBL", 1));
    assert_eq!(check(&sources).map_err(|e| e.file), Err("forward.wgsl".to_owned()));
}

#[test]
fn a_reload_checks_every_file() {
    let dir = std::env::temp_dir().join(format!("penumbra-unknown-switch-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let write = |file: &str, from: &str, to: &str| {
        let source = embedded(file);
        assert!(source.contains(from), "the test's edit must apply");
        std::fs::write(dir.join(file), source.replacen(from, to, 1)).unwrap();
    };
    // A module testing a switch an entry file defines: fine while the entry defines it.
    write("tonemap.wgsl", "#ifdef BLOOM", "#define GRADE\n#ifdef BLOOM");
    write("lights.wgsl", "#ifdef SPHERE_TUBE_LIGHTS", "#ifdef GRADE\n#endif\n#ifdef SPHERE_TUBE_LIGHTS");
    let lib = ShaderLibrary::from_dir(&dir).unwrap_or_else(|e| panic!("{e}"));
    // The entry file's define taken out (a reload that keeps the composer): the module's
    // test is now a name nothing defines, though the module itself did not change.
    write("tonemap.wgsl", "#ifdef BLOOM", "#ifdef BLOOM");
    let err = lib.reloaded(&["tonemap.wgsl".to_owned()]).err().expect("lights.wgsl's GRADE");
    assert_eq!((err.file.as_str(), err.line), ("lights.wgsl", 6), "{err}");
    // A typo in an entry file (the module as shipped again).
    std::fs::remove_file(dir.join("lights.wgsl")).unwrap();
    write("tonemap.wgsl", "#ifdef BLOOM", "#ifdef BLOM");
    let entry = lib.reloaded(&["tonemap.wgsl".to_owned()]).err().expect("a typo in an entry");
    assert!(entry.message.contains("(did you mean BLOOM?)"), "{entry}");
    let _ = std::fs::remove_dir_all(&dir);
}
