//! What the agent uses when not told otherwise: the simulated MiRo's calibration and the
//! shipped ball classifier.

use anyhow::{Context, Result};
use robot_agent::detect::{CandidateClassifier, DetectorConfig};

pub use robot_agent::builtin::SIM_CALIBRATION_TOML as SIM_CALIBRATION;

/// The shipped classifier with the detector's widest colour window for its colour check.
pub fn classifier(detector: &DetectorConfig) -> Result<Box<dyn CandidateClassifier + Send + Sync>> {
    let c = robot_agent::builtin::classifier(detector).context("the built-in ball classifier")?;
    Ok(Box::new(c))
}
