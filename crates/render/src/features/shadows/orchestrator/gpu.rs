//! The shadow data the shaders read, as the GPU lays it out: each struct mirrors its WGSL
//! declaration, and the tests below hold them together with naga.

use super::{MAX_CASCADES, MAX_SHADOWED_DIRECTIONAL};

/// Mirrors `ShadowCascade` in `shaders/shadows.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct GpuCascade {
    pub(super) clip_from_rel: [[f32; 4]; 4],
    pub(super) far: f32,
    pub(super) texel_size: f32,
    pub(super) depth_range: f32,
    pub(super) rendered: u32,
    /// The stored window's size over the layer's (it sits at the top-left).
    pub(super) window: [f32; 2],
    pub(super) _pad: [u32; 2],
}

/// Mirrors `DirectionalShadow` in `shaders/shadows.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct GpuDirectionalShadow {
    pub(super) light_slot: u32,
    pub(super) first_cascade: u32,
    pub(super) angular_tan: f32,
    pub(super) _pad: u32,
}

/// Mirrors `Shadows` in `shaders/shadows.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct GpuShadows {
    pub(super) cascades: [GpuCascade; MAX_CASCADES],
    pub(super) lights: [GpuDirectionalShadow; MAX_SHADOWED_DIRECTIONAL],
    pub(super) light_count: u32,
    pub(super) cascade_count: u32,
    pub(super) normal_bias: f32,
    pub(super) blend: f32,
    pub(super) filter: u32,
    pub(super) max_kernel: f32,
    pub(super) depth_tolerance: f32,
    pub(super) _pad: u32,
}

/// Mirrors `LocalShadow` in `shaders/shadows.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct GpuLocalShadow {
    pub(super) clip_from_rel: [[f32; 4]; 4],
    pub(super) texel_scale: f32,
    pub(super) valid: u32,
    pub(super) faces: u32,
    pub(super) _pad: u32,
}

/// Mirrors `CasterView` in `shaders/shadow_caster.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct GpuCasterView {
    pub(super) clip_from_rel: [[f32; 4]; 4],
    pub(super) camera_position: [f32; 3],
    /// Where the pass's draw list starts in the bound list (a culled map's own list).
    pub(super) slot_base: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The forward variant that declares every shadow struct.
    const SHADOW_DEFS: [&str; 3] = ["SHADOWS", "LOCAL_LIGHTS", "LOCAL_SHADOWS"];

    #[test]
    fn the_caster_view_mirrors_the_shader() {
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuCasterView,
            "shadow_caster.wgsl",
            [],
            "CasterView",
            [clip_from_rel, camera_position, slot_base]
        );
    }

    #[test]
    fn the_shadow_structs_mirror_the_shaders() {
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuCascade,
            "forward.wgsl",
            SHADOW_DEFS,
            "ShadowCascade",
            [clip_from_rel, far, texel_size, depth_range, rendered, window]
        );
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuDirectionalShadow,
            "forward.wgsl",
            SHADOW_DEFS,
            "DirectionalShadow",
            [light_slot, first_cascade, angular_tan]
        );
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuShadows,
            "forward.wgsl",
            SHADOW_DEFS,
            "Shadows",
            [
                cascades,
                lights,
                light_count,
                cascade_count,
                normal_bias,
                blend,
                filter => "filter_mode",
                max_kernel,
                depth_tolerance
            ]
        );
        crate::pipelines::shader_library::assert_mirrors_wgsl!(
            GpuLocalShadow,
            "forward.wgsl",
            SHADOW_DEFS,
            "LocalShadow",
            [clip_from_rel, texel_scale, valid, faces]
        );
    }
}
