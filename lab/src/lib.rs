//! What a laptop runs for a MiRo team's ball detector, never the robot: training its learned
//! stages, the teacher's labelling of photos nobody labelled, scoring the detector on
//! labelled photos (with its charts), fitting a camera model to chessboard photos and the
//! colour window to labelled balls. The `ball-lab` binary is a thin command line over it
//! ([`cli::main`]); the robot's program (`robot-agent`) holds none of it.
//!
//! - [`calibration`]: chessboard corners, homographies and the camera model's fit
//!   ([`calibrate_with`]).
//! - [`colour_fit`]: the colour detector's window fitted to labelled photos' ball pixels.
//! - [`svm_train`]: the RBF-kernel SVM's training (SMO) and its Platt scaling.
//! - [`training`]: the HOG + SVM filter, the ball network and the two-stage detector's
//!   networks trained on a CPU.
//! - [`labels`]: Pascal VOC and YOLO labels, the detector scored against them, the
//!   teacher's labels.
//! - [`cli`]: the command line, and the flag groups and steps the simulator-driven tools
//!   share with it.

pub mod calibration;
pub mod cli;
pub mod colour_fit;
pub mod labels;
pub mod svm_train;
pub mod training;

pub use calibration::calibrate::{Board, LensModel, calibrate_with, detect_views};
pub use training::hog_svm::miners as training_miners;

/// The charts' font (DejaVu Sans, its notice in `lab/assets/fonts/`), embedded once for
/// every chart the project draws.
pub static CHART_FONT_TTF: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
