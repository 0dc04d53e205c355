//! The one place the agent's detector is chosen: its name (`--detector`, `detector` in the
//! service's settings), the model file that replaces the shipped weights (`--model`,
//! `model`), and the pipeline settings' `[detector]` tuning. Every command that runs the
//! detector (`run`, `detect`, `evaluate`, the tools and the benchmarks) calls
//! [`choose_detector`], which reads the model file once, checks that it is the kind the
//! named detector runs, and refuses a mismatch with a sentence that says what to do.

use crate::projection::ProjectionNoise;
use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use vision::stages::ballnet::BallNet;
use vision::stages::candidates::HeatNet;
use vision::stages::checker::Checker;
use vision::stages::classifier::NetClassifier;
use vision::stages::svm::Model;
use vision::{CandidateClassifier, ClassifierKind, Detector, DetectorConfig, Proposer};

/// The detectors the agent ships, by name.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum DetectorKind {
    /// The robot's detector, in every command by default: the candidate network's heatmap
    /// peaks over the downscaled frame (and the strongest appearance proposals), judged by
    /// the colour-patch ball network (any ball colour, no colour calibration).
    #[default]
    Net,
    /// The candidate network's peaks judged by the grey checker, one weights file (kept
    /// for what it still wins; see the agent's guide).
    TwoStage,
    /// The dissertation's pipeline: the HSV colour mask, the circular Hough transform and
    /// the HOG + SVM filter (needs the ball's colour window, `calibrate-colour`).
    Dissertation,
}

impl DetectorKind {
    /// The name on the command line and in settings files.
    pub fn name(self) -> &'static str {
        match self {
            DetectorKind::TwoStage => "two-stage",
            DetectorKind::Net => "net",
            DetectorKind::Dissertation => "dissertation",
        }
    }

    /// The settings with this detector's proposals and classifier.
    pub fn apply(self, config: DetectorConfig) -> DetectorConfig {
        let (proposer, classifier) = match self {
            DetectorKind::TwoStage => (Proposer::Net, ClassifierKind::Checker),
            DetectorKind::Net => (Proposer::Net, ClassifierKind::Net),
            DetectorKind::Dissertation => (Proposer::Colour, ClassifierKind::HogSvm),
        };
        DetectorConfig {
            proposer,
            classifier,
            ..config
        }
    }

    /// The projection's noise for this detector's circles: the settings' own, raised for
    /// the learned detectors to what their circles really miss by (measured against the
    /// renderer's truth by `evaluate --vision`: centre and radius errors of a few pixels,
    /// growing with the ball's size, where the colour path's Hough circles are within a
    /// fraction of a pixel). A larger setting is kept.
    pub fn circle_noise(self, noise: ProjectionNoise) -> ProjectionNoise {
        match self {
            DetectorKind::Dissertation => noise,
            DetectorKind::Net | DetectorKind::TwoStage => ProjectionNoise {
                centre_sigma_px: noise.centre_sigma_px.max(1.0),
                centre_sigma_per_radius: noise.centre_sigma_per_radius.max(0.08),
                radius_sigma_px: noise.radius_sigma_px.max(0.5),
                radius_sigma_per_radius: noise.radius_sigma_per_radius.max(0.07),
                ..noise
            },
        }
    }

    /// The kind of model file this detector takes in place of its shipped weights.
    fn takes(self) -> ModelKind {
        match self {
            DetectorKind::TwoStage => ModelKind::TwoStage,
            DetectorKind::Net => ModelKind::BallNet,
            DetectorKind::Dissertation => ModelKind::HogSvm,
        }
    }
}

/// The flags that choose the detector.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct DetectorArgs {
    /// Which detector runs (`net`, the robot's; `two-stage`; `dissertation`, the
    /// dissertation's colour pipeline).
    #[arg(long = "detector", value_enum, default_value_t = DetectorKind::default())]
    pub kind: DetectorKind,
    /// A model file of `ball-lab train` in place of the detector's shipped weights: a
    /// colour-patch ball network (`.safetensors`) for `net`, a two-stage detector
    /// (`.safetensors`) for `two-stage`, a HOG + SVM filter (`.json`) for `dissertation`.
    #[arg(long = "model", visible_alias = "classifier", value_name = "FILE")]
    pub model: Option<PathBuf>,
}

