//! One camera frame to ball candidates: the image half of the detector.
//!
//! Stages, each timed through the caller's [`StageClock`] (the pipeline never reads a
//! clock itself):
//!
//! 1. `mask`: the HSV colour mask of the whole frame through the lookup table.
//! 2. `cleanup`: an opening removes speckle.
//! 3. `blobs`: connected components, largest first (with a patterned ball's fragments
//!    joined); each one's box, grown by a margin, is a region of interest.
//! 4. `hough`: each region is resampled as a local perspective view of the calibrated
//!    camera (so that a ball is round even at the edge of the fisheye), a closing smooths
//!    its mask, then the circular Hough transform finds circles. A blob sparse in its box
//!    may be a patterned ball: its two-colour mask, where the patches join the ball's
//!    colour and enclosed holes are filled ([`crate::colour::two_colour`]), is searched as well.
//! 5. `classify`: each circle goes through the caller's [`CandidateClassifier`] (the HOG +
//!    SVM filter and the dominant-colour check in the agent) on the same local view, which
//!    gives the probability that it is the ball.
//!
//! Stages 1 to 4 are the colour path's own folder (`colour/`, its proposals in `colour/propose.rs`); stage 5 is
//! [`crate::check`]. This module is the detector's front: its state (the
//! lighting-adapted colour window, the candidate network), the proposals of every kind in
//! order, then the check, each once per frame.
//!
//! With `proposer = "net"` the colour stages give way to stage `candidates`: the candidate
//! network's heatmap peaks ([`crate::candidates`]), then the strongest appearance
//! proposals that do not repeat them (stage `appearance`), and in the agent the tracked
//! ball's predicted place ([`Detector::detect_with_hint`]); a batching classifier (the grey
//! checker) judges each view's proposals at once.
//!
//! World validation and the choice of at most one ball per frame happen after projection
//! (see the agent's pipeline).

use crate::camera::CameraModel;
use crate::candidates::HeatNet;
#[cfg(any(test, feature = "test-support"))]
pub use crate::check::HoughOnly;
pub use crate::check::{Candidate, CandidateClassifier, judge};
use crate::circle::Circle;
use crate::colour::hough::HoughError;
use crate::colour::hsv::{HsvError, HsvThresholds, MaskLut, disc_hsv};
use crate::colour::kmeans::ColourError;
use crate::colour::seeded_mask::SeededLut;
use crate::colour::two_colour::PatternError;
pub use crate::detect::config::{ClassifierKind, DetectorConfig, Proposer};
use crate::image::{ImageError, RgbImage};
pub use crate::proposal::{Proposal, Proposals};
use proto::CandidateStage;
use thiserror::Error;

mod config;

