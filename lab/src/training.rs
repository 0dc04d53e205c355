//! Training the detector's learned stages on a CPU (with the tensor library, which the
//! robot's program never links).
//!
//! - [`hog_svm`]: the HOG + SVM filter from labelled patches: augmentation, split, grid
//!   search by cross-validation, held-out metrics; the detectors that mine training
//!   candidates.
//! - [`ballnet_data`]: the networks' training samples from labelled photos, and their
//!   augmentation.
//! - [`ballnet_train`]: training the ball network on a CPU, and its weights file.
//! - [`detector_train`]: training the two-stage detector's networks on a CPU, and its
//!   weights file.

pub mod ballnet_data;
pub mod ballnet_train;
pub mod detector_train;
pub mod hog_svm;
