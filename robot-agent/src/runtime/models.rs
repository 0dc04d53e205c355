//! The agent's models and settings from files, and what it uses when not told otherwise:
//! the simulated MiRo's calibration and the shipped ball classifier.

use crate::agent::PipelineConfig;
use crate::calibration::calibrate::Calibration;
use crate::calibration::camera::CameraModel;
use crate::detection::classifier::BallClassifier;
use crate::detection::detect::{CandidateClassifier, DetectorConfig};
use crate::detection::svm::Model;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

use crate::builtin::SIM_CALIBRATION_TOML;

/// The flag choosing the ball classifier.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct ClassifierArgs {
    /// A ball classifier made by `robot-agent train` instead of the shipped one: a ball
    /// network (`.safetensors`) or a HOG + SVM filter (`.json`); `hog-svm` names the
    /// shipped HOG + SVM filter.
    #[arg(long = "classifier", value_name = "MODEL")]
    pub classifier: Option<PathBuf>,
}

/// The detector a photo command runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DetectorPreset {
    /// Appearance proposals judged by the shipped ball network: any camera, any ball
    /// colour, no colour calibration.
    Net,
    /// Colour proposals judged by the HOG + SVM filter: the MiRo's calibrated colour path.
    Colour,
    /// As the `--config` file (or the pipeline's defaults) says.
    Config,
}

/// The flag choosing the detector of a photo command.
#[derive(Debug, Clone, clap::Args)]
pub struct DetectorArgs {
    /// Which detector to run.
    #[arg(long = "detector", value_enum, default_value_t = DetectorPreset::Net)]
    pub preset: DetectorPreset,
}

impl DetectorPreset {
    /// The settings with this preset's proposer and classifier.
    pub fn apply(self, config: DetectorConfig) -> DetectorConfig {
        use crate::detection::detect::{ClassifierKind, Proposer};
        match self {
            DetectorPreset::Net => DetectorConfig {
                proposer: Proposer::Appearance,
                classifier: ClassifierKind::Net,
                ..config
            },
            DetectorPreset::Colour => DetectorConfig {
                proposer: Proposer::Colour,
                classifier: ClassifierKind::HogSvm,
                ..config
            },
            DetectorPreset::Config => config,
        }
    }
}

/// The classifier of `model` (the shipped one without it), with the detector's widest
/// colour window for its colour check.
pub fn classifier(
    detector: &DetectorConfig,
    model: Option<&Path>,
) -> Result<Box<dyn CandidateClassifier + Send + Sync>> {
    let Some(path) = model else {
        return crate::builtin::classifier(detector).context("the built-in ball classifier");
    };
    if path.as_os_str() == "hog-svm" {
        let c =
            crate::builtin::svm_classifier(detector).context("the built-in HOG + SVM filter")?;
        return Ok(Box::new(c));
    }
    if path.extension().is_some_and(|e| e == "safetensors") {
        let bytes = std::fs::read(path)
            .with_context(|| format!("reading the ball network {}", path.display()))?;
        let net = crate::detection::ballnet::BallNet::from_safetensors(&bytes)
            .with_context(|| format!("{} is not a ball network", path.display()))?;
        return Ok(Box::new(crate::detection::classifier::NetClassifier::new(
            net,
        )));
    }
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading the classifier {}", path.display()))?;
    let model = Model::from_json(&text).with_context(|| {
        format!(
            "the classifier {} is not a ball classifier model",
            path.display()
        )
    })?;
    anyhow::ensure!(
        model.dim() == crate::detection::hog::HOG_LEN,
        "the classifier {} takes {} features, the detector gives {}",
        path.display(),
        model.dim(),
        crate::detection::hog::HOG_LEN
    );
    let patches = detector.pattern.enabled.then_some(detector.pattern.white);
    Ok(Box::new(
        BallClassifier::new(model, detector.limits)
            .with_colour_check(detector.colour_check, patches),
    ))
}

/// The left and right camera models: `left` from a file of `robot-agent calibrate` (or the
/// built-in calibration of the simulated camera), `right` from its own file or else the
/// same as the left.
pub fn load_models(left: Option<&Path>, right: Option<&Path>) -> Result<[CameraModel; 2]> {
    let read = |path: Option<&Path>| -> Result<CameraModel> {
        let (text, name) = match path {
            Some(p) => (
                std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?,
                p.display().to_string(),
            ),
            None => (
                SIM_CALIBRATION_TOML.to_string(),
                "the built-in calibration".to_string(),
            ),
        };
        let c = Calibration::from_toml_str(&text)
            .with_context(|| format!("{name} is not a calibration from `robot-agent calibrate`"))?;
        Ok(c.model)
    };
    let l = read(left)?;
    let r = match right {
        Some(_) => read(right)?,
        None => l,
    };
    Ok([l, r])
}

/// The pipeline settings of a TOML file (`[detector]`, `[noise]`, `[validation]`), or the
/// defaults without one.
pub fn load_config(path: Option<&Path>) -> Result<PipelineConfig> {
    match path {
        None => Ok(PipelineConfig::default()),
        Some(p) => {
            let text =
                std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            toml::from_str(&text).with_context(|| format!("{}: bad pipeline settings", p.display()))
        }
    }
}
