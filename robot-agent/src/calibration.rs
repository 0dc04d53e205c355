//! A camera's calibration file: the fitted camera model with its reprojection errors, as
//! TOML. The agent reads it; `ball-lab calibrate` (the `lab` crate) fits and writes it.

use serde::{Deserialize, Serialize};
use thiserror::Error;
use vision::camera::{CameraModel, CameraModelError};

pub use vision::camera;

/// The outcome for one view.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ViewResult {
    /// The view's name.
    pub name: String,
    /// Its reprojection error, pixels (√ of the mean squared point error); absent when it
    /// never took part in a fit.
    pub rms_px: Option<f64>,
    /// Whether the final fit used it.
    pub used: bool,
    /// Why it was not used.
    pub reason: Option<String>,
    /// The board's pose as an axis-angle rotation, radians, camera from board.
    pub rotation_rad: Option<[f64; 3]>,
    /// The board's position in the camera frame, metres.
    pub translation_m: Option<[f64; 3]>,
}

/// A calibration: the camera model (whose intrinsics hold the image size) and its errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// The fitted model.
    pub model: CameraModel,
    /// Reprojection error over all points of the used views, pixels.
    pub rms_px: f64,
    /// Number of views used.
    pub views_used: usize,
    /// Every input view, in input order.
    pub per_view: Vec<ViewResult>,
}

/// Why a calibration failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CalibrationError {
    /// Fewer usable views than the calibration needs.
    #[error("only {usable} usable view(s), at least {needed} needed")]
    TooFewViews {
        /// Views usable.
        usable: usize,
        /// Views needed.
        needed: usize,
    },
    /// The board or image size is unusable.
    #[error("invalid input: {0}")]
    InvalidInput(String),
    /// No starting point for the refinement could be found.
    #[error("no initial estimate of the intrinsics: {0}")]
    Initialisation(String),
    /// The refinement ended on an unusable model.
    #[error("the fitted model is unusable: {0}")]
    InvalidModel(#[from] CameraModelError),
    /// The calibration could not be written or read as TOML.
    #[error("TOML: {0}")]
    Toml(String),
}

impl Calibration {
    /// The calibration as a TOML document.
    pub fn to_toml_string(&self) -> Result<String, CalibrationError> {
        toml::to_string_pretty(self).map_err(|e| CalibrationError::Toml(e.to_string()))
    }

    /// Reads a calibration written by [`Calibration::to_toml_string`]; checks the model.
    pub fn from_toml_str(text: &str) -> Result<Self, CalibrationError> {
        let calibration: Self =
            toml::from_str(text).map_err(|e| CalibrationError::Toml(e.to_string()))?;
        calibration.model.check()?;
        Ok(calibration)
    }
}
