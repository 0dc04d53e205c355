//! What the agent uses when not told otherwise: the simulated MiRo's calibration and the
//! shipped ball classifier.

use anyhow::{Context, Result};
use robot_agent::classifier::BallClassifier;
use robot_agent::detect::{CandidateClassifier, DetectorConfig};
use robot_agent::svm::Model;
use std::path::{Path, PathBuf};

pub use robot_agent::builtin::SIM_CALIBRATION_TOML as SIM_CALIBRATION;

/// The flag choosing the ball classifier.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct ClassifierArgs {
    /// A ball classifier made by `robot-agent train` (JSON) instead of the shipped one.
    #[arg(long = "classifier", value_name = "MODEL.json")]
    pub classifier: Option<PathBuf>,
}

/// The classifier of `model` (the shipped one without it), with the detector's widest
/// colour window for its colour check.
pub fn classifier(
    detector: &DetectorConfig,
    model: Option<&Path>,
) -> Result<Box<dyn CandidateClassifier + Send + Sync>> {
    let Some(path) = model else {
        let c =
            robot_agent::builtin::classifier(detector).context("the built-in ball classifier")?;
        return Ok(Box::new(c));
    };
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading the classifier {}", path.display()))?;
    let model = Model::from_json(&text).with_context(|| {
        format!(
            "the classifier {} is not a ball classifier model",
            path.display()
        )
    })?;
    anyhow::ensure!(
        model.dim() == robot_agent::hog::HOG_LEN,
        "the classifier {} takes {} features, the detector gives {}",
        path.display(),
        model.dim(),
        robot_agent::hog::HOG_LEN
    );
    let patches = detector.pattern.enabled.then_some(detector.pattern.white);
    Ok(Box::new(
        BallClassifier::new(model, detector.limits)
            .with_colour_check(detector.colour_check, patches),
    ))
}
