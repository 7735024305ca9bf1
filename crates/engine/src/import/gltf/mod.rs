//! glTF 2.0 import (`.gltf` with external or data-URI buffers, and `.glb`).
//!
//! [`GltfScene::load`] is phase one and the only fallible part: read the file; refuse unsupported
//! required extensions by name; validate the JSON; resolve buffers (GLB chunk, data URIs, files
//! inside the scene's folder); check the node hierarchy is a forest; decode every primitive
//! (accessors bounds-checked, topology expanded, normals and tangents completed) and every
//! referenced image (in parallel), packing a separate occlusion image into the metallic-roughness
//! one where no pixel changes (`occlusion_packing`). [`GltfScene::spawn`] is phase two: assets
//! into `Assets<T>`, nodes into entities under one [`SceneRoot`], infallibly.

mod accessor;
mod animation;
mod area_lights;
mod cameras;
mod draco;
mod ies_lights;
pub(crate) mod images;
mod instancing;
mod material_extensions;
mod materials;
mod meshopt;
mod occlusion_packing;
mod primitive;
pub mod punctual_lights;
pub(crate) mod source;
mod spec_gloss;
mod variants;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use bevy_ecs::prelude::*;
use glam::{Mat4, Vec3};

use crate::animation::{AnimationClip, AnimationPlayer};
use crate::assets::{Assets, Handle};
use crate::components::{
    Camera, Exposure, IesLight, Mesh3d, MeshMaterial3d, MorphWeights, Name, SkinnedMesh, Transform, Visibility,
};
use crate::ies::IesProfile;
use crate::image::Image;
use crate::import::{ImportError, ImportErrorKind, ImportLimits, Limit};
use crate::material::{StandardMaterial, TextureRef};
use crate::mesh::Mesh;
use accessor::Buffers;
use materials::MaterialDesc;
use punctual_lights::LightDesc;

/// Extensions Penumbra implements. A file that lists any other in `extensionsRequired` is refused.
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "EXT_lights_ies",
    "PENUMBRA_lights_area",
    "KHR_materials_anisotropy",
    "KHR_materials_clearcoat",
    "KHR_materials_dispersion",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_iridescence",
    "KHR_materials_pbrSpecularGlossiness",
    "KHR_materials_sheen",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_unlit",
    "KHR_materials_variants",
    "KHR_materials_volume",
    "KHR_texture_transform",
    "KHR_mesh_quantization",
    "EXT_mesh_gpu_instancing",
    "EXT_texture_webp",
    "KHR_texture_basisu",
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
    // Metadata (XMP packets): nothing in them changes what is drawn.
    "KHR_xmp",
    "KHR_xmp_json_ld",
];

#[derive(Debug, Clone, Default)]
pub struct ImportOptions {
    /// Which scene to spawn; `None` is the file's default scene (or scene 0).
    pub scene: Option<usize>,
    /// Let relative URIs reach outside the scene's folder (`..`, absolute paths, symlinks).
    pub allow_outside_folder: bool,
    /// What the file may make the importer allocate (see [`ImportLimits`]).
    pub limits: ImportLimits,
    /// Reports the import's stages and counts (for a progress bar on another thread).
    pub progress: Option<super::ImportProgress>,
}

/// The root entity of a spawned scene; despawning it (recursively) removes the whole scene.
#[derive(Component, Debug, Clone)]
#[require(Transform, Visibility)]
pub struct SceneRoot {
    pub source: PathBuf,
    pub scene: Option<usize>,
}

impl SceneRoot {
    /// Spawns a scene's root entity, named after the file.
    pub(crate) fn spawn(world: &mut World, source: &Path, scene: Option<usize>) -> Entity {
        let name = source.file_name().map_or_else(|| "scene".into(), |n| n.to_string_lossy().into_owned());
        world.spawn((SceneRoot { source: source.to_path_buf(), scene }, Name::new(name))).id()
    }
}

/// A camera that came from the file (glTF camera index). Spawned inactive; activate one to look
/// through it (`penumbra render --camera N`).
#[derive(Component, Debug, Clone, Copy, PartialEq)]
pub struct GltfCamera {
    pub index: usize,
    /// The aspect ratio the file asks for (width / height), if any.
    pub aspect_ratio: Option<f32>,
}

#[derive(Debug, Clone)]
struct NodeDesc {
    name: String,
    transform: Transform,
    children: Vec<usize>,
    mesh: Option<usize>,
    camera: Option<usize>,
    light: Option<usize>,
    ies_light: Option<ies_lights::IesLightDesc>,
    area_light: Option<area_lights::AreaLightDesc>,
    skin: Option<usize>,
    /// The node's morph weights (glTF `node.weights`), else its mesh's.
    weights: Option<Vec<f32>>,
    /// EXT_mesh_gpu_instancing: the mesh is drawn once per transform, under the node's.
    instances: Option<Arc<[Transform]>>,
}

#[derive(Debug, Clone)]
struct PrimitiveDesc {
    mesh: Arc<Mesh>,
    material: Option<usize>,
    /// KHR_materials_variants: (variant, material) pairs.
    variants: Vec<(usize, usize)>,
}

/// A decoded, validated glTF file: plain data, ready to spawn any number of times.
#[derive(Debug, Clone)]
pub struct GltfScene {
    pub path: PathBuf,
    meshes: Vec<(String, Vec<PrimitiveDesc>)>,
    materials: Vec<MaterialDesc>,
    images: Vec<Option<Arc<Image>>>,
    nodes: Vec<NodeDesc>,
    cameras: Vec<cameras::CameraDesc>,
    lights: Vec<LightDesc>,
    /// EXT_lights_ies profiles.
    ies_profiles: Vec<Arc<IesProfile>>,
    skins: Vec<animation::SkinDesc>,
    /// Shared by every spawned instance's player.
    animations: Arc<[AnimationClip]>,
    /// Root nodes of the scene to spawn.
    roots: Vec<usize>,
    /// KHR_materials_variants: the file's variant names.
    variants: Vec<String>,
    scene_index: Option<usize>,
    /// Things the file uses that Penumbra ignores (optional extensions), for the user to see.
    pub warnings: Vec<String>,
}

