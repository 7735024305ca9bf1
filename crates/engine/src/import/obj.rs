//! Wavefront OBJ + MTL import, into the same meshes, materials and scene shape as glTF.
//!
//! Two phases like the glTF importer: [`ObjScene::load`] parses the OBJ (the `tobj` crate,
//! polygons triangulated, one index per vertex), its `mtllib` files and every texture they name
//! (all inside the OBJ's folder unless allowed otherwise), and is the only fallible part; any
//! failure names the file, and for syntax errors the line. [`ObjScene::spawn`] puts one entity per
//! OBJ object/group (and material) under a [`SceneRoot`].
//!
//! Conversions (OBJ is older than physically based shading; what each MTL field becomes):
//! - geometry: v flipped (OBJ's texture origin is bottom-left, glTF's top-left); vertex colours
//!   (`v x y z r g b`) kept; missing normals become smooth normals, averaged (area-weighted)
//!   over every face touching the same position, the way OBJ exporters' smoothing groups most
//!   often intend; tangents are generated (MikkTSpace) when the material has a normal map;
//! - `Kd`/`map_Kd` → base colour (factors taken as linear, textures as sRGB, as glTF);
//!   `d` (or `Tr` = 1 − d) below 1 → alpha blending with that alpha;
//! - `Pr`/`Pm` (the PBR extension) → roughness/metallic; without `Pr`, the Blinn-Phong exponent
//!   `Ns` maps to GGX roughness by α = √(2 / (Ns + 2)) (Walter et al. 2007, eq. 19's Beckmann
//!   equivalence), perceptual roughness √α; without `Pm`, metallic 0, except a black `Kd` with a
//!   coloured `Ks` reads as a metal of colour `Ks` (how old exporters wrote metals);
//! - `Ke`/`map_Ke` → emissive; `norm`, `map_Bump` or `bump` → normal map (Blender's exporter
//!   writes normal maps as `map_Bump`), `-bm` its scale;
//! - texture options `-o` and `-s` → the texture transform, `-clamp on` → clamp to edge;
//! - ignored, with a warning naming the material: `map_Ks`, `map_Ns`, `map_d`, `map_Pr`,
//!   `map_Pm` (glTF's metallic-roughness texture packs both channels in one image), `map_Ka`.

use std::cell::RefCell;
use std::collections::HashMap;
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use bevy_ecs::prelude::*;
use glam::{Vec2, Vec3, Vec4};

use super::gltf::SceneRoot;
use super::gltf::images::{decode, held_size};
use super::gltf::source::{ReadBudget, ReadLimit, UriError, read_file, resolve_inside};
use super::{ImportError, ImportErrorKind, ImportOptions, Limit};
use crate::assets::{Assets, Handle};
use crate::components::{Mesh3d, MeshMaterial3d, Name, Transform};
use crate::image::Image;
use crate::material::{AlphaMode, Sampler, StandardMaterial, TextureRef, UvTransform, WrapMode};
use crate::mesh::{Mesh, Topology};

/// A texture an MTL names: which decoded image, and how it is mapped.
#[derive(Debug, Clone)]
struct TextureDesc {
    image: usize,
    sampler: Sampler,
    transform: UvTransform,
}

#[derive(Debug, Clone)]
struct MaterialDesc {
    material: StandardMaterial,
    base_color: Option<TextureDesc>,
    normal: Option<TextureDesc>,
    emissive: Option<TextureDesc>,
}

/// A decoded OBJ file: plain data, ready to spawn any number of times.
#[derive(Debug, Clone)]
pub struct ObjScene {
    pub path: PathBuf,
    /// (object name, mesh, material index)
    objects: Vec<(String, Arc<Mesh>, Option<usize>)>,
    materials: Vec<MaterialDesc>,
    images: Vec<Arc<Image>>,
    pub warnings: Vec<String>,
}

impl ObjScene {
    pub fn load(path: &Path, options: &ImportOptions) -> Result<ObjScene, ImportError> {
        let bytes = crate::import::read_scene_file(path)?;
        Self::from_bytes(&bytes, path, options)
    }

    /// Decodes an OBJ already in memory; `path` names it in errors and anchors relative paths.
    pub fn from_bytes(bytes: &[u8], path: &Path, options: &ImportOptions) -> Result<ObjScene, ImportError> {
        load_inner(bytes, path, options)
    }

