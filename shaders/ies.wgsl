// IES-profiled lights: a point light whose intensity toward each direction is read from its
// luminaire's measured profile. The light store lays every profile in use into `ies_profiles`
// as a uniform grid (resources/ies_profiles.rs, grid built by penumbra_engine::ies): `rows`
// vertical angles γ from 0 (the nadir, the light's `direction`) to π, in `columns` planes of
// horizontal angle C from 0 (the light's C = 0° axis) round the full turn, column after
// column, each value a share of the profile's peak (which the light's colour carries).
#define_import_path penumbra::ies

#import penumbra::common::PI
#import penumbra::light_data::Light

@group(0) @binding(7) var<storage, read> ies_profiles: array<f32>;

// The share of `light`'s peak intensity it sends along `dir` (unit, away from the light):
// bilinear in (γ, C), which reproduces the file's own bilinear interpolation exactly where the
// grid holds the file's angles (it does for files on common angle steps).
fn ies_share(light: Light, dir: vec3<f32>) -> f32 {
    // Whole numbers stored as f32 values (see GpuLight in light_store.rs).
    let first = u32(light.size + 0.5);
    let dims = u32(light.shape.w + 0.5);
    let rows = max(dims / 4096u, 2u);
    let columns = max(dims % 4096u, 1u);
    // C turns counter-clockwise seen from above (from −direction): from the C = 0° axis
    // toward up × axis.
    let c_zero = light.shape.xyz;
    let c_ninety = cross(-light.direction, c_zero);
    let gamma = acos(clamp(dot(dir, light.direction), -1.0, 1.0));
    let across = vec2<f32>(dot(dir, c_zero), dot(dir, c_ninety));
    // Along the axis every plane meets, and atan2(0, 0) is not defined everywhere.
    let c = select(atan2(across.y, across.x), 0.0, abs(across.x) + abs(across.y) < 1e-20);
    let row_f = gamma * (f32(rows - 1u) / PI);
    let row = min(u32(row_f), rows - 2u);
    let row_t = clamp(row_f - f32(row), 0.0, 1.0);
    // fract keeps negative angles in [0, 1) of a turn.
    let col_f = fract(c / (2.0 * PI)) * f32(columns);
    let col = min(u32(col_f), columns - 1u);
    let col_next = (col + 1u) % columns;
    let col_t = clamp(col_f - f32(col), 0.0, 1.0);
    let here = first + col * rows + row;
    let next = first + col_next * rows + row;
    let near_plane = mix(ies_profiles[here], ies_profiles[here + 1u], row_t);
    let far_plane = mix(ies_profiles[next], ies_profiles[next + 1u], row_t);
    return mix(near_plane, far_plane, col_t);
}
