//! Match logs: MCAP files Foxglove opens. [`record`] writes them on a background thread
//! (rotating, crash-safe chunks), [`McapLog`] is the live server's log and [`RecorderSink`]
//! an offline tool's; [`read`] reads them back, including logs cut short by a crash;
//! [`replay`] re-fuses them offline (the shell plays them as if live).

pub mod read;
pub mod record;
pub mod replay;
mod writer;

pub use writer::{McapLog, RecorderSink, schema_name, schemas};

use proto::Stamp;
use std::fmt::Debug;

/// What a match log is told (the recorder maps kinds to channels and schemas).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogKind {
    Observation,
    Status,
    BallState,
    /// A Foxglove `SceneUpdate` of the match ([`crate::scene`]).
    Scene,
    /// Foxglove `FrameTransforms`: each robot's frame.
    Transforms,
    /// A camera view's metadata (`proto::CameraView`, its image in [`LogKind::Image`]).
    View,
    /// A camera view's image: Foxglove `CompressedImage`.
    Image,
    /// A camera view's candidates: Foxglove `ImageAnnotations`.
    Annotations,
}

/// A match log that never blocks the caller.
pub trait MatchLog: Send + Sync + Debug {
    fn log(&self, kind: LogKind, topic: &str, at: Stamp, payload: &[u8]);
    /// Records written and records dropped so far.
    fn counts(&self) -> (u64, u64);
    /// Payload bytes waiting to be written.
    fn queued_bytes(&self) -> u64 {
        0
    }
    /// How the recording stands (`None`: a log that cannot fail, or none).
    fn health(&self) -> Option<record::RecordingHealth> {
        None
    }
}
