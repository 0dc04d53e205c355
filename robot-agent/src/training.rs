//! Training the detector's learned stages, apart from what the robot runs (the networks'
//! training needs the `train` feature and its tensor library; a robot's build leaves it
//! out).
//!
//! - [`hog_svm`]: the HOG + SVM filter from labelled patches: augmentation, split, grid
//!   search by cross-validation, held-out metrics; the detectors that mine training
//!   candidates.
//! - [`ballnet_data`]: the networks' training samples from labelled photos, and their
//!   augmentation.
//! - [`ballnet_train`]: training the ball network on a CPU, and its weights file.
//! - [`detector_train`]: training the two-stage detector's networks on a CPU, and its
//!   weights file.

#[cfg(feature = "train")]
pub mod ballnet_data;
#[cfg(feature = "train")]
pub mod ballnet_train;
#[cfg(feature = "train")]
pub mod detector_train;
pub mod hog_svm;
