// Automatic exposure: a histogram of the frame's log luminance, then its mean between the
// 10th and 90th percentile (so a few very dark or very bright pixels do not swing it) as the
// scene's average luminance, turned into EV100 (EV100 = log2(L · 100 / 12.5), the reflected-
// light meter's calibration), clamped to the user's limits, moved towards from the last frame's
// value, and written as the correction the tonemap pass applies.

#import penumbra::post_params::{PostParams, HISTOGRAM_MIN_LOG, HISTOGRAM_RANGE_LOG}

@group(0) @binding(0) var hdr: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> histogram: array<atomic<u32>, 256>;
@group(0) @binding(2) var<storage, read_write> params: PostParams;

var<workgroup> local_bins: array<atomic<u32>, 256>;
var<workgroup> counts: array<u32, 256>;

@compute @workgroup_size(16, 16, 1)
fn build_histogram(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) t: u32) {
    atomicStore(&local_bins[t], 0u);
    workgroupBarrier();
    let size = textureDimensions(hdr);
    if id.x < size.x && id.y < size.y {
        let c = textureLoad(hdr, vec2<i32>(id.xy), 0).rgb;
        let lum = dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
        var bin = 0u;
        if lum > 1e-8 {
            let x = (log2(lum) - HISTOGRAM_MIN_LOG) / HISTOGRAM_RANGE_LOG;
            bin = 1u + u32(clamp(x, 0.0, 1.0) * 254.0);
        }
        atomicAdd(&local_bins[bin], 1u);
    }
    workgroupBarrier();
    let n = atomicLoad(&local_bins[t]);
    if n > 0u {
        atomicAdd(&histogram[t], n);
    }
}

@compute @workgroup_size(256, 1, 1)
fn average(@builtin(local_invocation_index) t: u32) {
    counts[t] = atomicLoad(&histogram[t]);
    // Cleared for the next frame.
    atomicStore(&histogram[t], 0u);
    workgroupBarrier();
    if t != 0u {
        return;
    }
    var total = 0.0;
    for (var i = 0u; i < 256u; i++) {
        total += f32(counts[i]);
    }
    let lo = 0.1 * total;
    let hi = 0.9 * total;
    var below = 0.0;
    var weighted = 0.0;
    var used = 0.0;
    for (var i = 0u; i < 256u; i++) {
        let n = f32(counts[i]);
        // The part of this bin inside the percentile window.
        let inside = max(min(below + n, hi) - max(below, lo), 0.0);
        below += n;
        if inside > 0.0 {
            // Black (bin 0) counts as the darkest bin.
            let x = (max(f32(i), 1.0) - 0.5) / 254.0;
            weighted += inside * (HISTOGRAM_MIN_LOG + x * HISTOGRAM_RANGE_LOG);
            used += inside;
        }
    }
    let mean_log = select(HISTOGRAM_MIN_LOG, weighted / used, used > 0.0);
    // Back to radiance before the camera's exposure.
    let luminance = exp2(mean_log) / max(params.camera_exposure, 1e-30);
    let target_ev = clamp(log2(max(luminance, 1e-10) * 100.0 / 12.5) - params.compensation, params.min_ev, params.max_ev);
    var ev = mix(params.adapted_ev, target_ev, params.adaptation);
    if !(ev == ev) {
        ev = target_ev;
    }
    params.adapted_ev = ev;
    let exposure = 1.0 / (1.2 * exp2(ev));
    params.exposure_scale = exposure / max(params.camera_exposure, 1e-30);
}