impl DetectorArgs {
    /// The detector these flags name, tuned by the pipeline settings' `[detector]`.
    pub fn choose(&self, settings: &DetectorConfig) -> Result<ChosenDetector> {
        choose_detector(self.kind, settings, self.model.as_deref())
    }

    /// The flags as a command line gives them (for commands that print how to repeat a
    /// run).
    pub fn command_line(&self) -> String {
        let mut s = String::new();
        if self.kind != DetectorKind::default() {
            s.push_str(&format!(" --detector {}", self.kind.name()));
        }
        if let Some(m) = &self.model {
            s.push_str(&format!(" --model {}", m.display()));
        }
        s
    }
}

/// The detector a command runs: the image half and the classifier, each made once (a clone
/// shares the classifier: each robot or camera of a tool gets its own detector state).
#[derive(Clone)]
pub struct ChosenDetector {
    pub kind: DetectorKind,
    /// The settings the detector runs with (its proposals and classifier set by `kind`).
    pub config: DetectorConfig,
    pub detector: Detector,
    pub classifier: Arc<dyn CandidateClassifier + Send + Sync>,
    /// Where the weights came from: `shipped`, or the model file.
    pub weights: String,
}

impl std::fmt::Debug for ChosenDetector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ChosenDetector")
            .field("kind", &self.kind)
            .field("weights", &self.weights)
            .finish_non_exhaustive()
    }
}

impl ChosenDetector {
    /// Detector `kind`, tuned by `settings`, judged by a classifier of the caller's (tests,
    /// and tools that bring their own).
    pub fn with_classifier(
        kind: DetectorKind,
        settings: &DetectorConfig,
        classifier: Arc<dyn CandidateClassifier + Send + Sync>,
    ) -> Result<Self, vision::DetectError> {
        let config = kind.apply(*settings);
        Ok(ChosenDetector {
            kind,
            config,
            detector: Detector::new(config)?,
            classifier,
            weights: "the caller's".to_string(),
        })
    }

    /// One line for logs: the detector's name and its weights.
    pub fn describe(&self) -> String {
        format!("detector {} ({} weights)", self.kind.name(), self.weights)
    }
}

/// What a model file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ModelKind {
    TwoStage,
    BallNet,
    HogSvm,
}

impl ModelKind {
    fn what(self) -> &'static str {
        match self {
            ModelKind::TwoStage => "a two-stage detector (candidate network and grey checker)",
            ModelKind::BallNet => "a colour-patch ball network",
            ModelKind::HogSvm => "a HOG + SVM filter",
        }
    }

    /// The detector that runs this kind of file.
    fn detector(self) -> DetectorKind {
        match self {
            ModelKind::TwoStage => DetectorKind::TwoStage,
            ModelKind::BallNet => DetectorKind::Net,
            ModelKind::HogSvm => DetectorKind::Dissertation,
        }
    }
}

/// A model file read once, as what it holds.
enum LoadedModel {
    TwoStage(Box<(HeatNet, Checker)>),
    BallNet(BallNet),
    HogSvm(Model),
}

impl LoadedModel {
    fn kind(&self) -> ModelKind {
        match self {
            LoadedModel::TwoStage(_) => ModelKind::TwoStage,
            LoadedModel::BallNet(_) => ModelKind::BallNet,
            LoadedModel::HogSvm(_) => ModelKind::HogSvm,
        }
    }
}

/// The weights file's `format` metadata, when it is a safetensors file that names one.
fn safetensors_format(bytes: &[u8]) -> Option<Option<String>> {
    let (_, meta) = safetensors::SafeTensors::read_metadata(bytes).ok()?;
    Some(
        meta.metadata()
            .as_ref()
            .and_then(|m| m.get("format").cloned()),
    )
}

