//! Training samples for the ball network, cut from labelled photos, and their augmentation.
//!
//! A photo gives three kinds of sample, all cut the way the detector cuts them
//! ([`vision::stages::ballnet::patch_for`]):
//!
//! - the appearance proposals ([`vision::stages::appearance::propose`]): one that lands on a
//!   labelled ball (centre within half the ball's radius, radius within a factor of two) is
//!   a ball with the correction from its circle to the label's as the target; one clear of
//!   every ball is not a ball; one in between (on a ball's edge) is left out, as it is
//!   neither;
//! - every labelled ball again, several times, from circles moved and scaled at random
//!   about the label's, so the network sees balls off centre and learns to correct them;
//! - random windows clear of every ball.
//!
//! Augmentation ([`augment`]) turns a sample by the square's eight symmetries (its target
//! with it), turns its colours (any ball colour on any floor: the hue turned about the grey
//! axis, the channels swapped, or all grey), and changes its brightness, contrast and
//! noise.

use crate::labels::BallBox;
use proto::rng::Rng;
use vision::Circle;
use vision::image::RgbImage;
use vision::stages::appearance::{AppearanceConfig, propose};
use vision::stages::patch::{PATCH_SIDE_PX, RgbPatch};

/// One training sample: a patch, whether it is a ball and, for a ball, the correction
/// from the patch's circle to the ball's (centre offset over the radius, log of the radius
/// ratio).
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    pub patch: RgbPatch,
    pub ball: bool,
    pub target: [f32; 3],
}

/// How samples are cut from a photo.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleConfig {
    /// The proposals, as the detector makes them.
    pub appearance: AppearanceConfig,
    /// Moved and scaled copies of every labelled ball.
    pub copies_per_ball: usize,
    /// Random windows clear of every ball, per photo.
    pub random_per_photo: usize,
    /// The largest offset of a copy's centre, over the ball's radius.
    pub copy_offset: f64,
    /// The largest log scale of a copy's radius.
    pub copy_log_scale: f64,
    /// The patch window's side over a circle's radius (the network's own).
    pub window_over_radius: f64,
    /// A proposal is on a ball when its centre is within this share of the ball's radius
    /// of the ball's centre ...
    pub on_ball_offset: f64,
    /// ... and its radius within this factor of the ball's.
    pub on_ball_ratio: f64,
}

impl Default for SampleConfig {
    fn default() -> Self {
        SampleConfig {
            // Proposals of every size, the small ones the detector leaves to the candidate
            // network included: more hard negatives, and the shipped network's recipe.
            appearance: AppearanceConfig {
                min_radius_px: 2.0,
                ..AppearanceConfig::default()
            },
            copies_per_ball: 6,
            random_per_photo: 4,
            copy_offset: 0.35,
            copy_log_scale: 0.45,
            window_over_radius: vision::stages::ballnet::WINDOW_OVER_RADIUS,
            on_ball_offset: 0.5,
            on_ball_ratio: 2.0,
        }
    }
}

/// How many of a photo's labelled balls had a proposal on them (the most the network can
/// find), and the sample counts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SampleCounts {
    pub balls: usize,
    pub proposed: usize,
    pub positives: usize,
    pub negatives: usize,
}

impl std::ops::AddAssign for SampleCounts {
    fn add_assign(&mut self, o: Self) {
        self.balls += o.balls;
        self.proposed += o.proposed;
        self.positives += o.positives;
        self.negatives += o.negatives;
    }
}

/// A ball box's circle in an image of `size_px`: its centre and half its larger side, or
/// half its smaller side when the box is cut by the image's edge (only part of the ball is
/// in the picture, and that part is what a proposal can be on).
pub fn ball_circle(ball: &BallBox, size_px: [f64; 2]) -> ([f64; 2], f64) {
    let cut = ball.x_min_px <= 1.0
        || ball.y_min_px <= 1.0
        || ball.x_max_px >= size_px[0] - 2.0
        || ball.y_max_px >= size_px[1] - 2.0;
    let (w, h) = (ball.width_px(), ball.height_px());
    let r = if cut { 0.5 * w.min(h) } else { 0.5 * w.max(h) };
    (ball.centre_px(), r.max(0.5))
}

