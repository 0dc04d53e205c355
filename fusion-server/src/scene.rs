//! The match as a Foxglove 3D scene: the pitch and its walls, each robot with its heading
//! and camera footprints (grey when offline), the recent sightings (accepted and refused,
//! with their 2σ ellipses), the ball with its 2σ ellipse and velocity, and the predicted
//! path with its bounces and stop point. Pure: the engine's view at a time in, Foxglove's
//! well-known messages (`foxglove.SceneUpdate`, `foxglove.FrameTransforms`, protobuf) out.
//!
//! Three channels, so that a player that seeks (and shows the last message of each topic)
//! always has the whole scene:
//! - [`SCENE_TOPIC`]: what moves, every [`SCENE_PERIOD_S`]; each update replaces all of the
//!   topic's entities (robots that left disappear).
//! - [`PITCH_TOPIC`]: the pitch, every [`PITCH_PERIOD_S`].
//! - [`TRANSFORMS_TOPIC`]: a frame per robot (`{robot_id}` in `pitch`), to follow one.

mod draw;
mod entities;

pub(crate) use draw::timestamp;

use crate::engine::{Engine, RecentObs, RobotView};
use crate::matchlog::record::Schema;
use foxglove::Encode;
use foxglove::messages::{FrameTransform, FrameTransforms, Quaternion, SceneUpdate, Vector3};
use proto::{BallState, Pitch, Stamp};
use std::sync::Arc;

/// What moves: robots, sightings, the ball and its path.
pub const SCENE_TOPIC: &str = "/scene";
/// The pitch and its walls.
pub const PITCH_TOPIC: &str = "/scene/pitch";
/// Each robot's frame in the pitch's.
pub const TRANSFORMS_TOPIC: &str = "/tf";
/// The frame everything is drawn in: the field frame of the protocol (origin at the centre
/// spot, x along the long side, z up).
pub const PITCH_FRAME: &str = "pitch";

/// Seconds between scene updates.
pub const SCENE_PERIOD_S: f64 = 0.1;
/// Seconds between repeats of the pitch.
pub const PITCH_PERIOD_S: f64 = 1.0;
/// How early an update may come: states arrive on a clock of their own (every 33.3 ms at
/// 30 Hz, with jitter), and an update due a hair after the third state must not wait for
/// the fourth.
const DUE_SLACK_S: f64 = 0.005;

/// Sightings received this long before the update are drawn.
pub const SIGHTING_WINDOW_S: f64 = 0.5;

/// Schema name of the scene channels.
pub const SCENE_SCHEMA: &str = "foxglove.SceneUpdate";
/// Schema name of the transforms channel.
pub const TRANSFORMS_SCHEMA: &str = "foxglove.FrameTransforms";

/// What the scene is drawn from, at one time.
#[derive(Debug, Clone, Copy)]
pub struct SceneInput<'a> {
    pub stamp: Stamp,
    pub pitch: &'a Pitch,
    pub ball: Option<&'a BallState>,
    pub robots: &'a [RobotView],
    /// Recent sightings, oldest first; those older than [`SIGHTING_WINDOW_S`] are left out.
    pub observations: &'a [RecentObs],
}

/// One message of the scene, encoded.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneRecord {
    pub topic: &'static str,
    /// [`SCENE_SCHEMA`] or [`TRANSFORMS_SCHEMA`].
    pub schema: &'static str,
    pub log_time: Stamp,
    pub payload: Vec<u8>,
}

/// The scene's schemas, for a match log's channels: Foxglove's protobuf descriptors.
pub fn schemas() -> Vec<Arc<Schema>> {
    protobuf_schemas([SceneUpdate::get_schema(), FrameTransforms::get_schema()])
}

/// Foxglove's descriptors of some of its messages, as a match log's schemas.
pub(crate) fn protobuf_schemas(
    schemas: impl IntoIterator<Item = Option<foxglove::Schema>>,
) -> Vec<Arc<Schema>> {
    schemas
        .into_iter()
        .flatten()
        .map(|s| {
            Arc::new(Schema::encoded(
                s.name,
                s.encoding,
                s.data.into_owned(),
                "protobuf",
            ))
        })
        .collect()
}