/// Reads `path` once and loads what it holds, or says in one sentence why it cannot.
fn load_model(path: &Path) -> Result<LoadedModel> {
    let name = path.display();
    let bytes = std::fs::read(path).with_context(|| format!("reading the model file {name}"))?;
    match safetensors_format(&bytes) {
        Some(Some(format)) if format == vision::stages::candidates::FORMAT => {
            let net = HeatNet::from_safetensors(&bytes)
                .with_context(|| format!("{name}: the candidate network"))?;
            let checker = Checker::from_safetensors(&bytes)
                .with_context(|| format!("{name}: the grey checker"))?;
            Ok(LoadedModel::TwoStage(Box::new((net, checker))))
        }
        Some(Some(format)) if format == vision::stages::ballnet::FORMAT => {
            let net = BallNet::from_safetensors(&bytes)
                .with_context(|| format!("{name}: the ball network"))?;
            Ok(LoadedModel::BallNet(net))
        }
        Some(format) => bail!(
            "{name} is a weights file of format {:?}, not a model of `ball-lab train`: \
             give a two-stage detector or a ball network file",
            format.unwrap_or_else(|| "unnamed".to_string())
        ),
        None => {
            let text = std::str::from_utf8(&bytes).map_err(|_| {
                anyhow::anyhow!(
                    "{name} is neither a weights file nor a JSON model (truncated, or another \
                     kind of file): give a model file of `ball-lab train`"
                )
            })?;
            let model = Model::from_json(text).with_context(|| {
                format!(
                    "{name} is not a model of `ball-lab train` (a .safetensors weights file \
                     or a HOG + SVM .json filter); it may be truncated"
                )
            })?;
            anyhow::ensure!(
                model.dim() == vision::stages::hog::HOG_LEN,
                "the HOG + SVM filter {name} takes {} features, the detector gives {}: train \
                 it again with this agent",
                model.dim(),
                vision::stages::hog::HOG_LEN
            );
            Ok(LoadedModel::HogSvm(model))
        }
    }
}

