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
