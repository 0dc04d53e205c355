//! The wire shared by the robot agents, the fusion server, the simulator and the web page.
//!
//! Everything that crosses a process boundary is defined here: message types (JSON via
//! serde), key expressions, validation of inbound data and the JSON Schemas generated from
//! the types. No I/O happens in this crate, except behind the `zenoh` feature: the session
//! settings every process shares (`proto::net`) and a robot program's typed view of the ball
//! (`proto::client`).
//!
//! Units are SI and appear in field names (`position_m`, `velocity_mps`). The field frame
//! has its origin at the pitch centre, x along the long side, y to the left of +x, z up.

#[cfg(feature = "zenoh")]
pub mod client;
mod codec;
mod keys;
mod messages;
pub mod miro;
#[cfg(feature = "zenoh")]
pub mod net;
mod pitch;
pub mod rng;
pub mod schema;
mod stamp;
pub mod stats;
#[cfg(any(test, feature = "test-support"))]
pub mod test_support;
mod validate;
mod view;

pub use codec::{DecodeError, decode, encode};
pub use keys::{DEFAULT_PREFIX, KeyError, KeySpace, camera_chunk, camera_of_chunk, is_valid_id};
pub use messages::{
    BallState, BallStatus, BounceEvent, Camera, CameraFootprint, HeadJoints, Intercept,
    ModelParams, Observation, PathSample, PixelBall, Pose2, Prediction, RobotStatus, StageTiming,
    StopPoint, polygon_contains,
};
pub use pitch::{Pitch, WallSide};
pub use stamp::Stamp;
pub use validate::{
    MAX_FOOTPRINT_POINTS, MAX_STAGE_NAME_BYTES, MAX_STATUS_FOOTPRINTS, MAX_STATUS_TIMINGS,
    Validate, ValidationContext, ValidationError,
};
pub use view::{
    CameraPerception, CameraView, CandidateOutcome, CandidateStage, MAX_REASON_BYTES,
    MAX_REJECTION_REASONS, MAX_VIEW_CANDIDATES, MAX_VIEW_JPEG_BYTES, MAX_VIEW_PAYLOAD_BYTES,
    MAX_VIEW_SIDE_PX, ViewCandidate, jpeg_base64, jpeg_size_px,
};

/// Version of the wire format. Decoders reject messages carrying any other version.
pub const VERSION: u32 = 1;
