//! The robot agent: finds the ball in a MiRo's camera frames, projects it onto the floor
//! with the robot's kinematics and publishes it as a `proto::Observation` with an honest
//! covariance.
//!
//! The perception pipeline (camera models and calibration, detection, projection) lives in
//! this crate. Today it holds:
//!
//! - [`camera`]: camera models (pinhole intrinsics with Brown–Conrady or Kannala–Brandt
//!   fisheye distortion): projection with its Jacobian, unprojection to rays, and a
//!   validity check.
//! - [`hough`]: a circular Hough transform finding ball candidates in a binary mask.
//!
//! Calibration, detection and floor projection are not written yet; the simulated
//! observers in `sim` stand in for the pipeline in the evaluation.

pub mod camera;
pub mod hough;
