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
//!    colour and enclosed holes are filled ([`crate::detection::two_colour`]), is searched as well.
//! 5. `classify`: each circle goes through the caller's [`CandidateClassifier`] (the HOG +
//!    SVM filter and the dominant-colour check in the agent) on the same local view, which
//!    gives the probability that it is the ball.
//!
//! With `proposer = "net"` the colour stages give way to stage `candidates`: the candidate
//! network's heatmap peaks ([`crate::detection::heatnet`]), then the strongest appearance
//! proposals that do not repeat them (stage `appearance`), and in the agent the tracked
//! ball's predicted place ([`Detector::detect_with_hint`]); a batching classifier (the grey
//! checker) judges each view's proposals at once.
//!
//! World validation and the choice of at most one ball per frame happen after projection
//! (see [`crate::pipeline`]).

use crate::calibration::camera::CameraModel;
use crate::detection::blob_circle::{
    blob_circle, blob_size_px, is_roundish, ring_share, shrink, unshrink,
};
use crate::detection::components::{BoundingBox, Component, joined_components};
pub use crate::detection::detect_config::{ClassifierKind, DetectorConfig, Proposer};
use crate::detection::heatnet::HeatNet;
use crate::detection::hough::{Circle, HoughConfig, HoughError};
use crate::detection::hsv::{HsvError, HsvThresholds, MaskLut, disc_hsv};
use crate::detection::kmeans::ColourError;
use crate::detection::morphology::{close, open};
use crate::detection::rectify::{LocalView, MAX_HALF_SIDE_PX};
use crate::detection::seeded_mask::SeededLut;
use crate::detection::two_colour::{Hull, PatternError, region_mask};
use crate::image::{ImageError, Mask, RgbImage};
use proto::CandidateStage;
use thiserror::Error;

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
    Appearance(#[from] crate::detection::contrast::AppearanceError),
    #[error("adapt_rate {0} is outside [0, 1]")]
    BadRate(f64),
    #[error("the candidate network: {0}")]
    CandidateNet(#[from] crate::detection::nn::WeightsError),
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

/// Judges a circle: the probability that it is the ball, or `None` to reject it outright.
pub trait CandidateClassifier {
    fn probability(&self, image: &RgbImage, circle: &Circle) -> Option<f64>;

    /// The probability and the ball's circle as the classifier sees it (a classifier
    /// that regresses the ball's centre and radius refines the proposal's).
    fn judge(&self, image: &RgbImage, circle: &Circle) -> Option<(f64, Circle)> {
        self.probability(image, circle).map(|p| (p, *circle))
    }

    /// [`CandidateClassifier::judge`] of every circle of one image, in order (a classifier
    /// that runs a batch at once overrides it).
    fn judge_all(&self, image: &RgbImage, circles: &[Circle]) -> Vec<Option<(f64, Circle)>> {
        circles.iter().map(|c| self.judge(image, c)).collect()
    }
}

/// Accepts every circle with its Hough score as the probability (no learned filter).
#[cfg(test)]
#[derive(Debug)]
pub struct HoughOnly;

#[cfg(test)]
impl CandidateClassifier for HoughOnly {
    fn probability(&self, _image: &RgbImage, circle: &Circle) -> Option<f64> {
        Some(circle.score.clamp(0.0, 1.0))
    }
}

/// Two circles of nearly the same place and size: the centres less than half the larger
/// radius apart, the radii within a factor of two.
fn same_place(a: &Circle, b: &Circle) -> bool {
    let d = (a.center_px[0] - b.center_px[0]).hypot(a.center_px[1] - b.center_px[1]);
    let (lo, hi) = (a.radius_px.min(b.radius_px), a.radius_px.max(b.radius_px));
    d < 0.5 * hi && hi < 2.0 * lo
}

/// One proposal after the classifier.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Judged {
    /// Its index in [`Proposals::items`].
    pub index: usize,
    /// Its candidate, or `None` when the classifier refused it.
    pub candidate: Option<Candidate>,
    /// A more probable candidate already covers its ball.
    pub repeat: bool,
}

/// Every proposal through the classifier, the scored ones most probable first, then the
/// refused ones. A proposal without a local view takes the classifier's refined circle; a
/// candidate whose centre lies within a more probable candidate's circle is a repeat.
pub fn judge(
    proposals: &Proposals,
    image: &RgbImage,
    classifier: &dyn CandidateClassifier,
) -> Vec<Judged> {
    // Proposals are judged a view at a time, so a batching classifier sees the frame's
    // proposals without a view in one batch.
    let mut verdicts: Vec<Option<(f64, Circle)>> = vec![None; proposals.items.len()];
    let mut groups: std::collections::BTreeMap<Option<usize>, Vec<usize>> = Default::default();
    for (i, p) in proposals.items.iter().enumerate() {
        groups.entry(p.view).or_default().push(i);
    }
    for (view, members) in groups {
        let circles: Vec<Circle> = members.iter().map(|&i| proposals.items[i].local).collect();
        let img = view.and_then(|v| proposals.views.get(v)).unwrap_or(image);
        for (&i, v) in members.iter().zip(classifier.judge_all(img, &circles)) {
            verdicts[i] = v;
        }
    }
    let mut judged: Vec<Judged> = proposals
        .items
        .iter()
        .zip(verdicts)
        .enumerate()
        .map(|(index, (p, verdict))| Judged {
            index,
            candidate: verdict.map(|(probability, refined)| Candidate {
                circle: if p.view.is_none() { refined } else { p.frame },
                probability,
                angular_radius_rad: p.angular_radius_rad,
                sparse_blob: p.sparse_blob,
                stage: p.stage,
            }),
            repeat: false,
        })
        .collect();
    let key = |j: &Judged| j.candidate.map_or(f64::NEG_INFINITY, |c| c.probability);
    judged.sort_by(|a, b| key(b).total_cmp(&key(a)));
    let mut kept: Vec<Circle> = Vec::new();
    for j in &mut judged {
        if let Some(c) = j.candidate {
            j.repeat = kept.iter().any(|k| {
                let d = (k.center_px[0] - c.circle.center_px[0])
                    .hypot(k.center_px[1] - c.circle.center_px[1]);
                d < k.radius_px.max(c.circle.radius_px)
            });
            if !j.repeat {
                kept.push(c.circle);
            }
        }
    }
    judged
}

/// A circle that passed the classifier.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// The circle's centre in the frame; its radius in the frame's (or the local view's)
    /// pixels.
    pub circle: Circle,
    /// The classifier's probability that this is the ball.
    pub probability: f64,
    /// Half the angle the ball subtends at the camera, when a camera model was given.
    pub angular_radius_rad: Option<f64>,
    /// See [`Proposal::sparse_blob`].
    pub sparse_blob: bool,
    /// The stage that proposed it.
    pub stage: CandidateStage,
}

