// How each kind of light lights a surface.
#define_import_path penumbra::lights

#import penumbra::brdf::{Surface, ambient, direct}
#import penumbra::light_data::{Light, LIGHT_DIRECTIONAL, LIGHT_SPOT, LIGHT_AMBIENT, LIGHT_SPHERE, LIGHT_TUBE, LIGHT_RECT, LIGHT_DISK, LIGHT_IES, range_window}
#ifdef SPHERE_TUBE_LIGHTS
#import penumbra::area_lights::{sphere_light, tube_light}
#endif
#ifdef LTC_LIGHTS
#import penumbra::ltc::ltc_light
#endif
#ifdef IES_LIGHTS
#import penumbra::ies::ies_share
#endif
#ifdef LOCAL_SHADOWS
#import penumbra::light_data::LIGHT_POINT
#import penumbra::shadows::local_shadow
#endif

// Light reaching the eye from `light` off the surface at `rel_pos` (camera-relative), with the
// camera at `camera_position` in world space. Directional, point and spot lights reduce to a
// direction and an illuminance for one shared call of `direct` (one inlined BRDF keeps the
// shader small, which matters for compile time on hot reload); lights with a size have their
// own integrals, compiled in only when the scene has such lights (SPHERE_TUBE_LIGHTS,
// LTC_LIGHTS); IES lights are point lights with a profile (IES_LIGHTS).
// Lights with a size are shadowed from their centre (a cube map, as a point light): sharper
// than the penumbra their size casts, but no light passes through what stands in the way.
fn area_shadow(light: Light, rel_pos: vec3<f32>, n: vec3<f32>, to_light: vec3<f32>) -> f32 {
#ifdef LOCAL_SHADOWS
    if light.shape.w > 0.5 {
        return local_shadow(light, rel_pos, n, to_light);
    }
#endif
    return 1.0;
}

// Whether a light whose sphere of influence is centred at `center_rel` (camera-relative), with
// squared radius `range2`, can reach the point `rel`. A light past its range shades exactly 0,
// so the cluster walks skip it after reading only its position and range (most lights of a
// large far cluster miss a given point). Written as a negation so that NaN is not skipped.
fn within_reach(center_rel: vec3<f32>, range2: f32, rel: vec3<f32>) -> bool {
    let d = center_rel - rel;
    return !(dot(d, d) >= range2);
}

fn shade_light(s: Surface, light: Light, rel_pos: vec3<f32>, camera_position: vec3<f32>) -> vec3<f32> {
    if light.kind == LIGHT_AMBIENT {
        return ambient(s, light.color);
    }
    var l = -light.direction;
    var e = light.color;
#ifdef LOCAL_LIGHTS
    if light.kind != LIGHT_DIRECTIONAL {
        let to_light = (light.position - camera_position) - rel_pos;
#ifdef SPHERE_TUBE_LIGHTS
        if light.kind == LIGHT_SPHERE {
            return sphere_light(s, light, to_light) * area_shadow(light, rel_pos, s.n, to_light);
        }
        if light.kind == LIGHT_TUBE {
            return tube_light(s, light, to_light) * area_shadow(light, rel_pos, s.n, to_light);
        }
#endif
#ifdef LTC_LIGHTS
        if light.kind == LIGHT_RECT || light.kind == LIGHT_DISK {
            return ltc_light(s, light, to_light) * area_shadow(light, rel_pos, s.n, to_light);
        }
#endif
        // Only guards the division: any fixed physical floor (1 mm, 1 cm as some engines use)
        // would break scenes modelled at small scales, so the floor sits just above f32's
        // smallest normal number. A light touching the surface saturates the pixel, and the
        // output clamp keeps it finite.
        let dist2 = max(dot(to_light, to_light), 1e-30);
        l = to_light * inverseSqrt(dist2);
        var atten = range_window(dist2, light.range) / dist2;
        if light.kind == LIGHT_SPOT {
            // Cone falloff as scale (size) and offset (shape.x) of cos(angle).
            let cd = dot(light.direction, -l);
            let a = clamp(cd * light.size + light.shape.x, 0.0, 1.0);
            atten *= a * a;
        }
#ifdef IES_LIGHTS
        if light.kind == LIGHT_IES {
            atten *= ies_share(light, -l);
        }
#endif
#ifdef LOCAL_SHADOWS
        // shape.w: the light's first layer in the local shadow atlas + 1 (0: none).
        if (light.kind == LIGHT_POINT || light.kind == LIGHT_SPOT) && light.shape.w > 0.5 && atten > 0.0 {
            atten *= local_shadow(light, rel_pos, s.n, to_light);
        }
#endif
        if atten <= 0.0 {
            return vec3<f32>(0.0);
        }
        e *= atten;
    }
#else
    // Compiled without local lights: the scene has none.
    if light.kind != LIGHT_DIRECTIONAL {
        return vec3<f32>(0.0);
    }
#endif
    return direct(s, l, e);
}