impl GltfScene {
    /// Reads and decodes `path`.
    pub fn load(path: &Path, options: &ImportOptions) -> Result<GltfScene, ImportError> {
        let bytes = crate::import::read_scene_file(path)?;
        Self::from_bytes(&bytes, path, options)
    }

    /// Decodes a file already in memory; `path` names it in errors and anchors relative URIs.
    pub fn from_bytes(bytes: &[u8], path: &Path, options: &ImportOptions) -> Result<GltfScene, ImportError> {
        load_inner(bytes, path, options).map_err(|kind| ImportError::new(path, kind))
    }

    pub fn camera_count(&self) -> usize {
        self.cameras.len()
    }

    pub fn scene_index(&self) -> Option<usize> {
        self.scene_index
    }

    pub fn animations(&self) -> &[AnimationClip] {
        &self.animations
    }

    /// Every primitive's mesh, mesh by mesh in file order (skipped primitives left out).
    pub fn primitives(&self) -> impl Iterator<Item = &Mesh> {
        self.meshes.iter().flat_map(|(_, prims)| prims.iter().map(|p| &*p.mesh))
    }

    /// The decoded images materials use (one per distinct source), in file order.
    pub fn images(&self) -> impl Iterator<Item = &Image> {
        let mut seen = std::collections::HashSet::new();
        self.images.iter().flatten().filter(move |i| seen.insert(Arc::as_ptr(i))).map(|i| &**i)
    }

    /// KHR_materials_variants: the file's material variant names, in its order.
    pub fn variant_names(&self) -> &[String] {
        &self.variants
    }

    /// Spawns the selected scene under a new [`SceneRoot`] entity and returns it.
    pub fn spawn(&self, world: &mut World) -> Entity {
        world.init_resource::<Assets<Image>>();
        world.init_resource::<Assets<StandardMaterial>>();
        world.init_resource::<Assets<Mesh>>();
        world.init_resource::<Assets<IesProfile>>();
        let ies_handles: Vec<Handle<IesProfile>> = {
            let mut profiles = world.resource_mut::<Assets<IesProfile>>();
            self.ies_profiles.iter().map(|p| profiles.add_arc(p.clone())).collect()
        };
        let image_handles: Vec<Option<Handle<Image>>> = {
            let mut images = world.resource_mut::<Assets<Image>>();
            // Shared, not copied: a textured model's images are tens of megabytes. Entries that
            // name the same source were decoded once and share one handle (one GPU texture).
            let mut handles: std::collections::HashMap<*const Image, Handle<Image>> = Default::default();
            self.images
                .iter()
                .map(|i| {
                    i.as_ref().map(|i| *handles.entry(Arc::as_ptr(i)).or_insert_with(|| images.add_arc(i.clone())))
                })
                .collect()
        };
        let (material_handles, default_material) = {
            let mut mats = world.resource_mut::<Assets<StandardMaterial>>();
            let handles: Vec<_> =
                self.materials.iter().map(|d| mats.add(resolve_material(d, &image_handles))).collect();
            let default = mats.add(StandardMaterial::default());
            (handles, default)
        };
        let mesh_handles: Vec<Vec<(Handle<Mesh>, Option<usize>)>> = {
            let mut meshes = world.resource_mut::<Assets<Mesh>>();
            self.meshes
                .iter()
                .map(|(_, prims)| prims.iter().map(|p| (meshes.add_arc(p.mesh.clone()), p.material)).collect())
                .collect()
        };
        let root = SceneRoot::spawn(world, &self.path, self.scene_index);
        if !self.variants.is_empty() {
            world
                .entity_mut(root)
                .insert(crate::variants::SceneVariants { names: self.variants.clone(), active: None });
        }
        world.entity_mut(root).insert(super::SceneAssets {
            meshes: mesh_handles.iter().flatten().map(|(h, _)| *h).collect(),
            materials: material_handles.iter().copied().chain([default_material]).collect(),
            images: {
                let mut unique: Vec<Handle<Image>> = image_handles.iter().flatten().copied().collect();
                unique.sort_by_key(|h| h.index());
                unique.dedup();
                unique
            },
            ies_profiles: ies_handles.clone(),
        });
        let ctx = SpawnCtx {
            scene: self,
            meshes: &mesh_handles,
            materials: &material_handles,
            default_material,
            ies_profiles: &ies_handles,
            root,
        };
        // Per node: its entity, then the entities drawing its mesh (itself for one primitive).
        let mut spawned: Vec<Vec<Entity>> = vec![Vec::new(); self.nodes.len()];
        let mut stack: Vec<(usize, Entity)> = self.roots.iter().rev().map(|&n| (n, root)).collect();
        while let Some((node, parent)) = stack.pop() {
            spawned[node] = ctx.spawn_node(world, node, parent);
            stack.extend(self.nodes[node].children.iter().rev().map(|&c| (c, spawned[node][0])));
        }
        self.spawn_deformers(world, &spawned);
        if !self.animations.is_empty() {
            let mut player = AnimationPlayer::new(self.animations.clone(), spawned.into());
            player.play(0).expect("the file has a clip 0");
            world.entity_mut(root).insert(player);
        }
        root
    }