/// A circle the colour and shape stages propose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Proposal {
    /// Centre in the frame; radius in the view's pixels (the frame's scale there).
    pub frame: Circle,
    /// The circle in its local view (or the frame, without a view).
    pub local: Circle,
    /// Index of its local view in [`Proposals::views`].
    pub view: Option<usize>,
    /// Half the angle the ball subtends at the camera, when a camera model was given.
    pub angular_radius_rad: Option<f64>,
    /// The circle came from a sparse blob (a patterned ball's fragments, or a ball partly
    /// hidden): its outline, and so its radius, is less certain than a solid disc's.
    pub sparse_blob: bool,
    /// The stage that proposed it (the colour path, the candidate network, the appearance
    /// proposer or the tracked ball's predicted place).
    pub stage: CandidateStage,
}

/// A frame's proposals and the local views they were found in.
#[derive(Debug, Clone, Default)]
pub struct Proposals {
    pub views: Vec<RgbImage>,
    pub items: Vec<Proposal>,
}

impl Proposals {
    /// The image a proposal's `local` circle refers to.
    pub fn image<'a>(&'a self, p: &Proposal, frame: &'a RgbImage) -> &'a RgbImage {
        p.view.and_then(|i| self.views.get(i)).unwrap_or(frame)
    }
}