    /// Spawns the objects under a new [`SceneRoot`] and returns it.
    pub fn spawn(&self, world: &mut World) -> Entity {
        world.init_resource::<Assets<Image>>();
        world.init_resource::<Assets<StandardMaterial>>();
        world.init_resource::<Assets<Mesh>>();
        let images: Vec<Handle<Image>> = {
            let mut assets = world.resource_mut::<Assets<Image>>();
            self.images.iter().map(|i| assets.add_arc(i.clone())).collect()
        };
        let (materials, default_material) = {
            let mut assets = world.resource_mut::<Assets<StandardMaterial>>();
            let texture = |t: &Option<TextureDesc>| {
                t.as_ref().map(|t| TextureRef {
                    image: images[t.image],
                    sampler: t.sampler,
                    uv_set: 0,
                    transform: t.transform,
                })
            };
            let handles: Vec<_> = self
                .materials
                .iter()
                .map(|d| {
                    let mut m = d.material.clone();
                    m.base_color_texture = texture(&d.base_color);
                    m.normal_texture = texture(&d.normal);
                    m.emissive_texture = texture(&d.emissive);
                    assets.add(m)
                })
                .collect();
            // OBJ without a material: a light grey dielectric, as OBJ viewers show it.
            let default = assets.add(StandardMaterial::from_color(Vec4::new(0.8, 0.8, 0.8, 1.0), 0.5));
            (handles, default)
        };
        let root = SceneRoot::spawn(world, &self.path, None);
        let mut added = super::SceneAssets {
            materials: materials.iter().copied().chain([default_material]).collect(),
            images: images.clone(),
            ..Default::default()
        };
        for (name, mesh, material) in &self.objects {
            let mesh = world.resource_mut::<Assets<Mesh>>().add_arc(mesh.clone());
            added.meshes.push(mesh);
            let material = material.and_then(|m| materials.get(m).copied()).unwrap_or(default_material);
            world.spawn((
                Name::new(name.clone()),
                Transform::IDENTITY,
                Mesh3d(mesh),
                MeshMaterial3d(material),
                ChildOf(root),
            ));
        }
        world.entity_mut(root).insert(added);
        root
    }
}

/// Counts the lines `tobj` has consumed, so a parse error can name its line.
struct LineCounter<R> {
    inner: R,
    newlines: usize,
}

impl<R: Read> Read for LineCounter<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.inner.read(buf)
    }
}

impl<R: BufRead> BufRead for LineCounter<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        self.inner.fill_buf()
    }
    fn consume(&mut self, amt: usize) {
        if let Ok(buf) = self.inner.fill_buf() {
            self.newlines += buf[..amt.min(buf.len())].iter().filter(|&&b| b == b'\n').count();
        }
        self.inner.consume(amt);
    }
}

fn parse_error(e: tobj::LoadError) -> String {
    format!("{e}")
}