/// The correction from a circle to the ball, when the circle is on it: its centre within
/// `offset` of the ball's radius (at least 2 px) of the ball's, its radius within a factor
/// `ratio` of the ball's.
pub fn correction(
    circle: &Circle,
    ball: &BallBox,
    size_px: [f64; 2],
    offset: f64,
    ratio: f64,
) -> Option<[f32; 3]> {
    let ([bx, by], rb) = ball_circle(ball, size_px);
    let [cx, cy] = circle.center_px;
    let r = circle.radius_px;
    let near = (bx - cx).hypot(by - cy) <= offset * rb.max(2.0);
    let scale = rb / r;
    (near && (1.0 / ratio..=ratio).contains(&scale)).then(|| {
        [
            ((bx - cx) / r) as f32,
            ((by - cy) / r) as f32,
            scale.ln() as f32,
        ]
    })
}

/// Whether a circle keeps clear of a ball: its centre farther from the ball's than the sum
/// of the ball's radius and the circle's.
pub fn clear_of(circle: &Circle, ball: &BallBox) -> bool {
    let [bx, by] = ball.centre_px();
    let rb = 0.5 * ball.width_px().max(ball.height_px());
    (circle.center_px[0] - bx).hypot(circle.center_px[1] - by) > rb + circle.radius_px
}

/// The samples of one labelled photo, and how many balls the proposals covered: the
/// appearance proposals and `extra` ones (another stage's candidates).
pub fn photo_samples(
    image: &RgbImage,
    balls: &[BallBox],
    extra: &[Circle],
    cfg: &SampleConfig,
    rng: &mut Rng,
) -> (Vec<Sample>, SampleCounts) {
    let patch_cfg = vision::settings::PatchConfig {
        window_over_radius: cfg.window_over_radius,
    };
    let patch_for = |image: &RgbImage, c: &Circle| {
        vision::stages::patch::extract_rgb(image, c.center_px, c.radius_px, &patch_cfg).ok()
    };
    let mut out = Vec::new();
    let mut counts = SampleCounts {
        balls: balls.len(),
        ..SampleCounts::default()
    };
    let size = [f64::from(image.width()), f64::from(image.height())];
    let mut covered = vec![false; balls.len()];
    let mut proposals = propose(image, &cfg.appearance);
    proposals.extend_from_slice(extra);
    for circle in proposals {
        let on = balls.iter().enumerate().find_map(|(k, b)| {
            correction(&circle, b, size, cfg.on_ball_offset, cfg.on_ball_ratio).map(|t| (k, t))
        });
        let sample = match on {
            Some((k, target)) => {
                covered[k] = true;
                Some((true, target))
            }
            None if balls.iter().all(|b| clear_of(&circle, b)) => Some((false, [0.0; 3])),
            None => None,
        };
        if let Some((ball, target)) = sample
            && let Some(patch) = patch_for(image, &circle)
        {
            out.push(Sample {
                patch,
                ball,
                target,
            });
        }
    }
    counts.proposed = covered.iter().filter(|&&c| c).count();
    for b in balls {
        let (centre, rb) = ball_circle(b, size);
        for k in 0..=cfg.copies_per_ball {
            // The first copy is the label's own circle.
            let (r, c) = if k == 0 {
                (rb, centre)
            } else {
                let r = rb * rng.range(-cfg.copy_log_scale, cfg.copy_log_scale).exp();
                let d = cfg.copy_offset * rb;
                (
                    r,
                    [centre[0] + rng.range(-d, d), centre[1] + rng.range(-d, d)],
                )
            };
            let circle = Circle {
                center_px: c,
                radius_px: r.max(1.0),
                score: 1.0,
            };
            if let (Some(target), Some(patch)) = (
                correction(&circle, b, size, cfg.on_ball_offset, cfg.on_ball_ratio),
                patch_for(image, &circle),
            ) {
                out.push(Sample {
                    patch,
                    ball: true,
                    target,
                });
            }
        }
    }
    let (w, h) = (f64::from(image.width()), f64::from(image.height()));
    let max_r = (0.2 * w.min(h)).max(4.0);
    let mut placed = 0;
    for _ in 0..cfg.random_per_photo * 20 {
        if placed == cfg.random_per_photo {
            break;
        }
        // Log-uniform radii: as many small windows as big ones.
        let r = (rng.range(2.0f64.ln(), max_r.ln())).exp();
        let circle = Circle {
            center_px: [rng.range(0.0, w), rng.range(0.0, h)],
            radius_px: r,
            score: 0.0,
        };
        if balls.iter().all(|b| clear_of(&circle, b))
            && let Some(patch) = patch_for(image, &circle)
        {
            out.push(Sample {
                patch,
                ball: false,
                target: [0.0; 3],
            });
            placed += 1;
        }
    }
    counts.positives = out.iter().filter(|s| s.ball).count();
    counts.negatives = out.len() - counts.positives;
    (out, counts)
}

