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

use super::shader_error::ShaderError;

/// Every feature switch some variant defines: every name a shader's `#ifdef`, `#ifndef` or `#if`
/// may test besides what it `#define`s. Sorted. The embedded shaders test exactly these names,
/// and pipeline code sets each of them (unit tests).
pub const FEATURE_SWITCHES: &[&str] = &[
    "ALPHA_BLEND",
    "ALPHA_COVERAGE",
    "ALPHA_MASK",
    "ALPHA_SAMPLE_RATE",
    "ANISOTROPY_TEXTURE",
    "AUTO_EXPOSURE",
    "BASE_COLOR_TEXTURE",
    "BLOOM",
    "CLEARCOAT_NORMAL_MAP",
    "CLEARCOAT_ROUGHNESS_TEXTURE",
    "CLEARCOAT_TEXTURE",
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
    "IRIDESCENCE_TEXTURE",
    "IRIDESCENCE_THICKNESS_TEXTURE",
    "IRRADIANCE_SH",
    "LINE_QUADS",
    "LOCAL_LIGHTS",
    "LOCAL_SHADOWS",
    "LTC_LIGHTS",
    "MATERIAL_ANISOTROPY",
    "MATERIAL_CLEARCOAT",
    "MATERIAL_EXTENSION",
    "MATERIAL_IRIDESCENCE",
    "MATERIAL_SHEEN",
    "MATERIAL_SPECULAR",
    "MATERIAL_TRANSMISSION",
    "METALLIC_ROUGHNESS_TEXTURE",
    "MULTISAMPLED",
    "NORMAL_MAP",
    "OCCLUSION_EARLY",
    "OCCLUSION_IN_METALLIC_ROUGHNESS",
    "OCCLUSION_LATE",
    "OCCLUSION_TEXTURE",
    "OVERLAY_MULTISAMPLED",
    "POOL_VERTICES",
    "PULLED_VERTICES",
    "SAMPLE_MASK_OUT",
    "SHADOWS",
    "SHADOW_DEPTH",
    "SHEEN_COLOR_TEXTURE",
    "SHEEN_ROUGHNESS_TEXTURE",
    "SPECULAR",
    "SPECULAR_COLOR_TEXTURE",
    "SPECULAR_TEXTURE",
    "SPHERE_TUBE_LIGHTS",
    "SRGB",
    "THICKNESS_TEXTURE",
    "TONEMAP_ACES",
    "TONEMAP_IN_FORWARD",
    "TONEMAP_NEUTRAL",
    "TRANSFORMED_UVS",
    "TRANSMISSION_TEXTURE",
    "TRIANGLE_CULLING",
    "UNBOUNDED_LIGHTS",
    "UNLIT",
    "VERTEX_COLORS",
    "VISIBILITY_BACKGROUND",
    "VISIBILITY_DISPLAY",
    "VISIBILITY_OCCLUSION",
    "VISIBILITY_OVERLAY",
    "VISIBILITY_REUSE",
    "VISIBILITY_SHADE",
    "VISIBILITY_TONEMAP",
];

/// A switch test: the name, the directive (`ifdef`, `ifndef`, `if`), and the 1-based line and
/// column of the name.
pub(super) struct Test {
    pub(super) name: String,
    directive: &'static str,
    line: u32,
    column: u32,
}

/// One file's preprocessor lines as naga_oil reads them (comments blanked out first).
#[derive(Default)]
pub(super) struct Directives {
    /// `#define_import_path`: a module other files import.
    module: bool,
    pub(super) tests: Vec<Test>,
    defines: Vec<String>,
    /// The first `#elseifdef NAME` or the like, which naga_oil reads as a plain `#else`: (line,
    /// column).
    malformed_else: Option<(u32, u32)>,
}

/// naga_oil's name characters (`[\w|\d|_]+`, Unicode `\w` as the regex crate reads it).
fn is_name_char(c: char) -> bool {
    regex_syntax::is_word_character(c) || c == '|'
}

pub(super) fn directives(source: &str) -> Directives {
    // naga_oil blanks comments before it reads directives, but only a block comment can hide a
    // directive (a line comment after one ends no name early: names stop at `/`). Blanking
    // costs a regex search per line, several times a plain scan; most sources have no block
    // comment and are read as they stand.
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
