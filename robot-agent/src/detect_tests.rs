//! Tests of the image half of the detector on drawn frames.

#![allow(clippy::unwrap_used)]

use super::*;

const W: u32 = 320;
const H: u32 = 180;

/// A grey frame with a faint texture.
fn background() -> RgbImage {
    let mut data = Vec::with_capacity((W * H * 3) as usize);
    for y in 0..H {
        for x in 0..W {
            let t = ((x * 7 + y * 13) % 17) as u8;
            data.extend_from_slice(&[110 + t, 105 + t, 100 + t]);
        }
    }
    RgbImage::new(W, H, data).unwrap()
}

/// Draws a shaded orange disc; with `patches`, white spots cover part of it.
fn draw_ball(image: &mut RgbImage, centre: [f64; 2], radius: f64, patches: bool) {
    for y in 0..H {
        for x in 0..W {
            let (dx, dy) = (f64::from(x) - centre[0], f64::from(y) - centre[1]);
            let d = dx.hypot(dy);
            if d > radius {
                continue;
            }
            let shade = 0.6 + 0.4 * (1.0 - (d / radius).powi(2)).sqrt() - 0.15 * dy / radius;
            let spot = patches
                && ((dx / radius * 3.0).round() as i32 + (dy / radius * 3.0).round() as i32) % 3
                    == 0
                && d < 0.8 * radius;
            let rgb = if spot {
                [235, 235, 230]
            } else {
                [
                    (240.0 * shade).min(255.0) as u8,
                    (120.0 * shade) as u8,
                    (30.0 * shade) as u8,
                ]
            };
            image.set_pixel(x, y, rgb);
        }
    }
}

fn draw_rect(image: &mut RgbImage, x0: u32, y0: u32, w: u32, h: u32, rgb: [u8; 3]) {
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            image.set_pixel(x, y, rgb);
        }
    }
}

struct Marks(Vec<&'static str>);

impl StageClock for Marks {
    fn mark(&mut self, stage: &'static str) {
        self.0.push(stage);
    }
}

#[test]
fn finds_a_shaded_ball_and_ignores_an_orange_stripe() {
    let mut image = background();
    draw_ball(&mut image, [200.4, 90.7], 14.0, false);
    draw_rect(&mut image, 20, 30, 60, 10, [230, 110, 20]);
    draw_ball(&mut image, [60.0, 120.0], 12.0, false);
    // A white disc of another colour is not a candidate.
    for y in 0..H {
        for x in 0..W {
            if (f64::from(x) - 130.0).hypot(f64::from(y) - 40.0) < 10.0 {
                image.set_pixel(x, y, [240, 240, 240]);
            }
        }
    }
    let detector = Detector::new(DetectorConfig::default()).unwrap();
    let mut marks = Marks(Vec::new());
    let found = detector
        .detect(&image, None, &HoughOnly, &mut marks)
        .unwrap();
    assert_eq!(
        marks.0,
        ["mask", "cleanup", "blobs", "hough", "classify"],
        "stages in order"
    );
    assert_eq!(found.len(), 2, "{found:?}");
    let mut balls: Vec<_> = found.iter().map(|c| c.circle).collect();
    balls.sort_by(|a, b| b.radius_px.total_cmp(&a.radius_px));
    let (c, r) = (balls[0].center_px, balls[0].radius_px);
    assert!(
        (c[0] - 200.4).abs() < 0.7 && (c[1] - 90.7).abs() < 0.7,
        "{c:?}"
    );
    assert!((r - 14.0).abs() < 1.0, "{r}");
    assert!((balls[1].center_px[0] - 60.0).abs() < 0.7);
}

#[test]
fn a_patterned_ball_is_found_through_its_white_patches() {
    let mut image = background();
    draw_ball(&mut image, [150.2, 100.6], 20.0, true);
    let detector = Detector::new(DetectorConfig::default()).unwrap();
    let found = detector
        .detect(&image, None, &HoughOnly, &mut NoClock)
        .unwrap();
    assert!(!found.is_empty());
    let c = found[0].circle;
    assert!(
        (c.center_px[0] - 150.2).abs() < 1.0 && (c.center_px[1] - 100.6).abs() < 1.0,
        "{c:?}"
    );
    assert!((c.radius_px - 20.0).abs() < 1.5, "{c:?}");
}

#[test]
fn classifier_rejections_and_order_are_kept() {
    struct RejectSmall;
    impl CandidateClassifier for RejectSmall {
        fn probability(&self, _image: &RgbImage, circle: &Circle) -> Option<f64> {
            (circle.radius_px > 13.0).then_some(0.9)
        }
    }
    let mut image = background();
    draw_ball(&mut image, [200.0, 90.0], 14.0, false);
    draw_ball(&mut image, [60.0, 120.0], 8.0, false);
    let detector = Detector::new(DetectorConfig::default()).unwrap();
    let found = detector
        .detect(&image, None, &RejectSmall, &mut NoClock)
        .unwrap();
    assert_eq!(found.len(), 1);
    assert_eq!(found[0].probability, 0.9);
}

#[test]
fn adaptation_follows_a_darker_ball() {
    let mut image = background();
    let centre = [160.0, 90.0];
    draw_ball(&mut image, centre, 20.0, false);
    let mut detector = Detector::new(DetectorConfig::default()).unwrap();
    let before = *detector.thresholds();
    // The same ball under dimmer light: value drops.
    let dim = RgbImage::new(
        W,
        H,
        image
            .data()
            .iter()
            .map(|v| (f64::from(*v) * 0.15) as u8)
            .collect(),
    )
    .unwrap();
    let circle = Circle {
        center_px: centre,
        radius_px: 20.0,
        score: 1.0,
    };
    for _ in 0..20 {
        detector.adapt(&dim, &circle).unwrap();
    }
    assert!(detector.thresholds().val_min < before.val_min);
    assert!(detector.thresholds().val_min >= DetectorConfig::default().limits.val_min);
    assert_eq!(
        detector.thresholds().val_max,
        DetectorConfig::default().limits.val_max
    );
    // A bright ball afterwards never tightens the window past the configured one.
    for _ in 0..20 {
        detector.adapt(&image, &circle).unwrap();
    }
    assert!(detector.thresholds().val_min <= before.val_min);
    assert!(detector.thresholds().sat_min <= before.sat_min);
}

#[test]
fn bad_settings_are_refused() {
    let cfg = DetectorConfig {
        adapt_rate: 2.0,
        ..DetectorConfig::default()
    };
    assert!(matches!(Detector::new(cfg), Err(DetectError::BadRate(_))));
    let mut cfg = DetectorConfig::default();
    cfg.hough.r_min_px = f64::NAN;
    assert!(Detector::new(cfg).is_err());
}
