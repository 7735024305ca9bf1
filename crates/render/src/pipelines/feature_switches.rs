//! Feature switches: the `#ifdef` names Penumbra's variants define, and the check that a shader
//! tests no other.
//!
//! A variant is a set of switches ([`super::shader_library::ShaderDefs`]) that naga_oil's
//! preprocessor resolves before compilation. A name no variant defines is a typo whose code would
//! silently never compile (`#ifdef NORMAL_MPA`), or always (`#ifndef`), or fail to compose in
//! every variant (`#if NAME == value`). The shader library runs [`check`] over every source when
//! it is built and on every reload, before composition, so such a name is an error at its place
//! with the closest switch suggested; `ShaderDefs::with` debug-asserts that what Rust sets is
//! listed.
//! Names a shader `#define`s itself count: an entry file's own, and for a module (which
//! naga_oil does not let define) any entry file's.

use std::borrow::Cow;
use std::collections::BTreeMap;

use naga_oil::compose::comment_strip_iter::CommentReplaceExt;

use super::shader_library::ShaderError;

/// Every feature switch some variant defines: every name a shader's `#ifdef`, `#ifndef` or `#if`
/// may test besides what it `#define`s. Sorted. The embedded shaders test exactly these names,
/// and pipeline code sets each of them (unit tests).
pub const FEATURE_SWITCHES: &[&str] = &[
    "ALPHA_BLEND",
    "ALPHA_COVERAGE",
    "ALPHA_MASK",
    "ALPHA_SAMPLE_RATE",
    "AUTO_EXPOSURE",
    "BASE_COLOR_TEXTURE",
    "BLOOM",
    "CLUSTERED_LIGHTS",
    "DEBUG_CASCADES",
    "DEBUG_CLUSTER_HEAT",
    "DEBUG_NORMALS",
    "DEBUG_UVS",
    "DECODE_SRGB",
    "DEFERRED_LOCAL_LIGHTS",
    "DOWNSAMPLE",
    "EMISSIVE_TEXTURE",
    "ENCODE_SRGB",
    "FIRST",
    "FROM_DEPTH",
    "GLOBAL_LIGHTS_IN_STORAGE",
    "IBL",
    "IES_LIGHTS",
    "IRRADIANCE_SH",
    "LINE_QUADS",
    "LOCAL_LIGHTS",
    "LOCAL_SHADOWS",
    "LTC_LIGHTS",
    "METALLIC_ROUGHNESS_TEXTURE",
    "MULTISAMPLED",
    "NORMAL_MAP",
    "OCCLUSION_EARLY",
    "OCCLUSION_IN_METALLIC_ROUGHNESS",
    "OCCLUSION_LATE",
    "OCCLUSION_TEXTURE",
    "POOL_VERTICES",
    "PULLED_VERTICES",
    "SHADOWS",
    "SPECULAR",
    "SPHERE_TUBE_LIGHTS",
    "SRGB",
    "TONEMAP_ACES",
    "TONEMAP_IN_FORWARD",
    "TONEMAP_NEUTRAL",
    "TRANSFORMED_UVS",
    "TRIANGLE_CULLING",
    "UNBOUNDED_LIGHTS",
    "UNLIT",
    "VERTEX_COLORS",
    "VISIBILITY_BACKGROUND",
    "VISIBILITY_DISPLAY",
    "VISIBILITY_SHADE",
    "VISIBILITY_TONEMAP",
];

/// A switch test: the name, the directive (`ifdef`, `ifndef`, `if`), and the 1-based line and
/// column of the name.
struct Test {
    name: String,
    directive: &'static str,
    line: u32,
    column: u32,
}

/// One file's preprocessor lines as naga_oil reads them (comments blanked out first).
#[derive(Default)]
struct Directives {
    /// `#define_import_path`: a module other files import.
    module: bool,
    tests: Vec<Test>,
    defines: Vec<String>,
    /// The first `#elseifdef NAME` or the like, which naga_oil reads as a plain `#else`: (line,
    /// column).
    malformed_else: Option<(u32, u32)>,
}

/// naga_oil's name characters (`[\w|\d|_]+`, Unicode `\w` as the regex crate reads it).
fn is_name_char(c: char) -> bool {
    regex_syntax::is_word_character(c) || c == '|'
}

fn directives(source: &str) -> Directives {
    // naga_oil blanks comments before it reads directives, but only a block comment can hide a
    // directive (a line comment after one ends no name early: names stop at `/`). Blanking
    // costs a regex search per line (2.1 against 0.75 ms a reload over the embedded set, dev
    // build); most sources have no block comment and are read as they stand.
    if source.contains("/*") {
        let mut lines = source.lines();
        scan(lines.replace_comments().zip(source.lines()))
    } else {
        scan(source.lines().map(Cow::Borrowed).zip(source.lines()))
    }
}

