//! KHR_materials_variants, read from the raw JSON (the gltf crate's typed support is behind a
//! feature this crate does not use): the file's variant names, and each primitive's mappings
//! from variants to materials. A mapping naming a variant or material the file lacks is
//! dropped with a warning naming the mesh and primitive; the run-time switching is
//! `crate::variants`.

/// The file's variant names, in order (an unnamed variant is called by its index).
pub(crate) fn names(document: &gltf::Document, warnings: &mut Vec<String>) -> Vec<String> {
    let Some(ext) = document.extension_value("KHR_materials_variants") else { return Vec::new() };
    let Some(list) = ext.get("variants").and_then(|v| v.as_array()) else {
        warnings.push("KHR_materials_variants: the extension lists no `variants` array; ignored".into());
        return Vec::new();
    };
    list.iter()
        .enumerate()
        .map(|(i, v)| v.get("name").and_then(|n| n.as_str()).map_or_else(|| format!("variant {i}"), str::to_owned))
        .collect()
}

/// The primitive's (variant, material) pairs.
pub(crate) fn mappings(
    prim: &gltf::Primitive,
    mesh: usize,
    variant_count: usize,
    material_count: usize,
    warnings: &mut Vec<String>,
) -> Vec<(usize, usize)> {
    let Some(ext) = prim.extension_value("KHR_materials_variants") else { return Vec::new() };
    let mut out = Vec::new();
    for mapping in ext.get("mappings").and_then(|m| m.as_array()).into_iter().flatten() {
        let material = mapping.get("material").and_then(|m| m.as_u64()).map(|m| m as usize);
        let Some(material) = material.filter(|&m| m < material_count) else {
            warnings.push(format!(
                "mesh {mesh} primitive {}: KHR_materials_variants mapping names no material of the file ({}); ignored",
                prim.index(),
                mapping.get("material").map_or("none".to_owned(), |m| m.to_string())
            ));
            continue;
        };
        for v in mapping.get("variants").and_then(|v| v.as_array()).into_iter().flatten() {
            match v.as_u64().map(|v| v as usize) {
                Some(v) if v < variant_count => out.push((v, material)),
                _ => warnings.push(format!(
                    "mesh {mesh} primitive {}: KHR_materials_variants mapping names variant {v}, which the file \
                     does not list; ignored",
                    prim.index()
                )),
            }
        }
    }
    out
}
