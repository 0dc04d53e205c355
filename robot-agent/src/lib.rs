//! The robot agent: finds the ball in a MiRo's camera frames, projects it onto the floor
//! with the robot's kinematics and publishes it as a `proto::Observation` with an honest
//! covariance.
//!
//! The perception pipeline (camera models and calibration, detection, projection) lives in
//! this crate. Today it holds:
//!
//! - [`camera`]: camera models (pinhole intrinsics with Brown–Conrady or Kannala–Brandt
//!   fisheye distortion): projection with its Jacobian, unprojection to rays, and a
//!   validity check.
//! - [`image`]: the RGB8 frame and binary mask buffers of the detection pipeline.
//! - [`hsv`]: the first stage of the ball detector: HSV colour thresholds, the frame's
//!   colour mask (exact, or through a lookup table), and lighting adaptation of the
//!   thresholds.
//! - [`morphology`]: mask cleanup by erosion, dilation, opening and closing.
//! - [`components`]: connected components of a mask with area, bounding box and centroid.
//! - [`hough`]: a circular Hough transform finding ball candidates in a binary mask.
//! - [`gray`]: the greyscale image of the calibration, and [`image_io`] to load it from
//!   JPEG and PNG files (the only file input of the library).
//! - [`chessboard`]: chessboard inner-corner detection with sub-pixel refinement.
//! - [`homography`]: plane-to-image homographies, Zhang's closed-form intrinsics and a
//!   board's pose from its homography.
//! - [`calibrate`]: camera calibration from chessboard views (Brown–Conrady or
//!   Kannala–Brandt), refined by Levenberg–Marquardt over all parameters, with the reasons
//!   for every view left out; saved and loaded as TOML.
//!
//! The later detection stages (HOG + SVM filter, colour check, world validation) and floor
//! projection are not written yet; the simulated observers in `sim`
//! stand in for the pipeline in the evaluation.

mod bundle;
pub mod calibrate;
#[cfg(test)]
mod calibration_fixtures;
pub mod camera;
pub mod chessboard;
pub mod components;
pub mod gray;
pub mod homography;
pub mod hough;
pub mod hsv;
pub mod image;
pub mod image_io;
pub mod morphology;
#[cfg(test)]
mod test_fixtures;
