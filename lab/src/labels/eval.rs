//! The detector scored against labelled ball boxes, image by image.
//!
//! **Hit rule.** A detected circle is on a ball when its centre lies inside the ball's
//! labelled box. The centre is what the agent projects onto the floor, so this is the
//! question that matters downstream; an IoU rule would also punish a right centre with a
//! wrong radius, and for balls a few pixels wide a one-pixel error in the box already costs
//! a large share of the IoU.
//!
//! Three things are scored in each image:
//!
//! - the **published** detection: the most probable candidate at or above the pipeline's
//!   `min_probability`, as the agent would publish it (without the world validation, which
//!   needs the robot's pose: a photo has none);
//! - the **best candidate** of any probability: whether the classifier ranks the ball first
//!   even when it does not believe it;
//! - **any candidate**: whether the colour and shape stages proposed the ball at all (and
//!   the colour check let it through).
//!
//! Recall is per image (an image with a ball counts as found when the published detection
//! is on one of its balls); recall by size band is per labelled ball, by the box's width.
//!
//! **Stages.** Given every candidate of a photo ([`LabelEval::add_stages`]), the stages are
//! also scored on their own:
//!
//! - **candidate recall**: the share of labelled balls some candidate is on, whatever the
//!   checker made of it (per labelled ball, overall and per width band), with the number of
//!   candidates per photo;
//! - the **checker** per candidate at `min_probability`: its recall is the share of the
//!   candidates on a ball it scores at or above the threshold, its precision the share of
//!   the candidates it scores at or above the threshold that are on a ball. A candidate
//!   the checker refused outright (no probability) counts as scored below.

use serde::{Deserialize, Serialize};

use crate::labels::BallBox;
use vision::Circle;

/// Size bands of a ball's box width, pixels: `[lower, upper)`.
pub const SIZE_BANDS_PX: [(f64, f64); 4] = [
    (0.0, 10.0),
    (10.0, 20.0),
    (20.0, 40.0),
    (40.0, f64::INFINITY),
];

/// The band name of `SIZE_BANDS_PX[i]`, e.g. `10–20 px`.
pub fn band_name(i: usize) -> String {
    match SIZE_BANDS_PX.get(i) {
        Some(&(0.0, hi)) => format!("< {hi} px"),
        Some(&(lo, hi)) if hi.is_infinite() => format!(">= {lo} px"),
        Some(&(lo, hi)) => format!("{lo}–{hi} px"),
        None => String::new(),
    }
}

fn band_of(width_px: f64) -> usize {
    SIZE_BANDS_PX
        .iter()
        .position(|&(lo, hi)| width_px >= lo && width_px < hi)
        .unwrap_or(SIZE_BANDS_PX.len() - 1)
}

/// Whether a detected circle is on a labelled ball (see the module's hit rule).
pub fn is_hit(circle: &Circle, ball: &BallBox) -> bool {
    ball.contains(circle.center_px)
}

/// One image's outcome, for the JSON report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImageRow {
    pub image: String,
    pub balls: Vec<BallBox>,
    /// Published detection: centre x, y and radius, pixels, and its probability.
    pub published: Option<[f64; 4]>,
    pub published_on_ball: bool,
    /// Most probable candidate of any probability: x, y, r, probability.
    pub best: Option<[f64; 4]>,
    pub best_on_ball: bool,
    /// Some candidate the checker scored, of any rank, is on a ball.
    pub any_on_ball: bool,
    /// Every candidate proposed, whatever the checker made of it.
    pub candidates: usize,
    /// Per labelled ball, in the order of `balls`: some candidate is on it.
    #[serde(default)]
    pub balls_proposed: Vec<bool>,
    /// Candidates on some labelled ball.
    #[serde(default)]
    pub candidates_on_ball: usize,
    /// Candidates the checker scored at or above `min_probability`.
    #[serde(default)]
    pub candidates_accepted: usize,
    /// Candidates the checker scored at or above `min_probability` that are on a ball.
    #[serde(default)]
    pub candidates_accepted_on_ball: usize,
    pub detect_ms: f64,
}

