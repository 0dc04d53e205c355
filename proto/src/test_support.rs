//! Test builders shared by every crate's tests (feature `test-support`, for dev-dependencies
//! only): one valid [`Observation`] to start from, its fields changed with struct update
//! syntax where a test needs others.

use crate::{Camera, Observation, Pose2, Stamp};

/// A valid observation: robot `robot_id`, sequence `seq`, captured at `stamp`, the ball at
/// `position_m` with a 2 cm standard deviation in both axes, seen by the left camera with
/// confidence 0.9 from a robot at the origin. For other fields:
/// `Observation { camera: Camera::Right, ..observation("miro1", 0, stamp, [0.0, 0.0]) }`.
pub fn observation(robot_id: &str, seq: u64, stamp: Stamp, position_m: [f64; 2]) -> Observation {
    Observation {
        version: crate::VERSION,
        robot_id: robot_id.to_owned(),
        seq,
        camera: Camera::Left,
        stamp,
        position_m,
        covariance_m2: isotropic(0.02),
        confidence: 0.9,
        robot_pose: Pose2::default(),
        pixel: None,
    }
}

/// A 16×9 JPEG (green, a yellow square in the middle), 330 bytes.
pub const TINY_JPEG_BASE64: &str = "/9j/4AAQSkZJRgABAQAAAQABAAD/2wBDABALDA4MChAODQ4SERATGCgaGBYWGDEjJR0oOjM9PDkzODdASFxOQERXRTc4UG1RV19iZ2hnPk1xeXBkeFxlZ2P/2wBDARESEhgVGC8aGi9jQjhCY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2NjY2P/wAARCAAJABADASIAAhEBAxEB/8QAFgABAQEAAAAAAAAAAAAAAAAAAAME/8QAHBAAAgICAwAAAAAAAAAAAAAAAgMBEQAEEiFh/8QAFAEBAAAAAAAAAAAAAAAAAAAABP/EABcRAQADAAAAAAAAAAAAAAAAABEAARL/2gAMAwEAAhEDEQA/AMOmtTdoAefBc3ZXEV17jcWpW0YIPmuKorib68yGMAXpYFrIT//Z";

/// A valid camera view of robot `robot_id`'s `camera` captured at `stamp`: the 16×9
/// [`TINY_JPEG_BASE64`] from a 640×360 frame, the ball at its centre and one rejected
/// candidate.
pub fn camera_view(robot_id: &str, camera: Camera, seq: u64, stamp: Stamp) -> crate::CameraView {
    use crate::{CandidateOutcome, CandidateStage, ViewCandidate};
    crate::CameraView {
        version: crate::VERSION,
        robot_id: robot_id.to_owned(),
        seq,
        camera,
        stamp,
        width_px: 16,
        height_px: 9,
        source_width_px: 640,
        source_height_px: 360,
        detector_ms: 5.0,
        candidates: vec![
            ViewCandidate {
                u_px: 8.0,
                v_px: 4.5,
                radius_px: 2.0,
                score: 0.95,
                stage: CandidateStage::Colour,
                outcome: CandidateOutcome::Ball,
                reason: None,
            },
            ViewCandidate {
                u_px: 2.0,
                v_px: 2.0,
                radius_px: 1.0,
                score: 0.3,
                stage: CandidateStage::Appearance,
                outcome: CandidateOutcome::Rejected,
                reason: Some("low_probability".to_owned()),
            },
        ],
        jpeg_base64: TINY_JPEG_BASE64.to_owned(),
    }
}

/// A covariance of `sigma_m` standard deviation in both axes, uncorrelated.
pub fn isotropic(sigma_m: f64) -> [f64; 4] {
    let v = sigma_m * sigma_m;
    [v, 0.0, 0.0, v]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Validate, ValidationContext};

    #[test]
    fn the_built_view_is_valid() {
        let at = Stamp(1_700_000_000_000_000_000);
        let v = camera_view("miro1", Camera::Right, 3, at);
        assert_eq!(
            v.validate(&ValidationContext::new(crate::Pitch::default(), at)),
            Ok(())
        );
    }

    #[test]
    fn the_built_observation_is_valid() {
        let stamp = Stamp(1_800_000_000_000_000_000);
        let o = observation("miro1", 3, stamp, [0.5, -0.2]);
        assert!(
            o.validate(&ValidationContext::new(crate::Pitch::default(), stamp))
                .is_ok()
        );
        assert_eq!(o.covariance_m2, [4e-4, 0.0, 0.0, 4e-4]);
    }
}