    /// Skins and morph weights go on the entities drawing a node's mesh, once every node (every
    /// possible joint) has its entity. Joints outside the spawned scene hold the bind pose.
    fn spawn_deformers(&self, world: &mut World, spawned: &[Vec<Entity>]) {
        for (node, entities) in spawned.iter().enumerate() {
            let desc = &self.nodes[node];
            let Some(mesh) = desc.mesh else { continue };
            // The node itself when it draws its one primitive, else the entities after it: one
            // per primitive, instance after instance (EXT_mesh_gpu_instancing).
            let drawn = if entities.len() > 1 { &entities[1..] } else { entities.as_slice() };
            let prims = &self.meshes[mesh].1;
            let prims = prims.iter().cycle().take(drawn.len());
            if let Some(skin) = desc.skin.map(|s| &self.skins[s]) {
                let joints: Vec<Entity> =
                    skin.joints.iter().map(|&j| spawned[j].first().copied().unwrap_or(Entity::PLACEHOLDER)).collect();
                for (&e, p) in drawn.iter().zip(prims.clone()) {
                    if p.mesh.is_skinned() {
                        world.entity_mut(e).insert(SkinnedMesh {
                            inverse_bindposes: skin.inverse_bindposes.clone(),
                            joints: joints.clone(),
                        });
                    }
                }
            }
            let targets = self.meshes[mesh].1.iter().map(|p| p.mesh.morph_targets.len()).max().unwrap_or(0);
            if targets > 0 {
                let mut weights = desc.weights.clone().unwrap_or_default();
                weights.resize(targets, 0.0);
                for (&e, p) in drawn.iter().zip(prims) {
                    if !p.mesh.morph_targets.is_empty() {
                        world.entity_mut(e).insert(MorphWeights(weights.clone()));
                    }
                }
            }
        }
    }
}

struct SpawnCtx<'a> {
    scene: &'a GltfScene,
    meshes: &'a [Vec<(Handle<Mesh>, Option<usize>)>],
    materials: &'a [Handle<StandardMaterial>],
    default_material: Handle<StandardMaterial>,
    ies_profiles: &'a [Handle<IesProfile>],
    /// The scene's root, whose `SceneVariants` selects the primitives' variants.
    root: Entity,
}

impl SpawnCtx<'_> {
    /// Gives the entity drawing primitive `k` of mesh `m` its materials per variant, if any
    /// variant maps it.
    fn insert_variants(
        &self,
        world: &mut World,
        entity: Entity,
        m: usize,
        k: usize,
        default: Handle<StandardMaterial>,
    ) {
        let mappings = &self.scene.meshes[m].1[k].variants;
        if mappings.is_empty() {
            return;
        }
        let by_variant =
            mappings.iter().map(|&(v, mat)| (self.scene.variants[v].clone(), self.materials[mat])).collect();
        world.entity_mut(entity).insert(crate::variants::VariantMaterials { root: self.root, default, by_variant });
    }

    /// Returns the node's entity, followed by its primitives' entities when it has several.
    fn spawn_node(&self, world: &mut World, node: usize, parent: Entity) -> Vec<Entity> {
        let desc = &self.scene.nodes[node];
        let mut e = world.spawn((Name::new(desc.name.clone()), desc.transform, ChildOf(parent)));
        if let Some(c) = desc.camera {
            let (_, projection, aspect_ratio) = &self.scene.cameras[c];
            e.insert((
                Camera { projection: *projection, exposure: Exposure::default(), is_active: false, order: 0 },
                GltfCamera { index: c, aspect_ratio: *aspect_ratio },
            ));
        }
        if let Some(l) = desc.light {
            match &self.scene.lights[l] {
                LightDesc::Directional(d) => e.insert(*d),
                LightDesc::Point(p) => e.insert(*p),
                LightDesc::Spot(s) => e.insert(*s),
            };
        }
        if let Some(l) = desc.ies_light {
            e.insert(IesLight {
                profile: self.ies_profiles[l.profile],
                color: l.color,
                scale: l.multiplier,
                range: None,
                shadows: true,
            });
        }
        if let Some(l) = desc.area_light {
            match l {
                area_lights::AreaLightDesc::Rect(l) => e.insert(l),
                area_lights::AreaLightDesc::Disk(l) => e.insert(l),
                area_lights::AreaLightDesc::Sphere(l) => e.insert(l),
                area_lights::AreaLightDesc::Tube(l) => e.insert(l),
            };
        }
        let id = e.id();
        let mut out = vec![id];
        if let (Some(m), Some(instances)) = (desc.mesh, &desc.instances) {
            // One child per instance, holding the mesh as a node would; the node keeps its own
            // transform (and animation) above them all.
            for (i, t) in instances.iter().enumerate() {
                let instance = world.spawn((Name::new(format!("{} instance {i}", desc.name)), *t, ChildOf(id))).id();
                out.extend(self.spawn_mesh(world, m, instance, true));
            }
        } else if let Some(m) = desc.mesh {
            out.extend(self.spawn_mesh(world, m, id, false));
        }
        out
    }

    /// Puts mesh `m` on `holder` (one primitive) or on one child of it per primitive; returns
    /// the entities that draw (`holder` too when `list_holder` and it draws the mesh itself).
    fn spawn_mesh(&self, world: &mut World, m: usize, holder: Entity, list_holder: bool) -> Vec<Entity> {
        let prims = &self.meshes[m];
        let material = |p: Option<usize>| p.map_or(self.default_material, |i| self.materials[i]);
        if let [(mesh, mat)] = prims.as_slice() {
            world.entity_mut(holder).insert((Mesh3d(*mesh), MeshMaterial3d(material(*mat))));
            self.insert_variants(world, holder, m, 0, material(*mat));
            return if list_holder { vec![holder] } else { Vec::new() };
        }
        let mesh_name = &self.scene.meshes[m].0;
        let mut out = Vec::new();
        for (k, (mesh, mat)) in prims.iter().enumerate() {
            let child = world
                .spawn((
                    Name::new(format!("{mesh_name} primitive {k}")),
                    Transform::IDENTITY,
                    Mesh3d(*mesh),
                    MeshMaterial3d(material(*mat)),
                    ChildOf(holder),
                ))
                .id();
            self.insert_variants(world, child, m, k, material(*mat));
            out.push(child);
        }
        out
    }
}

