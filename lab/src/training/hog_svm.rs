//! Training the candidate filter (HOG + RBF-SVM) from labelled patches.
//!
//! 1. **Split.** The original patches of each class are shuffled with a seeded generator
//!    and a fraction is held out for the final metrics. The split comes before
//!    augmentation, so no rotated copy of a held-out ball is ever trained on.
//! 2. **Augmentation.** Training positives are mirrored and rotated by ±10° and ±20°
//!    (10 samples per ball), as balls are rare in recorded candidates and their appearance
//!    is invariant to these transforms.
//! 3. **Grid search.** Every (C, γ) pair of the grid is scored by k-fold cross-validation
//!    on the training part: folds are drawn per original patch (all augmented copies of a
//!    ball stay in one fold, or the score would measure memory of near-duplicates). Above
//!    `grid_max_samples` samples the search runs on a seeded subsample, which bounds its
//!    time. The pair with the fewest cross-validated errors wins, ties going to the higher
//!    ROC AUC and then to the smaller C (the smoother boundary).
//! 4. **Calibration and final fit.** Platt's sigmoid is fitted on the winner's
//!    cross-validated decision values, then the SVM is fitted on the whole training part.
//! 5. **Metrics** on the held-out originals: confusion counts, precision and recall at the
//!    probability threshold, and the ROC AUC of the probabilities.

use std::fmt;

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::svm_train::{Model, Platt, SvmError, SvmParams, cross_val_decisions, fit_uncalibrated};
use proto::rng::SplitMix64;
use vision::settings::HsvThresholds;
use vision::settings::PatternConfig;
use vision::stages::hog::hog;
use vision::stages::patch::Patch;
use vision::{DetectError, Detector, DetectorConfig};

/// Why training failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum TrainError {
    /// Each class needs at least two patches (one to train on, one to hold out) and as
    /// many as there are folds in the training part.
    #[error("too few patches: {positives} positive and {negatives} negative")]
    TooFew {
        /// Positive patches.
        positives: usize,
        /// Negative patches.
        negatives: usize,
    },
    /// A configuration field is out of range.
    #[error("training configuration: {0}")]
    Config(String),
    /// The SVM failed.
    #[error(transparent)]
    Svm(#[from] SvmError),
}

/// Training configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainConfig {
    /// Seed of the split, the folds and the grid subsample.
    pub seed: u64,
    /// Fraction of each class's original patches held out for the metrics, in (0, 1).
    pub held_out_fraction: f64,
    /// Cross-validation folds of the grid search, at least 2.
    pub folds: usize,
    /// Values of C tried.
    pub c_grid: Vec<f64>,
    /// Values of γ tried, per squared standardised feature unit (1/288 is the usual scale
    /// for the 288 HOG features).
    pub gamma_grid: Vec<f64>,
    /// Whether positives are augmented by mirroring.
    pub mirror: bool,
    /// Rotations, degrees, added for each (mirrored or not) positive.
    pub rotations_deg: Vec<f64>,
    /// Largest number of samples the grid search uses.
    pub grid_max_samples: usize,
    /// Probability above which a candidate is called a ball.
    pub threshold: f64,
    /// Solver settings other than C and γ (theirs are ignored).
    pub solver: SvmParams,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            seed: 0xBA11,
            held_out_fraction: 0.2,
            folds: 3,
            c_grid: vec![1.0, 10.0, 100.0],
            gamma_grid: vec![0.5 / 288.0, 1.0 / 288.0, 2.0 / 288.0],
            mirror: true,
            rotations_deg: vec![-20.0, -10.0, 10.0, 20.0],
            grid_max_samples: 2000,
            threshold: 0.5,
            solver: SvmParams::default(),
        }
    }
}

impl TrainConfig {
    fn check(&self) -> Result<(), TrainError> {
        let bad = |s: &str| Err(TrainError::Config(s.to_owned()));
        if !(self.held_out_fraction > 0.0 && self.held_out_fraction < 1.0) {
            return bad("held_out_fraction must be in (0, 1)");
        }
        if self.folds < 2 {
            return bad("folds must be at least 2");
        }
        if self.c_grid.is_empty() || self.gamma_grid.is_empty() {
            return bad("the C and gamma grids must not be empty");
        }
        if !(self.threshold > 0.0 && self.threshold < 1.0) {
            return bad("threshold must be in (0, 1)");
        }
        if self.grid_max_samples < 2 * self.folds {
            return bad("grid_max_samples must allow two samples per fold");
        }
        Ok(())
    }
}