/// Reads directives from (line with comments blanked, line as written) pairs.
fn scan<'a>(lines: impl Iterator<Item = (Cow<'a, str>, &'a str)>) -> Directives {
    let mut found = Directives::default();
    for (i, (clean, raw)) in lines.enumerate() {
        // Blanking keeps byte offsets, so an offset in `clean` is one in `raw`.
        let column = |rest: &str| {
            let offset = clean.len() - rest.len();
            raw.get(..offset).map_or(offset, |s| s.chars().count()) as u32 + 1
        };
        let Some(rest) = clean.trim_start().strip_prefix('#') else { continue };
        let rest = rest.trim_start();
        let directive_at = column(rest);
        if rest.starts_with("define_import_path") {
            found.module = true;
            continue;
        }
        // naga_oil reads `#else` followed by anything but a whole branch directive
        // (`#elseifdef X`, `#else ifdef`, `#else if X`) as a plain `#else`, silently.
        let mut malformed = || {
            found.malformed_else.get_or_insert((i as u32 + 1, directive_at));
        };
        let (after_else, rest) = match rest.strip_prefix("else") {
            Some(r) if r.trim().is_empty() => continue,
            Some(r) if r.starts_with(char::is_whitespace) => (true, r.trim_start()),
            Some(_) => {
                malformed();
                continue;
            }
            None => (false, rest),
        };
        let directive = ["ifdef", "ifndef", "if", "define"].into_iter().find_map(|d| {
            rest.strip_prefix(d).filter(|r| r.starts_with(char::is_whitespace)).map(|r| (d, r.trim_start()))
        });
        let Some((directive, tail)) = directive.filter(|(d, _)| !(after_else && *d == "define")) else {
            if after_else {
                malformed();
            }
            continue;
        };
        let name = &tail[..tail.find(|c: char| !is_name_char(c)).unwrap_or(tail.len())];
        // `#if NAME op value`: naga_oil's operator may be empty, its value may not.
        let compared = || {
            let value = tail[name.len()..].trim_start().trim_start_matches(['=', '!', '<', '>']).trim_start();
            value.starts_with(|c: char| is_name_char(c) || c == '-')
        };
        if name.is_empty() || (directive == "if" && !compared()) {
            if after_else {
                malformed();
            }
            continue;
        }
        if directive == "define" {
            found.defines.push(name.to_owned());
        } else {
            found.tests.push(Test { name: name.to_owned(), directive, line: i as u32 + 1, column: column(tail) });
        }
    }
    found
}

/// The first switch in `sources` (by file name, then line) that no variant and no `#define` in
/// its reach defines, as an error at the name; or a listed switch in an `#if`, or an `#else`
/// naga_oil would read as a plain one.
pub fn check(sources: &BTreeMap<String, String>) -> Result<(), ShaderError> {
    let scanned: Vec<(&String, Directives)> = sources.iter().map(|(f, s)| (f, directives(s))).collect();
    // What an entry file defines reaches the modules it imports; which ones is the composer's
    // business, so a module may test what any entry file defines.
    let entry_defines: Vec<&str> =
        scanned.iter().filter(|(_, d)| !d.module).flat_map(|(_, d)| d.defines.iter().map(String::as_str)).collect();
    for (file, found) in &scanned {
        if let Some((line, column)) = found.malformed_else {
            let message = "naga_oil reads this as a plain #else: write #else ifdef NAME (or #else ifndef NAME)";
            return Err(ShaderError { file: (*file).clone(), line, column, message: message.to_owned() });
        }
        let own: Vec<&str>;
        let in_reach: &[&str] = if found.module {
            &entry_defines
        } else {
            own = found.defines.iter().map(String::as_str).collect();
            &own
        };
        let listed = |name: &str| FEATURE_SWITCHES.binary_search(&name).is_ok();
        // A switch is defined only where it is on, and naga_oil fails an `#if` on an undefined
        // name: switches are for `#ifdef` and `#ifndef`, `#if` for a file's own values.
        if let Some(t) =
            found.tests.iter().find(|t| t.directive == "if" && listed(&t.name) && !in_reach.contains(&t.name.as_str()))
        {
            return Err(ShaderError {
                file: (*file).clone(),
                line: t.line,
                column: t.column,
                message: format!(
                    "feature switch {} in an #if: a switch is defined only where it is on, so this fails to compose \
                     wherever it is off; test it with #ifdef or #ifndef",
                    t.name
                ),
            });
        }
        let Some(test) = found.tests.iter().find(|t| !listed(&t.name) && !in_reach.contains(&t.name.as_str())) else {
            continue;
        };
        let name = test.name.as_str();
        let closest = FEATURE_SWITCHES
            .iter()
            .chain(in_reach)
            // Optimal string alignment: a swap of two letters (UNLTI) is one edit.
            .map(|d| (strsim::osa_distance(d, name), *d))
            .min()
            .filter(|(distance, _)| *distance <= (name.chars().count() / 3).max(1))
            .map_or(String::new(), |(_, d)| format!(" (did you mean {d}?)"));
        let outcome = match test.directive {
            "ifdef" => "the code this #ifdef guards would never be compiled",
            "ifndef" => "the code this #ifndef guards would always be compiled",
            _ => "this #if would fail to compose in every variant",
        };
        return Err(ShaderError {
            file: (*file).clone(),
            line: test.line,
            column: test.column,
            message: format!("unknown feature switch {name}{closest}: no variant defines it, so {outcome}"),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipelines::shader_library::{EMBEDDED, ShaderLibrary};

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
        let pipeline_code = [
            include_str!("pipeline_cache.rs"),
            include_str!("pipeline_cache/casters.rs"),
            include_str!("pipeline_cache/culling.rs"),
            include_str!("pipeline_cache/deform.rs"),
            include_str!("pipeline_cache/gizmos.rs"),
            include_str!("pipeline_cache/environment.rs"),
            include_str!("pipeline_cache/post.rs"),
            include_str!("pipeline_cache/visibility.rs"),
        ]
        .concat();
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
            assert_eq!(
                (err.file.as_str(), err.line, err.column as usize),
                ("forward.wgsl", line as u32, column),
                "{err}"
            );
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
        let mut sources: BTreeMap<String, String> =
            EMBEDDED.iter().map(|(f, s)| (f.to_string(), s.to_string())).collect();
        sources.insert("tonemap.wgsl".into(), tonemap);
        sources
            .insert("forward.wgsl".into(), forward.replacen("#ifdef IBL", "#ifdef MY_SWITCH\n#endif\n#ifdef IBL", 1));
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
}