/// Recall of the labelled balls of one size band.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BandRecall {
    pub band: String,
    pub min_width_px: f64,
    /// `None` for the open top band.
    pub max_width_px: Option<f64>,
    pub balls: usize,
    pub found_published: usize,
    pub found_best: usize,
    /// Balls some candidate is on, whatever the checker made of it.
    #[serde(default)]
    pub found_candidate: usize,
    /// `None` without balls in the band.
    pub recall_published: Option<f64>,
    pub recall_best: Option<f64>,
    /// `found_candidate` over `balls`.
    #[serde(default)]
    pub recall_candidate: Option<f64>,
}

/// Time the detector took per image, milliseconds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TimingMs {
    pub median: f64,
    pub p90: f64,
}

/// How many candidates a photo had, over the photos scored.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CandidatesPerFrame {
    pub mean: f64,
    pub median: f64,
    pub p90: f64,
    pub max: usize,
}

/// The checker judged per candidate at the evaluation's `min_probability`; a candidate
/// without a probability (refused outright) counts as scored below it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct CheckerScores {
    /// Every candidate of every photo.
    pub candidates: usize,
    /// Candidates on a labelled ball.
    pub on_ball: usize,
    /// Candidates scored at or above `min_probability`.
    pub accepted: usize,
    /// Candidates on a labelled ball scored at or above `min_probability`.
    pub accepted_on_ball: usize,
    /// `accepted_on_ball` over `on_ball`; `None` without candidates on a ball.
    pub recall: Option<f64>,
    /// `accepted_on_ball` over `accepted`; `None` when nothing was accepted.
    pub precision: Option<f64>,
}

/// The whole folder's scores.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LabelReport {
    pub hit_rule: String,
    pub min_probability: f64,
    pub images: usize,
    pub images_with_ball: usize,
    pub balls: usize,
    /// Images with a ball whose published detection is on one of them.
    pub found_published: usize,
    pub found_best: usize,
    pub found_any: usize,
    pub recall_published: Option<f64>,
    pub recall_best: Option<f64>,
    pub recall_any: Option<f64>,
    pub published: usize,
    pub published_on_ball: usize,
    pub precision: Option<f64>,
    pub false_positives: usize,
    pub false_positives_per_image: Option<f64>,
    pub bands: Vec<BandRecall>,
    /// Labelled balls the published detection is on, over all labelled balls (an image
    /// publishes one detection, so a photo with two balls finds at most one).
    pub ball_recall: Option<f64>,
    /// Labelled balls some candidate is on, whatever the checker made of it.
    #[serde(default)]
    pub balls_proposed: usize,
    /// `balls_proposed` over all labelled balls: the candidate stage's recall.
    #[serde(default)]
    pub candidate_recall: Option<f64>,
    /// Candidates per photo; `None` without photos.
    #[serde(default)]
    pub candidates_per_frame: Option<CandidatesPerFrame>,
    /// The checker per candidate.
    #[serde(default)]
    pub checker: CheckerScores,
    /// Image recall and precision of the best candidate as the probability threshold
    /// falls: one point per distinct probability, highest first.
    pub pr_curve: Vec<PrPoint>,
    pub timing_ms: Option<TimingMs>,
    pub rows: Vec<ImageRow>,
}

/// One point of the precision-recall curve: publishing the best candidate when its
/// probability is at least `threshold`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PrPoint {
    pub threshold: f64,
    pub recall: f64,
    pub precision: f64,
}

/// The precision-recall curve of rows (see [`LabelReport::pr_curve`]).
pub fn pr_curve(rows: &[ImageRow]) -> Vec<PrPoint> {
    let with_ball = rows.iter().filter(|r| !r.balls.is_empty()).count();
    let mut best: Vec<(f64, bool)> = rows
        .iter()
        .filter_map(|r| r.best.map(|b| (b[3], r.best_on_ball)))
        .collect();
    best.sort_by(|a, b| b.0.total_cmp(&a.0));
    let (mut published, mut hits) = (0usize, 0usize);
    let mut out: Vec<PrPoint> = Vec::new();
    for (k, &(p, on)) in best.iter().enumerate() {
        published += 1;
        hits += usize::from(on);
        if best.get(k + 1).is_some_and(|n| n.0 == p) {
            continue;
        }
        out.push(PrPoint {
            threshold: p,
            recall: ratio(hits, with_ball).unwrap_or(0.0),
            precision: hits as f64 / published as f64,
        });
    }
    out
}