/// Classification metrics at a probability threshold.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Probability above which a sample is called positive.
    pub threshold: f64,
    /// Balls called balls.
    pub true_positives: usize,
    /// Non-balls called balls.
    pub false_positives: usize,
    /// Non-balls rejected.
    pub true_negatives: usize,
    /// Balls rejected.
    pub false_negatives: usize,
    /// TP / (TP + FP); 1 when nothing is called positive.
    pub precision: f64,
    /// TP / (TP + FN); 1 when there are no positives.
    pub recall: f64,
    /// Area under the ROC curve of the scores (ties count one half).
    pub auc: f64,
}

impl Metrics {
    /// Metrics of scores (probabilities) against labels at `threshold`.
    pub fn from_scores(scores: &[f64], labels: &[bool], threshold: f64) -> Self {
        let (mut tp, mut fp, mut tn, mut fn_) = (0, 0, 0, 0);
        for (&s, &l) in scores.iter().zip(labels) {
            match (s >= threshold, l) {
                (true, true) => tp += 1,
                (true, false) => fp += 1,
                (false, false) => tn += 1,
                (false, true) => fn_ += 1,
            }
        }
        let ratio = |a: usize, b: usize| if b == 0 { 1.0 } else { a as f64 / b as f64 };
        Self {
            threshold,
            true_positives: tp,
            false_positives: fp,
            true_negatives: tn,
            false_negatives: fn_,
            precision: ratio(tp, tp + fp),
            recall: ratio(tp, tp + fn_),
            auc: roc_auc(scores, labels),
        }
    }
}

/// ROC AUC by the Mann–Whitney statistic: the probability that a random positive scores
/// above a random negative, ties counting one half; 0.5 without both classes.
pub fn roc_auc(scores: &[f64], labels: &[bool]) -> f64 {
    let mut order: Vec<usize> = (0..scores.len().min(labels.len())).collect();
    order.sort_by(|&a, &b| scores[a].total_cmp(&scores[b]));
    let (mut rank_sum, mut n_pos) = (0.0, 0usize);
    let mut i = 0;
    while i < order.len() {
        let mut j = i;
        while j + 1 < order.len() && scores[order[j + 1]] == scores[order[i]] {
            j += 1;
        }
        // Tied scores share the average of their 1-based ranks.
        let rank = (i + j) as f64 / 2.0 + 1.0;
        for &t in &order[i..=j] {
            if labels[t] {
                rank_sum += rank;
                n_pos += 1;
            }
        }
        i = j + 1;
    }
    let n_neg = order.len() - n_pos;
    if n_pos == 0 || n_neg == 0 {
        return 0.5;
    }
    (rank_sum - (n_pos * (n_pos + 1)) as f64 / 2.0) / (n_pos * n_neg) as f64
}

/// One point of the grid search.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GridPoint {
    /// C.
    pub c: f64,
    /// γ.
    pub gamma: f64,
    /// Cross-validated misclassifications (decision value sign against label).
    pub cv_errors: usize,
    /// Cross-validated ROC AUC of the decision values.
    pub cv_auc: f64,
}

/// What training did and how well the model does on the held-out patches.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainReport {
    /// Original positive patches given.
    pub positives: usize,
    /// Original negative patches given.
    pub negatives: usize,
    /// Training samples after augmentation.
    pub train_samples: usize,
    /// Samples the grid search used.
    pub grid_samples: usize,
    /// Held-out original patches.
    pub held_out_samples: usize,
    /// Every grid point, in the order tried.
    pub grid: Vec<GridPoint>,
    /// Chosen C.
    pub c: f64,
    /// Chosen γ.
    pub gamma: f64,
    /// Fitted calibration.
    pub platt: Platt,
    /// Support vectors of the final model.
    pub support_vectors: usize,
    /// Metrics on the held-out patches.
    pub held_out: Metrics,
}

