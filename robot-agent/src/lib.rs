//! The robot agent: finds the ball in a MiRo's camera frames, projects it onto the floor
//! with the robot's kinematics and publishes it as a `proto::Observation` with an honest
//! covariance.
//!
//! The perception pipeline (camera models and calibration, detection, projection) lives in
//! this crate; today it holds only the crate's place in the workspace, and the simulated
//! observers in `sim` stand in for it in the evaluation.
