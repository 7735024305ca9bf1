// How each kind of light lights a surface.
#define_import_path penumbra::lights

#import penumbra::brdf::{Surface, ambient, direct}
#import penumbra::light_data::{Light, LIGHT_DIRECTIONAL, LIGHT_SPOT, LIGHT_AMBIENT}

// glTF KHR_lights_punctual's range window: (1 − (d/r)⁴)² clamped. The store gives every local
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

// Light reaching the eye from `light` off the surface at `rel_pos` (camera-relative), with the
// camera at `camera_position` in world space. Every kind reduces to a direction and an
// illuminance for one shared call of `direct` (one inlined BRDF keeps the shader small, which
// matters for compile time on hot reload).
fn shade_light(s: Surface, light: Light, rel_pos: vec3<f32>, camera_position: vec3<f32>) -> vec3<f32> {
    if light.kind == LIGHT_AMBIENT {
        return ambient(s, light.color);
    }
    var l = -light.direction;
    var e = light.color;
#ifdef LOCAL_LIGHTS
    if light.kind != LIGHT_DIRECTIONAL {
        let to_light = (light.position - camera_position) - rel_pos;
        // Only guards the division: any fixed physical floor (1 mm, 1 cm as some engines use)
        // would break scenes modelled at small scales, so the floor sits just above f32's
        // smallest normal number. A light touching the surface saturates the pixel, and the
        // output clamp keeps it finite.
        let dist2 = max(dot(to_light, to_light), 1e-30);
        l = to_light * inverseSqrt(dist2);
        var atten = range_window(dist2, light.range) / dist2;
        if light.kind == LIGHT_SPOT {
            let cd = dot(light.direction, -l);
            let a = clamp(cd * light.spot_scale + light.spot_offset, 0.0, 1.0);
            atten *= a * a;
        }
        if atten <= 0.0 {
            return vec3<f32>(0.0);
        }
        e *= atten;
    }
#else
    // Compiled without point and spot lights: the scene has none.
    if light.kind != LIGHT_DIRECTIONAL {
        return vec3<f32>(0.0);
    }
#endif
    return direct(s, l, e);
}
