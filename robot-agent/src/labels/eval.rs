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

use serde::{Deserialize, Serialize};

use crate::detection::hough::Circle;
use crate::labels::BallBox;

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
    /// Some candidate, of any rank, is on a ball.
    pub any_on_ball: bool,
    pub candidates: usize,
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
    /// `None` without balls in the band.
    pub recall_published: Option<f64>,
    pub recall_best: Option<f64>,
}

/// Time the detector took per image, milliseconds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TimingMs {
    pub median: f64,
    pub p90: f64,
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
    /// Per band: balls, found by the published detection, found by the best candidate.
    band_balls: [[usize; 3]; SIZE_BANDS_PX.len()],
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
            band_balls: [[0; 3]; SIZE_BANDS_PX.len()],
        }
    }

    /// Scores one image: its labelled balls and the candidates the detector scored, most
    /// probable first, with the time detection took.
    pub fn add(&mut self, image: &str, balls: &[BallBox], scored: &[(Circle, f64)], ms: f64) {
        let published = scored.first().filter(|(_, p)| *p >= self.min_probability);
        let best = scored.first();
        let on_ball = |c: &(Circle, f64)| balls.iter().any(|b| is_hit(&c.0, b));
        for b in balls {
            let band = &mut self.band_balls[band_of(b.width_px())];
            band[0] += 1;
            band[1] += usize::from(published.is_some_and(|c| is_hit(&c.0, b)));
            band[2] += usize::from(best.is_some_and(|c| is_hit(&c.0, b)));
        }
        self.rows.push(ImageRow {
            image: image.to_owned(),
            balls: balls.to_vec(),
            published: published.map(|(c, p)| circle_row(c, *p)),
            published_on_ball: published.is_some_and(on_ball),
            best: best.map(|(c, p)| circle_row(c, *p)),
            best_on_ball: best.is_some_and(on_ball),
            any_on_ball: scored.iter().any(on_ball),
            candidates: scored.len(),
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
            .map(|(i, (&(lo, hi), &[balls, fp, fb]))| BandRecall {
                band: band_name(i),
                min_width_px: lo,
                max_width_px: hi.is_finite().then_some(hi),
                balls,
                found_published: fp,
                found_best: fb,
                recall_published: ratio(fp, balls),
                recall_best: ratio(fb, balls),
            })
            .collect();
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
            ball_recall: ratio(
                self.band_balls.iter().map(|b| b[1]).sum(),
                self.band_balls.iter().map(|b| b[0]).sum(),
            ),
            pr_curve: pr_curve(&self.rows),
            bands,
            timing_ms,
            rows: self.rows.clone(),
        }
    }
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
            "{:<10} {:>6} {:>10} {:>10}",
            "ball width", "balls", "published", "best"
        )?;
        for b in &self.bands {
            writeln!(
                f,
                "{:<10} {:>6} {:>10} {:>10}",
                b.band,
                b.balls,
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
    }
}