impl LabelReport {
    /// The highest image recall on the curve whose precision is at least `precision`,
    /// with its threshold.
    pub fn recall_at_precision(&self, precision: f64) -> Option<PrPoint> {
        self.pr_curve
            .iter()
            .filter(|p| p.precision >= precision)
            .max_by(|a, b| a.recall.total_cmp(&b.recall))
            .copied()
    }
}

/// Scores images one at a time.
#[derive(Debug, Clone)]
pub struct LabelEval {
    min_probability: f64,
    rows: Vec<ImageRow>,
    /// Per band: balls, found by the published detection, found by the best candidate,
    /// found by some candidate.
    band_balls: [[usize; 4]; SIZE_BANDS_PX.len()],
}

fn ratio(a: usize, b: usize) -> Option<f64> {
    (b > 0).then(|| a as f64 / b as f64)
}

fn circle_row(c: &Circle, p: f64) -> [f64; 4] {
    [c.center_px[0], c.center_px[1], c.radius_px, p]
}

impl LabelEval {
    pub fn new(min_probability: f64) -> Self {
        Self {
            min_probability,
            rows: Vec::new(),
            band_balls: [[0; 4]; SIZE_BANDS_PX.len()],
        }
    }

    /// The probability at or above which a candidate is accepted (and the most probable
    /// of those published).
    pub fn min_probability(&self) -> f64 {
        self.min_probability
    }

    /// Scores one image from the candidates the checker scored alone, most probable first,
    /// with the time detection took. The stage figures then count those candidates only:
    /// [`LabelEval::add_stages`] takes every candidate.
    pub fn add(&mut self, image: &str, balls: &[BallBox], scored: &[(Circle, f64)], ms: f64) {
        let candidates: Vec<(Circle, Option<f64>)> =
            scored.iter().map(|&(c, p)| (c, Some(p))).collect();
        self.add_stages(image, balls, &candidates, ms);
    }

    /// Scores one image: its labelled balls and every candidate proposed in it, with the
    /// checker's probability (`None` when it refused the candidate outright), in any order,
    /// and the time detection took. The published detection is the most probable candidate
    /// (the first of equals) when it reaches `min_probability`; a probability that is not a
    /// number counts as none.
    pub fn add_stages(
        &mut self,
        image: &str,
        balls: &[BallBox],
        candidates: &[(Circle, Option<f64>)],
        ms: f64,
    ) {
        let scored: Vec<(&Circle, f64)> = candidates
            .iter()
            .filter_map(|(c, p)| p.filter(|p| !p.is_nan()).map(|p| (c, p)))
            .collect();
        let best = scored
            .iter()
            .copied()
            .reduce(|best, c| if c.1 > best.1 { c } else { best });
        let published = best.filter(|&(_, p)| p >= self.min_probability);
        let on_ball = |c: &Circle| balls.iter().any(|b| is_hit(c, b));
        let is_accepted = |p: Option<f64>| p.is_some_and(|p| p >= self.min_probability);
        let mut balls_proposed = Vec::with_capacity(balls.len());
        for b in balls {
            let proposed = candidates.iter().any(|(c, _)| is_hit(c, b));
            balls_proposed.push(proposed);
            let band = &mut self.band_balls[band_of(b.width_px())];
            band[0] += 1;
            band[1] += usize::from(published.is_some_and(|(c, _)| is_hit(c, b)));
            band[2] += usize::from(best.is_some_and(|(c, _)| is_hit(c, b)));
            band[3] += usize::from(proposed);
        }
        let (mut candidates_on_ball, mut candidates_accepted, mut candidates_accepted_on_ball) =
            (0, 0, 0);
        for (c, p) in candidates {
            let (on, accepted) = (on_ball(c), is_accepted(*p));
            candidates_on_ball += usize::from(on);
            candidates_accepted += usize::from(accepted);
            candidates_accepted_on_ball += usize::from(on && accepted);
        }
        self.rows.push(ImageRow {
            image: image.to_owned(),
            balls: balls.to_vec(),
            published: published.map(|(c, p)| circle_row(c, p)),
            published_on_ball: published.is_some_and(|(c, _)| on_ball(c)),
            best: best.map(|(c, p)| circle_row(c, p)),
            best_on_ball: best.is_some_and(|(c, _)| on_ball(c)),
            any_on_ball: scored.iter().any(|(c, _)| on_ball(c)),
            candidates: candidates.len(),
            balls_proposed,
            candidates_on_ball,
            candidates_accepted,
            candidates_accepted_on_ball,
            detect_ms: ms,
        });
    }

