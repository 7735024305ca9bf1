//! The draw list's vocabulary: a [`Batch`] (instances of one mesh, material and pipeline) and
//! the [`PipelineKey`] that selects its shader variant and raster state. Prepare builds the
//! batches; the forward pass draws them, the cull pass, the shadow casters and the visibility
//! buffer read them.
//!
//! Keys include the shader variant: which material textures a draw samples, its alpha mode,
//! whether it is unlit, which lights the scene has. Each variant's shader is composed with only
//! that code (`#ifdef` switches, see `pipelines::shader_library`), so a scene without normal
//! maps or local lights runs shaders without them. Every draw is instanced (a batch of one has
//! an instance count of one), so instancing is not a key dimension.

use penumbra_engine::Handle;
use penumbra_engine::mesh::{Mesh, Topology};

use crate::gpu::context::Capabilities;
use crate::gpu::formats::FormatKey;
use crate::pipelines::ShaderDefs;
use crate::resources::light_store::LightShapes;
use crate::resources::materials::{AlphaKey, MaterialFeatures, MaterialKey, TextureSet};
use crate::resources::mesh_pool::MeshId;

/// Instances `first..first + count` of `draw_slots`, drawn with one pipeline, material and mesh.
#[derive(Debug, Clone, Copy)]
pub struct Batch {
    pub key: PipelineKey,
    pub material: MaterialKey,
    pub mesh: Handle<Mesh>,
    pub mesh_id: MeshId,
    pub first: u32,
    pub count: u32,
}

/// Everything that selects a forward pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PipelineKey {
    pub unlit: bool,
    pub alpha: AlphaKey,
    pub textures: TextureSet,
    /// The material extensions its shading reads.
    pub features: MaterialFeatures,
    /// How (and whether) local lights are found; without any, their code is left out.
    pub local_lights: LocalLights,
    /// Which lights with a size need their shading code.
    pub light_shapes: LightShapes,
    /// More global lights than the uniform array holds (`LightStore::global_lights_fit_uniform`):
    /// they are walked in the storage array.
    pub global_lights_in_storage: bool,
    /// Directional lights cast shadows this frame: the shadow-map lookups are compiled in.
    pub shadows: bool,
    /// Some local light reads a shadow map this frame.
    pub local_shadows: bool,
    /// The scene has an environment: image-based light is compiled in.
    pub ibl: bool,
    pub debug: DebugView,
    pub topology: TopologyKey,
    /// The mesh has vertex colours other than white (`PoolEntry::vertex_colors`).
    pub vertex_colors: bool,
    /// Double-sided materials draw both faces.
    pub cull_back_faces: bool,
    /// Mirrored instances (negative determinant) wind clockwise.
    pub front_face_cw: bool,
    pub sample_count: u32,
    /// Where a masked draw tests its alpha.
    pub alpha_test: AlphaTest,
    pub color_format: FormatKey,
    /// `None`: the frame has no depth target (its draws cannot cover a pixel twice).
    pub depth_format: Option<FormatKey>,
    /// The fragment shader tonemaps (with this curve) and writes the output itself, when
    /// nothing reads the HDR colour (`color_format` is then the output's format).
    pub tonemap: Option<Tonemapper>,
    /// A triangle-culled draw: the vertex shader reads its vertices from the mesh pool, named
    /// by the culled index list (`features::culling`), instead of from a vertex buffer.
    pub pulled_vertices: bool,
    /// Drawn over the visibility buffer in a hybrid frame (`features::visibility::overlay`):
    /// each sample is tested against the buffer's depth, which binds as group 2.
    pub visibility_occlusion: bool,
}

