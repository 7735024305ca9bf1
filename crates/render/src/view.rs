//! The view: the camera uniform every pass reads, and the view group (group 0 of the forward,
//! deferred-lights, background, gizmo and visibility-shading pipelines) assembled from its
//! owners' shares ([`crate::bindings`]).
//!
//! Each frame the renderer writes the uniform ([`ViewGroup::write`]); the bind group is made
//! again only when an owner replaced a buffer or texture it contributes
//! ([`ViewGroup::bind`]).

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};
use penumbra_engine::components::Projection;

use crate::bindings::{GroupBuilder, GroupResources, SharedGroup};
use crate::features::clusters::ClusterBinner;
use crate::features::environment::EnvironmentLighting;
use crate::features::shadows::orchestrator::ShadowOrchestrator;
use crate::resources::light_store::LightStore;
use crate::resources::mesh_pool::MeshPool;
use crate::scene::world::ExtractedView;

/// Mirrors `struct View` in `shaders/forward.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuView {
    clip_from_rel: [[f32; 4]; 4],
    camera_position: [f32; 3],
    exposure: f32,
    camera_forward: [f32; 3],
    is_orthographic: u32,
    global_light_count: u32,
    local_light_count: u32,
    /// The target's size in pixels (line quads are a pixel wide).
    target_size: [f32; 2],
    rel_from_clip: [[f32; 4]; 4],
}

/// The view group's bindings in order: the view uniform, the draw list (instances, the slots
/// drawn, materials), then each owner's share.
pub fn declare(b: &mut GroupBuilder) {
    let vf = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
    // Compute too: the visibility buffer's shading pass places vertices and reads materials.
    let vc = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::COMPUTE;
    // What the deferred-lights compute pass reads as well.
    let lit = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
    let storage = wgpu::BufferBindingType::Storage { read_only: true };
    b.buffer("view", vf, wgpu::BufferBindingType::Uniform)
        .buffer("instances", vc, storage)
        .buffer("draw_slots", vc, storage)
        .buffer("materials", lit, storage);
    LightStore::declare_view(b);
    ClusterBinner::declare_view(b);
    ShadowOrchestrator::declare_view(b);
    EnvironmentLighting::declare_view(b);
    MeshPool::declare_view(b);
}

/// What the view group binds besides the uniform.
pub struct ViewSources<'a> {
    pub instances: &'a wgpu::Buffer,
    /// The slots drawn: the cull pass's visible list, or every draw's slot.
    pub draw_slots: &'a wgpu::Buffer,
    pub materials: &'a wgpu::Buffer,
    pub lights: &'a LightStore,
    pub clusters: &'a ClusterBinner,
    pub shadows: &'a ShadowOrchestrator,
    pub environment: &'a EnvironmentLighting,
    pub mesh_pool: &'a MeshPool,
}

/// The view uniform, the view group's layout and its current bind group.
pub struct ViewGroup {
    uniform: wgpu::Buffer,
    group: SharedGroup,
    /// With the mesh pool's vertex-buffer generation it binds.
    bind_group: Option<(u64, wgpu::BindGroup)>,
}

