// Parameters shared by the post-processing passes (mirrors `GpuPostParams` in
// features/post/). The first two fields belong to the GPU when automatic exposure runs.
#define_import_path penumbra::post_params

struct PostParams {
    // Multiplier the tonemap pass applies on top of the camera exposure the forward pass
    // applied: 1, or automatic exposure's correction.
    exposure_scale: f32,
    // Automatic exposure's adapted EV100 (its state from frame to frame).
    adapted_ev: f32,
    bloom_strength: f32,
    // 1 / the number of bloom levels.
    bloom_norm: f32,
    min_ev: f32,
    max_ev: f32,
    compensation: f32,
    // Fraction of the way to the target this frame (1 on the first frame).
    adaptation: f32,
    // The exposure scale the forward pass applied.
    camera_exposure: f32,
    _pad_a: f32,
    _pad_b: f32,
    _pad_c: f32,
};

// Histogram of log2 of pre-exposed luminance: bin 0 holds black, bins 1..255 span
// [HISTOGRAM_MIN_LOG, HISTOGRAM_MIN_LOG + HISTOGRAM_RANGE_LOG].
const HISTOGRAM_MIN_LOG: f32 = -12.0;
const HISTOGRAM_RANGE_LOG: f32 = 24.0;
