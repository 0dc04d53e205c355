//! A labeller scored box by box: every box it gives a ball, at every score threshold,
//! against the labelled ball boxes of the same photos.
//!
//! A labeller is judged differently from the robot's detector: the robot publishes one
//! ball per frame, a labeller must find every ball of a photo and give nothing else a
//! ball's label. So a box is a true positive when its centre lies in a labelled ball's
//! box that no better box took already (one box per ball; the hit rule is the one of
//! `lab::labels::eval`), a false positive otherwise; a ball no box took is
//! missed. Recall is per labelled ball, overall and per width band; precision per box.

use lab::labels::BallBox;
use lab::labels::eval::SIZE_BANDS_PX;
use serde::Serialize;

/// One photo's labelled balls and the labeller's ball boxes with their scores.
#[derive(Debug, Clone, Default)]
pub struct PhotoBoxes {
    pub balls: Vec<BallBox>,
    pub found: Vec<(BallBox, f64)>,
}

/// Each found box's score and whether it is on a ball; each ball's best score (0 when no
/// box is on it) and width.
#[derive(Debug, Clone, Default)]
struct Matched {
    boxes: Vec<(f64, bool)>,
    balls: Vec<(f64, f64)>,
}

/// Best boxes first, each on the first ball it lies on that no better box took.
fn match_photo(p: &PhotoBoxes) -> Matched {
    let mut found: Vec<&(BallBox, f64)> = p.found.iter().collect();
    found.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut taken = vec![None::<f64>; p.balls.len()];
    let mut boxes = Vec::new();
    for (b, score) in found {
        let c = b.centre_px();
        let hit = p
            .balls
            .iter()
            .enumerate()
            .find(|(k, ball)| taken[*k].is_none() && ball.contains(c))
            .map(|(k, _)| k);
        if let Some(k) = hit {
            taken[k] = Some(*score);
        }
        boxes.push((*score, hit.is_some()));
    }
    let balls = p
        .balls
        .iter()
        .zip(taken)
        .map(|(b, s)| (s.unwrap_or(0.0), b.width_px()))
        .collect();
    Matched { boxes, balls }
}

/// The scores at one threshold.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct AtThreshold {
    pub threshold: f64,
    pub recall: f64,
    pub precision: f64,
    pub false_per_photo: f64,
    /// Recall per width band of `SIZE_BANDS_PX`.
    pub band_recall: [f64; 4],
}

/// A labeller's score over some photos.
#[derive(Debug, Clone, Serialize)]
pub struct LabellerReport {
    pub photos: usize,
    pub balls: usize,
    /// Balls per width band.
    pub band_balls: [usize; 4],
    /// Recall with every box counted (threshold 0).
    pub reach: f64,
    /// The threshold grid, low to high.
    pub curve: Vec<AtThreshold>,
}

impl LabellerReport {
    /// The scores at the lowest threshold whose precision is at least `precision`.
    pub fn at_precision(&self, precision: f64) -> Option<&AtThreshold> {
        self.curve.iter().find(|a| a.precision >= precision)
    }

    /// The scores at the grid threshold nearest `threshold`.
    pub fn at_threshold(&self, threshold: f64) -> Option<&AtThreshold> {
        self.curve.iter().min_by(|a, b| {
            (a.threshold - threshold)
                .abs()
                .total_cmp(&(b.threshold - threshold).abs())
        })
    }
}

fn band_of(width_px: f64) -> usize {
    SIZE_BANDS_PX
        .iter()
        .position(|&(lo, hi)| width_px >= lo && width_px < hi)
        .unwrap_or(SIZE_BANDS_PX.len() - 1)
}

/// The report over `photos`, on a grid of thresholds 0.01 apart.
pub fn score(photos: &[PhotoBoxes]) -> LabellerReport {
    let matched: Vec<Matched> = photos.iter().map(match_photo).collect();
    let balls: Vec<(f64, f64)> = matched.iter().flat_map(|m| m.balls.clone()).collect();
    let boxes: Vec<(f64, bool)> = matched.iter().flat_map(|m| m.boxes.clone()).collect();
    let mut band_balls = [0usize; 4];
    for (_, w) in &balls {
        band_balls[band_of(*w)] += 1;
    }
    let share = |n: usize, d: usize| if d > 0 { n as f64 / d as f64 } else { 0.0 };
    let curve = (1..100)
        .map(|k| {
            let t = f64::from(k) / 100.0;
            let found = balls.iter().filter(|(s, _)| *s >= t).count();
            let kept = boxes.iter().filter(|(s, _)| *s >= t).count();
            let right = boxes.iter().filter(|(s, hit)| *s >= t && *hit).count();
            let mut band_found = [0usize; 4];
            for (s, w) in &balls {
                if *s >= t {
                    band_found[band_of(*w)] += 1;
                }
            }
            let mut band_recall = [0.0; 4];
            for b in 0..4 {
                band_recall[b] = share(band_found[b], band_balls[b]);
            }
            AtThreshold {
                threshold: t,
                recall: share(found, balls.len()),
                precision: if kept > 0 { share(right, kept) } else { 1.0 },
                false_per_photo: share(kept - right, photos.len()),
                band_recall,
            }
        })
        .collect();
    LabellerReport {
        photos: photos.len(),
        balls: balls.len(),
        band_balls,
        reach: share(balls.iter().filter(|(s, _)| *s > 0.0).count(), balls.len()),
        curve,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn b(x: f64, w: f64) -> BallBox {
        BallBox {
            x_min_px: x,
            y_min_px: 0.0,
            x_max_px: x + w,
            y_max_px: w,
        }
    }

    #[test]
    fn each_ball_takes_one_box_and_the_rest_are_false() {
        let photo = PhotoBoxes {
            balls: vec![b(0.0, 12.0), b(100.0, 50.0)],
            found: vec![
                (b(1.0, 10.0), 0.9),   // on the small ball
                (b(2.0, 10.0), 0.8),   // a second box on it: false
                (b(300.0, 10.0), 0.6), // on nothing: false
                (b(101.0, 48.0), 0.4), // on the big ball
            ],
        };
        let r = score(&[photo]);
        assert_eq!(r.balls, 2);
        assert_eq!(r.band_balls, [0, 1, 0, 1]);
        let at = r.at_threshold(0.5).expect("grid");
        assert_eq!(at.recall, 0.5);
        assert!((at.precision - 1.0 / 3.0).abs() < 1e-9);
        assert_eq!(at.band_recall, [0.0, 1.0, 0.0, 0.0]);
        let low = r.at_threshold(0.3).expect("grid");
        assert_eq!(low.recall, 1.0);
        assert_eq!(low.precision, 0.5);
        assert_eq!(low.false_per_photo, 2.0);
        // Precision 1 is reached above 0.8 only, where nothing but the best box is kept.
        assert_eq!(r.at_precision(1.0).map(|a| a.threshold), Some(0.81));
        assert_eq!(r.reach, 1.0);
    }
}
