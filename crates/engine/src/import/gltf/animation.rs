//! glTF skins and animations to plain data: a skin's joints (node indices) and inverse bind
//! matrices; each animation's channels as [`AnimationClip`]s whose target slot is the node index.
//! Every accessor is bounds-checked by [`super::accessor`] and every sampler validated
//! ([`Sampler::new`]) before anything spawns.

use std::sync::Arc;

use glam::Mat4;
use gltf::animation::{Interpolation as GltfInterpolation, Property};

use super::accessor::{AccessorError, Buffers, read_f32};
use crate::animation::{AnimatedProperty, AnimationChannel, AnimationClip, Interpolation, Sampler};
use crate::import::ImportErrorKind;

#[derive(Debug, Clone)]
pub(crate) struct SkinDesc {
    /// Node indices, in JOINTS_0 order.
    pub joints: Vec<usize>,
    pub inverse_bindposes: Arc<[Mat4]>,
}

pub(crate) fn load_skins(document: &gltf::Document, buffers: &Buffers) -> Result<Vec<SkinDesc>, ImportErrorKind> {
    document
        .skins()
        .map(|skin| {
            let skin_err = |reason: String| ImportErrorKind::Skin { index: skin.index(), reason };
            let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
            if joints.is_empty() {
                return Err(skin_err("has no joints".into()));
            }
            let inverse_bindposes: Arc<[Mat4]> = match skin.inverse_bind_matrices() {
                Some(a) => {
                    let m = read_f32::<16>(&a, buffers).map_err(|e| {
                        e.into_kind_with(|r| skin_err(format!("inverseBindMatrices (accessor {}): {r}", a.index())))
                    })?;
                    if m.len() < joints.len() {
                        return Err(skin_err(format!("{} inverse bind matrices for {} joints", m.len(), joints.len())));
                    }
                    let m: Vec<Mat4> = m.iter().take(joints.len()).map(Mat4::from_cols_array).collect();
                    if let Some(i) = m.iter().position(|m| !m.is_finite()) {
                        return Err(skin_err(format!("inverse bind matrix {i} is not finite")));
                    }
                    m.into()
                }
                // The spec: without the accessor every inverse bind matrix is the identity.
                None => vec![Mat4::IDENTITY; joints.len()].into(),
            };
            Ok(SkinDesc { joints, inverse_bindposes })
        })
        .collect()
}

pub(crate) fn load_animations(
    document: &gltf::Document,
    buffers: &Buffers,
) -> Result<Vec<AnimationClip>, ImportErrorKind> {
    let mut clips = Vec::new();
    for animation in document.animations() {
        let index = animation.index();
        let anim_err = |reason: String| ImportErrorKind::Animation { index, reason };
        let mut channels = Vec::new();
        for (c, channel) in animation.channels().enumerate() {
            let sampler = channel.sampler();
            let (input, output) = (sampler.input(), sampler.output());
            let times: Vec<f32> = read_f32::<1>(&input, buffers)
                .map_err(|e| {
                    e.into_kind_with(|r| anim_err(format!("channel {c}: input (accessor {}): {r}", input.index())))
                })?
                .into_iter()
                .map(|[t]| t)
                .collect();
            let out_err = |e: AccessorError| {
                e.into_kind_with(|r| anim_err(format!("channel {c}: output (accessor {}): {r}", output.index())))
            };
            let (property, values): (AnimatedProperty, Vec<f32>) = match channel.target().property() {
                Property::Translation => {
                    (AnimatedProperty::Translation, read_f32::<3>(&output, buffers).map_err(out_err)?.concat())
                }
                Property::Scale => {
                    (AnimatedProperty::Scale, read_f32::<3>(&output, buffers).map_err(out_err)?.concat())
                }
                Property::Rotation => {
                    (AnimatedProperty::Rotation, read_f32::<4>(&output, buffers).map_err(out_err)?.concat())
                }
                Property::MorphTargetWeights => {
                    (AnimatedProperty::MorphWeights, read_f32::<1>(&output, buffers).map_err(out_err)?.concat())
                }
            };
            let interpolation = match sampler.interpolation() {
                GltfInterpolation::Step => Interpolation::Step,
                GltfInterpolation::Linear => Interpolation::Linear,
                GltfInterpolation::CubicSpline => Interpolation::CubicSpline,
            };
            let width = match property {
                AnimatedProperty::Translation | AnimatedProperty::Scale => 3,
                AnimatedProperty::Rotation => 4,
                AnimatedProperty::MorphWeights => {
                    // One value per target per element: the count tells the target count.
                    let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
                    let elements = times.len() * per_key;
                    if elements == 0 || !values.len().is_multiple_of(elements) {
                        return Err(anim_err(format!(
                            "channel {c}: {} weights are not a whole number per keyframe ({} keyframes)",
                            values.len(),
                            times.len()
                        )));
                    }
                    values.len() / elements
                }
            };
            let sampler =
                Sampler::new(interpolation, times, values, width).map_err(|e| anim_err(format!("channel {c}: {e}")))?;
            channels.push(AnimationChannel { target: channel.target().node().index(), property, sampler });
        }
        let name = animation.name().map_or_else(|| format!("animation{index}"), str::to_owned);
        clips.push(AnimationClip { name, channels });
    }
    Ok(clips)
}