    /// The last image scored.
    pub fn last(&self) -> Option<&ImageRow> {
        self.rows.last()
    }

    /// The scores so far; `timing_ms` is the shell's (it owns the clock and the workspace's
    /// quantile).
    pub fn report(&self, timing_ms: Option<TimingMs>) -> LabelReport {
        let with_ball: Vec<&ImageRow> = self.rows.iter().filter(|r| !r.balls.is_empty()).collect();
        let count = |f: fn(&ImageRow) -> bool| with_ball.iter().filter(|r| f(r)).count();
        let (found_published, found_best, found_any) = (
            count(|r| r.published_on_ball),
            count(|r| r.best_on_ball),
            count(|r| r.any_on_ball),
        );
        let published = self.rows.iter().filter(|r| r.published.is_some()).count();
        let published_on_ball = self.rows.iter().filter(|r| r.published_on_ball).count();
        let false_positives = published - published_on_ball;
        let bands = SIZE_BANDS_PX
            .iter()
            .zip(&self.band_balls)
            .enumerate()
            .map(|(i, (&(lo, hi), &[balls, fp, fb, fc]))| BandRecall {
                band: band_name(i),
                min_width_px: lo,
                max_width_px: hi.is_finite().then_some(hi),
                balls,
                found_published: fp,
                found_best: fb,
                found_candidate: fc,
                recall_published: ratio(fp, balls),
                recall_best: ratio(fb, balls),
                recall_candidate: ratio(fc, balls),
            })
            .collect();
        let all_balls: usize = self.band_balls.iter().map(|b| b[0]).sum();
        let balls_proposed: usize = self.band_balls.iter().map(|b| b[3]).sum();
        let sum = |f: fn(&ImageRow) -> usize| self.rows.iter().map(f).sum::<usize>();
        let (on_ball, accepted, accepted_on_ball) = (
            sum(|r| r.candidates_on_ball),
            sum(|r| r.candidates_accepted),
            sum(|r| r.candidates_accepted_on_ball),
        );
        let checker = CheckerScores {
            candidates: sum(|r| r.candidates),
            on_ball,
            accepted,
            accepted_on_ball,
            recall: ratio(accepted_on_ball, on_ball),
            precision: ratio(accepted_on_ball, accepted),
        };
        LabelReport {
            hit_rule: "the detected circle's centre lies inside the labelled box".into(),
            min_probability: self.min_probability,
            images: self.rows.len(),
            images_with_ball: with_ball.len(),
            balls: self.rows.iter().map(|r| r.balls.len()).sum(),
            found_published,
            found_best,
            found_any,
            recall_published: ratio(found_published, with_ball.len()),
            recall_best: ratio(found_best, with_ball.len()),
            recall_any: ratio(found_any, with_ball.len()),
            published,
            published_on_ball,
            precision: ratio(published_on_ball, published),
            false_positives,
            false_positives_per_image: ratio(false_positives, self.rows.len()),
            ball_recall: ratio(self.band_balls.iter().map(|b| b[1]).sum(), all_balls),
            balls_proposed,
            candidate_recall: ratio(balls_proposed, all_balls),
            candidates_per_frame: candidates_per_frame(&self.rows),
            checker,
            pr_curve: pr_curve(&self.rows),
            bands,
            timing_ms,
            rows: self.rows.clone(),
        }
    }
}