/// The image half of the ball detector, with its lighting-adapted colour window.
#[derive(Debug, Clone)]
pub struct Detector {
    config: DetectorConfig,
    thresholds: HsvThresholds,
    lut: MaskLut,
    /// The window grown into the limits, when `config.seeded`.
    seeded: SeededLut,
    /// The patches' colour, when patterned balls are looked for.
    white_lut: Option<MaskLut>,
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
            None if config.proposer.net() => {
                Some(std::sync::Arc::new(crate::builtin::candidate_net()?))
            }
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

    /// The circles of a region's ball-colour mask, closed; for a possibly patterned ball
    /// (`patterned`: the region's patch-colour mask and the blob's hull in the region's
    /// pixels) also those of its two-colour mask.
    fn circles(
        &self,
        roi: Mask,
        patterned: Option<(Mask, Hull)>,
    ) -> Result<Vec<Circle>, DetectError> {
        let hough = |m: &Mask| {
            crate::detection::hough::detect(
                m.data(),
                m.width() as usize,
                m.height() as usize,
                &self.config.hough,
            )
        };
        let closed = close(&roi, self.config.close_radius_px);
        let mut circles = hough(&closed)?;
        if let Some((white, hull)) = patterned {
            let region = region_mask(
                &roi,
                &white,
                &hull,
                self.config.close_radius_px,
                &self.config.pattern,
            );
            if region != closed {
                // A circle the ball colour alone gave is kept as it was.
                let cfg = &self.config.hough;
                let new: Vec<Circle> = hough(&region)?
                    .into_iter()
                    .filter(|p| !circles.iter().any(|c| same_circle(c, p, cfg)))
                    .collect();
                circles.extend(new);
            }
        }
        Ok(circles)
    }

