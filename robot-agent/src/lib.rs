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
//! - [`patch`]: the 32×32 candidate patch around a circle, with mirroring and rotation.
//! - [`hog`]: the histogram-of-oriented-gradients descriptor of a patch (288 features).
//! - [`svm`]: the RBF-kernel SVM candidate filter: SMO training, Platt-calibrated
//!   probability, model serialisation.
//! - [`train`]: training the filter from labelled patches: augmentation, split, grid
//!   search by cross-validation, held-out metrics.
//! - [`kmeans`]: the dominant-colour check of a candidate by k-means clustering.
//!
//! The world validation of detections,
//! calibration and floor projection are not written yet; the simulated observers in `sim`
//! stand in for the pipeline in the evaluation.

pub mod agent;
pub mod camera;
pub mod components;
pub mod detect;
pub mod hog;
pub mod hough;
pub mod hsv;
pub mod image;
pub mod kinematics;
pub mod kmeans;
pub mod morphology;
pub mod patch;
#[cfg(test)]
mod patch_fixtures;
pub mod pipeline;
pub mod projection;
mod rng;
pub mod svm;
mod svm_model;
#[cfg(test)]
mod test_fixtures;
pub mod train;