fn resolve_material(d: &MaterialDesc, images: &[Option<Handle<Image>>]) -> StandardMaterial {
    let mut m = d.material.clone();
    for (slot, tex) in m.textures_mut().into_iter().zip(&d.textures) {
        *slot = tex.as_ref().and_then(|t| {
            images.get(t.image).copied().flatten().map(|image| TextureRef {
                image,
                sampler: t.sampler,
                uv_set: t.uv_set,
                transform: t.transform,
            })
        });
    }
    m
}

fn load_inner(bytes: &[u8], path: &Path, options: &ImportOptions) -> Result<GltfScene, ImportErrorKind> {
    let mut warnings = Vec::new();
    let bytes = source::check_glb_header(bytes, &mut warnings)?;
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| {
        // A glTF 1.0 file has another JSON shape: say so rather than what serde found missing.
        match source::probe_version(bytes).map(|v| source::check_version(&v, None)) {
            Some(Err(refused)) => refused,
            _ => ImportErrorKind::Malformed(e.to_string()),
        }
    })?;
    let asset = &document.as_json().asset;
    source::check_version(&asset.version, asset.min_version.as_deref())?;

    // Required extensions first: a file that needs what we lack must be refused by name, before
    // validation complains about its contents in less useful terms.
    if let Some(name) = document.extensions_required().find(|e| !SUPPORTED_EXTENSIONS.contains(e)) {
        return Err(ImportErrorKind::UnsupportedExtension { name: name.to_owned() });
    }
    validate(&document)?;
    check_totals(&document, &options.limits)?;
    warnings.extend(
        document
            .extensions_used()
            .filter(|e| !SUPPORTED_EXTENSIONS.contains(e))
            .map(|e| format!("optional extension {e} is not supported and is ignored")),
    );

    let progress = |stage, total| {
        if let Some(p) = &options.progress {
            p.enter(stage, total);
        }
    };
    let step = || {
        if let Some(p) = &options.progress {
            p.step();
        }
    };
    let base_dir = path.parent().unwrap_or(Path::new("."));
    progress(super::ImportStage::Buffers, document.buffers().len());
    let roots = scene_roots(&document, options.scene, &options.limits)?;
    let reads = source::ReadBudget::new(options);
    let data = load_buffers(&document, blob, base_dir, options, &reads, &mut warnings)?;
    let decoded_views = meshopt::decode_views(&document, &data, &options.limits)?;
    let buffers = Buffers::new(data, decoded_views, options.limits);

    let mut materials: Vec<MaterialDesc> = document
        .materials()
        .map(|m| {
            let mut desc = materials::convert(&m, &mut warnings);
            let label = materials::label(&m);
            if let Some(sg) = m.pbr_specular_glossiness() {
                spec_gloss::convert(&sg, &mut desc, &label, materials::info, &mut warnings);
            }
            material_extensions::read(&m, &document, &mut desc, &label, &mut warnings);
            materials::check_transforms(&mut desc, &label, &mut warnings);
            desc
        })
        .collect();
    let variant_names = variants::names(&document, &mut warnings);
    // Images are read (and checked against the limits) here, and decoded on other threads while
    // the meshes are built on this one: neither needs the other, and on a many-core host the
    // meshes' tangents would otherwise sit in front of the longest image. Errors come in the
    // order they did one after the other: a mesh's before an image's.
    let image_jobs = image_jobs(&document, &materials, &buffers, base_dir, path, options, &reads);
    let images_progress = ImagesProgress::new(options.progress.clone());
    // Set when a mesh fails: the images not started yet are not decoded for nothing.
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let (meshes, decoded) = std::thread::scope(|scope| {
        let decoding = image_jobs.as_ref().ok().map(|jobs| {
            let (images_progress, cancel) = (&images_progress, &cancel);
            scope.spawn(move || decode_image_jobs(jobs, options, images_progress, cancel))
        });
        progress(super::ImportStage::Meshes, document.meshes().len());
        let meshes = build_meshes(&document, &materials, &buffers, variant_names.len(), &mut warnings, &step);
        if meshes.is_ok() {
            images_progress.meshes_done(image_jobs.as_ref().map_or(0, |j| j.jobs.len()));
        } else {
            cancel.store(true, std::sync::atomic::Ordering::Relaxed);
        }
        let decoded = decoding.map(|d| d.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)));
        (meshes, decoded)
    });
    let meshes = meshes?;
    let image_jobs = image_jobs?;
    let decoded = decoded.expect("decoded when the jobs were made")?;
    let mut images: Vec<Option<Arc<Image>>> =
        image_jobs.job_of.into_iter().map(|j| j.map(|j| decoded[j].clone())).collect();

    for texture in document.textures().filter(|t| materials::texture_image(t).is_none()) {
        warnings.push(format!(
            "texture {} has no image (no source, no {}); materials using it are drawn untextured",
            texture.index(),
            materials::WEBP
        ));
    }
    spec_gloss::derive_roughness(&mut materials, &mut images).map_err(|(index, reason)| ImportErrorKind::Image {
        index,
        uri: "its glossiness, read for roughness".into(),
        reason,
    })?;
    occlusion_packing::pack_occlusion(&mut materials, &mut images);
    let file = path.file_name().map_or_else(String::new, |f| f.to_string_lossy().into_owned());
    let ies_profiles = ies_lights::load_profiles(&document, &buffers, base_dir, &file, options, &reads)?;
    let ies_node_lights: Vec<Option<ies_lights::IesLightDesc>> =
        document.nodes().map(|n| ies_lights::node_light(&n, ies_profiles.len())).collect::<Result<_, _>>()?;
    let area_node_lights: Vec<Option<area_lights::AreaLightDesc>> =
        document.nodes().map(|n| area_lights::node_light(&n)).collect::<Result<_, _>>()?;
    let node_instances: Vec<Option<Arc<[Transform]>>> = document
        .nodes()
        .map(|n| instancing::node_instances(&n, &document, &buffers, &mut warnings))
        .collect::<Result<_, _>>()?;
    // Each instance spawns an entity per primitive: with the nodes, what the node limit bounds.
    let instanced: u64 = document
        .nodes()
        .filter_map(|n| {
            let count = node_instances[n.index()].as_ref()?.len() as u64;
            Some(count * n.mesh().map_or(1, |m| m.primitives().len().max(1)) as u64)
        })
        .sum();
    if instanced > 0 {
        options.limits.check(
            Limit::Nodes,
            "the nodes and the entities EXT_mesh_gpu_instancing spawns (instances × primitives)",
            document.nodes().len() as u64 + instanced,
        )?;
    }
    let nodes = document
        .nodes()
        .map(|n| NodeDesc {
            name: n.name().map_or_else(|| format!("node{}", n.index()), str::to_owned),
            transform: node_transform(&n, &mut warnings),
            children: n.children().map(|c| c.index()).collect(),
            mesh: n.mesh().map(|m| m.index()),
            camera: n.camera().map(|c| c.index()),
            light: n.light().map(|l| l.index()),
            ies_light: ies_node_lights[n.index()],
            area_light: area_node_lights[n.index()],
            skin: n.skin().map(|s| s.index()),
            weights: n.weights().or_else(|| n.mesh().and_then(|m| m.weights())).map(<[f32]>::to_vec),
            instances: node_instances[n.index()].clone(),
        })
        .collect::<Vec<NodeDesc>>();
    let skins = animation::load_skins(&document, &buffers)?;
    check_skinned_meshes(&nodes, &meshes, &skins)?;
    let animations: Arc<[AnimationClip]> = animation::load_animations(&document, &buffers)?.into();
    let cameras = cameras::convert(&document, &mut warnings)?;
    cameras::check_nodes(&document, &mut warnings);
    let lights = punctual_lights::convert(&document, &mut warnings);

    crate::import::report::log_warnings(path, &warnings);
    Ok(GltfScene {
        path: path.to_path_buf(),
        meshes,
        materials,
        images,
        nodes,
        cameras,
        lights,
        ies_profiles,
        skins,
        animations,
        roots,
        variants: variant_names,
        scene_index: options.scene.or_else(|| document.default_scene().map(|s| s.index())),
        warnings,
    })
}

