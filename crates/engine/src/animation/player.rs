//! [`AnimationPlayer`]: playback state as a component (which clip, where in it, how fast,
//! paused or not, looping or not), and [`animate`], the system that applies it.

use std::sync::Arc;

use bevy_ecs::prelude::*;
use glam::{Quat, Vec3, Vec4};

use super::{AnimatedProperty, AnimationClip};
use crate::components::skin::MorphWeights;
use crate::components::transform::Transform;
use crate::time::Time;

/// What happens at the end of a clip.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Repeat {
    /// Wrap around to the start (and to the end when playing backwards).
    #[default]
    Loop,
    /// Stop at the last (or, backwards, the first) frame and stay there.
    Once,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlayerError {
    #[error("no clip {index} (the player has {count})")]
    NoSuchClip { index: usize, count: usize },
    #[error("no clip named {name:?} (the player has: {available})")]
    NoSuchName { name: String, available: String },
    #[error("{what} must be finite, not {value}")]
    NotFinite { what: &'static str, value: f32 },
}

/// Plays one of a scene instance's clips on that instance's entities. The glTF importer puts
/// one on a scene's root when the file has animations, playing clip 0 in a loop.
#[derive(Component, Debug, Clone)]
pub struct AnimationPlayer {
    clips: Arc<[AnimationClip]>,
    /// Per target slot, the entities a channel on that slot writes: the node first, then (for
    /// morph weights) the entities drawing the node's mesh primitives.
    targets: Arc<[Vec<Entity>]>,
    active: Option<usize>,
    time: f32,
    speed: f32,
    paused: bool,
    repeat: Repeat,
    /// (clip, time) last written to the targets.
    applied: Option<(usize, f32)>,
}

impl AnimationPlayer {
    pub fn new(clips: Arc<[AnimationClip]>, targets: Arc<[Vec<Entity>]>) -> Self {
        Self { clips, targets, active: None, time: 0.0, speed: 1.0, paused: false, repeat: Repeat::Loop, applied: None }
    }

    pub fn clips(&self) -> &[AnimationClip] {
        &self.clips
    }

    /// The target slots, for a script that wants to know which entity a channel drives.
    pub fn targets(&self) -> &[Vec<Entity>] {
        &self.targets
    }

    /// The playing clip's index.
    pub fn active(&self) -> Option<usize> {
        self.active
    }

    pub fn active_clip(&self) -> Option<&AnimationClip> {
        self.active.map(|i| &self.clips[i])
    }

    /// Starts clip `index` from its beginning (unpaused).
    pub fn play(&mut self, index: usize) -> Result<&mut Self, PlayerError> {
        if index >= self.clips.len() {
            return Err(PlayerError::NoSuchClip { index, count: self.clips.len() });
        }
        self.active = Some(index);
        self.time = if self.speed < 0.0 { self.clips[index].duration() } else { 0.0 };
        self.paused = false;
        self.applied = None;
        Ok(self)
    }

    /// Starts the clip called `name`.
    pub fn play_named(&mut self, name: &str) -> Result<&mut Self, PlayerError> {
        match self.clips.iter().position(|c| c.name == name) {
            Some(i) => self.play(i),
            None => Err(PlayerError::NoSuchName {
                name: name.to_owned(),
                available: self.clips.iter().map(|c| format!("{:?}", c.name)).collect::<Vec<_>>().join(", "),
            }),
        }
    }

    /// No clip plays; the targets keep their last pose.
    pub fn stop(&mut self) {
        self.active = None;
        self.applied = None;
    }

    pub fn pause(&mut self) {
        self.paused = true;
    }

    pub fn resume(&mut self) {
        self.paused = false;
    }

    pub fn is_paused(&self) -> bool {
        self.paused
    }

    /// Seconds into the active clip.
    pub fn time(&self) -> f32 {
        self.time
    }

    /// Moves the play head (also while paused; the pose follows on the next update).
    pub fn seek(&mut self, seconds: f32) -> Result<&mut Self, PlayerError> {
        if !seconds.is_finite() {
            return Err(PlayerError::NotFinite { what: "an animation time", value: seconds });
        }
        self.time = self.wrap(seconds);
        Ok(self)
    }

    pub fn speed(&self) -> f32 {
        self.speed
    }

    /// Playback rate: 1 is real time, 0.5 half speed, negative plays backwards.
    pub fn set_speed(&mut self, speed: f32) -> Result<&mut Self, PlayerError> {
        if !speed.is_finite() {
            return Err(PlayerError::NotFinite { what: "an animation speed", value: speed });
        }
        self.speed = speed;
        Ok(self)
    }

    pub fn repeat(&self) -> Repeat {
        self.repeat
    }

    pub fn set_repeat(&mut self, repeat: Repeat) -> &mut Self {
        self.repeat = repeat;
        self
    }

    /// Whether a `Once` clip has reached its end (in the direction it plays).
    pub fn is_finished(&self) -> bool {
        let Some(clip) = self.active_clip() else { return false };
        self.repeat == Repeat::Once && if self.speed >= 0.0 { self.time >= clip.duration() } else { self.time <= 0.0 }
    }

    /// Takes `other`'s playback state (clip, time, speed, pause, repeat), keeping this player's
    /// own clips and targets: how a cloned scene instance continues where its original is.
    pub fn copy_playback(&mut self, other: &AnimationPlayer) {
        self.active = other.active.filter(|&i| i < self.clips.len());
        self.time = other.time;
        self.speed = other.speed;
        self.paused = other.paused;
        self.repeat = other.repeat;
        self.applied = None;
    }

    fn wrap(&self, t: f32) -> f32 {
        let duration = self.active_clip().map_or(0.0, AnimationClip::duration);
        if duration <= 0.0 {
            return 0.0;
        }
        match self.repeat {
            // The last keyframe is reached exactly at the end of a pass, and wraps to time 0.
            Repeat::Loop => t.rem_euclid(duration),
            Repeat::Once => t.clamp(0.0, duration),
        }
    }

    fn advance(&mut self, dt: f32) {
        if !self.paused && self.active.is_some() {
            self.time = self.wrap(self.time + dt * self.speed);
        }
    }
}

/// Writes every playing player's clip, sampled at its play head, into the targets (unless that
/// pose is already there), then advances the play head by this frame's `Time` × speed. Runs
/// first in `PostUpdate`, so `Update` systems can steer players and the pose is propagated the
/// same frame.
pub fn animate(
    time: Res<Time>,
    mut players: Query<&mut AnimationPlayer>,
    mut transforms: Query<&mut Transform>,
    mut weights: Query<&mut MorphWeights>,
) {
    let dt = time.delta_secs();
    let mut value = Vec::new();
    for mut player in &mut players {
        let Some(index) = player.active else { continue };
        // The pose at the play head first, then the head moves on: the frame after `play` or
        // `seek(t)` shows exactly the start or `t`, which is what screenshot tests ask for.
        if player.applied != Some((index, player.time)) {
            player.applied = Some((index, player.time));
            apply(&player.clips[index], player.time, &player.targets, &mut transforms, &mut weights, &mut value);
        }
        player.advance(dt);
    }
}

fn apply(
    clip: &AnimationClip,
    t: f32,
    targets: &[Vec<Entity>],
    transforms: &mut Query<&mut Transform>,
    weights: &mut Query<&mut MorphWeights>,
    value: &mut Vec<f32>,
) {
    for channel in &clip.channels {
        let Some(entities) = targets.get(channel.target) else { continue };
        let sampler = &channel.sampler;
        value.resize(sampler.width(), 0.0);
        sampler.sample(t, channel.property.value_kind(), value);
        let property = channel.property;
        if property == AnimatedProperty::MorphWeights {
            for &e in entities {
                if let Ok(mut w) = weights.get_mut(e) {
                    let n = w.0.len().min(value.len());
                    w.0[..n].copy_from_slice(&value[..n]);
                }
            }
            continue;
        }
        let Some(mut transform) = entities.first().and_then(|&e| transforms.get_mut(e).ok()) else {
            continue;
        };
        match property {
            AnimatedProperty::Translation => transform.translation = Vec3::from_slice(value),
            AnimatedProperty::Scale => transform.scale = Vec3::from_slice(value),
            AnimatedProperty::Rotation => {
                transform.rotation = Vec4::from_slice(value).try_normalize().map_or(Quat::IDENTITY, Quat::from_vec4)
            }
            AnimatedProperty::MorphWeights => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::animation::{AnimationChannel, Interpolation, Sampler};
    use crate::time::TimeMode;
    use std::time::Duration;

    fn world_with_clip() -> (World, Entity, Entity) {
        let mut world = World::new();
        world.insert_resource(Time::new(TimeMode::Fixed(Duration::from_millis(250))));
        let node = world.spawn(Transform::default()).id();
        let sampler =
            Sampler::new(Interpolation::Linear, vec![0.0, 1.0], vec![0.0, 0.0, 0.0, 4.0, 0.0, 0.0], 3).expect("valid");
        let clip = AnimationClip {
            name: "slide".into(),
            channels: vec![AnimationChannel { target: 0, property: AnimatedProperty::Translation, sampler }],
        };
        let mut player = AnimationPlayer::new(Arc::from([clip]), Arc::from([vec![node]]));
        player.play(0).unwrap();
        let root = world.spawn(player).id();
        (world, root, node)
    }

    fn step(world: &mut World) -> f32 {
        world.resource_mut::<Time>().tick();
        world.run_system_cached(animate).unwrap();
        let node = world.query::<(&Transform, Entity)>().iter(world).map(|(t, _)| t.translation.x).next();
        node.unwrap()
    }

    #[test]
    fn plays_loops_pauses_and_seeks() {
        let (mut world, root, _) = world_with_clip();
        // 0.25 s steps over a 1 s clip sliding x from 0 to 4; each update shows the play head's
        // time, then moves it on.
        assert_eq!(step(&mut world), 0.0, "the first frame shows the start");
        assert_eq!(step(&mut world), 1.0);
        assert_eq!(step(&mut world), 2.0);
        assert_eq!(step(&mut world), 3.0);
        assert_eq!(step(&mut world), 0.0, "wraps to the start after a whole clip");
        world.get_mut::<AnimationPlayer>(root).unwrap().pause();
        assert_eq!(step(&mut world), 1.0);
        assert_eq!(step(&mut world), 1.0, "paused");
        world.get_mut::<AnimationPlayer>(root).unwrap().seek(0.5).unwrap();
        assert_eq!(step(&mut world), 2.0, "seeking while paused poses the new time");
        let mut p = world.get_mut::<AnimationPlayer>(root).unwrap();
        p.resume();
        p.set_speed(-2.0).unwrap();
        assert_eq!(step(&mut world), 2.0);
        assert_eq!(step(&mut world), 0.0);
        assert_eq!(step(&mut world), 2.0, "backwards wraps to the end");
        let mut p = world.get_mut::<AnimationPlayer>(root).unwrap();
        p.set_speed(1.0).unwrap().set_repeat(Repeat::Once);
        p.seek(0.9).unwrap();
        assert!((step(&mut world) - 3.6).abs() < 1e-5);
        assert!(world.get::<AnimationPlayer>(root).unwrap().is_finished());
        assert_eq!(step(&mut world), 4.0, "a Once clip holds its last frame");
        assert_eq!(step(&mut world), 4.0);
    }

    #[test]
    fn paused_players_write_nothing() {
        let (mut world, root, _) = world_with_clip();
        let changed = |world: &mut World| {
            world.run_system_cached(|q: Query<Ref<Transform>>| q.iter().any(|t| t.is_changed())).unwrap()
        };
        world.get_mut::<AnimationPlayer>(root).unwrap().pause();
        step(&mut world);
        assert!(changed(&mut world), "the first paused update poses the clip once");
        step(&mut world);
        assert!(!changed(&mut world), "a paused player left a change tick");
    }

    #[test]
    fn bad_requests_are_errors() {
        let (mut world, root, _) = world_with_clip();
        let mut p = world.get_mut::<AnimationPlayer>(root).unwrap();
        assert!(matches!(p.play(3), Err(PlayerError::NoSuchClip { index: 3, count: 1 })));
        assert!(matches!(p.play_named("walk"), Err(PlayerError::NoSuchName { .. })));
        assert!(p.set_speed(f32::NAN).is_err());
        assert!(p.seek(f32::INFINITY).is_err());
        assert!(p.play_named("slide").is_ok());
    }
}
