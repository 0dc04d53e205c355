//! The robot agent: finds the ball in a MiRo's camera frames, projects it onto the floor
//! with the robot's kinematics and publishes it as a `proto::Observation` with an honest
//! covariance.
//!
//! The library is pure: functions over images and numbers, no clock reads, no I/O except
//! [`image_io`]'s file loading. The `robot-agent` binary is the shell: frame sources, Zenoh,
//! the command line.
//!
//! Calibration:
//! - [`camera`]: camera models (pinhole intrinsics with Brown–Conrady or Kannala–Brandt
//!   fisheye distortion): projection with its Jacobian, unprojection to rays, and a
//!   validity check.
//! - [`gray`]: the greyscale image of the calibration, and [`image_io`] to load images from
//!   JPEG and PNG files and to write PNGs.
//! - [`chessboard`]: chessboard inner-corner detection with sub-pixel refinement.
//! - [`homography`]: plane-to-image homographies, Zhang's closed-form intrinsics and a
//!   board's pose from its homography.
//! - [`calibrate`]: camera calibration from chessboard views (Brown–Conrady or
//!   Kannala–Brandt), refined by Levenberg–Marquardt over all parameters, with the reasons
//!   for every view left out; saved and loaded as TOML.
//!
//! Detection, one stage per module:
//! - [`image`]: the RGB8 frame and binary mask buffers of the detection pipeline.
//! - [`hsv`]: HSV colour thresholds, the frame's colour mask (exact, or through a lookup
//!   table), and lighting adaptation of the thresholds.
//! - [`seeded_mask`]: the colour mask grown from the strict window's pixels through a
//!   wider window, decided per image.
//! - [`morphology`]: mask cleanup by erosion, dilation, opening and closing.
//! - [`components`]: connected components of a mask with area, bounding box and centroid,
//!   optionally joining fragments a few pixels apart.
//! - [`hough`]: a circular Hough transform finding ball candidates in a binary mask.
//! - [`blob_circle`]: circles straight from small or roundish blobs, and masks shrunk for
//!   blobs too big for the Hough transform.
//! - [`patch`]: the 32×32 candidate patch around a circle, with mirroring and rotation.
//! - [`hog`]: the histogram-of-oriented-gradients descriptor of a patch (288 features).
//! - [`svm`]: the RBF-kernel SVM candidate filter: SMO training, Platt-calibrated
//!   probability, model serialisation.
//! - [`train`]: training the filter from labelled patches: augmentation, split, grid
//!   search by cross-validation, held-out metrics.
//! - [`kmeans`]: the dominant-colour check of a candidate by k-means clustering.
//! - [`classifier`]: the colour check and the HOG + SVM filter as one candidate classifier.
//! - [`rectify`]: local perspective views of a fisheye frame, where a ball is round.
//! - [`two_colour`]: the two-colour mask of a patterned ball (the ball's colour with white
//!   patches) as one disc.
//! - [`detect`]: one frame to ball candidates through the stages above.
//! - [`photo`]: every candidate of one photo on its own (no pose, no projection), with
//!   what became of it, and the photo with the candidates drawn.
//!
//! Projection and the agent:
//! - [`kinematics`]: the MiRo's chain from pose and head joints to each camera.
//! - [`projection`]: pixel to floor point with the covariance propagated from the pixel,
//!   pose and joint uncertainties; camera footprints.
//! - [`pipeline`]: detection, projection and world validation of one frame, at most one
//!   ball per frame.
//! - [`agent`]: a robot's perception state between frames: observations, status, counters.
//! - [`builtin`]: the shipped calibration of the simulated camera and the ball classifier.
//!
//! Recordings:
//! - [`ros_msg`]: the ROS messages of a MiRo's recordings (compressed images, joint states,
//!   poses, odometry) decoded from ROS 1 and ROS 2 (CDR) bytes.
//!
//! Labelled photographs:
//! - [`labels`]: labelled ball boxes and their checks, shared by [`voc`] (Pascal VOC XML)
//!   and [`yolo`] (YOLO text) label readers.
//! - [`label_eval`]: the detector's candidates scored against labelled boxes.

pub mod agent;
pub mod blob_circle;
pub mod builtin;
mod bundle;
pub mod calibrate;
#[cfg(test)]
mod calibration_fixtures;
pub mod camera;
pub mod chessboard;
pub mod classifier;
pub mod components;
pub mod detect;
mod detect_config;
pub mod gray;
pub mod hog;
pub mod homography;
pub mod hough;
pub mod hsv;
pub mod image;
pub mod image_io;
pub mod kinematics;
pub mod kmeans;
pub mod label_eval;
pub mod labels;
pub mod morphology;
pub mod patch;
#[cfg(test)]
mod patch_fixtures;
pub mod photo;
pub mod pipeline;
pub mod projection;
pub mod rectify;
mod rng;
pub mod ros_msg;
#[cfg(test)]
mod ros_msg_fixtures;
pub mod seeded_mask;
pub mod svm;
mod svm_model;
#[cfg(test)]
mod test_fixtures;
pub mod train;
pub mod two_colour;
pub mod voc;
pub mod yolo;