/// A node's transform, checked against the schema: every number finite (a non-finite one is
/// replaced, translation by 0, scale by 1, rotation and matrix by the identity) and the rotation
/// a unit quaternion (normalised; a zero one, seen in the wild, is the identity), each with a
/// warning naming the node. Zero and negative scales are valid glTF and kept.
fn node_transform(n: &gltf::Node, warnings: &mut Vec<String>) -> Transform {
    let mut warn = |what: String| warnings.push(format!("node {} (\"{}\"): {what}", n.index(), n.name().unwrap_or("")));
    match n.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            let m = Mat4::from_cols_array_2d(&matrix);
            if m.is_finite() {
                Transform::from_matrix(m)
            } else {
                warn("matrix has a non-finite element; using the identity".into());
                Transform::IDENTITY
            }
        }
        gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
            let mut translation = Vec3::from(translation);
            if !translation.is_finite() {
                warn(format!("translation {translation} is not finite; its non-finite parts are 0"));
                translation = Vec3::from_array(translation.to_array().map(|c| if c.is_finite() { c } else { 0.0 }));
            }
            let mut scale = Vec3::from(scale);
            if !scale.is_finite() {
                warn(format!("scale {scale} is not finite; its non-finite parts are 1"));
                scale = Vec3::from_array(scale.to_array().map(|c| if c.is_finite() { c } else { 1.0 }));
            }
            let q = glam::Vec4::from_array(rotation);
            let length = q.length();
            let rotation = if !(length.is_finite() && length > 0.0) {
                warn(format!("rotation {q} is not a unit quaternion (length {length}); using the identity"));
                glam::Quat::IDENTITY
            } else {
                // Exporters write unit quaternions rounded to f32: a few ulps off is no news.
                if (length - 1.0).abs() > 1e-3 {
                    warn(format!("rotation {q} is not a unit quaternion (length {length}); normalised"));
                }
                glam::Quat::from_vec4(q / length)
            };
            Transform { translation, rotation, scale }
        }
    }
}

/// Every joint index a skinned vertex uses (with non-zero weight) must name one of its skin's
/// joints: checked here so that the GPU never reads past a joint list.
fn check_skinned_meshes(
    nodes: &[NodeDesc],
    meshes: &[(String, Vec<PrimitiveDesc>)],
    skins: &[animation::SkinDesc],
) -> Result<(), ImportErrorKind> {
    for (i, node) in nodes.iter().enumerate() {
        let (Some(skin), Some(mesh)) = (node.skin, node.mesh) else { continue };
        let joints = skins[skin].joints.len();
        for (k, p) in meshes[mesh].1.iter().enumerate() {
            if let Some(j) = p.mesh.max_joint()
                && j as usize >= joints
            {
                return Err(ImportErrorKind::Skin {
                    index: skin,
                    reason: format!(
                        "node {i}'s mesh {mesh} primitive {k} uses joint {j}, but the skin has {joints} joints"
                    ),
                });
            }
        }
    }
    Ok(())
}