fn load_inner(bytes: &[u8], path: &Path, options: &ImportOptions) -> Result<ObjScene, ImportError> {
    let base_dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let reads = ReadBudget::new(options);
    let obj_err = |kind| ImportError::new(path, kind);
    // The MTL loader runs inside tobj; it records the first failure with its file.
    let mtl_failure: RefCell<Option<ImportError>> = RefCell::new(None);
    let load_options =
        tobj::LoadOptions { single_index: true, triangulate: true, ignore_points: true, ignore_lines: true };
    check_face_indices(bytes).map_err(|(line, reason)| obj_err(ImportErrorKind::Obj { line: Some(line), reason }))?;
    let mut reader = LineCounter { inner: std::io::BufReader::new(bytes), newlines: 0 };
    // Bad input must not panic: should the parser still meet a case the check above misses, its
    // panic is an error naming the file, not a crash.
    let parsed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        tobj::load_obj_buf(&mut reader, &load_options, |mtl: &Path| {
            let rel = mtl.to_string_lossy();
            let fail = |kind: ImportErrorKind| {
                mtl_failure.borrow_mut().get_or_insert(ImportError::new(base_dir.join(mtl), kind));
                Err(tobj::LoadError::GenericFailure)
            };
            let file = match resolve_inside(&base_dir, &rel, options.allow_outside_folder) {
                Ok(f) => f,
                Err(UriError::OutsideFolder) => {
                    return fail(ImportErrorKind::UriOutsideFolder { uri: rel.into_owned() });
                }
                Err(e) => return fail(ImportErrorKind::Obj { line: None, reason: e.to_string() }),
            };
            let text = match read_file(&file, ReadLimit::file(options, "an MTL file's size"), &reads) {
                Ok(t) => t,
                Err(e) => {
                    let kind = e.into_kind(&rel, |reason| ImportErrorKind::Obj { line: None, reason });
                    mtl_failure.borrow_mut().get_or_insert(ImportError::new(&file, kind));
                    return Err(tobj::LoadError::OpenFileFailed);
                }
            };
            let mut mtl_reader = LineCounter { inner: std::io::BufReader::new(text.as_slice()), newlines: 0 };
            tobj::load_mtl_buf(&mut mtl_reader).inspect_err(|e| {
                let line = Some(mtl_reader.newlines.max(1));
                mtl_failure
                    .borrow_mut()
                    .get_or_insert(ImportError::new(&file, ImportErrorKind::Obj { line, reason: parse_error(*e) }));
            })
        })
    }));
    let line = reader.newlines;
    let Ok(result) = parsed else {
        return Err(obj_err(ImportErrorKind::Obj {
            line: Some(line.max(1)),
            reason: "the OBJ parser failed on this line".into(),
        }));
    };
    if let Some(e) = mtl_failure.into_inner() {
        return Err(e);
    }
    let (models, materials) = result.map_err(|e| {
        use tobj::LoadError::*;
        match e {
            // tobj checks face indices when an object ends, not on the face's own line.
            FaceVertexOutOfBounds | FaceTexCoordOutOfBounds | FaceNormalOutOfBounds | FaceColorOutOfBounds => {
                obj_err(ImportErrorKind::Obj {
                    line: None,
                    reason: format!("{} (a face of the object or group ending at line {line})", parse_error(e)),
                })
            }
            e => obj_err(ImportErrorKind::Obj { line: Some(line.max(1)), reason: parse_error(e) }),
        }
    })?;
    let materials = materials.map_err(|e| obj_err(ImportErrorKind::Obj { line: None, reason: parse_error(e) }))?;

    let mut warnings = Vec::new();
    let mut images = ObjImages::new(path, reads);
    let mut descs = Vec::new();
    for m in &materials {
        descs.push(convert_material(m, &base_dir, options, &mut images, &mut warnings)?);
    }
    let images = images.images;

    // Totals over the file, before any mesh is converted (tobj's own arrays are bounded by the
    // file's size).
    let (vertices, indices) = models
        .iter()
        .fold((0u64, 0u64), |(v, i), m| (v + m.mesh.positions.len() as u64 / 3, i + m.mesh.indices.len() as u64));
    for (limit, what, value) in [
        (Limit::Vertices, "the vertex count over all objects", vertices),
        (Limit::Indices, "the index count over all objects", indices),
    ] {
        options.limits.check(limit, what, value).map_err(obj_err)?;
    }

    let mut objects = Vec::new();
    for (i, model) in models.iter().enumerate() {
        let material = model.mesh.material_id.filter(|&m| m < descs.len());
        let normal_mapped = material.is_some_and(|m| descs[m].normal.is_some());
        let name = if model.name.is_empty() { format!("object{i}") } else { model.name.clone() };
        let Some(mesh) = convert_mesh(&model.mesh, normal_mapped).map_err(|reason| {
            obj_err(ImportErrorKind::Obj { line: None, reason: format!("object {name:?}: {reason}") })
        })?
        else {
            continue;
        };
        objects.push((name, Arc::new(mesh), material));
    }
    if objects.is_empty() {
        warnings.push("the file has no faces".into());
    }
    crate::import::report::log_warnings(path, &warnings);
    Ok(ObjScene { path: path.to_path_buf(), objects, materials: descs, images, warnings })
}

