//! The agent's models and settings from files, and what it uses when not told otherwise:
//! the simulated MiRo's calibration and the shipped ball classifier.

use crate::agent::PipelineConfig;
use crate::calibration::calibrate::Calibration;
use crate::calibration::camera::CameraModel;
use crate::detection::classifier::BallClassifier;
use crate::detection::detect::{CandidateClassifier, Detector, DetectorConfig};
use crate::detection::heatnet::HeatNet;
use crate::detection::svm::Model;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

use crate::builtin::SIM_CALIBRATION_TOML;

/// The flag choosing the ball classifier.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct ClassifierArgs {
    /// A model made by `robot-agent train` instead of the shipped one: a two-stage
    /// detector (`.safetensors`: its candidate network and grey checker), a colour-patch
    /// ball network (`.safetensors`) or a HOG + SVM filter (`.json`); `hog-svm` names the
    /// shipped HOG + SVM filter.
    #[arg(long = "classifier", visible_alias = "model", value_name = "MODEL")]
    pub classifier: Option<PathBuf>,
}

/// The detector a photo command runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DetectorPreset {
    /// Appearance proposals judged by the shipped colour-patch ball network: any camera,
    /// any ball colour, no colour calibration.
    Net,
    /// The two-stage detector: the candidate network's heatmap peaks and the strongest
    /// appearance proposals, judged by the grey checker (see the agent's guide for how far
    /// its shipped weights are from the colour-patch network).
    TwoStage,
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

impl DetectorArgs {
    /// The preset to run with `model` (see [`DetectorPreset::with_model`]).
    pub fn preset_for(&self, model: Option<&Path>) -> DetectorPreset {
        self.preset.with_model(model)
    }
}

impl DetectorPreset {
    /// The preset to run with `model`: a two-stage detector's file given with the `net` or
    /// `config` preset runs as `two-stage` (its candidate network needs it).
    pub fn with_model(self, model: Option<&Path>) -> DetectorPreset {
        let detector_file = model
            .filter(|p| p.extension().is_some_and(|e| e == "safetensors"))
            .and_then(|p| std::fs::read(p).ok())
            .is_some_and(|bytes| is_detector_file(&bytes));
        match self {
            DetectorPreset::Net | DetectorPreset::Config if detector_file => {
                DetectorPreset::TwoStage
            }
            p => p,
        }
    }

    /// The settings with this preset's proposer and classifier.
    pub fn apply(self, config: DetectorConfig) -> DetectorConfig {
        use crate::detection::detect::{ClassifierKind, Proposer};
        match self {
            DetectorPreset::Net => DetectorConfig {
                proposer: Proposer::Appearance,
                classifier: ClassifierKind::Net,
                ..config
            },
            DetectorPreset::TwoStage => DetectorConfig {
                proposer: Proposer::Net,
                classifier: ClassifierKind::Checker,
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
        let bytes =
            std::fs::read(path).with_context(|| format!("reading the model {}", path.display()))?;
        if is_detector_file(&bytes) {
            let checker = crate::detection::checker::Checker::from_safetensors(&bytes)
                .with_context(|| format!("{}: the grey checker", path.display()))?;
            return Ok(Box::new(checker));
        }
        let net =
            crate::detection::ballnet::BallNet::from_safetensors(&bytes).with_context(|| {
                format!(
                    "{} is neither a two-stage detector nor a ball network",
                    path.display()
                )
            })?;
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

/// Whether a weights file is a two-stage detector's (by the format its metadata names).
fn is_detector_file(bytes: &[u8]) -> bool {
    !matches!(
        crate::detection::nn::WeightsFile::read(bytes, crate::detection::heatnet::FORMAT),
        Err(crate::detection::nn::WeightsError::WrongFormat { .. })
    )
}

/// The candidate network of `model` when it is a two-stage detector's file.
pub fn candidate_net(model: Option<&Path>) -> Result<Option<HeatNet>> {
    let Some(path) = model.filter(|p| p.extension().is_some_and(|e| e == "safetensors")) else {
        return Ok(None);
    };
    let bytes =
        std::fs::read(path).with_context(|| format!("reading the model {}", path.display()))?;
    if !is_detector_file(&bytes) {
        return Ok(None);
    }
    let net = HeatNet::from_safetensors(&bytes)
        .with_context(|| format!("{}: the candidate network", path.display()))?;
    Ok(Some(net))
}

/// The detector of the settings, with the candidate network of `model` when it is a
/// two-stage detector's file (the shipped one otherwise).
pub fn detector(config: &DetectorConfig, model: Option<&Path>) -> Result<Detector> {
    match candidate_net(model)? {
        Some(net) => Detector::with_net(*config, net),
        None => Detector::new(*config),
    }
    .context("the detector's settings")
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