fn validate(document: &gltf::Document) -> Result<(), ImportErrorKind> {
    use gltf::json::validation::Validate;
    let root = document.as_json();
    // The gltf crate unwraps an image's source: a bufferView needs a mimeType, and one of the two
    // must be there (found by fuzzing; gltf-json's validation checks neither).
    for (i, image) in root.images.iter().enumerate() {
        let problem = match (&image.uri, &image.buffer_view, &image.mime_type) {
            (None, None, _) => Some("has neither a uri nor a bufferView"),
            (Some(_), Some(_), _) => Some("has both a uri and a bufferView"),
            (None, Some(_), None) => Some("has a bufferView but no mimeType"),
            _ => None,
        };
        if let Some(problem) = problem {
            return Err(ImportErrorKind::Invalid(format!("images[{i}] {problem}")));
        }
    }
    // A texture samples its EXT_texture_webp image where it names one, else its `source`
    // (which the extension lets a file leave out): an index outside `images` is invalid.
    for (t, texture) in document.textures().enumerate() {
        for name in [materials::BASISU, materials::WEBP] {
            let source = texture.extension_value(name).map(|e| e.get("source").and_then(|s| s.as_u64()));
            let bad = match source {
                Some(Some(i)) if (i as usize) < root.images.len() => None,
                Some(source) => Some(format!(
                    "textures[{t}].extensions.{name}.source is {}, but the file has {} images",
                    source.map_or("missing or not an index".to_owned(), |i| i.to_string()),
                    root.images.len()
                )),
                None => None,
            };
            if let Some(bad) = bad {
                return Err(ImportErrorKind::Invalid(bad));
            }
        }
    }
    // gltf-json's own primitive check indexes `accessors` with POSITION unchecked (a panic on an
    // out-of-range index): check every attribute index first.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let targets = prim.targets.iter().flatten().flat_map(|t| [&t.positions, &t.normals, &t.tangents]);
            let indices = prim.attributes.values().chain(targets.flatten()).chain(prim.indices.as_ref());
            if let Some(bad) = indices.map(|i| i.value()).find(|&i| i >= root.accessors.len()) {
                return Err(ImportErrorKind::Invalid(format!(
                    "meshes[{m}].primitives[{p}] uses accessor {bad}, but the file has {}",
                    root.accessors.len()
                )));
            }
        }
    }
    let mut errors = Vec::new();
    let mut report = |path: &dyn Fn() -> gltf::json::Path, error| {
        let path = path().to_string();
        // An accessor without a bufferView is all zeros (glTF 2.0 §5.1.1); gltf-json reports it
        // as missing data. Draco-compressed primitives' accessors have none, by design.
        let zeros = matches!(error, gltf::json::validation::Error::Missing)
            && path.starts_with("accessors[")
            && path.ends_with("].bufferView");
        // Required extensions were checked against Penumbra's own list already.
        if !path.starts_with("extensionsRequired") && !zeros {
            errors.push(format!("{path}: {error}"));
        }
    };
    root.validate(root, gltf::json::Path::new, &mut report);
    // gltf-json does not validate animation channel targets (node index, path); the gltf crate
    // unwraps them (found by fuzzing).
    for (a, animation) in root.animations.iter().enumerate() {
        for (c, channel) in animation.channels.iter().enumerate() {
            let at = || gltf::json::Path::new().field("animations").index(a).field("channels").index(c).field("target");
            channel.target.validate(root, at, &mut report);
        }
    }
    if errors.is_empty() {
        return Ok(());
    }
    let more = if errors.len() > 5 { format!(" (and {} more)", errors.len() - 5) } else { String::new() };
    errors.truncate(5);
    Err(ImportErrorKind::Invalid(format!("{}{more}", errors.join("; "))))
}

fn load_buffers(
    document: &gltf::Document,
    mut blob: Option<Vec<u8>>,
    base_dir: &Path,
    options: &ImportOptions,
    reads: &source::ReadBudget,
    warnings: &mut Vec<String>,
) -> Result<Vec<Vec<u8>>, ImportErrorKind> {
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let index = buffer.index();
        if meshopt::is_fallback(&buffer) {
            // Placeholder storage for loaders without the extension: never read here (its views
            // are decoded from the compressed buffer), so not loaded, whatever its byteLength.
            buffers.push(Vec::new());
            continue;
        }
        options.limits.check(Limit::BufferBytes, "a buffer's byteLength", buffer.length() as u64)?;
        if buffer.length() == 0 {
            // glTF requires at least 1; an empty buffer can hold nothing a bufferView could
            // name (each of those is checked against the buffer's length), so it is skipped.
            warnings.push(format!("buffers[{index}] has byteLength 0 (glTF requires at least 1); ignored"));
            buffers.push(Vec::new());
            continue;
        }
        let (uri, data) = match buffer.source() {
            gltf::buffer::Source::Bin => {
                let data = blob.take().ok_or_else(|| ImportErrorKind::Buffer {
                    index,
                    uri: "GLB binary chunk".into(),
                    reason: "the file has no binary chunk".into(),
                })?;
                ("GLB binary chunk".to_owned(), data)
            }
            gltf::buffer::Source::Uri(uri) => {
                let short = if uri.starts_with("data:") { "data URI".to_owned() } else { uri.to_owned() };
                let limit = source::ReadLimit::buffer(buffer.length() as u64);
                let data = source::read_uri(base_dir, uri, options, limit, reads).map_err(|e| {
                    e.into_kind(uri, |reason| ImportErrorKind::Buffer { index, uri: short.clone(), reason })
                })?;
                (short, data)
            }
        };
        if data.len() < buffer.length() {
            return Err(ImportErrorKind::Buffer {
                index,
                uri,
                reason: format!("has {} bytes but byteLength says {}", data.len(), buffer.length()),
            });
        }
        buffers.push(data);
    }
    Ok(buffers)
}

