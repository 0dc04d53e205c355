//! The learned half of the detector: the ball network ([`NetClassifier`]), or the seed's
//! k-means dominant-colour check and HOG + SVM filter as one [`CandidateClassifier`].
//!
//! The colour check runs first because it is cheap and rejects blobs whose pixels are
//! mostly not the ball's colour (a white robot part under warm light that only grazes the
//! colour window, a stripe across a wall marking). The survivors' 32×32 patches go through
//! HOG and the SVM, whose Platt-calibrated output is the probability that the candidate is
//! the ball. With a patterned ball's patch colour, the colour check accepts the ball's
//! colour and the patches' together.

use crate::check::CandidateClassifier;
use crate::check::ballnet::BallNet;
use crate::check::hog::hog;
use crate::check::patch::{PatchConfig, extract};
use crate::check::svm::Model;
use crate::circle::Circle;
use crate::colour::hsv::HsvThresholds;
use crate::colour::kmeans::{ColourCheckConfig, colour_check};
use crate::image::RgbImage;

/// Colour check, then HOG + SVM.
#[derive(Debug, Clone)]
pub struct BallClassifier {
    model: Model,
    patch: PatchConfig,
    colour: ColourCheckConfig,
    /// The widest colour window the ball may take (the detector's adaptation limits).
    colours: HsvThresholds,
    /// A patterned ball's patch colour, accepted beside the ball's.
    patches: Option<HsvThresholds>,
}

impl BallClassifier {
    /// The default colour check, for a plain ball.
    pub fn new(model: Model, colours: HsvThresholds) -> Self {
        BallClassifier {
            model,
            patch: PatchConfig::default(),
            colour: ColourCheckConfig::default(),
            colours,
            patches: None,
        }
    }

    /// The same classifier with the given colour check and patch colour.
    pub fn with_colour_check(
        self,
        colour: ColourCheckConfig,
        patches: Option<HsvThresholds>,
    ) -> Self {
        BallClassifier {
            colour,
            patches,
            ..self
        }
    }

    /// The SVM's probability for a candidate, without the colour check.
    pub fn svm_probability(&self, image: &RgbImage, circle: &Circle) -> Option<f64> {
        let patch = extract(image, circle.center_px, circle.radius_px, &self.patch).ok()?;
        self.model.probability(&hog(&patch)).ok()
    }
}

impl CandidateClassifier for BallClassifier {
    fn probability(&self, image: &RgbImage, circle: &Circle) -> Option<f64> {
        let colour = colour_check(
            image,
            circle.center_px,
            circle.radius_px,
            &self.colours,
            self.patches.as_ref(),
            &self.colour,
        )
        .ok()?;
        if !colour.passes {
            return None;
        }
        self.svm_probability(image, circle)
    }
}

/// The ball network: a probability for any ball colour, and the ball's refined circle.
#[derive(Debug, Clone)]
pub struct NetClassifier {
    net: BallNet,
}

impl NetClassifier {
    pub fn new(net: BallNet) -> Self {
        NetClassifier { net }
    }
}

impl CandidateClassifier for NetClassifier {
    fn probability(&self, image: &RgbImage, circle: &Circle) -> Option<f64> {
        self.judge(image, circle).map(|(p, _)| p)
    }

    fn judge(&self, image: &RgbImage, circle: &Circle) -> Option<(f64, Circle)> {
        let v = self.net.judge(image, circle)?;
        Some((v.probability(), v.refine(circle)))
    }

    fn judge_all(&self, image: &RgbImage, circles: &[Circle]) -> Vec<Option<(f64, Circle)>> {
        self.net
            .judge_all(image, circles)
            .into_iter()
            .zip(circles)
            .map(|(v, c)| v.map(|v| (v.probability(), v.refine(c))))
            .collect()
    }
}
