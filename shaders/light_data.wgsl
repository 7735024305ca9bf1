// The packed light (mirrors `GpuLight` in prepare/light_store.rs): what the forward shader and
// the cluster binner both read.
#define_import_path penumbra::light_data

const LIGHT_DIRECTIONAL: u32 = 0u;
const LIGHT_POINT: u32 = 1u;
const LIGHT_SPOT: u32 = 2u;
const LIGHT_AMBIENT: u32 = 3u;

struct Light {
    position: vec3<f32>,
    kind: u32,
    // Direction the light shines (spot, directional), world space, unit length.
    direction: vec3<f32>,
    // Influence radius of a local light (> 0; 0: lights nothing). 0 for global lights.
    range: f32,
    // Linear colour times intensity (cd, lux, or cd/m² for ambient).
    color: vec3<f32>,
    spot_scale: f32,
    spot_offset: f32,
    _pad_a: f32,
    _pad_b: f32,
    _pad_c: f32,
};
