//! Keyframe animation: clips of channels that drive node transforms and morph weights, and the
//! [`AnimationPlayer`] component that plays them.
//!
//! Data flow: an importer (glTF) builds [`AnimationClip`]s whose channels name a *target slot*,
//! and spawns the scene's root with an [`AnimationPlayer`] that maps each slot to the entities of
//! that scene instance. Every frame, [`animate`] (first in `PostUpdate`, before transform
//! propagation) advances each playing player by `Time`'s delta × its speed, samples every
//! channel of its clip at the player's time ([`sampler`]) and writes the results into the
//! targets' `Transform` and [`MorphWeights`]. A paused player at the time it last applied writes
//! nothing, so a still scene stays free of change ticks. Skinning is downstream: joints are
//! ordinary entities, so their animated transforms reach the skinned mesh through
//! [`crate::components::skin`].
//!
//! [`MorphWeights`]: crate::components::skin::MorphWeights

pub mod player;
pub mod sampler;

pub use player::{AnimationPlayer, PlayerError, Repeat, animate};
pub use sampler::{Interpolation, Sampler, SamplerError, ValueKind};

/// What a channel writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AnimatedProperty {
    Translation,
    Rotation,
    Scale,
    /// Every morph-target weight of the target's mesh (the sampler's width is the target count).
    MorphWeights,
}

impl AnimatedProperty {
    pub fn value_kind(self) -> ValueKind {
        if self == AnimatedProperty::Rotation { ValueKind::Rotation } else { ValueKind::Linear }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct AnimationChannel {
    /// Index into the player's target slots (for glTF: the node index).
    pub target: usize,
    pub property: AnimatedProperty,
    pub sampler: Sampler,
}

#[derive(Debug, Clone, PartialEq)]
pub struct AnimationClip {
    pub name: String,
    pub channels: Vec<AnimationChannel>,
}

impl AnimationClip {
    /// The clip's length: its latest keyframe (glTF clips start at time 0 whatever their first
    /// keyframe, as the reference viewers play them).
    pub fn duration(&self) -> f32 {
        self.channels.iter().map(|c| c.sampler.end_time()).fold(0.0, f32::max)
    }
}
