//! Tests of the image half of the detector on drawn frames.

#![allow(clippy::unwrap_used)]

use super::*;
use crate::colour::hough::HoughConfig;
use crate::colour::kmeans::ColourCheckConfig;
use crate::colour::two_colour::PatternConfig;

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
fn the_appearance_proposer_finds_a_ball_of_another_colour_and_both_add_up() {
    let mut image = background();
    draw_ball(&mut image, [200.4, 90.7], 14.0, false);
    // A blue disc: outside every colour window.
    for y in 0..H {
        for x in 0..W {
            if (f64::from(x) - 80.0).hypot(f64::from(y) - 60.0) < 9.0 {
                image.set_pixel(x, y, [30, 60, 220]);
            }
        }
    }
    let near = |c: &Circle, x: f64, y: f64, r: f64| {
        (c.center_px[0] - x).hypot(c.center_px[1] - y) < 0.5 * r
    };
    let run = |proposer: Proposer| {
        let detector = Detector::new(DetectorConfig {
            proposer,
            ..DetectorConfig::default()
        })
        .unwrap();
        let mut marks = Marks(Vec::new());
        let found = detector
            .detect(&image, None, &HoughOnly, &mut marks)
            .unwrap();
        (found, marks.0)
    };
    let (colour, _) = run(Proposer::Colour);
    assert!(!colour.iter().any(|c| near(&c.circle, 80.0, 60.0, 9.0)));
    assert!(colour.iter().all(|c| c.stage == CandidateStage::Colour));
    let (appearance, marks) = run(Proposer::Appearance);
    assert_eq!(marks, ["appearance", "classify"]);
    assert!(appearance.iter().any(|c| near(&c.circle, 80.0, 60.0, 9.0)));
    assert!(
        appearance
            .iter()
            .any(|c| near(&c.circle, 200.4, 90.7, 14.0))
    );
    let (both, marks) = run(Proposer::Both);
    assert_eq!(marks.first(), Some(&"mask"));
    assert!(marks.contains(&"appearance"));
    assert!(both.iter().any(|c| near(&c.circle, 80.0, 60.0, 9.0)));
    // The orange ball is proposed by both paths but kept once, as the colour path's.
    let orange: Vec<_> = both
        .iter()
        .filter(|c| near(&c.circle, 200.4, 90.7, 14.0))
        .collect();
    assert_eq!(orange.len(), 1, "{both:?}");
    assert_eq!(orange[0].stage, CandidateStage::Colour);
    let blue = both.iter().find(|c| near(&c.circle, 80.0, 60.0, 9.0));
    assert_eq!(blue.map(|c| c.stage), Some(CandidateStage::Appearance));
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

#[test]
fn white_alone_never_makes_a_candidate() {
    // White discs (a robot's head), grey bodies and a white wall marking, no ball colour.
    let mut image = background();
    for (c, r, rgb) in [
        ([100.0, 60.0], 16.0, [235, 235, 230]),
        ([220.0, 120.0], 22.0, [130, 130, 135]),
        ([40.0, 140.0], 9.0, [250, 250, 250]),
    ] {
        for y in 0..H {
            for x in 0..W {
                if (f64::from(x) - c[0]).hypot(f64::from(y) - c[1]) < r {
                    image.set_pixel(x, y, rgb);
                }
            }
        }
    }
    draw_rect(&mut image, 150, 20, 80, 6, [240, 240, 240]);
    let detector = Detector::new(DetectorConfig::default()).unwrap();
    let proposals = detector.propose(&image, None, &mut NoClock).unwrap();
    assert!(proposals.items.is_empty(), "{:?}", proposals.items);
    let lens = crate::test_fixtures::miro_lens();
    let proposals = detector.propose(&image, Some(&lens), &mut NoClock).unwrap();
    assert!(proposals.items.is_empty(), "{:?}", proposals.items);
}

/// A settings file's `[detector]` table.
#[derive(serde::Deserialize)]
struct Settings {
    #[serde(default)]
    detector: DetectorConfig,
}

/// The settings a `--config` file's TOML gives.
fn settings(toml_text: &str) -> Result<DetectorConfig, toml::de::Error> {
    toml::from_str::<Settings>(toml_text).map(|c| c.detector)
}

/// A table with one key changes that key and keeps every other default, whichever table
/// it is; the colour windows keep their own defaults, not each other's.
#[test]
fn a_one_key_settings_table_keeps_the_other_defaults() {
    let d = DetectorConfig::default();
    let c = settings("[detector.thresholds]\nhue_hi_deg = 40.0").unwrap();
    assert_eq!(
        c,
        DetectorConfig {
            thresholds: HsvThresholds {
                hue_hi_deg: 40.0,
                ..d.thresholds
            },
            ..d
        }
    );
    let c = settings("[detector.limits]\nsat_min = 0.2").unwrap();
    assert_eq!(
        c,
        DetectorConfig {
            limits: HsvThresholds {
                sat_min: 0.2,
                ..d.limits
            },
            ..d
        }
    );
    let c = settings("[detector.hough]\nr_max_px = 60.0").unwrap();
    assert_eq!(
        c,
        DetectorConfig {
            hough: HoughConfig {
                r_max_px: 60.0,
                ..d.hough
            },
            ..d
        }
    );
    let c = settings("[detector.pattern.white]\nval_min = 0.3").unwrap();
    assert_eq!(
        c,
        DetectorConfig {
            pattern: PatternConfig {
                white: HsvThresholds {
                    val_min: 0.3,
                    ..d.pattern.white
                },
                ..d.pattern
            },
            ..d
        }
    );
    let c = settings("[detector.pattern]\nenabled = false").unwrap();
    assert_eq!(
        c,
        DetectorConfig {
            pattern: PatternConfig {
                enabled: false,
                ..d.pattern
            },
            ..d
        }
    );
    let c = settings("[detector.colour_check]\nk = 3").unwrap();
    assert_eq!(
        c,
        DetectorConfig {
            colour_check: ColourCheckConfig {
                k: 3,
                ..d.colour_check
            },
            ..d
        }
    );
    // Empty tables and an empty file are the defaults.
    let empty = "[detector]\n[detector.thresholds]\n[detector.limits]\n[detector.hough]\n\
                 [detector.pattern]\n[detector.pattern.white]\n[detector.colour_check]";
    assert_eq!(settings(empty).unwrap(), d);
    assert_eq!(settings("").unwrap(), d);
    // What a one-key table gives builds a detector.
    Detector::new(settings("[detector.limits]\nhue_hi_deg = 60.0").unwrap()).unwrap();
}

/// A misspelt key is an error in every table, naming the key.
#[test]
fn an_unknown_settings_key_is_an_error() {
    for table in [
        "detector",
        "detector.thresholds",
        "detector.limits",
        "detector.hough",
        "detector.pattern",
        "detector.pattern.white",
        "detector.colour_check",
    ] {
        let err = settings(&format!("[{table}]\nhue_low_deg = 5.0")).unwrap_err();
        assert!(err.to_string().contains("hue_low_deg"), "[{table}]: {err}");
    }
    // A key of the wrong type is an error too.
    assert!(settings("[detector.thresholds]\nsat_min = \"low\"").is_err());
}

#[test]
fn a_hint_is_judged_as_a_candidate_where_nothing_else_is() {
    let image = background();
    let detector = Detector::new(DetectorConfig::default()).unwrap();
    let none = detector
        .detect(&image, None, &HoughOnly, &mut NoClock)
        .unwrap();
    assert!(none.is_empty(), "{none:?}");
    let hint = Circle {
        center_px: [100.0, 80.0],
        radius_px: 6.0,
        score: 0.25,
    };
    let found = detector
        .detect_with_hint(&image, None, Some(hint), &HoughOnly, &mut NoClock)
        .unwrap();
    assert_eq!(found.len(), 1);
    assert_eq!(found[0].circle.center_px, hint.center_px);
    assert!((found[0].probability - 0.25).abs() < 1e-9);
    assert_eq!(found[0].stage, CandidateStage::Predicted);
}

#[test]
fn the_network_proposer_marks_its_candidates() {
    let mut image = background();
    draw_ball(&mut image, [200.4, 90.7], 14.0, false);
    let detector = Detector::new(DetectorConfig {
        proposer: Proposer::Net,
        ..DetectorConfig::default()
    })
    .unwrap();
    let found = detector
        .detect(&image, None, &HoughOnly, &mut NoClock)
        .unwrap();
    let stages: Vec<CandidateStage> = found.iter().map(|c| c.stage).collect();
    assert!(stages.contains(&CandidateStage::Network), "{found:?}");
    assert!(
        stages
            .iter()
            .all(|s| matches!(s, CandidateStage::Network | CandidateStage::Appearance)),
        "{stages:?}"
    );
}