/// One of the square's eight symmetries: a transpose, then a mirror of x, then of y.
fn symmetry(s: &Sample, code: usize) -> Sample {
    let (transpose, flip_x, flip_y) = (code & 1 != 0, code & 2 != 0, code & 4 != 0);
    let n = PATCH_SIDE_PX;
    let data = s.patch.data();
    let patch = RgbPatch::from_fn_rgb(|x, y| {
        // Output (x, y) reads the source pixel that the transform sends there.
        let (mut sx, mut sy) = (x, y);
        if flip_y {
            sy = n - 1 - sy;
        }
        if flip_x {
            sx = n - 1 - sx;
        }
        if transpose {
            std::mem::swap(&mut sx, &mut sy);
        }
        let i = 3 * (sy * n + sx);
        [data[i], data[i + 1], data[i + 2]]
    });
    let [mut dx, mut dy, ds] = s.target;
    if transpose {
        std::mem::swap(&mut dx, &mut dy);
    }
    if flip_x {
        dx = -dx;
    }
    if flip_y {
        dy = -dy;
    }
    Sample {
        patch,
        ball: s.ball,
        target: [dx, dy, ds],
    }
}

/// A colour change: a 3×3 matrix applied to every pixel's RGB about grey. Hue turns reach
/// `max_hue_turn_rad` either way; at π or more the channels may also be swapped.
pub fn colour_matrix(rng: &mut Rng, max_hue_turn_rad: f64) -> [[f64; 3]; 3] {
    let any_colour = max_hue_turn_rad >= std::f64::consts::PI;
    let roll = rng.uniform();
    if roll < 0.15 {
        // Grey.
        let g = [0.299, 0.587, 0.114];
        return [g, g, g];
    }
    if roll < 0.55 || !any_colour {
        // A turn of the hue about the grey axis (Rodrigues' rotation about (1,1,1)/√3).
        let a = rng.range(-max_hue_turn_rad, max_hue_turn_rad);
        let (c, s) = (a.cos(), a.sin());
        let (k1, k2) = ((1.0 - c) / 3.0, s / 3f64.sqrt());
        return [
            [c + k1, k1 - k2, k1 + k2],
            [k1 + k2, c + k1, k1 - k2],
            [k1 - k2, k1 + k2, c + k1],
        ];
    }
    // A permutation of the channels (the identity among them).
    let mut order = [0usize, 1, 2];
    rng.shuffle(&mut order);
    let mut m = [[0.0; 3]; 3];
    for (row, &col) in m.iter_mut().zip(&order) {
        row[col] = 1.0;
    }
    m
}

