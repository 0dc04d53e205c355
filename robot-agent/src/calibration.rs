//! Calibration: camera models and fitting them to chessboard views.
//!
//! - [`camera`]: camera models (pinhole intrinsics with Brown–Conrady or Kannala–Brandt
//!   fisheye distortion): projection with its Jacobian, unprojection to rays, and a
//!   validity check.
//! - [`chessboard`]: chessboard inner-corner detection with sub-pixel refinement.
//! - [`homography`]: plane-to-image homographies, Zhang's closed-form intrinsics and a
//!   board's pose from its homography.
//! - [`calibrate`]: camera calibration from chessboard views (Brown–Conrady or
//!   Kannala–Brandt), refined by Levenberg–Marquardt over all parameters, with the reasons
//!   for every view left out; saved and loaded as TOML.

mod bundle;
pub mod calibrate;
pub use vision::camera;
pub mod chessboard;
#[cfg(test)]
mod fixtures;
pub mod homography;
