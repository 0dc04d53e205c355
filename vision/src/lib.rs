//! The robot's vision: one camera frame to ball candidates, with the image buffers and the
//! camera model it looks through. What the robot runs, and nothing else: training is the
//! `lab` crate's (`ball-lab train`), the floor and the world are the agent's pipeline.
//!
//! The front door is a few names: the [`Detector`] and its settings ([`DetectorConfig`],
//! the parts in [`settings`]), what it gives ([`Candidate`], its [`Circle`]), the images
//! ([`RgbImage`], [`GrayImage`], [`image`]) and the camera models ([`camera`]); [`photo`]
//! runs the detector on a photo with no pose. The stages are private modules, in folders
//! by stage:
//!
//! - `colour/`: the colour path (HSV mask, cleanup, blobs, the circular Hough transform on
//!   local perspective views, the two-colour mask of a patterned ball, the dominant-colour
//!   check) and its proposals;
//! - `candidates`: the candidate network, a heatmap of balls over the downscaled frame,
//!   and its peaks;
//! - `appearance`: proposals by appearance, of any colour (centre-surround filters over an
//!   image pyramid);
//! - `check/`: the proposals judged (the candidate patch, HOG + SVM, the ball network, the
//!   grey checker);
//! - `nn`: the small networks' forward pass and weights files;
//! - `detect`: one frame's proposals of every kind in order, then the check.
//!
//! [`stages`] opens the learned stages and the ones training draws its samples with, for
//! the trainer: the same code the detector runs, so a model learns from what it will see.
//!
//! ```
//! use vision::{Detector, DetectorConfig, NoClock, RgbImage};
//!
//! // A grey carpet with an orange ball of radius 20 px centred at (80, 60).
//! let mut image = RgbImage::filled(160, 120, [90, 100, 90]).unwrap();
//! for y in 0..120u32 {
//!     for x in 0..160u32 {
//!         if (f64::from(x) - 80.0).hypot(f64::from(y) - 60.0) <= 20.0 {
//!             image.set_pixel(x, y, [235, 120, 25]);
//!         }
//!     }
//! }
//! let detector = Detector::new(DetectorConfig::default()).unwrap();
//! let proposals = detector.propose(&image, None, &mut NoClock).unwrap();
//! assert!(proposals.items.iter().any(|p| (p.frame.center_px[0] - 80.0).abs() < 3.0));
//! ```

mod appearance;
pub mod camera;
mod candidates;
mod check;
mod circle;
mod colour;
mod detect;
pub mod image;
mod nn;
#[cfg(any(test, feature = "test-support"))]
pub mod patch_fixtures;
pub mod photo;
mod proposal;
#[cfg(any(test, feature = "test-support"))]
pub mod test_fixtures;

pub use circle::Circle;
#[cfg(any(test, feature = "test-support"))]
pub use detect::HoughOnly;
pub use detect::{
    Candidate, CandidateClassifier, ClassifierKind, DetectError, Detector, DetectorConfig, NoClock,
    Proposer, StageClock,
};
pub use image::RgbImage;
pub use image::gray::GrayImage;

/// The detector's settings, stage by stage: the parts of a [`DetectorConfig`].
pub mod settings {
    pub use crate::appearance::AppearanceConfig;
    pub use crate::candidates::PeakConfig;
    pub use crate::check::patch::PatchConfig;
    pub use crate::colour::hsv::HsvThresholds;
    pub use crate::colour::kmeans::ColourCheckConfig;
    pub use crate::colour::two_colour::PatternConfig;
}

/// The stages one at a time, for the trainer (the `lab` crate) and the evaluation: the
/// learned stages with their inputs and weights files, and the stages training draws its
/// samples with. The detector runs the same code.
pub mod stages {
    /// Proposals by appearance.
    pub mod appearance {
        pub use crate::appearance::*;
    }
    /// The candidate network.
    pub mod candidates {
        pub use crate::candidates::*;
    }
    /// The ball network.
    pub mod ballnet {
        pub use crate::check::ballnet::*;
    }
    /// The grey checker.
    pub mod checker {
        pub use crate::check::checker::*;
    }
    /// The candidate classifiers.
    pub mod classifier {
        pub use crate::check::classifier::*;
    }
    /// The HOG descriptor.
    pub mod hog {
        pub use crate::check::hog::*;
    }
    /// The candidate patch.
    pub mod patch {
        pub use crate::check::patch::*;
    }
    /// The SVM filter's model.
    pub mod svm {
        pub use crate::check::svm::*;
    }
    /// The networks' forward pass and weights files.
    pub mod nn {
        pub use crate::nn::*;
    }
    /// The colour path's pieces the colour window's fit and the filter's training use.
    pub mod colour {
        pub use crate::colour::hsv::{disc_hsv, rgb_to_hsv};
        pub use crate::colour::kmeans::colour_check;
    }
}