/// An augmented copy of a sample, its hue turned by at most `max_hue_turn_rad`.
pub fn augment(s: &Sample, rng: &mut Rng, max_hue_turn_rad: f64) -> Sample {
    let mut out = symmetry(s, rng.index(8));
    let m = if rng.chance(0.7) {
        colour_matrix(rng, max_hue_turn_rad)
    } else {
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    };
    let gain = rng.range(0.6, 1.4);
    let offset = rng.range(-40.0, 40.0);
    let contrast = rng.range(0.7, 1.3);
    let noise = if rng.chance(0.5) {
        rng.range(0.0, 10.0)
    } else {
        0.0
    };
    let data = out.patch.data().to_vec();
    let mean: f64 = data.iter().map(|&v| f64::from(v)).sum::<f64>() / data.len() as f64;
    let mut mixed = Vec::with_capacity(data.len());
    for px in data.chunks_exact(3) {
        let rgb = [f64::from(px[0]), f64::from(px[1]), f64::from(px[2])];
        for row in &m {
            let v = row[0] * rgb[0] + row[1] * rgb[1] + row[2] * rgb[2];
            let v = ((v - mean) * contrast + mean) * gain + offset + noise * rng.normal();
            mixed.push(v.round().clamp(0.0, 255.0) as u8);
        }
    }
    if let Ok(p) = RgbPatch::from_bytes(mixed) {
        out.patch = p;
    }
    out
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn ball_box(cx: f64, cy: f64, r: f64) -> BallBox {
        BallBox {
            x_min_px: cx - r,
            y_min_px: cy - r,
            x_max_px: cx + r,
            y_max_px: cy + r,
        }
    }

    #[test]
    fn a_circle_on_a_ball_has_the_correction_to_it() {
        let b = ball_box(50.0, 40.0, 10.0);
        let c = Circle {
            center_px: [48.0, 43.0],
            radius_px: 8.0,
            score: 1.0,
        };
        let size = [200.0, 200.0];
        let t = correction(&c, &b, size, 0.5, 2.0).unwrap();
        assert!((t[0] - 0.25).abs() < 1e-6 && (t[1] + 0.375).abs() < 1e-6);
        assert!((t[2] - (10.0f32 / 8.0).ln()).abs() < 1e-6);
        let far = Circle {
            center_px: [60.0, 40.0],
            ..c
        };
        assert_eq!(correction(&far, &b, size, 0.5, 2.0), None);
        assert!(!clear_of(&far, &b));
        let clear = Circle {
            center_px: [80.0, 40.0],
            ..c
        };
        assert!(clear_of(&clear, &b));
    }

    #[test]
    fn symmetries_move_the_target_with_the_patch() {
        // A bright pixel right of centre and a target pointing right.
        let patch =
            RgbPatch::from_fn_rgb(|x, y| if x == 24 && y == 16 { [255; 3] } else { [0; 3] });
        let s = Sample {
            patch,
            ball: true,
            target: [0.5, 0.0, 0.1],
        };
        let mirrored = symmetry(&s, 2);
        assert_eq!(mirrored.target, [-0.5, 0.0, 0.1]);
        assert_eq!(mirrored.patch.data()[3 * (16 * 32 + 7)], 255);
        let transposed = symmetry(&s, 1);
        assert_eq!(transposed.target, [0.0, 0.5, 0.1]);
        assert_eq!(transposed.patch.data()[3 * (24 * 32 + 16)], 255);
    }

    #[test]
    fn a_photo_gives_balls_and_others() {
        let mut image = RgbImage::filled(160, 120, [40, 120, 40]).unwrap();
        for y in 0..120 {
            for x in 0..160 {
                if (f64::from(x) - 60.0).hypot(f64::from(y) - 50.0) < 9.0 {
                    image.set_pixel(x, y, [240, 120, 20]);
                }
            }
        }
        let balls = [ball_box(60.0, 50.0, 9.0)];
        let mut rng = Rng::new(3);
        let (samples, counts) =
            photo_samples(&image, &balls, &[], &SampleConfig::default(), &mut rng);
        assert_eq!(counts.balls, 1);
        assert_eq!(counts.proposed, 1, "the contrast stage proposes the disc");
        assert!(counts.positives > SampleConfig::default().copies_per_ball);
        assert!(counts.negatives >= SampleConfig::default().random_per_photo);
        assert_eq!(samples.len(), counts.positives + counts.negatives);
        let a = augment(&samples[0], &mut rng, 1.0);
        assert_eq!(a.ball, samples[0].ball);
    }
}