impl PipelineKey {
    /// The shader variant this key compiles.
    pub fn shader_defs(&self) -> ShaderDefs {
        let t = self.textures;
        let lit = !self.unlit;
        // Deferred: the compute pass shades local lights; fragments only hand it their surface.
        let local = lit && !matches!(self.local_lights, LocalLights::None | LocalLights::Deferred);
        let specular = lit && self.features.has(MaterialFeatures::SPECULAR);
        let clearcoat = lit && self.features.has(MaterialFeatures::CLEARCOAT);
        let sheen = lit && self.features.has(MaterialFeatures::SHEEN);
        let transmission = lit && self.features.has(MaterialFeatures::TRANSMISSION);
        let anisotropy = lit && self.features.has(MaterialFeatures::ANISOTROPY);
        let iridescence = lit && self.features.has(MaterialFeatures::IRIDESCENCE);
        ShaderDefs::default()
            .with("UNLIT", self.unlit)
            .with("ALPHA_MASK", self.alpha == AlphaKey::Mask)
            .with("ALPHA_COVERAGE", self.alpha_test == AlphaTest::SampleMask)
            .with("VISIBILITY_OCCLUSION", self.visibility_occlusion)
            .with("SAMPLE_MASK_OUT", self.alpha_test == AlphaTest::SampleMask || self.visibility_occlusion)
            .with("ALPHA_SAMPLE_RATE", self.alpha_test == AlphaTest::SampleRate)
            .with("ALPHA_BLEND", self.alpha == AlphaKey::Blend)
            .with("BASE_COLOR_TEXTURE", t.has(TextureSet::BASE_COLOR))
            // An unlit surface reads only its base colour.
            .with("METALLIC_ROUGHNESS_TEXTURE", lit && t.has(TextureSet::METALLIC_ROUGHNESS))
            .with("NORMAL_MAP", lit && t.has(TextureSet::NORMAL))
            .with("OCCLUSION_TEXTURE", lit && t.has(TextureSet::OCCLUSION))
            .with("EMISSIVE_TEXTURE", lit && t.has(TextureSet::EMISSIVE))
            .with("MATERIAL_SPECULAR", specular)
            .with("SPECULAR_TEXTURE", specular && t.has(TextureSet::SPECULAR))
            .with("SPECULAR_COLOR_TEXTURE", specular && t.has(TextureSet::SPECULAR_COLOR))
            .with("MATERIAL_CLEARCOAT", clearcoat)
            .with("CLEARCOAT_TEXTURE", clearcoat && t.has(TextureSet::CLEARCOAT))
            .with("CLEARCOAT_ROUGHNESS_TEXTURE", clearcoat && t.has(TextureSet::CLEARCOAT_ROUGHNESS))
            .with("CLEARCOAT_NORMAL_MAP", clearcoat && t.has(TextureSet::CLEARCOAT_NORMAL))
            .with("MATERIAL_SHEEN", sheen)
            .with("SHEEN_COLOR_TEXTURE", sheen && t.has(TextureSet::SHEEN_COLOR))
            .with("SHEEN_ROUGHNESS_TEXTURE", sheen && t.has(TextureSet::SHEEN_ROUGHNESS))
            .with("MATERIAL_TRANSMISSION", transmission)
            .with("TRANSMISSION_TEXTURE", transmission && t.has(TextureSet::TRANSMISSION))
            .with("THICKNESS_TEXTURE", transmission && t.has(TextureSet::THICKNESS))
            .with("MATERIAL_ANISOTROPY", anisotropy)
            .with("ANISOTROPY_TEXTURE", anisotropy && t.has(TextureSet::ANISOTROPY))
            .with("MATERIAL_IRIDESCENCE", iridescence)
            .with("IRIDESCENCE_TEXTURE", iridescence && t.has(TextureSet::IRIDESCENCE))
            .with("IRIDESCENCE_THICKNESS_TEXTURE", iridescence && t.has(TextureSet::IRIDESCENCE_THICKNESS))
            .with("MATERIAL_EXTENSION", specular || clearcoat || sheen || transmission || anisotropy || iridescence)
            .with("TRANSFORMED_UVS", t.has(TextureSet::TRANSFORMED_UVS))
            // Set only with both textures (materials.rs).
            .with("OCCLUSION_IN_METALLIC_ROUGHNESS", lit && t.has(TextureSet::OCCLUSION_IN_METALLIC_ROUGHNESS))
            .with("LOCAL_LIGHTS", local)
            .with("GLOBAL_LIGHTS_IN_STORAGE", lit && self.global_lights_in_storage)
            .with("DEFERRED_LOCAL_LIGHTS", self.local_lights == LocalLights::Deferred)
            .with("CLUSTERED_LIGHTS", lit && self.local_lights == LocalLights::Clustered)
            .with("UNBOUNDED_LIGHTS", lit && self.local_lights == LocalLights::AllUnbounded)
            .with("SPHERE_TUBE_LIGHTS", local && self.light_shapes.sphere_tube)
            .with("LTC_LIGHTS", local && self.light_shapes.ltc)
            .with("IES_LIGHTS", local && self.light_shapes.ies)
            .with("SHADOWS", lit && self.shadows)
            .with("LOCAL_SHADOWS", local && self.local_shadows)
            .with("IBL", lit && self.ibl)
            .with("DEBUG_CLUSTER_HEAT", self.debug == DebugView::ClusterHeat)
            .with("DEBUG_CASCADES", self.debug == DebugView::Cascades)
            .with("DEBUG_NORMALS", self.debug == DebugView::Normals)
            .with("DEBUG_UVS", self.debug == DebugView::Uvs)
            .with("LINE_QUADS", self.topology == TopologyKey::Lines)
            .with("PULLED_VERTICES", self.pulled_vertices)
            .with("POOL_VERTICES", self.pulled_vertices || self.topology == TopologyKey::Lines)
            .with("VERTEX_COLORS", self.vertex_colors)
            .with("TONEMAP_IN_FORWARD", self.tonemap.is_some())
            .with("TONEMAP_NEUTRAL", self.tonemap == Some(Tonemapper::Neutral))
            .with("TONEMAP_ACES", self.tonemap == Some(Tonemapper::Aces))
            .with("ENCODE_SRGB", self.tonemap.is_some() && !self.color_format.0.is_srgb())
    }
}