impl fmt::Display for TrainReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "patches: {} positive, {} negative; {} training samples after augmentation \
             ({} in the grid search), {} held out",
            self.positives,
            self.negatives,
            self.train_samples,
            self.grid_samples,
            self.held_out_samples
        )?;
        writeln!(
            f,
            "{:>10} {:>10} {:>9} {:>7}",
            "C", "gamma", "cv errors", "cv AUC"
        )?;
        for p in &self.grid {
            let mark = if p.c == self.c && p.gamma == self.gamma {
                " *"
            } else {
                ""
            };
            writeln!(
                f,
                "{:>10.3} {:>10.5} {:>9} {:>7.4}{mark}",
                p.c, p.gamma, p.cv_errors, p.cv_auc
            )?;
        }
        let m = &self.held_out;
        writeln!(
            f,
            "model: {} support vectors, Platt A = {:.3}, B = {:.3}",
            self.support_vectors, self.platt.a, self.platt.b
        )?;
        writeln!(
            f,
            "held out at p >= {}: TP {} FP {} TN {} FN {}",
            m.threshold, m.true_positives, m.false_positives, m.true_negatives, m.false_negatives
        )?;
        write!(
            f,
            "precision {:.4}  recall {:.4}  ROC AUC {:.4}",
            m.precision, m.recall, m.auc
        )
    }
}

/// The augmented copies of a positive patch: itself, optionally its mirror, and each of
/// those rotated by every angle.
pub fn augment(patch: &Patch, mirror: bool, rotations_deg: &[f64]) -> Vec<Patch> {
    let mut bases = vec![patch.clone()];
    if mirror {
        bases.push(patch.mirrored());
    }
    let mut out = bases.clone();
    for base in &bases {
        for &angle in rotations_deg {
            out.push(base.rotated(angle.to_radians()));
        }
    }
    out
}

/// Splits `0..n` into (train, held out) with at least one of each.
fn split(n: usize, fraction: f64, rng: &mut SplitMix64) -> (Vec<usize>, Vec<usize>) {
    let mut idx: Vec<usize> = (0..n).collect();
    rng.shuffle(&mut idx);
    let held = ((n as f64 * fraction).round() as usize).clamp(1, n - 1);
    let train = idx.split_off(held);
    (train, idx)
}

/// Training samples: HOG features, labels and the original patch each came from.
struct Samples {
    features: Vec<Vec<f32>>,
    labels: Vec<bool>,
    groups: Vec<usize>,
}

fn training_samples(
    positives: &[Patch],
    negatives: &[Patch],
    pos_idx: &[usize],
    neg_idx: &[usize],
    cfg: &TrainConfig,
) -> Samples {
    let mut s = Samples {
        features: Vec::new(),
        labels: Vec::new(),
        groups: Vec::new(),
    };
    for (group, &i) in pos_idx.iter().enumerate() {
        for p in augment(&positives[i], cfg.mirror, &cfg.rotations_deg) {
            s.features.push(hog(&p).to_vec());
            s.labels.push(true);
            s.groups.push(group);
        }
    }
    for (k, &i) in neg_idx.iter().enumerate() {
        s.features.push(hog(&negatives[i]).to_vec());
        s.labels.push(false);
        s.groups.push(pos_idx.len() + k);
    }
    s
}

