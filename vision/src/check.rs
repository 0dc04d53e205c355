//! Stage `classify`: every proposal of a frame judged by the candidate classifier (the
//! HOG + SVM filter, the ball network or the grey checker), the proposals of one view in
//! one batch, the most probable first, a candidate on a more probable one's ball marked a
//! repeat. The choice of the frame's ball comes after projection
//! (the agent's pipeline), or for a photo on its own in [`crate::photo`].
//!
//! - `patch`: the 32×32 candidate patch around a circle, with mirroring and rotation.
//! - `hog`: the histogram-of-oriented-gradients descriptor of a patch (288 features).
//! - `svm`: the RBF-kernel SVM candidate filter: its model file and Platt-calibrated
//!   probability (its training is the `lab` crate's).
//! - `classifier`: the colour check and the HOG + SVM filter as one candidate classifier,
//!   and the ball network's.
//! - `ballnet`: the ball network, a small CNN on a candidate's colour patch giving the
//!   ball's probability and its refined centre and radius.
//! - `checker`: the grey checker, a network on a candidate's brightness-normalised grey
//!   patch, a batch at a time.

pub(crate) mod ballnet;
pub(crate) mod checker;
pub(crate) mod classifier;
pub(crate) mod hog;
pub(crate) mod patch;
pub(crate) mod svm;

use crate::circle::Circle;
use crate::image::RgbImage;
use crate::proposal::Proposals;
use proto::CandidateStage;

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
#[cfg(any(test, feature = "test-support"))]
#[derive(Debug)]
pub struct HoughOnly;

#[cfg(any(test, feature = "test-support"))]
impl CandidateClassifier for HoughOnly {
    fn probability(&self, _image: &RgbImage, circle: &Circle) -> Option<f64> {
        Some(circle.score.clamp(0.0, 1.0))
    }
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
    /// See [`crate::proposal::Proposal::sparse_blob`].
    pub sparse_blob: bool,
    /// The stage that proposed it.
    pub stage: CandidateStage,
}