/// Whether a log's schema is one the scene writes (a replay draws it anew).
pub fn is_scene_schema(name: &str) -> bool {
    name == SCENE_SCHEMA || name == TRANSFORMS_SCHEMA
}

/// The moving part of the scene at `input.stamp`.
pub fn scene_update(input: &SceneInput) -> SceneUpdate {
    entities::scene(input)
}

/// The pitch, on its own topic.
pub fn pitch_update(pitch: &Pitch, stamp: Stamp) -> SceneUpdate {
    entities::pitch(pitch, stamp)
}

/// Each robot's frame (`{robot_id}`, x forward, in [`PITCH_FRAME`]).
pub fn transforms(input: &SceneInput) -> FrameTransforms {
    let transforms = input
        .robots
        .iter()
        .filter_map(|r| {
            let pose = r.pose?;
            let half = pose.theta_rad / 2.0;
            Some(FrameTransform {
                timestamp: Some(draw::timestamp(input.stamp)),
                parent_frame_id: PITCH_FRAME.into(),
                child_frame_id: r.robot_id.clone(),
                translation: Some(Vector3 {
                    x: pose.x_m,
                    y: pose.y_m,
                    z: 0.0,
                }),
                rotation: Some(Quaternion {
                    x: 0.0,
                    y: 0.0,
                    z: half.sin(),
                    w: half.cos(),
                }),
            })
        })
        .collect();
    FrameTransforms { transforms }
}

/// A message in its wire encoding (protobuf).
pub(crate) fn encode<M: Encode>(message: &M) -> Vec<u8> {
    let mut buf = Vec::with_capacity(message.encoded_len().unwrap_or(256));
    // Encoding into a growable buffer cannot run out of room.
    let _ = message.encode(&mut buf);
    buf
}

/// When the scene is due: every [`SCENE_PERIOD_S`], the pitch every [`PITCH_PERIOD_S`].
/// Time is passed in; a time before the last one (a replay sought back) starts over.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    last_update: Option<Stamp>,
    last_pitch: Option<Stamp>,
}

impl Scene {
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether an update is due at `at` (without drawing it).
    pub fn due(&self, at: Stamp) -> bool {
        self.last_update
            .is_none_or(|t| at < t || at.secs_since(t) >= SCENE_PERIOD_S - DUE_SLACK_S)
    }

    /// The scene's messages due at `at`, drawn from `engine` (`ball`: its state at `at`,
    /// already computed by the caller); none when not due.
    pub fn tick(
        &mut self,
        engine: &Engine,
        at: Stamp,
        ball: Option<&BallState>,
    ) -> Vec<SceneRecord> {
        if !self.due(at) {
            return Vec::new();
        }
        let robots = engine.robots(at);
        let observations = engine.recent_observations(at, SIGHTING_WINDOW_S);
        self.draw(&SceneInput {
            stamp: at,
            pitch: engine.pitch(),
            ball,
            robots: &robots,
            observations: &observations,
        })
    }

    /// The scene's messages for `input`, due or not (the pitch only when due).
    pub fn draw(&mut self, input: &SceneInput) -> Vec<SceneRecord> {
        let at = input.stamp;
        let mut out = Vec::with_capacity(3);
        let pitch_due = self
            .last_pitch
            .is_none_or(|t| at < t || at.secs_since(t) >= PITCH_PERIOD_S - DUE_SLACK_S);
        if pitch_due {
            self.last_pitch = Some(at);
            out.push(SceneRecord {
                topic: PITCH_TOPIC,
                schema: SCENE_SCHEMA,
                log_time: at,
                payload: encode(&pitch_update(input.pitch, at)),
            });
        }
        self.last_update = Some(at);
        out.push(SceneRecord {
            topic: TRANSFORMS_TOPIC,
            schema: TRANSFORMS_SCHEMA,
            log_time: at,
            payload: encode(&transforms(input)),
        });
        out.push(SceneRecord {
            topic: SCENE_TOPIC,
            schema: SCENE_SCHEMA,
            log_time: at,
            payload: encode(&scene_update(input)),
        });
        out
    }
}

#[cfg(test)]
mod tests;