/// The candidates per photo of rows; `None` without rows.
fn candidates_per_frame(rows: &[ImageRow]) -> Option<CandidatesPerFrame> {
    let counts: Vec<f64> = rows.iter().map(|r| r.candidates as f64).collect();
    let max = rows.iter().map(|r| r.candidates).max()?;
    Some(CandidatesPerFrame {
        mean: counts.iter().sum::<f64>() / counts.len() as f64,
        median: proto::stats::quantile(&counts, 0.5)?,
        p90: proto::stats::quantile(&counts, 0.9)?,
        max,
    })
}

fn pct(v: Option<f64>) -> String {
    v.map_or("–".to_string(), |v| format!("{:.1} %", 100.0 * v))
}

impl std::fmt::Display for LabelReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} images, {} with a ball ({} labelled balls); hit: {}",
            self.images, self.images_with_ball, self.balls, self.hit_rule
        )?;
        writeln!(
            f,
            "published (p >= {}): recall {} ({} of {}), precision {} ({} of {}), \
             false positives per image {}",
            self.min_probability,
            pct(self.recall_published),
            self.found_published,
            self.images_with_ball,
            pct(self.precision),
            self.published_on_ball,
            self.published,
            self.false_positives_per_image
                .map_or("–".to_string(), |v| format!("{v:.3}"))
        )?;
        writeln!(
            f,
            "best candidate of any probability: recall {} ({}); any candidate: recall {} ({})",
            pct(self.recall_best),
            self.found_best,
            pct(self.recall_any),
            self.found_any
        )?;
        writeln!(
            f,
            "balls found by the published detection: {}",
            pct(self.ball_recall)
        )?;
        writeln!(
            f,
            "candidates: on {} of the balls ({} of {}); per image {}",
            pct(self.candidate_recall),
            self.balls_proposed,
            self.balls,
            self.candidates_per_frame
                .map_or("–".to_string(), |c| format!(
                    "mean {:.2}, median {:.1}, p90 {:.1}, max {}",
                    c.mean, c.median, c.p90, c.max
                ))
        )?;
        let c = &self.checker;
        writeln!(
            f,
            "checker per candidate (p >= {}): recall {} ({} of {} on a ball), precision {} \
             ({} of {} accepted)",
            self.min_probability,
            pct(c.recall),
            c.accepted_on_ball,
            c.on_ball,
            pct(c.precision),
            c.accepted_on_ball,
            c.accepted
        )?;
        for target in [0.97, 0.9] {
            if let Some(p) = self.recall_at_precision(target) {
                writeln!(
                    f,
                    "at precision >= {:.0} %: recall {} (threshold {:.3})",
                    100.0 * target,
                    pct(Some(p.recall)),
                    p.threshold
                )?;
            }
        }
        writeln!(
            f,
            "{:<10} {:>6} {:>10} {:>10} {:>10}",
            "ball width", "balls", "candidate", "published", "best"
        )?;
        for b in &self.bands {
            writeln!(
                f,
                "{:<10} {:>6} {:>10} {:>10} {:>10}",
                b.band,
                b.balls,
                pct(b.recall_candidate),
                pct(b.recall_published),
                pct(b.recall_best)
            )?;
        }
        match self.timing_ms {
            Some(t) => write!(
                f,
                "detector per image: median {:.2} ms, p90 {:.2} ms",
                t.median, t.p90
            ),
            None => write!(f, "detector per image: no images"),
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn ball(x: f64, y: f64, w: f64) -> BallBox {
        BallBox {
            x_min_px: x - w / 2.0,
            y_min_px: y - w / 2.0,
            x_max_px: x + w / 2.0,
            y_max_px: y + w / 2.0,
        }
    }

    fn circle(x: f64, y: f64, r: f64) -> Circle {
        Circle {
            center_px: [x, y],
            radius_px: r,
            score: 1.0,
        }
    }

    #[test]
    fn bands_cover_every_width() {
        assert_eq!(band_of(3.0), 0);
        assert_eq!(band_of(10.0), 1);
        assert_eq!(band_of(39.9), 2);
        assert_eq!(band_of(400.0), 3);
        assert_eq!(band_name(0), "< 10 px");
        assert_eq!(band_name(2), "20–40 px");
        assert_eq!(band_name(3), ">= 40 px");
    }

    #[test]
    fn scores_published_best_and_any_candidate() {
        let mut e = LabelEval::new(0.5);
        // Found and published.
        e.add(
            "a",
            &[ball(50.0, 50.0, 30.0)],
            &[(circle(52.0, 49.0, 14.0), 0.9)],
            1.0,
        );
        // The ball is the best candidate but below the threshold.
        e.add(
            "b",
            &[ball(50.0, 50.0, 8.0)],
            &[(circle(50.0, 51.0, 4.0), 0.2)],
            2.0,
        );
        // A false positive is published; the ball is only the runner-up.
        e.add(
            "c",
            &[ball(50.0, 50.0, 50.0)],
            &[
                (circle(200.0, 10.0, 5.0), 0.8),
                (circle(50.0, 50.0, 25.0), 0.7),
            ],
            3.0,
        );
        // No ball, nothing found.
        e.add("d", &[], &[], 4.0);
        let r = e.report(Some(TimingMs {
            median: 2.5,
            p90: 3.7,
        }));
        assert_eq!((r.images, r.images_with_ball, r.balls), (4, 3, 3));
        assert_eq!((r.found_published, r.found_best, r.found_any), (1, 2, 3));
        assert_eq!(
            (r.published, r.published_on_ball, r.false_positives),
            (2, 1, 1)
        );
        assert_eq!(r.precision, Some(0.5));
        assert_eq!(r.false_positives_per_image, Some(0.25));
        let balls: Vec<usize> = r.bands.iter().map(|b| b.balls).collect();
        assert_eq!(balls, vec![1, 0, 1, 1]);
        assert_eq!(r.bands[0].recall_published, Some(0.0));
        assert_eq!(r.bands[0].recall_best, Some(1.0));
        assert_eq!(r.bands[1].recall_published, None);
        assert_eq!(r.bands[3].recall_best, Some(0.0));
        let text = r.to_string();
        assert!(text.contains("recall 33.3 % (1 of 3)"), "{text}");
        assert!(text.contains("median 2.50 ms, p90 3.70 ms"), "{text}");
        assert_eq!(r.ball_recall, Some(1.0 / 3.0));
        // Thresholds 0.9 (a: hit), 0.8 (c: miss), 0.2 (b: hit).
        let curve: Vec<(f64, f64, f64)> = r
            .pr_curve
            .iter()
            .map(|p| (p.threshold, p.recall, p.precision))
            .collect();
        assert_eq!(
            curve,
            vec![
                (0.9, 1.0 / 3.0, 1.0),
                (0.8, 1.0 / 3.0, 0.5),
                (0.2, 2.0 / 3.0, 2.0 / 3.0)
            ]
        );
        assert_eq!(r.recall_at_precision(0.6).unwrap().threshold, 0.2);
        assert_eq!(r.recall_at_precision(0.97).unwrap().threshold, 0.9);
        let json = serde_json::to_string(&r).unwrap();
        assert!(json.contains("\"bands\""));
        // Fed the scored candidates alone, the stages see those.
        assert_eq!(r.candidate_recall, Some(1.0));
        assert_eq!(r.checker.candidates, 4);
        assert_eq!((r.checker.on_ball, r.checker.accepted_on_ball), (3, 2));
    }

    #[test]
    fn a_candidate_on_the_ball_among_two_is_the_candidate_recall() {
        let mut e = LabelEval::new(0.5);
        // A 15 px ball: one candidate on it refused outright, one off it accepted.
        e.add_stages(
            "a",
            &[ball(50.0, 50.0, 15.0)],
            &[
                (circle(200.0, 20.0, 6.0), Some(0.9)),
                (circle(51.0, 49.0, 7.0), None),
            ],
            1.0,
        );
        let r = e.report(None);
        assert_eq!((r.balls, r.balls_proposed), (1, 1));
        assert_eq!(r.candidate_recall, Some(1.0));
        let per_band: Vec<(usize, usize)> = r
            .bands
            .iter()
            .map(|b| (b.balls, b.found_candidate))
            .collect();
        assert_eq!(per_band, vec![(0, 0), (1, 1), (0, 0), (0, 0)]);
        assert_eq!(r.bands[1].recall_candidate, Some(1.0));
        assert_eq!(r.bands[1].recall_published, Some(0.0));
        assert_eq!(r.bands[0].recall_candidate, None);
        // The refused candidate is no scored one: the off-ball one is published.
        assert!(!r.rows[0].any_on_ball);
        assert_eq!(r.found_published, 0);
        assert_eq!(r.rows[0].balls_proposed, vec![true]);
        assert_eq!(r.rows[0].candidates, 2);
        assert_eq!(r.checker.recall, Some(0.0));
        assert_eq!(r.checker.precision, Some(0.0));
    }

    #[test]
    fn balls_without_a_candidate_lower_the_candidate_recall_in_their_band() {
        let mut e = LabelEval::new(0.5);
        // Two balls, a candidate on the wide one only.
        e.add_stages(
            "a",
            &[ball(20.0, 20.0, 6.0), ball(100.0, 100.0, 50.0)],
            &[(circle(101.0, 99.0, 24.0), Some(0.8))],
            1.0,
        );
        e.add_stages("b", &[ball(20.0, 20.0, 8.0)], &[], 1.0);
        let r = e.report(None);
        assert_eq!((r.balls, r.balls_proposed), (3, 1));
        assert_eq!(r.candidate_recall, Some(1.0 / 3.0));
        assert_eq!(r.bands[0].balls, 2);
        assert_eq!(r.bands[0].recall_candidate, Some(0.0));
        assert_eq!(r.bands[3].recall_candidate, Some(1.0));
        assert_eq!(r.rows[0].balls_proposed, vec![false, true]);
    }

    #[test]
    fn checker_precision_and_recall_count_candidates() {
        let mut e = LabelEval::new(0.5);
        e.add_stages(
            "a",
            &[ball(50.0, 50.0, 20.0)],
            &[
                // On the ball: accepted, below the threshold, refused, accepted twice.
                (circle(50.0, 50.0, 10.0), Some(0.9)),
                (circle(52.0, 48.0, 9.0), Some(0.3)),
                (circle(48.0, 50.0, 11.0), None),
                (circle(51.0, 51.0, 10.0), Some(0.5)),
                // Off it: accepted twice, below.
                (circle(150.0, 50.0, 10.0), Some(0.7)),
                (circle(150.0, 100.0, 10.0), Some(0.55)),
                (circle(150.0, 150.0, 10.0), Some(0.1)),
            ],
            1.0,
        );
        e.add_stages(
            "b",
            &[],
            &[
                (circle(10.0, 10.0, 4.0), Some(0.6)),
                (circle(30.0, 10.0, 4.0), Some(f64::NAN)),
            ],
            1.0,
        );
        let r = e.report(None);
        let c = r.checker;
        assert_eq!(c.candidates, 9);
        assert_eq!((c.on_ball, c.accepted, c.accepted_on_ball), (4, 5, 2));
        assert_eq!(c.recall, Some(0.5));
        assert_eq!(c.precision, Some(0.4));
        // The most probable candidate is published whatever the order.
        assert_eq!(r.rows[0].published, Some([50.0, 50.0, 10.0, 0.9]));
        assert_eq!(r.rows[1].published, Some([10.0, 10.0, 4.0, 0.6]));
        let per_frame = r.candidates_per_frame.unwrap();
        assert_eq!(per_frame.mean, 4.5);
        assert_eq!(per_frame.median, 4.5);
        assert_eq!(per_frame.max, 7);
        assert!((per_frame.p90 - 6.5).abs() < 1e-9, "{per_frame:?}");
        let text = r.to_string();
        assert!(
            text.contains("recall 50.0 % (2 of 4 on a ball), precision 40.0 % (2 of 5 accepted)"),
            "{text}"
        );
        assert!(
            text.contains("mean 4.50, median 4.5, p90 6.5, max 7"),
            "{text}"
        );
    }

    #[test]
    fn nothing_scored_gives_no_stage_figures() {
        let r = LabelEval::new(0.5).report(None);
        assert_eq!(r.candidates_per_frame, None);
        assert_eq!(r.candidate_recall, None);
        assert_eq!((r.checker.recall, r.checker.precision), (None, None));
    }
}