impl ViewGroup {
    pub fn new(device: &wgpu::Device) -> Self {
        let mut b = GroupBuilder::default();
        declare(&mut b);
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view"),
            size: std::mem::size_of::<GpuView>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self { uniform, group: b.build(device, "view"), bind_group: None }
    }

    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        self.group.layout()
    }

    /// How many textures a fragment shader samples from the view group.
    pub fn fragment_textures(&self) -> u32 {
        self.group.fragment_textures()
    }

    pub fn uniform(&self) -> &wgpu::Buffer {
        &self.uniform
    }

    /// Writes this frame's camera (none: zeros, nothing is drawn for it). Returns the camera's
    /// `clip_from_rel`, which the deferred-lights pass needs too.
    pub fn write(
        &self,
        queue: &wgpu::Queue,
        view: Option<&ExtractedView>,
        size: (u32, u32),
        light_counts: (u32, u32),
    ) -> Option<Mat4> {
        let aspect = size.0.max(1) as f32 / size.1.max(1) as f32;
        let (gpu, clip_from_rel) = match view {
            Some(view) => {
                let rotation = glam::Mat3::from(view.world_from_view.matrix3);
                let view_from_rel = Mat4::from_mat3(rotation.transpose());
                let clip_from_rel = view.projection.clip_from_view(aspect) * view_from_rel;
                let gpu = GpuView {
                    clip_from_rel: clip_from_rel.to_cols_array_2d(),
                    camera_position: Vec3::from(view.world_from_view.translation).to_array(),
                    exposure: view.exposure,
                    camera_forward: (rotation * Vec3::NEG_Z).normalize().to_array(),
                    is_orthographic: matches!(view.projection, Projection::Orthographic { .. }) as u32,
                    global_light_count: light_counts.0,
                    local_light_count: light_counts.1,
                    target_size: [size.0 as f32, size.1 as f32],
                    rel_from_clip: clip_from_rel.inverse().to_cols_array_2d(),
                };
                (gpu, Some(clip_from_rel))
            }
            None => (GpuView::zeroed(), None),
        };
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&gpu));
        clip_from_rel
    }

    /// Makes the bind group again when `rebind` (an owner replaced what it contributes) or the
    /// mesh pool's vertex buffer was replaced.
    pub fn bind(&mut self, device: &wgpu::Device, rebind: bool, sources: &ViewSources) {
        let vertices = sources.mesh_pool.vertex_generation();
        if !rebind && self.bind_group.as_ref().is_some_and(|(g, _)| *g == vertices) {
            return;
        }
        let mut r = GroupResources::default();
        r.buffer("view", &self.uniform)
            .buffer("instances", sources.instances)
            .buffer("draw_slots", sources.draw_slots)
            .buffer("materials", sources.materials);
        sources.lights.view_resources(&mut r);
        sources.clusters.view_resources(&mut r);
        sources.shadows.view_resources(&mut r);
        sources.environment.view_resources(&mut r);
        sources.mesh_pool.view_resources(&mut r);
        self.bind_group = Some((vertices, self.group.bind_group(device, r)));
    }

    /// The bind group of the last [`ViewGroup::bind`].
    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.bind_group.as_ref().expect("bound before encoding").1
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipelines::shader_library::{EMBEDDED, ShaderDefs, ShaderLibrary};

    #[test]
    fn gpu_view_mirrors_the_shaders_view() {
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuView,
            "forward.wgsl",
            [],
            "View",
            [
                clip_from_rel,
                camera_position,
                exposure,
                camera_forward,
                is_orthographic,
                global_light_count,
                local_light_count,
                target_size,
                rel_from_clip
            ]
        );
    }

    /// Every shader that binds the view group as group 0, in the variants that declare the
    /// most of it.
    fn view_readers() -> Vec<(&'static str, ShaderDefs)> {
        let all = |list: &[&'static str]| ShaderDefs(list.iter().copied().collect());
        let lit = [
            "LOCAL_LIGHTS",
            "CLUSTERED_LIGHTS",
            "SPHERE_TUBE_LIGHTS",
            "LTC_LIGHTS",
            "IES_LIGHTS",
            "SHADOWS",
            "LOCAL_SHADOWS",
            "IBL",
            "POOL_VERTICES",
            "PULLED_VERTICES",
        ];
        let mut in_storage = lit.to_vec();
        in_storage.push("GLOBAL_LIGHTS_IN_STORAGE");
        vec![
            ("forward.wgsl", all(&lit)),
            ("forward.wgsl", all(&in_storage)),
            ("forward.wgsl", all(&[&lit[..], &["VISIBILITY_SHADE"]].concat())),
            (
                "deferred_lights.wgsl",
                all(&[
                    "LOCAL_LIGHTS",
                    "CLUSTERED_LIGHTS",
                    "SPHERE_TUBE_LIGHTS",
                    "LTC_LIGHTS",
                    "IES_LIGHTS",
                    "LOCAL_SHADOWS",
                ]),
            ),
            ("background.wgsl", ShaderDefs::default()),
            ("gizmo.wgsl", ShaderDefs::default()),
        ]
    }

    #[test]
    fn every_shader_binds_the_view_group_as_declared() {
        let mut b = GroupBuilder::default();
        declare(&mut b);
        let mut lib = ShaderLibrary::embedded().expect("the embedded shaders build");
        let mut seen = std::collections::BTreeSet::new();
        for (entry, defs) in view_readers() {
            let module = lib.compose(entry, &defs).unwrap_or_else(|e| panic!("{entry} {defs}: {e}"));
            for (_, var) in module.global_variables.iter() {
                let (Some(binding), Some(name)) = (&var.binding, &var.name) else { continue };
                if binding.group != 0 {
                    continue;
                }
                // naga_oil decorates names imported from modules; the WGSL name is the prefix.
                let name = name.split("X_naga_oil_mod_X").next().unwrap_or(name);
                assert_eq!(
                    b.binding(name),
                    Some(binding.binding),
                    "{entry} {defs}: `{name}` at @binding({}) against the view group's declaration",
                    binding.binding
                );
                seen.insert(name.to_owned());
            }
        }
        let declared: std::collections::BTreeSet<String> = b.names().map(str::to_owned).collect();
        assert_eq!(seen, declared, "every declared binding is read by some shader, and only those");
        assert!(EMBEDDED.iter().any(|(f, _)| *f == "forward.wgsl"));
    }
}
