//! The agent's camera models and pipeline settings from files, and what it uses when not
//! told otherwise: the simulated MiRo's calibration and the pipeline's defaults. The
//! detector and its model file are chosen in `detector_choice`.

use crate::agent::PipelineConfig;
use crate::calibration::Calibration;
use crate::calibration::camera::CameraModel;
use anyhow::{Context, Result};
use std::path::Path;

use crate::builtin::SIM_CALIBRATION_TOML;

/// The left and right camera models: `left` from a file of `ball-lab calibrate` (or the
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
            .with_context(|| format!("{name} is not a calibration from `ball-lab calibrate`"))?;
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
            check_no_detector_choice(&text, p)?;
            toml::from_str(&text).with_context(|| format!("{}: bad pipeline settings", p.display()))
        }
    }
}

/// The keys that once chose the detector in the pipeline settings; the detector is now
/// named in one place (`--detector`, or `detector` in the service's settings).
const GONE_KEYS: [&str; 2] = ["proposer", "classifier"];

/// Refuses pipeline settings that try to choose the detector, with what to do instead.
fn check_no_detector_choice(text: &str, path: &Path) -> Result<()> {
    let Ok(table) = text.parse::<toml::Table>() else {
        // The typed parse that follows reports the syntax error with its line.
        return Ok(());
    };
    let detector = table.get("detector").and_then(|d| d.as_table());
    for key in GONE_KEYS {
        if detector.is_some_and(|d| d.contains_key(key)) {
            anyhow::bail!(
                "{}: `[detector] {key}` no longer chooses the detector: remove it and name the                  detector with `--detector two-stage|net|dissertation` (or `detector = ...` in                  the agent's settings file)",
                path.display()
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn settings_that_choose_the_detector_are_refused_with_what_to_do() {
        let dir = tempfile::tempdir().unwrap();
        for key in GONE_KEYS {
            let path = dir.path().join(format!("{key}.toml"));
            std::fs::write(&path, format!("[detector]\n{key} = \"colour\"\n")).unwrap();
            let e = format!("{:#}", load_config(Some(&path)).unwrap_err());
            assert!(e.contains(&path.display().to_string()), "{e}");
            assert!(e.contains(key) && e.contains("--detector"), "{e}");
        }
        // Tuning the detector's stages is still the settings' part.
        let path = dir.path().join("tuned.toml");
        std::fs::write(
            &path,
            "[detector]\nnet_appearance_candidates = 2\n[detector.candidates]\ninput_width_px = 256\n",
        )
        .unwrap();
        let config = load_config(Some(&path)).unwrap();
        assert_eq!(config.detector.net_appearance_candidates, 2);
        assert_eq!(config.detector.candidates.input_width_px, 256);
        // A syntax error still names its file.
        std::fs::write(&path, "[detector\n").unwrap();
        let e = format!("{:#}", load_config(Some(&path)).unwrap_err());
        assert!(e.contains("tuned.toml"), "{e}");
    }
}
