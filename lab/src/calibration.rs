//! Calibration from chessboard photos: the camera model fitted to views of a planar board.
//! The model and its file are the agent's ([`robot_agent::Calibration`]); this is the fit.
//!
//! - [`chessboard`]: chessboard inner-corner detection with sub-pixel refinement.
//! - [`homography`]: plane-to-image homographies, Zhang's closed-form intrinsics and a
//!   board's pose from its homography.
//! - [`calibrate`]: camera calibration from chessboard views (Brown–Conrady or
//!   Kannala–Brandt), refined by Levenberg–Marquardt over all parameters, with the reasons
//!   for every view left out.

mod bundle;
pub mod calibrate;
pub mod chessboard;
#[cfg(test)]
mod fixtures;
pub mod homography;
