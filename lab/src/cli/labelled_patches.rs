//! Training patches from labelled photos: each labelled ball is a positive, cut as the
//! detector's candidate window around a circle inscribed in its box; negatives are the
//! candidates the detector's first stages propose away from every ball (with the mining
//! windows of [`crate::training::hog_svm::miners`]: the ball's widest colour window and
//! white/grey), and random windows that touch no ball.

use crate::cli::labelled::LabelledFolder;
use crate::labels::BallBox;
use anyhow::Result;
use proto::rng::Rng;
use vision::NoClock;
use vision::stages::patch::{Patch, PatchConfig, extract};

/// Smallest radius of a random negative window, pixels (the detector's smallest circle).
const MIN_RANDOM_RADIUS_PX: f64 = 4.0;

/// Whether a circle keeps clear of a ball's box: its centre is farther from the box's
/// centre than the two half-diagonals.
fn clear_of(centre_px: [f64; 2], radius_px: f64, ball: &BallBox) -> bool {
    let [bx, by] = ball.centre_px();
    let half = 0.5 * ball.width_px().hypot(ball.height_px());
    (centre_px[0] - bx).hypot(centre_px[1] - by) > half + radius_px * std::f64::consts::SQRT_2
}

/// Whether a proposed circle is the ball of a box: its centre within 30 % of the ball's
/// radius (at least 1.5 px) of the box's centre and its radius within 30 % of the ball's
/// (at least 1.2 px).
fn matches_ball(centre_px: [f64; 2], radius_px: f64, ball: &BallBox) -> bool {
    let [bx, by] = ball.centre_px();
    let r = 0.5 * ball.width_px().max(ball.height_px());
    (centre_px[0] - bx).hypot(centre_px[1] - by) <= (0.3 * r).max(1.5)
        && (radius_px - r).abs() <= (0.3 * r).max(1.2)
}

/// Positive and negative patches of a labelled folder, `random_per_image` random
/// negatives per photo.
pub fn labelled_patches(
    folder: &LabelledFolder,
    random_per_image: usize,
    seed: u64,
    progress: &mut dyn FnMut(&str),
) -> Result<(Vec<Patch>, Vec<Patch>)> {
    let detectors = crate::training::hog_svm::miners()?;
    let cfg = PatchConfig::default();
    let mut rng = Rng::stream(seed, "labelled-negatives", 0);
    let (mut pos, mut neg) = (Vec::new(), Vec::new());
    let n = folder.items.len();
    for (k, item) in folder.items.iter().enumerate() {
        let loaded = robot_agent::load_rgb(&item.image)
            .map_err(anyhow::Error::from)
            .and_then(|image| {
                let labels = folder.labels(item, &image)?;
                let model = folder.camera.model_for(&image)?;
                Ok((image, labels, model))
            });
        let (image, labels, model) = match loaded {
            Ok(l) => l,
            Err(e) => {
                progress(&format!("[{}/{n}] {}: left out: {e:#}", k + 1, item.name()));
                continue;
            }
        };
        for b in &labels.balls {
            let radius = 0.5 * b.width_px().max(b.height_px());
            if let Ok(p) = extract(&image, b.centre_px(), radius, &cfg) {
                pos.push(p);
            }
        }
        let clear = |c: [f64; 2], r: f64| labels.balls.iter().all(|b| clear_of(c, r, b));
        for detector in &detectors {
            let proposals = detector.propose(&image, model.as_ref(), &mut NoClock)?;
            for p in &proposals.items {
                let view = proposals.image(p, &image);
                let Ok(patch) = extract(view, p.local.center_px, p.local.radius_px, &cfg) else {
                    continue;
                };
                // A proposal that matches a ball is a positive as the detector really cuts
                // it (off centre, a little too big or small); one that only overlaps a
                // ball is left out.
                let (c, r) = (p.frame.center_px, p.frame.radius_px);
                if labels.balls.iter().any(|b| matches_ball(c, r, b)) {
                    pos.push(patch);
                } else if clear(c, r) {
                    neg.push(patch);
                }
            }
        }
        let (w, h) = (f64::from(image.width()), f64::from(image.height()));
        let max_r = (0.25 * w.min(h)).max(MIN_RANDOM_RADIUS_PX);
        let mut placed = 0;
        for _ in 0..random_per_image * 20 {
            if placed == random_per_image {
                break;
            }
            let r = rng.range(MIN_RANDOM_RADIUS_PX, max_r);
            let c = [rng.range(r, w - r), rng.range(r, h - r)];
            if clear(c, r)
                && let Ok(patch) = extract(&image, c, r, &cfg)
            {
                neg.push(patch);
                placed += 1;
            }
        }
        progress(&format!(
            "[{}/{n}] {}: {} ball and {} other patches so far",
            k + 1,
            item.name(),
            pos.len(),
            neg.len()
        ));
    }
    Ok((pos, neg))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negatives_keep_clear_of_balls() {
        let ball = BallBox {
            x_min_px: 10.0,
            y_min_px: 10.0,
            x_max_px: 30.0,
            y_max_px: 30.0,
        };
        assert!(!clear_of([20.0, 20.0], 5.0, &ball));
        assert!(!clear_of([40.0, 20.0], 5.0, &ball));
        assert!(clear_of([60.0, 20.0], 5.0, &ball));
    }

    #[test]
    fn a_proposal_close_to_the_box_matches_its_ball() {
        let ball = BallBox {
            x_min_px: 10.0,
            y_min_px: 10.0,
            x_max_px: 30.0,
            y_max_px: 30.0,
        };
        assert!(matches_ball([21.0, 19.5], 11.0, &ball));
        assert!(!matches_ball([25.0, 20.0], 10.0, &ball));
        assert!(!matches_ball([20.0, 20.0], 15.0, &ball));
    }
}