/// Why the detector could not be built or run.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DetectError {
    #[error(transparent)]
    Hsv(#[from] HsvError),
    #[error(transparent)]
    Hough(#[from] HoughError),
    #[error(transparent)]
    Image(#[from] ImageError),
    #[error(transparent)]
    Pattern(#[from] PatternError),
    #[error(transparent)]
    Colour(#[from] ColourError),
    #[error(transparent)]
    Appearance(#[from] crate::appearance::AppearanceError),
    #[error("adapt_rate {0} is outside [0, 1]")]
    BadRate(f64),
    #[error("the candidate network: {0}")]
    CandidateNet(#[from] crate::nn::WeightsError),
    #[error("candidates: {0}")]
    Candidates(String),
}

/// Marks the end of each stage; the agent's shell measures the time between marks.
pub trait StageClock {
    fn mark(&mut self, stage: &'static str);
}

/// A clock that measures nothing, for tests and offline runs.
#[derive(Debug)]
pub struct NoClock;

impl StageClock for NoClock {
    fn mark(&mut self, _stage: &'static str) {}
}

/// Two circles of nearly the same place and size: the centres less than half the larger
/// radius apart, the radii within a factor of two.
fn same_place(a: &Circle, b: &Circle) -> bool {
    let d = (a.center_px[0] - b.center_px[0]).hypot(a.center_px[1] - b.center_px[1]);
    let (lo, hi) = (a.radius_px.min(b.radius_px), a.radius_px.max(b.radius_px));
    d < 0.5 * hi && hi < 2.0 * lo
}

/// The image half of the ball detector, with its lighting-adapted colour window.
#[derive(Debug, Clone)]
pub struct Detector {
    pub(crate) config: DetectorConfig,
    thresholds: HsvThresholds,
    /// The colour window's mask (the colour path's proposals read these three).
    pub(crate) lut: MaskLut,
    /// The window grown into the limits, when `config.seeded`.
    pub(crate) seeded: SeededLut,
    /// The patches' colour, when patterned balls are looked for.
    pub(crate) white_lut: Option<MaskLut>,
    /// The candidate network, when the proposer uses it.
    heat: Option<std::sync::Arc<HeatNet>>,
}

impl Detector {
    /// The detector of `config`, with the shipped candidate network when the proposer
    /// runs one.
    pub fn new(config: DetectorConfig) -> Result<Self, DetectError> {
        Self::build(config, None)
    }

    /// The detector of `config` with this candidate network (a trained model's) in place of
    /// the shipped one.
    pub fn with_net(config: DetectorConfig, net: HeatNet) -> Result<Self, DetectError> {
        Self::build(config, Some(net))
    }

    fn build(config: DetectorConfig, net: Option<HeatNet>) -> Result<Self, DetectError> {
        config.thresholds.check()?;
        config.limits.check()?;
        config.hough.check()?;
        config.pattern.check()?;
        config.colour_check.check()?;
        config.appearance.check()?;
        if !(0.0..=1.0).contains(&config.adapt_rate) {
            return Err(DetectError::BadRate(config.adapt_rate));
        }
        config.candidates.check().map_err(DetectError::Candidates)?;
        let heat = match net {
            Some(n) => Some(std::sync::Arc::new(n)),
            None if config.proposer.net() => Some(std::sync::Arc::new(HeatNet::from_safetensors(
                crate::candidates::SHIPPED_WEIGHTS,
            )?)),
            None => None,
        };
        Ok(Detector {
            heat,
            config,
            thresholds: config.thresholds,
            lut: MaskLut::new(&config.thresholds)?,
            seeded: SeededLut::new(&config.thresholds, &config.limits)?,
            white_lut: if config.pattern.enabled {
                Some(MaskLut::new(&config.pattern.white)?)
            } else {
                None
            },
        })
    }

    pub fn config(&self) -> &DetectorConfig {
        &self.config
    }

    /// The candidate network in use, if any.
    pub fn candidate_net(&self) -> Option<&HeatNet> {
        self.heat.as_deref().filter(|_| self.config.proposer.net())
    }

    /// The colour window in use, after lighting adaptation.
    pub fn thresholds(&self) -> &HsvThresholds {
        &self.thresholds
    }

    /// The circles of a frame before classification.
    ///
    /// With the camera's calibrated `model`, each blob is searched in its own local
    /// perspective view ([`crate::colour::rectify::LocalView`]), where a ball is round even at the edge of a
    /// fisheye image; proposals then carry that view and their angular radius. Without a
    /// model the frame is searched as it is.
    ///
    /// With the appearance proposer ([`DetectorConfig::proposer`]), the centre-surround
    /// proposals of the whole frame follow (stage `appearance`), in frame pixels without a
    /// view, less those that repeat a colour proposal.
    pub fn propose(
        &self,
        image: &RgbImage,
        model: Option<&CameraModel>,
        clock: &mut dyn StageClock,
    ) -> Result<Proposals, DetectError> {
        let mut proposals = if self.config.proposer.colour() {
            self.propose_colour(image, model, clock)?
        } else {
            Proposals::default()
        };
        let frame_proposal = |circle: Circle, stage: CandidateStage| Proposal {
            frame: circle,
            local: circle,
            view: None,
            angular_radius_rad: None,
            sparse_blob: false,
            stage,
        };
        // The candidate network's shrunk frame, kept for the appearance proposals when it
        // is the frame halved (their first level).
        let mut half: Option<(Vec<f32>, usize, usize)> = None;
        if let Some(net) = self.candidate_net() {
            let g = crate::candidates::InputGeometry::for_frame_at(
                image.width(),
                image.height(),
                self.config.candidates.input_width_px,
            );
            let shrunk = crate::candidates::shrink(image, &g);
            for circle in net.candidates_from_shrunk(&shrunk, g, &self.config.candidates) {
                proposals
                    .items
                    .push(frame_proposal(circle, CandidateStage::Network));
            }
            if 2 * g.width_px == image.width() as usize
                && 2 * g.height_px == image.height() as usize
            {
                half = Some((shrunk, g.width_px, g.height_px));
            }
            clock.mark("candidates");
        }
        let net_only = self.config.proposer.net() && self.config.net_appearance_candidates == 0;
        if self.config.proposer.appearance() && !net_only {
            let mut found = match &half {
                Some((data, w, h)) => {
                    crate::appearance::propose_from_half(data, *w, *h, &self.config.appearance)
                }
                None => crate::appearance::propose(image, &self.config.appearance),
            };
            if self.config.proposer.net() {
                found.retain(|c| !proposals.items.iter().any(|p| same_place(&p.frame, c)));
                found.truncate(self.config.net_appearance_candidates);
            }
            let colour = proposals.items.len();
            for circle in found {
                let repeats = proposals.items[..colour]
                    .iter()
                    .any(|p| same_place(&p.frame, &circle));
                if !repeats {
                    proposals
                        .items
                        .push(frame_proposal(circle, CandidateStage::Appearance));
                }
            }
            clock.mark("appearance");
        }
        Ok(proposals)
    }

    /// The candidates in a frame, most probable first: [`Detector::propose`], then the
    /// classifier on each proposal's view.
    pub fn detect(
        &self,
        image: &RgbImage,
        model: Option<&CameraModel>,
        classifier: &dyn CandidateClassifier,
        clock: &mut dyn StageClock,
    ) -> Result<Vec<Candidate>, DetectError> {
        self.detect_with_hint(image, model, None, classifier, clock)
    }

    /// [`Detector::detect`] with one more candidate, `hint`, where the tracked ball is
    /// predicted to be (in frame pixels), unless a proposal is already there.
    pub fn detect_with_hint(
        &self,
        image: &RgbImage,
        model: Option<&CameraModel>,
        hint: Option<Circle>,
        classifier: &dyn CandidateClassifier,
        clock: &mut dyn StageClock,
    ) -> Result<Vec<Candidate>, DetectError> {
        let mut proposals = self.propose(image, model, clock)?;
        if let Some(h) = hint
            && !proposals.items.iter().any(|p| same_place(&p.frame, &h))
        {
            proposals.items.push(Proposal {
                frame: h,
                local: h,
                view: None,
                angular_radius_rad: None,
                sparse_blob: false,
                stage: CandidateStage::Predicted,
            });
        }
        let candidates = judge(&proposals, image, classifier)
            .into_iter()
            .filter(|j| !j.repeat)
            .filter_map(|j| j.candidate)
            .collect();
        clock.mark("classify");
        Ok(candidates)
    }

    /// Moves the colour window towards the colours inside an accepted ball's circle: the hue
    /// window slides, the lower saturation and value bounds may drop below the configured
    /// ones (never below the limits) and never rise above them.
    pub fn adapt(&mut self, image: &RgbImage, ball: &Circle) -> Result<(), DetectError> {
        let mut samples = disc_hsv(image, ball, 0.7);
        if self.config.pattern.enabled {
            // A patterned ball's patches say nothing about the light on the ball's colour.
            let limits = self.config.limits;
            samples.retain(|&(h, s, v)| limits.contains(h, s, v));
        }
        let mut next = crate::colour::hsv::adapt(
            &self.thresholds,
            &samples,
            self.config.adapt_rate,
            &self.config.limits,
        )?;
        // Light changes faster than the window follows it: tightening a bound to the last
        // ball's colours loses the ball at the next exposure step. So the window only ever
        // widens past the configured one (towards the limits) and its hue slides; the upper
        // bounds stay at the limits.
        let base = &self.config.thresholds;
        next.sat_min = next.sat_min.min(base.sat_min);
        next.val_min = next.val_min.min(base.val_min);
        next.sat_max = self.config.limits.sat_max;
        next.val_max = self.config.limits.val_max;
        if next != self.thresholds {
            self.lut = MaskLut::new(&next)?;
            self.seeded = SeededLut::new(&next, &self.config.limits)?;
            self.thresholds = next;
        }
        Ok(())
    }
}

#[cfg(test)]
#[path = "detect_tests.rs"]
mod tests;

#[cfg(test)]
#[path = "detect_photo_tests.rs"]
mod photo_tests;
