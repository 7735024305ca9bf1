// Sphere and tube lights by the representative-point method with energy normalisation (Karis,
// "Real Shading in Unreal Engine 4", SIGGRAPH 2013 course notes): the specular lobe is lit from
// the point of the light nearest the reflected ray, with its peak lowered by how much the
// light's size widens it, α/α′ per widened axis, α′ = α + extent / (2·distance) (the widening
// Karis's notes and most implementations use; the extent is the radius across and the half
// length along a tube). Diffuse light is exact where the whole light is above the horizon: a
// sphere lights like a point at its centre (clipped at the horizon by the closed form of
// Snyder 1996, as given in Lagarde and de Rousiers, "Moving Frostbite to PBR", 2014), a tube
// like a line of points (closed-form line integral, clipped at the horizon).
//
// Both keep the units of a point light (candela): a sphere or tube of size zero is exactly the
// point light of the same intensity.
#define_import_path penumbra::area_lights

#import penumbra::common::{PI, safe_normalize}
#import penumbra::brdf::{Surface, diffuse_brdf, specular_cos}
#import penumbra::light_data::{Light, range_window}

// The illuminance of a uniform sphere (or disk) of unit luminance subtending a cap of
// sin²(half-angle) `sin2`, whose centre is at cos θ = `cos_theta` from the normal, divided by
// π·sin2: so saturate(cos θ) where the cap is wholly above the horizon.
fn cap_irradiance_ratio(cos_theta: f32, sin2: f32) -> f32 {
    if cos_theta * cos_theta > sin2 || sin2 < 1e-7 {
        return clamp(cos_theta, 0.0, 1.0);
    }
    let sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
    let x = sqrt(max(1.0 / sin2 - 1.0, 0.0));
    let y = clamp(-x * cos_theta / max(sin_theta, 1e-7), -1.0, 1.0);
    let sin_theta_sqrt_y = sin_theta * sqrt(max(1.0 - y * y, 0.0));
    let illuminance = (cos_theta * acos(y) - x * sin_theta_sqrt_y) * sin2 + atan2(sin_theta_sqrt_y, x);
    return max(illuminance, 0.0) / (PI * sin2);
}

// sin² of the largest cap a light is treated as: inside a sphere light the surface sees it
// over nearly the whole hemisphere, and the division by d² is replaced by one by r².
const MAX_CAP_SIN2: f32 = 0.9999;

// The point on a ball of `radius` around `center` (surface-relative) nearest the ray `dir`.
fn nearest_on_ball(center: vec3<f32>, radius: f32, dir: vec3<f32>) -> vec3<f32> {
    let to_ray = dot(center, dir) * dir - center;
    return center + to_ray * clamp(radius * inverseSqrt(max(dot(to_ray, to_ray), 1e-30)), 0.0, 1.0);
}

// `to_light`: from the surface to the light's centre.
fn sphere_light(s: Surface, light: Light, to_light: vec3<f32>) -> vec3<f32> {
    let dist2 = max(dot(to_light, to_light), 1e-30);
    let window = range_window(dist2, light.range);
    if window <= 0.0 {
        return vec3<f32>(0.0);
    }
    let radius = light.size;
    let dist = sqrt(dist2);
    let l = to_light / dist;
    let falloff = window / max(dist2, radius * radius / MAX_CAP_SIN2);
    let sin2 = min(radius * radius / dist2, MAX_CAP_SIN2);
    let diffuse = diffuse_brdf(s) * cap_irradiance_ratio(dot(s.n, l), sin2);

    let l_spec = safe_normalize(nearest_on_ball(to_light, radius, reflect(-s.v, s.n)), l);
    let widened = s.alpha / clamp(s.alpha + radius / (2.0 * dist), 0.0, 1.0);
    let specular = specular_cos(s, l_spec) * (widened * widened);
    return (diffuse + specular) * light.color * falloff;
}