/// The root nodes to spawn, after checking the node graph is a forest (each node has at most one
/// parent and no cycles), as glTF requires, and no deeper than the limit.
fn scene_roots(
    document: &gltf::Document,
    requested: Option<usize>,
    limits: &ImportLimits,
) -> Result<Vec<usize>, ImportErrorKind> {
    let n = document.nodes().len();
    let mut parent: Vec<Option<usize>> = vec![None; n];
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); n];
    for node in document.nodes() {
        for child in node.children() {
            if let Some(p) = parent[child.index()] {
                return Err(ImportErrorKind::Hierarchy(format!(
                    "node {} is a child of both node {p} and node {}",
                    child.index(),
                    node.index()
                )));
            }
            parent[child.index()] = Some(node.index());
            children[node.index()].push(child.index());
        }
    }
    // Every node reachable from a parentless node is in a tree; anything left over is on a cycle.
    let mut depth: Vec<Option<u64>> = vec![None; n];
    let mut stack: Vec<(usize, u64)> = (0..n).filter(|&i| parent[i].is_none()).map(|i| (i, 1)).collect();
    while let Some((i, d)) = stack.pop() {
        limits.check(Limit::NodeDepth, "the node hierarchy's depth", d)?;
        depth[i] = Some(d);
        stack.extend(children[i].iter().map(|&c| (c, d + 1)));
    }
    if let Some(i) = depth.iter().position(Option::is_none) {
        return Err(ImportErrorKind::Hierarchy(format!("node {i} is part of a cycle")));
    }
    let scene_count = document.scenes().len();
    let scene = match requested {
        Some(index) if index >= scene_count => {
            return Err(ImportErrorKind::NoSuchScene { index, count: scene_count });
        }
        Some(index) => document.scenes().nth(index),
        None => document.default_scene().or_else(|| document.scenes().next()),
    };
    let roots: Vec<usize> = match scene {
        Some(s) => s.nodes().map(|n| n.index()).collect(),
        // No scenes at all: show every root node rather than nothing.
        None => (0..n).filter(|&i| parent[i].is_none()).collect(),
    };
    if let Some(&r) = roots.iter().find(|&&r| parent[r].is_some()) {
        return Err(ImportErrorKind::Hierarchy(format!("scene root node {r} is also a child of another node")));
    }
    let mut listed = vec![false; n];
    for &r in &roots {
        if std::mem::replace(&mut listed[r], true) {
            return Err(ImportErrorKind::Hierarchy(format!("the scene lists root node {r} twice")));
        }
    }
    Ok(roots)
}

/// Totals the file declares, checked before anything is decoded: per-accessor checks alone would
/// let a file reuse one large accessor in a million primitives.
fn check_totals(document: &gltf::Document, limits: &ImportLimits) -> Result<(), ImportErrorKind> {
    limits.check(Limit::Nodes, "the node count", document.nodes().len() as u64)?;
    let (mut vertices, mut indices) = (0u64, 0u64);
    for prim in document.meshes().flat_map(|m| m.primitives()) {
        // Counts come straight from the JSON (up to 2^64 - 1): saturate, never wrap.
        vertices = vertices.saturating_add(prim.get(&gltf::mesh::Semantic::Positions).map_or(0, |a| a.count() as u64));
        indices = indices.saturating_add(prim.indices().map_or(0, |a| a.count() as u64));
    }
    limits.check(Limit::Vertices, "the vertex count over all primitives", vertices)?;
    limits.check(Limit::Indices, "the index count over all primitives", indices)?;
    let keys =
        document.animations().flat_map(|a| a.samplers()).fold(0u64, |n, s| n.saturating_add(s.input().count() as u64));
    limits.check(Limit::AnimationKeys, "keyframes over all animation samplers", keys)
}

/// Every mesh's primitives, built in the document's order; warnings in that order too.
fn build_meshes(
    document: &gltf::Document,
    materials: &[MaterialDesc],
    buffers: &Buffers,
    variant_count: usize,
    warnings: &mut Vec<String>,
    step: &dyn Fn(),
) -> Result<Vec<(String, Vec<PrimitiveDesc>)>, ImportErrorKind> {
    let start = std::time::Instant::now();
    let mut meshes = Vec::new();
    for mesh in document.meshes() {
        let mut prims = Vec::new();
        for prim in mesh.primitives() {
            if prim.get(&gltf::mesh::Semantic::Joints(1)).is_some() {
                warnings.push(format!(
                    "mesh {} primitive {}: more than four joint influences (JOINTS_1); only JOINTS_0/WEIGHTS_0 are used",
                    mesh.index(),
                    prim.index()
                ));
            }
            let material = prim.material().index();
            let needs = primitive::GeometryNeeds {
                // The base's normal map, else the coat's: either needs tangents; so does an
                // anisotropic lobe (its direction is in tangent space), in its texture's set.
                normal_map_uv_set: material.and_then(|m| materials.get(m)).and_then(|m| {
                    materials::NORMAL_SLOTS.iter().find_map(|&slot| m.textures[slot].as_ref()).map(|t| t.uv_set).or(m
                        .material
                        .has_anisotropy()
                        .then(|| m.textures[materials::ANISOTROPY_SLOT].as_ref().map_or(0, |t| t.uv_set)))
                }),
            };
            let mesh_index = mesh.index();
            match primitive::build(document, &prim, buffers, &needs, mesh_index)? {
                primitive::Built::Mesh(mesh, notes) => {
                    warnings.extend(notes);
                    let variants = variants::mappings(&prim, mesh_index, variant_count, materials.len(), warnings);
                    prims.push(PrimitiveDesc { mesh: Arc::new(*mesh), material, variants })
                }
                primitive::Built::Skipped(why) => warnings.push(why),
            }
        }
        meshes.push((mesh.name().map_or_else(|| format!("mesh{}", mesh.index()), str::to_owned), prims));
        step();
    }
    tracing::debug!("{} meshes built in {:.1} ms", meshes.len(), start.elapsed().as_secs_f64() * 1e3);
    Ok(meshes)
}

/// The images materials use, read and checked against the limits, each source once.
struct ImageJobs<'b> {
    /// (image index, where it came from, label, encoded bytes, read as sRGB by some slot)
    jobs: Vec<(usize, String, String, images::ImageBytes<'b>, bool)>,
    /// Each document image's job, `None` for images no material uses.
    job_of: Vec<Option<usize>>,
}

