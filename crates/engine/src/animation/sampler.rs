//! Keyframe samplers: glTF 2.0's STEP, LINEAR and CUBICSPLINE interpolation, exactly as the
//! specification's "Animations / Interpolation" section and Appendix C define them.
//!
//! A sampler holds its keyframe times and its output values flattened into one `f32` array,
//! `width` values per element (3 for translation and scale, 4 for a rotation quaternion, the
//! target count for morph weights). A CUBICSPLINE sampler stores three elements per keyframe, in
//! the file's order: in-tangent, value, out-tangent.

use glam::{Quat, Vec4};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interpolation {
    /// The value of the keyframe at or before the time, held until the next keyframe.
    Step,
    /// Linear between keyframes; spherical linear (slerp) for rotations.
    Linear,
    /// Cubic Hermite spline with per-keyframe in- and out-tangents.
    CubicSpline,
}

/// What a sampler's values mean, which decides how they interpolate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ValueKind {
    /// Translation, scale or morph weights: component-wise.
    Linear,
    /// A unit quaternion (x, y, z, w): slerp, and the cubic result renormalised.
    Rotation,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SamplerError {
    #[error("keyframe times must be finite and strictly increasing (time {index} is {value})")]
    Times { index: usize, value: f32 },
    #[error("{values} output values are not {expected} ({keys} keyframes of {elements} element(s) of {width})")]
    OutputCount { values: usize, expected: usize, keys: usize, elements: usize, width: usize },
    #[error("a sampler needs at least one keyframe")]
    Empty,
    #[error("output value {index} is not finite")]
    NonFinite { index: usize },
}

#[derive(Debug, Clone, PartialEq)]
pub struct Sampler {
    interpolation: Interpolation,
    times: Vec<f32>,
    values: Vec<f32>,
    width: usize,
}

impl Sampler {
    /// Checks what sampling relies on: times finite and strictly increasing (the spec requires
    /// it), and exactly one element per keyframe (three for CUBICSPLINE). Non-finite output
    /// values are refused too: an animation must not write NaN into a transform.
    pub fn new(
        interpolation: Interpolation,
        times: Vec<f32>,
        values: Vec<f32>,
        width: usize,
    ) -> Result<Sampler, SamplerError> {
        if times.is_empty() || width == 0 {
            return Err(SamplerError::Empty);
        }
        for (i, t) in times.iter().enumerate() {
            if !t.is_finite() || (i > 0 && *t <= times[i - 1]) {
                return Err(SamplerError::Times { index: i, value: *t });
            }
        }
        let elements = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
        let expected = times.len() * elements * width;
        if values.len() != expected {
            return Err(SamplerError::OutputCount {
                values: values.len(),
                expected,
                keys: times.len(),
                elements,
                width,
            });
        }
        if let Some(index) = values.iter().position(|v| !v.is_finite()) {
            return Err(SamplerError::NonFinite { index });
        }
        Ok(Sampler { interpolation, times, values, width })
    }

    pub fn interpolation(&self) -> Interpolation {
        self.interpolation
    }

    pub fn times(&self) -> &[f32] {
        &self.times
    }

    /// Values per element.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Time of the last keyframe.
    pub fn end_time(&self) -> f32 {
        *self.times.last().expect("validated non-empty")
    }

    /// The value element of keyframe `k` (for CUBICSPLINE the middle of its three).
    fn value(&self, k: usize) -> &[f32] {
        let w = self.width;
        match self.interpolation {
            Interpolation::CubicSpline => &self.values[(3 * k + 1) * w..(3 * k + 2) * w],
            _ => &self.values[k * w..(k + 1) * w],
        }
    }

    fn in_tangent(&self, k: usize) -> &[f32] {
        &self.values[3 * k * self.width..(3 * k + 1) * self.width]
    }

    fn out_tangent(&self, k: usize) -> &[f32] {
        &self.values[(3 * k + 2) * self.width..(3 * k + 3) * self.width]
    }