fn tube_light(s: Surface, light: Light, to_light: vec3<f32>) -> vec3<f32> {
    let axis = light.direction;
    let half_len = light.shape.x;
    let radius = light.size;
    // The window counts from the nearest point of the segment.
    let to_nearest = to_light + axis * clamp(-dot(to_light, axis), -half_len, half_len);
    let window = range_window(dot(to_nearest, to_nearest), light.range - half_len);
    if window <= 0.0 {
        return vec3<f32>(0.0);
    }
    // The tube is a capsule, not its axis: where an end comes within `radius` of the surface's
    // plane (or below it), the part of the capsule the surface still sees is up to `radius`
    // above the axis, so that end is raised toward there. Without this a tube lying in a floor
    // (its axis in the plane) would leave the floor dark, and rounding would flip pixels
    // between dark and lit; far from the surface nothing moves.
    let axis_a = to_light - axis * half_len;
    let axis_b = to_light + axis * half_len;
    let end_a = axis_a + s.n * clamp(radius - dot(s.n, axis_a), 0.0, radius);
    let end_b = axis_b + s.n * clamp(radius - dot(s.n, axis_b), 0.0, radius);

    // Only the part of the segment above the horizon lights the surface: cut the rest off.
    let h_a = dot(s.n, end_a);
    let h_b = dot(s.n, end_b);
    if h_a <= 0.0 && h_b <= 0.0 {
        return vec3<f32>(0.0);
    }
    let a = select(end_a, end_a + (end_b - end_a) * (h_a / (h_a - h_b)), h_a < 0.0);
    let b = select(end_b, end_b + (end_a - end_b) * (h_b / (h_b - h_a)), h_b < 0.0);
    let kept_len = length(b - a);

    // Diffuse: the mean of cos θ / d² over a segment above the horizon is, in closed form,
    // (N·a/|a| + N·b/|b|) / (|a||b| + a·b) for end points a, b; it covers the kept part.
    let len_a = max(length(a), 1e-30);
    let len_b = max(length(b), 1e-30);
    let mean = (dot(s.n, a) / len_a + dot(s.n, b) / len_b) / max(len_a * len_b + dot(a, b), 1e-30);
    let kept = select(1.0, kept_len / (2.0 * half_len), half_len > 0.0);
    let diffuse = diffuse_brdf(s) * (max(mean, 0.0) * kept * window);

    // Specular: the point of the kept segment nearest the reflected ray, then of the tube's
    // round section around it.
    let refl = reflect(-s.v, s.n);
    let seg = b - a;
    let r_seg = dot(refl, seg);
    let t = clamp((dot(refl, a) * r_seg - dot(a, seg)) / max(dot(seg, seg) - r_seg * r_seg, 1e-30), 0.0, 1.0);
    let on_line = a + t * seg;
    let line_dist2 = max(dot(on_line, on_line), 1e-30);
    let line_dist = sqrt(line_dist2);
    let l_spec = safe_normalize(nearest_on_ball(on_line, radius, refl), s.n);
    let along = s.alpha / clamp(s.alpha + 0.5 * kept_len / (2.0 * line_dist), 0.0, 1.0);
    let across = s.alpha / clamp(s.alpha + radius / (2.0 * line_dist), 0.0, 1.0);
    let karis = along / max(line_dist2, radius * radius / MAX_CAP_SIN2);
    // Karis's widening suits narrow lobes; a lobe wider than the tube sees the whole line, whose
    // ∫ dI/d² is, per unit of intensity, atan2(h·ℓ, h² + s_a·s_b) / (h·ℓ) for a segment of length
    // ℓ with ends at s_a, s_b along it and h from it. The smaller of the two keeps rough surfaces
    // from reflecting more than the tube emits.
    // Along the kept segment itself: raising its ends near a surface may tilt it off the axis.
    let line_axis = select(axis, seg / kept_len, kept_len > 1e-20);
    let s_a = dot(a, line_axis);
    let s_b = dot(b, line_axis);
    let h2 = max(dot(a, a) - s_a * s_a, 0.0);
    let denom = h2 + s_a * s_b;
    let y = sqrt(h2) * (s_b - s_a);
    let whole_line = select(atan2(y, denom) / max(y, 1e-30), 1.0 / denom, denom > 0.0 && y < 1e-4 * denom);
    let specular = specular_cos(s, l_spec) * (across * across * min(karis, whole_line) * kept * window);
    return (diffuse + specular) * light.color;
}