fn image_jobs<'b>(
    document: &gltf::Document,
    materials: &[MaterialDesc],
    buffers: &'b Buffers,
    base_dir: &Path,
    path: &Path,
    options: &ImportOptions,
    reads: &source::ReadBudget,
) -> Result<ImageJobs<'b>, ImportErrorKind> {
    let mut used = vec![false; document.images().len()];
    // Read as sRGB by some slot: its mip chain averages in linear light.
    let mut srgb = vec![false; used.len()];
    for m in materials {
        for (slot, t) in m.textures.iter().enumerate() {
            if let Some(t) = t
                && let Some(u) = used.get_mut(t.image)
            {
                *u = true;
                srgb[t.image] |= StandardMaterial::SRGB_SLOTS[slot];
            }
        }
    }
    let file = path.file_name().map_or_else(String::new, |f| f.to_string_lossy().into_owned());
    // Images naming the same source (URI or bufferView) are read and decoded once.
    let mut by_source: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    let mut job_of: Vec<Option<usize>> = vec![None; used.len()];
    let mut jobs: Vec<(usize, String, String, images::ImageBytes, bool)> = Vec::new();
    let mut total = 0u64;
    for image in document.images().filter(|i| used[i.index()]) {
        let (uri, key) = match image.source() {
            gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => (uri.to_owned(), uri.to_owned()),
            gltf::image::Source::Uri { uri, .. } => ("data URI".to_owned(), uri.to_owned()),
            gltf::image::Source::View { view, .. } => {
                let name = format!("bufferView {}", view.index());
                (name.clone(), name)
            }
        };
        if let Some(&job) = by_source.get(&key) {
            job_of[image.index()] = Some(job);
            jobs[job].4 |= srgb[image.index()];
            continue;
        }
        let label = format!("{file}#{}", image.name().map_or_else(|| format!("image{}", image.index()), str::to_owned));
        let bytes = images::image_bytes(&image, buffers, base_dir, options, reads)?;
        // The decoded size with the mip chain, from the header, summed before anything is
        // decoded.
        let encoded = match &bytes {
            images::ImageBytes::Slice(s) => *s,
            images::ImageBytes::Owned(v) => v.as_slice(),
        };
        total = total.saturating_add(images::held_size(encoded).unwrap_or(0));
        options.limits.check(Limit::TotalImageBytes, "the decoded size of all images with their mip chains", total)?;
        by_source.insert(key, jobs.len());
        job_of[image.index()] = Some(jobs.len());
        jobs.push((image.index(), uri, label, bytes, srgb[image.index()]));
    }
    Ok(ImageJobs { jobs, job_of })
}

/// The jobs' images, decoded in parallel, each with its mip chain; the first error in the jobs'
/// order.
fn decode_image_jobs(
    jobs: &ImageJobs,
    options: &ImportOptions,
    progress: &ImagesProgress,
    cancel: &std::sync::atomic::AtomicBool,
) -> Result<Vec<Arc<Image>>, ImportErrorKind> {
    let decoded = crate::parallel::parallel_map(&jobs.jobs, |(index, uri, label, bytes, srgb)| {
        if cancel.load(std::sync::atomic::Ordering::Relaxed) {
            // Never reported: the mesh's error that set it is.
            return Err(ImportErrorKind::Malformed("the import stopped at an earlier error".into()));
        }
        let bytes = match bytes {
            images::ImageBytes::Slice(s) => s,
            images::ImageBytes::Owned(v) => v.as_slice(),
        };
        // The chain is made here, on the thread that decoded the image, while it is fresh.
        let start = std::time::Instant::now();
        let image = images::decode(bytes, *index, uri, label.clone(), options).map(|mut image| {
            let decoded = start.elapsed();
            // A compressed texture brings its own chain (or the renderer makes one).
            if image.compressed.is_none() {
                image.mips = Some(image.build_mips(*srgb));
            }
            tracing::debug!(
                "{label}: {}x{} decoded in {:.1} ms, mip chain in {:.1} ms",
                image.width,
                image.height,
                decoded.as_secs_f64() * 1e3,
                (start.elapsed() - decoded).as_secs_f64() * 1e3
            );
            image
        });
        progress.image_done();
        image
    });
    decoded.into_iter().map(|d| d.map(Arc::new)).collect()
}

/// The import's progress while images decode beside the meshes: images finished before the
/// meshes are counted, and the images stage is entered with them once the meshes are done.
struct ImagesProgress {
    progress: Option<super::ImportProgress>,
    /// Whether the images stage was entered; images finished so far.
    state: std::sync::Mutex<(bool, usize)>,
}

impl ImagesProgress {
    fn new(progress: Option<super::ImportProgress>) -> Self {
        Self { progress, state: std::sync::Mutex::new((false, 0)) }
    }

    fn image_done(&self) {
        let mut state = self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        state.1 += 1;
        if state.0
            && let Some(p) = &self.progress
        {
            p.step();
        }
    }

    fn meshes_done(&self, images: usize) {
        let mut state = self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        state.0 = true;
        if let Some(p) = &self.progress {
            p.enter(super::ImportStage::Images, images);
            for _ in 0..state.1 {
                p.step();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::{ImportProgress, ImportStage};

    #[test]
    fn images_decoded_beside_the_meshes_count_once_the_meshes_are_done() {
        let p = ImportProgress::default();
        let images = ImagesProgress::new(Some(p.clone()));
        p.enter(ImportStage::Meshes, 2);
        p.step();
        images.image_done();
        images.image_done();
        let s = p.snapshot();
        assert_eq!((s.stage, s.done, s.total), (ImportStage::Meshes, 1, 2), "images do not count as meshes");
        images.meshes_done(3);
        let s = p.snapshot();
        assert_eq!((s.stage, s.done, s.total), (ImportStage::Images, 2, 3));
        images.image_done();
        let s = p.snapshot();
        assert_eq!((s.stage, s.done, s.total), (ImportStage::Images, 3, 3));
        // Without a watcher nothing is reported, nothing fails.
        let quiet = ImagesProgress::new(None);
        quiet.image_done();
        quiet.meshes_done(1);
    }
}
