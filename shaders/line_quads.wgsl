// Lines as quads a pixel wide (crates/render/src/resources/line_quads.rs): each segment's four
// corners are its two ends, each moved half a pixel to either side, so the quad covers what a
// strict hardware line of width 1 covers, on every driver. Used by the forward shader's
// LINE_QUADS variant and by the gizmo lines.
#define_import_path penumbra::line_quads

// How far along the segment from `clip` to `other_clip` (0..1) an end behind the eye (w ≤ 0)
// must move to lie just in front of it; 0 when `clip` is in front. A quad with corners on both
// sides of the eye plane is no quad on screen; moved, the near plane clips it where the line is
// cut. Attributes at the moved end are those at that fraction of the segment.
fn behind_eye_fraction(clip: vec4<f32>, other_clip: vec4<f32>) -> f32 {
    let w_min = 1e-6 * max(abs(clip.w), abs(other_clip.w));
    if clip.w < w_min && other_clip.w > w_min {
        return (w_min - clip.w) / (other_clip.w - clip.w);
    }
    return 0.0;
}

// A corner of a segment's quad: the end at `clip` (in front of the eye, see
// behind_eye_fraction) moved half a pixel to `side` (−1 or 1) of the segment towards
// `other_clip`; `second_end` says which end of the segment `clip` is, so both ends take the side
// from the same direction. The offset is made in clip space (times w), so it stays half a pixel
// all along the segment once the rasteriser divides by w.
fn line_corner(clip: vec4<f32>, other_clip: vec4<f32>, side: f32, second_end: bool, target_size: vec2<f32>) -> vec4<f32> {
    // Where the other end is behind the eye, the direction on screen is that of the part in
    // front: towards the point just in front of the eye where that end's corners will be.
    let q = mix(other_clip, clip, behind_eye_fraction(other_clip, clip));
    let pixels = 0.5 * target_size;
    var along = (q.xy / q.w - clip.xy / clip.w) * pixels;
    if second_end {
        along = -along;
    }
    let len2 = dot(along, along);
    // A segment shorter than f32 can resolve covers nothing, as a hardware line of length 0.
    let dir = select(vec2<f32>(0.0), along * inverseSqrt(len2), len2 > 1e-30 && len2 < 3e38);
    let offset = vec2<f32>(-dir.y, dir.x) * (0.5 * side) / pixels;
    return vec4<f32>(clip.xy + offset * clip.w, clip.zw);
}
