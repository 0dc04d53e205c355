//! Test fixtures of the agent's own tests; the vision stages' are the vision crate's.

pub use vision::test_fixtures::miro_lens;

/// The head pose robots hold when not scanning, turned `yaw_rad` to the left.
pub fn head(yaw_rad: f64) -> proto::HeadJoints {
    proto::HeadJoints {
        lift_rad: proto::miro::DEFAULT_LIFT_RAD,
        yaw_rad,
        pitch_rad: proto::miro::DEFAULT_PITCH_RAD,
    }
}