/// Face corners (`f v/vt/vn ...`) must name elements that exist: an index of 0, or a negative
/// (relative) index reaching before the first element, is refused with its line. The parser
/// checks positive indices itself but computes relative ones with unchecked arithmetic.
fn check_face_indices(bytes: &[u8]) -> Result<(), (usize, String)> {
    let text = String::from_utf8_lossy(bytes);
    let kind_of = |word: Option<&str>| match word {
        Some("v") => Some(0),
        Some("vt") => Some(1),
        Some("vn") => Some(2),
        _ => None,
    };
    // Positive indices may name elements defined later; none may pass the file's total. tobj
    // multiplies an index by 2 or 3 unchecked (an overflow, found by fuzzing), so a bound here
    // keeps every index it sees below the file's line count.
    let mut totals = [0i64; 3];
    for line in text.lines() {
        if let Some(k) = kind_of(line.split_whitespace().next()) {
            totals[k] += 1;
        }
    }
    let mut counts = [0i64; 3];
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let first = words.next();
        if let Some(k) = kind_of(first) {
            counts[k] += 1;
        }
        if first != Some("f") {
            continue;
        }
        for corner in words {
            for (kind, index) in corner.split('/').enumerate().take(3) {
                if index.is_empty() {
                    continue;
                }
                let what = ["vertex", "texture coordinate", "normal"][kind];
                let i: i64 = index.parse().map_err(|_| (n + 1, format!("face index {index:?} is not a number")))?;
                // `i64::MIN` has no negation: it names no element either way.
                if i == 0 || i.checked_neg().is_none_or(|neg| neg > counts[kind]) {
                    return Err((
                        n + 1,
                        format!("face {what} index {i} names no {what} ({} defined so far)", counts[kind]),
                    ));
                }
                if i > totals[kind] {
                    return Err((
                        n + 1,
                        format!("face {what} index {i} names no {what} (the file has {})", totals[kind]),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// One tobj mesh (single-indexed, triangulated) to a `Mesh`; `None` when it has no faces.
fn convert_mesh(m: &tobj::Mesh, normal_mapped: bool) -> Result<Option<Mesh>, String> {
    let n = m.positions.len() / 3;
    if m.indices.is_empty() || n == 0 {
        return Ok(None);
    }
    let vec3s = |v: &[f32]| v.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect::<Vec<_>>();
    let mut mesh = Mesh {
        topology: Topology::TriangleList,
        positions: vec3s(&m.positions),
        normals: if m.normals.len() == m.positions.len() { vec3s(&m.normals) } else { Vec::new() },
        // OBJ's v grows upwards from the image's bottom edge, glTF's downwards from its top.
        uv0: if m.texcoords.len() / 2 == n {
            m.texcoords.chunks_exact(2).map(|c| Vec2::new(c[0], 1.0 - c[1])).collect()
        } else {
            Vec::new()
        },
        colors: if m.vertex_color.len() == m.positions.len() {
            m.vertex_color.chunks_exact(3).map(|c| Vec4::new(c[0], c[1], c[2], 1.0)).collect()
        } else {
            Vec::new()
        },
        indices: Some(m.indices.clone()),
        ..Default::default()
    };
    mesh.validate().map_err(|e| e.to_string())?;
    let replaced = mesh.sanitize();
    if replaced > 0 {
        tracing::warn!("replaced {replaced} non-finite attribute values");
    }
    if mesh.normals.is_empty() {
        mesh.compute_smooth_normals();
    }
    if normal_mapped && !mesh.uv0.is_empty() {
        mesh.generate_tangents(0).map_err(|e| e.to_string())?;
    }
    Ok(Some(mesh))
}

/// An MTL texture statement's options and file name (`-o 0.5 0 -s 2 2 -clamp on wood.png`).
#[derive(Debug, Clone, PartialEq)]
struct TextureStatement {
    file: String,
    offset: Vec2,
    scale: Vec2,
    clamp: bool,
    bump_multiplier: f32,
}

fn parse_texture_statement(s: &str) -> TextureStatement {
    let tokens: Vec<&str> = s.split_whitespace().collect();
    let mut t = TextureStatement {
        file: String::new(),
        offset: Vec2::ZERO,
        scale: Vec2::ONE,
        clamp: false,
        bump_multiplier: 1.0,
    };
    let mut i = 0;
    let numbers = |i: &mut usize, max: usize| {
        let mut v = Vec::new();
        while v.len() < max
            && let Some(x) = tokens.get(*i).and_then(|t| t.parse::<f32>().ok()).filter(|x| x.is_finite())
        {
            v.push(x);
            *i += 1;
        }
        v
    };
    while let Some(tok) = tokens.get(i).filter(|t| t.starts_with('-')) {
        i += 1;
        match *tok {
            "-o" | "-s" | "-t" => {
                let v = numbers(&mut i, 3);
                let uv = Vec2::new(v.first().copied().unwrap_or(0.0), v.get(1).copied().unwrap_or(0.0));
                match *tok {
                    "-o" => t.offset = uv,
                    "-s" => t.scale = Vec2::new(v.first().copied().unwrap_or(1.0), v.get(1).copied().unwrap_or(1.0)),
                    _ => {}
                }
            }
            "-bm" => t.bump_multiplier = numbers(&mut i, 1).first().copied().unwrap_or(1.0),
            "-clamp" => {
                t.clamp = tokens.get(i) == Some(&"on");
                i += 1;
            }
            "-mm" => {
                numbers(&mut i, 2);
            }
            // -blendu, -blendv, -cc, -imfchan, -texres, -boost: one argument each.
            _ => i += 1,
        }
    }
    t.file = tokens[i.min(tokens.len())..].join(" ");
    t
}

/// The textures an OBJ's materials name, each read and decoded once, with what reading and
/// decoding them has used of the limits.
struct ObjImages {
    /// The OBJ file, which errors about all of its images together name.
    scene: PathBuf,
    images: Vec<Arc<Image>>,
    index: HashMap<PathBuf, usize>,
    reads: ReadBudget,
    /// Decoded bytes held so far, mip chains included (`TotalImageBytes`).
    held: u64,
}

impl ObjImages {
    fn new(scene: &Path, reads: ReadBudget) -> Self {
        Self { scene: scene.to_path_buf(), images: Vec::new(), index: HashMap::new(), reads, held: 0 }
    }
}

fn convert_material(
    m: &tobj::Material,
    base_dir: &Path,
    options: &ImportOptions,
    textures: &mut ObjImages,
    warnings: &mut Vec<String>,
) -> Result<MaterialDesc, ImportError> {
    // Rust's float parsing (tobj's too) accepts "nan" and "inf": every factor that is not finite
    // counts as absent, so no NaN reaches a material.
    let finite = |x: f32| x.is_finite().then_some(x);
    let param = |k: &str| {
        m.unknown_param.get(k).and_then(|v| v.split_whitespace().next()?.parse::<f32>().ok()).and_then(finite)
    };
    let rgb = |c: Option<[f32; 3]>| c.map(Vec3::from_array).filter(|c| c.is_finite());
    let diffuse = rgb(m.diffuse).unwrap_or(Vec3::ONE);
    let specular = rgb(m.specular).unwrap_or(Vec3::ZERO);
    let alpha = m.dissolve.and_then(finite).or_else(|| param("Tr").map(|tr| 1.0 - tr)).unwrap_or(1.0).clamp(0.0, 1.0);
    let roughness = param("Pr").unwrap_or_else(|| {
        let ns = m.shininess.and_then(finite).unwrap_or(0.0).max(0.0);
        (2.0 / (ns + 2.0)).sqrt().sqrt()
    });
    let old_style_metal = diffuse.max_element() < 1e-4 && specular.max_element() > 1e-4;
    let (base, metallic) = match param("Pm") {
        Some(pm) => (diffuse, pm),
        None if old_style_metal => (specular, 1.0),
        None => (diffuse, 0.0),
    };
    let mut material = StandardMaterial {
        base_color: base.extend(alpha),
        metallic: metallic.clamp(0.0, 1.0),
        roughness: roughness.clamp(0.0, 1.0),
        emissive: rgb(m.emissive)
            .or_else(|| {
                m.unknown_param.get("Ke").and_then(|v| {
                    let c: Vec<f32> =
                        v.split_whitespace().filter_map(|x| x.parse().ok()).filter(|x: &f32| x.is_finite()).collect();
                    (c.len() == 3).then(|| Vec3::new(c[0], c[1], c[2]))
                })
            })
            .unwrap_or(Vec3::ZERO),
        alpha_mode: if alpha < 1.0 { AlphaMode::Blend } else { AlphaMode::Opaque },
        ..StandardMaterial::default()
    };
    // `slot`: the texture's place in `StandardMaterial::textures`, which says its colour space.
    let mut texture = |statement: Option<&String>,
                       what: &str,
                       slot: usize|
     -> Result<Option<(TextureDesc, f32)>, ImportError> {
        let Some(statement) = statement else { return Ok(None) };
        let t = parse_texture_statement(statement);
        if t.file.is_empty() {
            warnings.push(format!("material {:?}: {what} texture statement names no file", m.name));
            return Ok(None);
        }
        let path = resolve_inside(base_dir, &t.file, options.allow_outside_folder).map_err(|e| match e {
            UriError::OutsideFolder => {
                ImportError::new(base_dir, ImportErrorKind::UriOutsideFolder { uri: t.file.clone() })
            }
            e => ImportError::new(base_dir.join(&t.file), ImportErrorKind::Obj { line: None, reason: e.to_string() }),
        })?;
        let index = match textures.index.get(&path) {
            Some(&i) => i,
            None => {
                let bytes = read_file(&path, ReadLimit::image(options), &textures.reads).map_err(|e| {
                    ImportError::new(&path, e.into_kind(&t.file, |reason| ImportErrorKind::Obj { line: None, reason }))
                })?;
                textures.held = textures.held.saturating_add(held_size(&bytes).unwrap_or(0));
                let what = "the decoded size of all images with their mip chains";
                let scene = &textures.scene;
                options
                    .limits
                    .check(Limit::TotalImageBytes, what, textures.held)
                    .map_err(|k| ImportError::new(scene, k))?;
                let label = t.file.clone();
                let n = textures.images.len();
                let mut image = decode(&bytes, n, &t.file, label, options).map_err(|k| ImportError::new(&path, k))?;
                // The chain for the slot that first reads the image (another slot's colour
                // space has it made on the GPU).
                // A compressed (KTX2) texture brings its own chain or has one made on the GPU.
                if image.compressed.is_none() {
                    image.mips = Some(image.build_mips(StandardMaterial::SRGB_SLOTS[slot]));
                }
                textures.images.push(Arc::new(image));
                textures.index.insert(path, n);
                n
            }
        };
        let wrap = if t.clamp { WrapMode::ClampToEdge } else { WrapMode::Repeat };
        // In flipped (glTF) v: v' = 1 − (s·(1 − v) + o) = s·v + (1 − s − o).
        let transform =
            UvTransform { offset: Vec2::new(t.offset.x, 1.0 - t.scale.y - t.offset.y), rotation: 0.0, scale: t.scale };
        let sampler = Sampler { wrap_u: wrap, wrap_v: wrap, ..Sampler::default() };
        Ok(Some((TextureDesc { image: index, sampler, transform }, t.bump_multiplier)))
    };
    let base_color = texture(m.diffuse_texture.as_ref(), "base colour", 0)?.map(|(t, _)| t);
    let normal_statement = m.unknown_param.get("norm").or(m.normal_texture.as_ref());
    let normal = texture(normal_statement, "normal", 2)?.map(|(t, bm)| {
        material.normal_scale = bm;
        t
    });
    let emissive = texture(m.unknown_param.get("map_Ke"), "emissive", 4)?.map(|(t, _)| t);
    if emissive.is_some() && material.emissive == Vec3::ZERO {
        material.emissive = Vec3::ONE;
    }
    let ignored: Vec<&str> = [
        ("map_Ks", m.specular_texture.is_some()),
        ("map_Ns", m.shininess_texture.is_some()),
        ("map_d", m.dissolve_texture.is_some()),
        ("map_Ka", m.ambient_texture.is_some()),
        ("map_Pr", m.unknown_param.contains_key("map_Pr")),
        ("map_Pm", m.unknown_param.contains_key("map_Pm")),
    ]
    .into_iter()
    .filter(|(_, present)| *present)
    .map(|(k, _)| k)
    .collect();
    if !ignored.is_empty() {
        warnings.push(format!("material {:?}: {} not supported, ignored", m.name, ignored.join(", ")));
    }
    Ok(MaterialDesc { material, base_color, normal, emissive })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_statements_keep_options_apart_from_the_file_name() {
        let t = parse_texture_statement("-o 0.5 0.25 -s 2 3 1 -clamp on -bm 0.8 my wood.png");
        assert_eq!(t.file, "my wood.png");
        assert_eq!(
            (t.offset, t.scale, t.clamp, t.bump_multiplier),
            (Vec2::new(0.5, 0.25), Vec2::new(2.0, 3.0), true, 0.8)
        );
        assert_eq!(parse_texture_statement("plain.png").file, "plain.png");
        assert_eq!(parse_texture_statement("-blendu off -imfchan l x.png").file, "x.png");
    }

    #[test]
    fn shininess_maps_to_roughness_through_the_beckmann_equivalence() {
        let m = |ns: f32| tobj::Material { shininess: Some(ns), ..Default::default() };
        let r = |ns| {
            let d = convert_material(
                &m(ns),
                Path::new("."),
                &ImportOptions::default(),
                &mut ObjImages::new(Path::new("test.obj"), ReadBudget::new(&ImportOptions::default())),
                &mut Vec::new(),
            )
            .unwrap();
            d.material.roughness
        };
        // Ns 0: α = 1, roughness 1. Ns 98: α = √(2/100) = 0.1414, roughness 0.376.
        assert!((r(0.0) - 1.0).abs() < 1e-6);
        assert!((r(98.0) - 0.376).abs() < 1e-3, "{}", r(98.0));
        assert!(r(1000.0) < r(98.0));
    }
}
