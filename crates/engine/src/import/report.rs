//! How an import's warnings reach the log: one line per kind of problem, not one per mesh.
//!
//! A file with the same problem in 49 primitives (degenerate triangles in every sphere of
//! MetalRoughSpheresNoTextures) would otherwise print 49 near-identical lines. Warnings that
//! differ only in their numbers and quoted names are one kind; the first of each kind is logged
//! as a warning with how many more there are, and every one of them at `info` level (`-v`). The
//! scene's `warnings` list keeps them all.

use std::path::Path;

/// Logs `warnings` for the file at `path`, grouped by kind.
pub(crate) fn log_warnings(path: &Path, warnings: &[String]) {
    let kinds = group(warnings);
    let grouped = warnings.len() > kinds.len();
    for (first, count) in kinds {
        if count == 1 {
            tracing::warn!("{}: {first}", path.display());
        } else {
            tracing::warn!("{}: {first} (and {} more like it; `-v` lists them)", path.display(), count - 1);
        }
    }
    if grouped {
        for w in warnings {
            tracing::info!("{}: {w}", path.display());
        }
    }
}

/// The first warning of each kind, with how many of that kind there are, in order of first
/// appearance.
fn group(warnings: &[String]) -> Vec<(&str, usize)> {
    let mut kinds: Vec<(String, &str, usize)> = Vec::new();
    for w in warnings {
        let k = kind(w);
        match kinds.iter_mut().find(|(key, ..)| *key == k) {
            Some((_, _, count)) => *count += 1,
            None => kinds.push((k, w, 1)),
        }
    }
    kinds.into_iter().map(|(_, first, count)| (first, count)).collect()
}

/// A warning with its numbers and quoted names blanked: what stays is the kind of problem.
fn kind(w: &str) -> String {
    let mut out = String::with_capacity(w.len());
    let mut quoted = false;
    let mut last_digit = false;
    for c in w.chars() {
        if c == '"' {
            quoted = !quoted;
            out.push('"');
            continue;
        }
        if quoted {
            continue;
        }
        let digit = c.is_ascii_digit() || (last_digit && c == '.');
        if digit {
            if !last_digit {
                out.push('#');
            }
        } else {
            out.push(c);
        }
        last_digit = digit;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warnings_differing_only_in_numbers_and_names_are_one_kind() {
        let w: Vec<String> = [
            "mesh 0 primitive 0: 12 degenerate triangles (zero area: the rasteriser draws nothing for them)",
            "optional extension KHR_x is not supported and is ignored",
            "mesh 1 primitive 0: 3 degenerate triangles (zero area: the rasteriser draws nothing for them)",
            "material \"a\": metallicFactor 5 is outside 0..=1; using 1",
            "material \"b\": metallicFactor 2.5 is outside 0..=1; using 1",
            "mesh 12 primitive 3: 1 degenerate triangles (zero area: the rasteriser draws nothing for them)",
        ]
        .map(String::from)
        .to_vec();
        let g = group(&w);
        assert_eq!(g.len(), 3, "{g:?}");
        assert_eq!((g[0].0, g[0].1), (w[0].as_str(), 3));
        assert_eq!(g[1].1, 1);
        assert_eq!(g[2].1, 2);
        assert_ne!(kind("metallicFactor 5 is outside"), kind("roughnessFactor 5 is outside"));
    }
}
