//! What the agent uses when not told otherwise: the simulated MiRo's calibration (made by
//! `robot-agent calibrate --from-sim --fisheye`) and the shipped ball classifier.

use anyhow::{Context, Result};
use robot_agent::classifier::BallClassifier;
use robot_agent::detect::{CandidateClassifier, DetectorConfig};

/// The calibration of the simulator's MiRo camera, from rendered chessboards.
pub const SIM_CALIBRATION: &str = include_str!("../../../data/sim-calibration.toml");

/// The shipped classifier with the detector's widest colour window for its colour check.
pub fn classifier(detector: &DetectorConfig) -> Result<Box<dyn CandidateClassifier + Send + Sync>> {
    let model = BallClassifier::default_model().context("the built-in ball classifier")?;
    Ok(Box::new(BallClassifier::new(model, detector.limits)))
}