/// The detector `kind`, tuned by `settings`, with the weights of `model` (a file of
/// `ball-lab train`) in place of the shipped ones. The file is read once; one of another
/// kind than the detector takes is refused with a sentence naming the file and the
/// detector that runs it.
pub fn choose_detector(
    kind: DetectorKind,
    settings: &DetectorConfig,
    model: Option<&Path>,
) -> Result<ChosenDetector> {
    let config = kind.apply(*settings);
    let loaded = model.map(load_model).transpose()?;
    if let (Some(path), Some(loaded)) = (model, &loaded)
        && loaded.kind() != kind.takes()
    {
        bail!(
            "{} is {}, which `--detector {}` runs; `--detector {}` takes {}: name the \
             detector that runs the file, or give a file of the right kind",
            path.display(),
            loaded.kind().what(),
            loaded.kind().detector().name(),
            kind.name(),
            kind.takes().what(),
        );
    }
    let weights = model.map_or_else(|| "shipped".to_string(), |p| p.display().to_string());
    let bad_settings = || format!("the detector's settings ({})", kind.name());
    let (detector, classifier): (Detector, Arc<dyn CandidateClassifier + Send + Sync>) =
        match loaded {
            Some(LoadedModel::TwoStage(both)) => {
                let (net, checker) = *both;
                (
                    Detector::with_net(config, net).with_context(bad_settings)?,
                    Arc::new(checker),
                )
            }
            Some(LoadedModel::BallNet(net)) => (
                Detector::new(config).with_context(bad_settings)?,
                Arc::new(NetClassifier::new(net)),
            ),
            Some(LoadedModel::HogSvm(model)) => (
                Detector::new(config).with_context(bad_settings)?,
                Arc::new(crate::builtin::hog_svm_classifier(model, &config)),
            ),
            None => (
                Detector::new(config).with_context(bad_settings)?,
                crate::builtin::classifier(&config)
                    .context("the shipped classifier")?
                    .into(),
            ),
        };
    Ok(ChosenDetector {
        kind,
        config,
        detector,
        classifier,
        weights,
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    #[test]
    fn every_detector_runs_with_its_shipped_weights() {
        for kind in [
            DetectorKind::Net,
            DetectorKind::TwoStage,
            DetectorKind::Dissertation,
        ] {
            let chosen = choose_detector(kind, &DetectorConfig::default(), None).unwrap();
            assert_eq!(chosen.kind, kind);
            assert_eq!(chosen.weights, "shipped");
            assert_eq!(chosen.config, kind.apply(DetectorConfig::default()));
        }
        let default =
            choose_detector(DetectorKind::default(), &DetectorConfig::default(), None).unwrap();
        assert!(default.detector.candidate_net().is_some());
    }

    #[test]
    fn learned_detectors_state_the_circle_noise_they_have() {
        let base = ProjectionNoise::default();
        // The colour pipeline's Hough circles keep the settings' noise.
        assert_eq!(DetectorKind::Dissertation.circle_noise(base), base);
        for kind in [DetectorKind::Net, DetectorKind::TwoStage] {
            let n = kind.circle_noise(base);
            assert!(n.centre_sigma_px > base.centre_sigma_px, "{n:?}");
            assert!(
                n.radius_sigma_per_radius > base.radius_sigma_per_radius,
                "{n:?}"
            );
            assert_eq!(n.max_range_m, base.max_range_m);
            // A setting already larger is kept.
            let wide = ProjectionNoise {
                centre_sigma_px: 9.0,
                ..base
            };
            assert_eq!(kind.circle_noise(wide).centre_sigma_px, 9.0);
        }
    }

    #[test]
    fn a_file_of_another_kind_is_refused_with_what_to_do() {
        let dir = tempfile::tempdir().unwrap();
        let detector = write(dir.path(), "d.safetensors", crate::builtin::DETECTOR);
        let net = write(dir.path(), "n.safetensors", crate::builtin::BALLNET);
        let svm = write(
            dir.path(),
            "s.json",
            crate::builtin::CLASSIFIER_JSON.as_bytes(),
        );
        let settings = DetectorConfig::default();
        for (kind, file, runs) in [
            (DetectorKind::Net, &detector, "--detector two-stage"),
            (DetectorKind::TwoStage, &net, "--detector net"),
            (DetectorKind::TwoStage, &svm, "--detector dissertation"),
            (
                DetectorKind::Dissertation,
                &detector,
                "--detector two-stage",
            ),
        ] {
            let e = format!(
                "{:#}",
                choose_detector(kind, &settings, Some(file)).unwrap_err()
            );
            assert!(e.contains(&file.display().to_string()), "{e}");
            assert!(e.contains(runs), "{e}");
        }
        // The right kinds load.
        for (kind, file) in [
            (DetectorKind::TwoStage, &detector),
            (DetectorKind::Net, &net),
            (DetectorKind::Dissertation, &svm),
        ] {
            let chosen = choose_detector(kind, &settings, Some(file)).unwrap();
            assert_eq!(chosen.weights, file.display().to_string());
        }
    }

    #[test]
    fn a_truncated_or_foreign_file_names_itself() {
        let dir = tempfile::tempdir().unwrap();
        let half = &crate::builtin::DETECTOR[..crate::builtin::DETECTOR.len() / 2];
        let cut = write(dir.path(), "cut.safetensors", half);
        let junk = write(dir.path(), "photo.png", &[0x89, b'P', b'N', b'G', 0, 1, 2]);
        let text = write(dir.path(), "notes.json", b"{\"hello\": 1}");
        let missing = dir.path().join("missing.safetensors");
        for file in [&cut, &junk, &text, &missing] {
            let e = format!(
                "{:#}",
                choose_detector(
                    DetectorKind::TwoStage,
                    &DetectorConfig::default(),
                    Some(file)
                )
                .unwrap_err()
            );
            assert!(e.contains(&file.display().to_string()), "{e}");
        }
    }
}
