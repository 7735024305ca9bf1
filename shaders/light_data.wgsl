// The packed light (mirrors `GpuLight` in resources/light_store.rs): what the forward shader and
// the cluster binner both read.
#define_import_path penumbra::light_data

const LIGHT_DIRECTIONAL: u32 = 0u;
const LIGHT_POINT: u32 = 1u;
const LIGHT_SPOT: u32 = 2u;
const LIGHT_AMBIENT: u32 = 3u;
const LIGHT_SPHERE: u32 = 4u;
const LIGHT_TUBE: u32 = 5u;
const LIGHT_RECT: u32 = 6u;
const LIGHT_DISK: u32 = 7u;
const LIGHT_IES: u32 = 8u;

struct Light {
    position: vec3<f32>,
    kind: u32,
    // Direction the light shines (spot, directional, rect, disk) or a tube's axis; unit length.
    direction: vec3<f32>,
    // Radius around `position` bounding everything a local light reaches: its influence range
    // plus its own extent (> 0; 0: lights nothing). 0 for global lights.
    range: f32,
    // Linear colour times intensity (cd, lux, or cd/m² for ambient, rect and disk lights).
    color: vec3<f32>,
    // Spot: cone falloff scale. Sphere, tube, disk: radius. Rect: half width. IES: the
    // profile's first index in `ies_profiles` (a whole number).
    size: f32,
    // Spot: (cone falloff offset, -, -, -). Tube: (half length, -, -, -). Rect: (unit width
    // axis, half height). Disk: (unit axis in its plane, -). IES: (unit C = 0° axis,
    // rows · 4096 + columns).
    shape: vec4<f32>,
};

// glTF KHR_lights_punctual's range window: (1 − (d/r)⁴)² clamped, at squared distance `dist2`
// from the light (from its nearest point, for lights with a size). The store gives every local
// light a range (glTF's, or where it falls below the visible cutoff), so the window always
// applies, except in the UNBOUNDED_LIGHTS reference variant that measures its error.
fn range_window(dist2: f32, range: f32) -> f32 {
#ifdef UNBOUNDED_LIGHTS
    return 1.0;
#else
    let x = dist2 / (range * range);
    let w = clamp(1.0 - x * x, 0.0, 1.0);
    return w * w;
#endif
}