    /// Writes the value at time `t` into `out` (`width` values). Before the first keyframe the
    /// first value holds, after the last the last value (the spec leaves it to the runtime;
    /// this is what every reference viewer does).
    pub fn sample(&self, t: f32, kind: ValueKind, out: &mut [f32]) {
        let out = &mut out[..self.width];
        let last = self.times.len() - 1;
        // NaN time samples the first keyframe rather than poisoning the output.
        if t.is_nan() || t <= self.times[0] {
            out.copy_from_slice(self.value(0));
            return;
        }
        if t >= self.times[last] {
            out.copy_from_slice(self.value(last));
            return;
        }
        // times[k] <= t < times[k + 1].
        let k = self.times.partition_point(|&x| x <= t) - 1;
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let td = t1 - t0;
        let s = (t - t0) / td;
        match self.interpolation {
            Interpolation::Step => out.copy_from_slice(self.value(k)),
            Interpolation::Linear => {
                let (a, b) = (self.value(k), self.value(k + 1));
                if kind == ValueKind::Rotation && self.width == 4 {
                    // glam's slerp is the spec's: shortest arc (the sign of the dot product),
                    // and a normalised lerp where the angle is too small for sin(θ) to divide.
                    let q = quat(a).slerp(quat(b), s);
                    out.copy_from_slice(&q.to_array());
                } else {
                    for (o, (a, b)) in out.iter_mut().zip(a.iter().zip(b)) {
                        *o = a + s * (b - a);
                    }
                }
            }
            Interpolation::CubicSpline => {
                // Appendix C: p(s) = (2s³ − 3s² + 1) v_k + td (s³ − 2s² + s) b_k
                //                  + (−2s³ + 3s²) v_k+1 + td (s³ − s²) a_k+1,
                // where b_k is keyframe k's out-tangent and a_k+1 keyframe k+1's in-tangent.
                let (s2, s3) = (s * s, s * s * s);
                let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
                let h10 = td * (s3 - 2.0 * s2 + s);
                let h01 = -2.0 * s3 + 3.0 * s2;
                let h11 = td * (s3 - s2);
                let (v0, b0, v1, a1) = (self.value(k), self.out_tangent(k), self.value(k + 1), self.in_tangent(k + 1));
                for i in 0..self.width {
                    out[i] = h00 * v0[i] + h10 * b0[i] + h01 * v1[i] + h11 * a1[i];
                }
                if kind == ValueKind::Rotation && self.width == 4 {
                    let q = Vec4::from_slice(out).try_normalize().unwrap_or(Vec4::W);
                    out.copy_from_slice(&q.to_array());
                }
            }
        }
    }
}

fn quat(v: &[f32]) -> Quat {
    // Keyframes are stored as written; a non-unit one is normalised before slerp divides by it.
    Vec4::from_slice(v).try_normalize().map_or(Quat::IDENTITY, Quat::from_vec4)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: &Sampler, t: f32, kind: ValueKind) -> Vec<f32> {
        let mut out = vec![0.0; s.width()];
        s.sample(t, kind, &mut out);
        out
    }

    #[test]
    fn step_holds_the_earlier_keyframe_until_the_next() {
        let s = Sampler::new(Interpolation::Step, vec![0.0, 1.0, 2.0], vec![10.0, 20.0, 30.0], 1).unwrap();
        assert_eq!(at(&s, -1.0, ValueKind::Linear), [10.0]);
        assert_eq!(at(&s, 0.999, ValueKind::Linear), [10.0]);
        assert_eq!(at(&s, 1.0, ValueKind::Linear), [20.0]);
        assert_eq!(at(&s, 5.0, ValueKind::Linear), [30.0]);
        assert_eq!(at(&s, f32::NAN, ValueKind::Linear), [10.0]);
    }

    #[test]
    fn linear_rotation_takes_the_shorter_arc() {
        // 0° and 270° about Y, the second written with the sign that makes the dot product
        // negative: the short way is −90°, so halfway is −45°.
        let a = Quat::IDENTITY;
        let b = -Quat::from_rotation_y(270f32.to_radians());
        let values: Vec<f32> = a.to_array().into_iter().chain(b.to_array()).collect();
        let s = Sampler::new(Interpolation::Linear, vec![0.0, 1.0], values, 4).unwrap();
        let q = quat(&at(&s, 0.5, ValueKind::Rotation));
        let expected = Quat::from_rotation_y(-45f32.to_radians());
        assert!(q.angle_between(expected) < 1e-5, "{q:?}");
    }

    #[test]
    fn cubic_spline_meets_its_keyframes_and_tangents() {
        // One component: v0 = 0, out-tangent 2; v1 = 1, in-tangent 0; td = 2.
        let values = vec![9.0, 0.0, 2.0, 0.0, 1.0, 9.0];
        let s = Sampler::new(Interpolation::CubicSpline, vec![1.0, 3.0], values, 1).unwrap();
        assert_eq!(at(&s, 1.0, ValueKind::Linear), [0.0]);
        assert_eq!(at(&s, 3.0, ValueKind::Linear), [1.0]);
        // s = 0.5: h00 0.5, h10 td·0.125, h01 0.5, h11 td·(−0.125): 0 + 2·0.125·2 + 0.5 + 0 = 1.
        assert!((at(&s, 2.0, ValueKind::Linear)[0] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn bad_keyframes_are_refused() {
        assert!(matches!(
            Sampler::new(Interpolation::Linear, vec![0.0, 0.0], vec![1.0, 2.0], 1),
            Err(SamplerError::Times { index: 1, .. })
        ));
        assert!(matches!(
            Sampler::new(Interpolation::Linear, vec![0.0, f32::NAN], vec![1.0, 2.0], 1),
            Err(SamplerError::Times { index: 1, .. })
        ));
        assert!(matches!(
            Sampler::new(Interpolation::CubicSpline, vec![0.0, 1.0], vec![1.0, 2.0], 1),
            Err(SamplerError::OutputCount { expected: 6, .. })
        ));
    }
}