/// Trains the candidate filter; see the module documentation for the steps. `progress`
/// receives one line per step.
pub fn train(
    positives: &[Patch],
    negatives: &[Patch],
    cfg: &TrainConfig,
    progress: &mut dyn FnMut(&str),
) -> Result<(Model, TrainReport), TrainError> {
    cfg.check()?;
    let too_few = |n: usize| n < 2 || ((n as f64) * (1.0 - cfg.held_out_fraction)) < 1.0;
    if too_few(positives.len()) || too_few(negatives.len()) {
        return Err(TrainError::TooFew {
            positives: positives.len(),
            negatives: negatives.len(),
        });
    }
    let mut rng = SplitMix64::new(cfg.seed);
    let (pos_train, pos_held) = split(positives.len(), cfg.held_out_fraction, &mut rng);
    let (neg_train, neg_held) = split(negatives.len(), cfg.held_out_fraction, &mut rng);
    let samples = training_samples(positives, negatives, &pos_train, &neg_train, cfg);
    progress(&format!(
        "{} training samples ({} positive originals augmented), {} held out",
        samples.labels.len(),
        pos_train.len(),
        pos_held.len() + neg_held.len()
    ));

    // Folds per original patch; the grid subsample keeps whole samples, not whole groups.
    let groups = pos_train.len() + neg_train.len();
    let mut group_fold: Vec<usize> = (0..groups).map(|g| g % cfg.folds).collect();
    rng.shuffle(&mut group_fold);
    let mut grid_idx: Vec<usize> = (0..samples.labels.len()).collect();
    rng.shuffle(&mut grid_idx);
    grid_idx.truncate(cfg.grid_max_samples);
    grid_idx.sort_unstable();
    let gf: Vec<&[f32]> = grid_idx.iter().map(|&t| &samples.features[t][..]).collect();
    let gl: Vec<bool> = grid_idx.iter().map(|&t| samples.labels[t]).collect();
    let gfold: Vec<usize> = grid_idx
        .iter()
        .map(|&t| group_fold[samples.groups[t]])
        .collect();

    let mut grid = Vec::new();
    let mut best: Option<(GridPoint, Vec<f64>)> = None;
    for &c in &cfg.c_grid {
        for &gamma in &cfg.gamma_grid {
            let params = SvmParams {
                c,
                gamma,
                ..cfg.solver
            };
            let decisions = cross_val_decisions(&gf, &gl, &gfold, cfg.folds, &params)?;
            let cv_errors = decisions
                .iter()
                .zip(&gl)
                .filter(|&(&d, &l)| (d > 0.0) != l)
                .count();
            let point = GridPoint {
                c,
                gamma,
                cv_errors,
                cv_auc: roc_auc(&decisions, &gl),
            };
            progress(&format!(
                "C {c} gamma {gamma:.5}: {cv_errors} cross-validated errors, AUC {:.4}",
                point.cv_auc
            ));
            grid.push(point);
            let better = best.as_ref().is_none_or(|(b, _)| {
                (point.cv_errors, -point.cv_auc, point.c) < (b.cv_errors, -b.cv_auc, b.c)
            });
            if better {
                best = Some((point, decisions));
            }
        }
    }
    let (chosen, decisions) = best.ok_or_else(|| TrainError::Config("empty grid".into()))?;
    let platt = Platt::fit(&decisions, &gl)?;
    let params = SvmParams {
        c: chosen.c,
        gamma: chosen.gamma,
        ..cfg.solver
    };
    let model = fit_uncalibrated(&samples.features, &samples.labels, &params)?.with_platt(platt);
    progress(&format!(
        "final fit: C {} gamma {:.5}, {} support vectors",
        chosen.c,
        chosen.gamma,
        model.support_vector_count()
    ));

    let mut scores = Vec::new();
    let mut labels = Vec::new();
    for (set, idx, label) in [(positives, &pos_held, true), (negatives, &neg_held, false)] {
        for &i in idx {
            scores.push(model.probability(&hog(&set[i]))?);
            labels.push(label);
        }
    }
    let report = TrainReport {
        positives: positives.len(),
        negatives: negatives.len(),
        train_samples: samples.labels.len(),
        grid_samples: gl.len(),
        held_out_samples: labels.len(),
        grid,
        c: chosen.c,
        gamma: chosen.gamma,
        platt,
        support_vectors: model.support_vector_count(),
        held_out: Metrics::from_scores(&scores, &labels, cfg.threshold),
    };
    Ok((model, report))
}

/// The detectors that mine training candidates, one per colour window: the ball's widest
/// window with the two-colour mask of a patterned ball, which proposes the ball, plain or
/// patterned, and orange-ish look-alikes; and white and grey, which proposes robot heads
/// and bodies, walls and the patterned ball's white patches, the round look-alikes the
/// shape filter must learn to refuse.
pub fn miners() -> Result<Vec<Detector>, DetectError> {
    let ball = DetectorConfig::default();
    let ball_wide = DetectorConfig {
        thresholds: ball.limits,
        ..ball
    };
    let white = HsvThresholds {
        hue_lo_deg: 0.0,
        hue_hi_deg: 360.0,
        sat_min: 0.0,
        sat_max: 0.25,
        val_min: 0.55,
        val_max: 1.0,
    };
    let white_cfg = DetectorConfig {
        thresholds: white,
        limits: white,
        pattern: PatternConfig {
            enabled: false,
            ..ball.pattern
        },
        ..ball
    };
    Ok(vec![Detector::new(ball_wide)?, Detector::new(white_cfg)?])
}

#[cfg(test)]
#[path = "hog_svm_tests.rs"]
mod tests;
