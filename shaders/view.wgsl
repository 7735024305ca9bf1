// The per-frame view uniform (mirrors `GpuView` in renderer.rs), shared by the forward shader
// and the compute pass that shades local lights.
#define_import_path penumbra::view

#import penumbra::common::safe_normalize

struct View {
    clip_from_rel: mat4x4<f32>,
    camera_position: vec3<f32>,
    exposure: f32,
    // Direction the camera looks, for orthographic views (all view rays parallel).
    camera_forward: vec3<f32>,
    is_orthographic: u32,
    // Slots 0 .. global_light_count of `lights` are global; local lights follow.
    global_light_count: u32,
    local_light_count: u32,
    // The target's size in pixels.
    target_size: vec2<f32>,
    // Inverse of clip_from_rel: the background's view rays.
    rel_from_clip: mat4x4<f32>,
};

// Unit direction from a point at `rel` (camera-relative) toward the eye.
fn eye_direction(view: View, rel: vec3<f32>) -> vec3<f32> {
    return select(safe_normalize(-rel, vec3<f32>(0.0, 0.0, 1.0)), -view.camera_forward, view.is_orthographic != 0u);
}