/// Where a masked draw (glTF's alpha mode MASK) tests its alpha against the cutoff.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub enum AlphaTest {
    /// Once, at the pixel's centre: not masked, or one sample per pixel.
    #[default]
    PerPixel,
    /// At each of the 4 samples, by a sample mask the shader computes (`ALPHA_COVERAGE`,
    /// forward.wgsl's `alpha_coverage`): masked edges are antialiased like geometric ones.
    SampleMask,
    /// At each of the 4 samples, by shading each sample (`ALPHA_SAMPLE_RATE`): the same test
    /// where the backend cannot write a sample mask (`Capabilities::sample_mask_output`).
    SampleRate,
}

impl AlphaTest {
    /// The test for a draw with `alpha` mode in a frame of `samples` per pixel. `alpha_varies`:
    /// the draw's alpha can change within a pixel (a base colour texture or vertex colours);
    /// a constant alpha passes or fails every sample alike, so it is tested once.
    pub fn choose(alpha: AlphaKey, samples: u32, alpha_varies: bool, caps: &Capabilities) -> Self {
        if alpha != AlphaKey::Mask || samples != 4 || !alpha_varies {
            AlphaTest::PerPixel
        } else if caps.sample_mask_output {
            AlphaTest::SampleMask
        } else if caps.sample_rate_shading {
            AlphaTest::SampleRate
        } else {
            AlphaTest::PerPixel
        }
    }
}

/// How the forward shader walks local lights (every kind but directional and ambient).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub enum LocalLights {
    /// The scene has none: no local-light code at all.
    #[default]
    None,
    /// Each fragment walks its cluster's list (the normal path).
    Clustered,
    /// Each fragment walks every local light, windowed by range: the brute-force reference the
    /// clustered path must equal.
    All,
    /// Every local light with no range window (inverse square to infinity): the reference for
    /// the error the window introduces.
    AllUnbounded,
    /// Opaque fragments write their surface to extra targets and a compute pass walks the
    /// cluster lists (`deferred_lights.wgsl`); blended draws keep `Clustered`.
    Deferred,
}

/// Debug views replacing the shaded colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub enum DebugView {
    #[default]
    None,
    /// Lights in each fragment's cluster as a heat map (black 0, then blue → green → yellow →
    /// red → white on a log scale up to 256 and beyond).
    ClusterHeat,
    /// The first shadowed directional light's cascade of each fragment (red, green, blue,
    /// yellow from near to far; grey beyond them), shaded by the lit image's brightness.
    Cascades,
    /// The shading normal (after normal mapping) in world space, as colour: n · 0.5 + 0.5.
    Normals,
    /// The first texture coordinate set, as colour: red u, green v (wrapped into 0..1).
    Uvs,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum TopologyKey {
    Triangles,
    Lines,
    Points,
}

impl From<Topology> for TopologyKey {
    fn from(t: Topology) -> Self {
        match t {
            Topology::TriangleList => TopologyKey::Triangles,
            Topology::LineList => TopologyKey::Lines,
            Topology::PointList => TopologyKey::Points,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Tonemapper {
    /// Khronos PBR Neutral: hue-preserving, base colours reproduce as authored. The default.
    Neutral,
    /// ACES filmic (Hill's RRT+ODT fit).
    Aces,
    /// Clamp only.
    None,
}