    /// The circles of a frame before classification.
    ///
    /// With the camera's calibrated `model`, each blob is searched in its own local
    /// perspective view ([`LocalView`]), where a ball is round even at the edge of a
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
        if let Some(net) = self.candidate_net() {
            for circle in net.candidates(image, &self.config.candidates) {
                proposals
                    .items
                    .push(frame_proposal(circle, CandidateStage::Network));
            }
            clock.mark("candidates");
        }
        let net_only = self.config.proposer.net() && self.config.net_appearance_candidates == 0;
        if self.config.proposer.appearance() && !net_only {
            let mut found = crate::detection::contrast::propose(image, &self.config.appearance);
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

    /// The colour path's proposals, stage by stage: the ball-colour mask and its cleanup,
    /// the blobs in it, the circles of each blob (in its local view with a camera model, in
    /// the frame without), and the proposals from them, less fragments of bigger things.
    fn propose_colour(
        &self,
        image: &RgbImage,
        model: Option<&CameraModel>,
        clock: &mut dyn StageClock,
    ) -> Result<Proposals, DetectError> {
        let (mask, seeds) = self.colour_mask(image, clock);
        let blobs = self.colour_blobs(&mask, seeds.as_ref())?;
        clock.mark("blobs");
        let mut found = Vec::with_capacity(blobs.len());
        for blob in &blobs {
            found.extend(self.blob_circles(image, &mask, blob, model)?);
        }
        let mut proposals = assemble(found, image, model)?;
        // A circle with the ball's colours all round it is a fragment of something bigger.
        let fragment = |p: &Proposal| ring_share(image, &p.frame) > FRAGMENT_RING_SHARE;
        proposals.items.retain(|p| !fragment(p));
        clock.mark("hough");
        Ok(proposals)
    }

    /// Stages `mask` and `cleanup`: the pixels of the ball's colours, opened; with seeded
    /// growth, also the seeds it grew from.
    fn colour_mask(&self, image: &RgbImage, clock: &mut dyn StageClock) -> (Mask, Option<Mask>) {
        let cfg = &self.config;
        let (mask, seeds) = if cfg.seeded {
            let (grown, seeds) = self.seeded.apply_with_seeds(image, cfg.seeded_reach_px);
            (grown, Some(seeds))
        } else {
            (self.lut.apply(image), None)
        };
        clock.mark("mask");
        let mask = if cfg.open_radius_px > 0 {
            open(&mask, cfg.open_radius_px)
        } else {
            mask
        };
        clock.mark("cleanup");
        (mask, seeds)
    }

    /// The blobs of the mask, joined across a pattern's gaps; a big blob the growth made of
    /// a ball and its surroundings is searched again around its own seeds.
    fn colour_blobs(
        &self,
        mask: &Mask,
        seeds: Option<&Mask>,
    ) -> Result<Vec<Component>, DetectError> {
        let cfg = &self.config;
        let reach_px = if cfg.pattern.enabled {
            cfg.pattern.join_reach_px
        } else {
            1
        };
        let mut blobs = joined_components(mask, reach_px, cfg.min_blob_area_px, cfg.max_blobs);
        if let Some(seeds) = seeds {
            // A ball that the growth joined to a bigger region of ball-like colours (a warm
            // wall, a hand, a marking it touches) is searched again around its own seeds.
            let mut merged = Vec::new();
            for g in blobs.iter().filter(|g| {
                blob_size_px(g) > cfg.small_blob_max_px
                    && !is_roundish(g, FALLBACK_MAX_ASPECT, FALLBACK_MIN_FILL)
            }) {
                let b = &g.bbox;
                let window = crop(
                    seeds,
                    b.x_min,
                    b.y_min,
                    b.x_max - b.x_min + 1,
                    b.y_max - b.y_min + 1,
                )?;
                let (dx, dy) = (b.x_min, b.y_min);
                merged.extend(
                    joined_components(&window, reach_px, cfg.min_blob_area_px, cfg.max_blobs)
                        .into_iter()
                        .filter(|s| {
                            f64::from(blob_size_px(g))
                                > MERGED_SIZE_RATIO * f64::from(blob_size_px(s))
                        })
                        .map(|s| Component {
                            bbox: BoundingBox {
                                x_min: s.bbox.x_min + dx,
                                y_min: s.bbox.y_min + dy,
                                x_max: s.bbox.x_max + dx,
                                y_max: s.bbox.y_max + dy,
                            },
                            centroid_px: [
                                s.centroid_px[0] + f64::from(dx),
                                s.centroid_px[1] + f64::from(dy),
                            ],
                            ..s
                        }),
                );
            }
            merged.truncate(cfg.max_blobs);
            blobs.extend(merged);
        }
        Ok(blobs)
    }

    /// The circles of one blob: in its local view with a camera `model` (`None` when no
    /// view fits), else in the frame; with whether the blob is a patterned ball's.
    fn blob_circles(
        &self,
        image: &RgbImage,
        mask: &Mask,
        blob: &Component,
        model: Option<&CameraModel>,
    ) -> Result<Option<BlobCircles>, DetectError> {
        let cfg = &self.config;
        let m = cfg.roi_margin_px + cfg.close_radius_px;
        let hull = cfg.pattern.patterned_hull(blob);
        let growth = if hull.is_some() {
            cfg.pattern.view_growth
        } else {
            0.0
        };
        let size = blob_size_px(blob);
        let small = size <= cfg.small_blob_max_px;
        // A blob Hough may miss, as its own circle (in frame pixels), proposed when the
        // Hough transform finds nothing in it.
        let own = (small
            || (cfg.blob_fallback && is_roundish(blob, FALLBACK_MAX_ASPECT, FALLBACK_MIN_FILL)))
        .then(|| blob_circle(blob));
        let blob_view = BlobView {
            blob,
            hull,
            growth,
            margin_px: m,
            size_px: size,
            own,
        };
        match model {
            Some(model) => self.circles_in_view(image, mask, model, &blob_view),
            None => self.circles_in_frame(image, mask, &blob_view).map(Some),
        }
    }

    /// A blob's circles searched in its local perspective view, mapped to the view's centre.
    fn circles_in_view(
        &self,
        image: &RgbImage,
        mask: &Mask,
        model: &CameraModel,
        b: &BlobView<'_>,
    ) -> Result<Option<BlobCircles>, DetectError> {
        let (blob, hull, growth, m, size, own) =
            (b.blob, b.hull, b.growth, b.margin_px, b.size_px, b.own);
        let half = 0.5 * f64::from(size) * (1.0 + growth) + f64::from(m);
        // Big blobs are seen at a coarser scale, so the ball's radius stays
        // within the Hough transform's range.
        let max_half = (self.config.hough.r_max_px as u32 + m).min(MAX_HALF_SIDE_PX);
        let Some(view) = LocalView::fitting(model, blob.centroid_px, half, max_half) else {
            return Ok(None);
        };
        // The view looks at the blob's centroid through its centre pixel.
        let centre = f64::from(view.side() / 2);
        let in_view = |c: Circle| Circle {
            center_px: [centre, centre],
            radius_px: c.radius_px / view.scale(),
            ..c
        };
        let patterned = match (hull, &self.white_lut) {
            (Some(hull), Some(lut)) => Some((
                view.sample_lut(image, lut)?,
                Hull {
                    centre_px: [centre, centre],
                    radius_px: hull.radius_px / view.scale(),
                },
            )),
            _ => None,
        };
        let mut circles = self.circles(view.sample_mask(mask)?, patterned)?;
        if circles.is_empty() {
            circles.extend(own.map(in_view));
        }
        Ok(Some((Some(view), circles, hull.is_some())))
    }

    /// A blob's circles searched in a window of the frame around it, shrunk so the ball's
    /// radius is within the Hough transform's range.
    fn circles_in_frame(
        &self,
        image: &RgbImage,
        mask: &Mask,
        b: &BlobView<'_>,
    ) -> Result<BlobCircles, DetectError> {
        let (blob, hull, growth, m, size, own) =
            (b.blob, b.hull, b.growth, b.margin_px, b.size_px, b.own);
        let b = &blob.bbox;
        let m = m + (0.5 * f64::from(size) * growth).ceil() as u32;
        let x0 = b.x_min.saturating_sub(m);
        let y0 = b.y_min.saturating_sub(m);
        let x1 = (b.x_max + m).min(mask.width() - 1);
        let y1 = (b.y_max + m).min(mask.height() - 1);
        let (w, h) = (x1 - x0 + 1, y1 - y0 + 1);
        // Shrunk so that the ball's radius is within the Hough range.
        let k = (f64::from(size) / (1.8 * self.config.hough.r_max_px))
            .ceil()
            .max(1.0) as u32;
        let roi = shrink(&crop(mask, x0, y0, w, h)?, k);
        let patterned = match (hull, &self.white_lut) {
            (Some(hull), Some(lut)) => Some((
                shrink(&crop_lut(image, lut, x0, y0, w, h)?, k),
                Hull {
                    centre_px: [
                        (hull.centre_px[0] - f64::from(x0)) / f64::from(k),
                        (hull.centre_px[1] - f64::from(y0)) / f64::from(k),
                    ],
                    radius_px: hull.radius_px / f64::from(k),
                },
            )),
            _ => None,
        };
        let shift = |c: Circle| {
            let c = unshrink(c, k);
            Circle {
                center_px: [
                    c.center_px[0] + f64::from(x0),
                    c.center_px[1] + f64::from(y0),
                ],
                ..c
            }
        };
        let mut circles: Vec<Circle> = self
            .circles(roi, patterned)?
            .into_iter()
            .map(shift)
            .collect();
        if circles.is_empty() {
            circles.extend(own);
        }
        Ok((None, circles, hull.is_some()))
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
        let mut next = crate::detection::hsv::adapt(
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

/// A fallback blob must be about as wide as tall...
const FALLBACK_MAX_ASPECT: f64 = 1.6;
/// ... and fill most of its disc.
const FALLBACK_MIN_FILL: f64 = 0.55;

/// A seed blob inside a grown blob this many times its size was merged with something.
const MERGED_SIZE_RATIO: f64 = 1.6;

/// A blob with more of the ball's colours than this share around it is a fragment of
/// something bigger, not proposed as its own circle.
const FRAGMENT_RING_SHARE: f64 = 0.4;

/// A window of a mask.
fn crop(mask: &Mask, x0: u32, y0: u32, w: u32, h: u32) -> Result<Mask, ImageError> {
    let stride = mask.width() as usize;
    let mut data = Vec::with_capacity(w as usize * h as usize);
    for y in y0..y0 + h {
        let start = y as usize * stride + x0 as usize;
        data.extend_from_slice(&mask.data()[start..start + w as usize]);
    }
    Mask::new(w, h, data)
}

/// Whether two circles are one: centres closer than the Hough transform's smallest
/// distance and radii within a fifth of each other.
fn same_circle(a: &Circle, b: &Circle, hough: &HoughConfig) -> bool {
    let d = (a.center_px[0] - b.center_px[0]).hypot(a.center_px[1] - b.center_px[1]);
    d < hough.min_center_distance_px
        && (a.radius_px - b.radius_px).abs() <= 0.2 * a.radius_px.max(b.radius_px)
}

/// A window of a frame's colour mask through `lut`.
fn crop_lut(
    image: &RgbImage,
    lut: &MaskLut,
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
) -> Result<Mask, ImageError> {
    let mut data = Vec::with_capacity(w as usize * h as usize);
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let [r, g, b] = image.pixel(x, y).unwrap_or([0; 3]);
            data.push(u8::from(lut.accepts(r, g, b)));
        }
    }
    Mask::new(w, h, data)
}

/// One blob's circles: the local view they are in (`None`: frame pixels) and whether the
/// blob is a patterned ball's.
type BlobCircles = (Option<LocalView>, Vec<Circle>, bool);

/// What the circle search needs of a blob.
struct BlobView<'a> {
    blob: &'a Component,
    hull: Option<Hull>,
    growth: f64,
    margin_px: u32,
    size_px: u32,
    own: Option<Circle>,
}

/// The colour stage's proposals from every blob's circles: in frame pixels, with the local view (kept
/// once per blob) and the angular radius when a camera model placed them.
fn assemble(
    found: Vec<BlobCircles>,
    image: &RgbImage,
    model: Option<&CameraModel>,
) -> Result<Proposals, DetectError> {
    let mut proposals = Proposals::default();
    for (view, circles, sparse_blob) in found {
        match (view, model) {
            (Some(view), Some(model)) => {
                if circles.is_empty() {
                    continue;
                }
                let index = proposals.views.len();
                proposals.views.push(view.sample_rgb(image)?);
                for c in circles {
                    let Some(center_px) = model.project(view.ray(c.center_px)) else {
                        continue;
                    };
                    proposals.items.push(Proposal {
                        frame: Circle {
                            center_px,
                            radius_px: c.radius_px * view.scale(),
                            ..c
                        },
                        local: c,
                        view: Some(index),
                        angular_radius_rad: Some(view.angular_radius_rad(c.center_px, c.radius_px)),
                        sparse_blob,
                        stage: CandidateStage::Colour,
                    });
                }
            }
            _ => proposals
                .items
                .extend(circles.into_iter().map(|c| Proposal {
                    frame: c,
                    local: c,
                    view: None,
                    angular_radius_rad: None,
                    sparse_blob,
                    stage: CandidateStage::Colour,
                })),
        }
    }
    Ok(proposals)
}

#[cfg(test)]
#[path = "detect_tests.rs"]
mod tests;

#[cfg(test)]
#[path = "detect_photo_tests.rs"]
mod photo_tests;
