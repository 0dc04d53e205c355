//! Tests of single-photo detection on drawn photos, of fitting a calibration to a photo's
//! size and of the overlay.

#![allow(clippy::unwrap_used)]

use super::*;
use crate::detect::{DetectorConfig, NoClock};

/// A grey photo with shaded orange discs `(centre, radius)`.
fn photo(balls: &[([f64; 2], f64)]) -> RgbImage {
    let (w, h) = (240, 160);
    let mut image = RgbImage::filled(w, h, [112, 108, 100]).unwrap();
    for &(c, r) in balls {
        for y in 0..h {
            for x in 0..w {
                let (dx, dy) = (f64::from(x) - c[0], f64::from(y) - c[1]);
                if dx.hypot(dy) <= r {
                    let shade = 0.8 - 0.15 * dy / r;
                    let rgb = [240.0 * shade, 120.0 * shade, 30.0 * shade];
                    image.set_pixel(x, y, rgb.map(|v| v as u8));
                }
            }
        }
    }
    image
}

/// Refuses circles under 6 px; otherwise the probability grows with the radius.
struct BySize;

impl CandidateClassifier for BySize {
    fn probability(&self, _image: &RgbImage, circle: &Circle) -> Option<f64> {
        (circle.radius_px >= 6.0).then(|| (circle.radius_px / 20.0).min(1.0))
    }
}

fn detect(image: &RgbImage, model: Option<&CameraModel>) -> Vec<PhotoCandidate> {
    let detector = Detector::new(DetectorConfig::default()).unwrap();
    detect_photo(&detector, &BySize, 0.5, image, model, &mut NoClock).unwrap()
}

fn near(c: &PhotoCandidate, centre: [f64; 2], radius: f64) -> bool {
    let p = c.circle.center_px;
    (p[0] - centre[0]).hypot(p[1] - centre[1]) < 1.0 && (c.circle.radius_px - radius).abs() < 1.5
}

#[test]
fn every_candidate_is_reported_with_what_became_of_it() {
    let big = ([160.3, 80.6], 16.0);
    let middle = ([60.0, 50.0], 12.0);
    let small = ([60.0, 120.0], 5.0);
    let small_photo = photo(&[big, middle, small]);
    let found = detect(&small_photo, None);
    assert_eq!(found.len(), 3, "{found:?}");
    assert!(near(&found[0], big.0, big.1), "{found:?}");
    assert!(found[0].published());
    assert_eq!(found.iter().filter(|c| c.published()).count(), 1);
    assert!(near(&found[1], middle.0, middle.1));
    assert_eq!(found[1].rejection, Some(PhotoRejection::RunnerUp));
    assert!(near(&found[2], small.0, small.1));
    assert_eq!(found[2].rejection, Some(PhotoRejection::ColourCheck));
    assert_eq!(found[2].probability, None);
    assert!(found.iter().all(|c| c.angular_radius_rad.is_none()));
    // Below the threshold nothing is published.
    let faint = detect(&photo(&[middle]), None);
    assert_eq!(faint.len(), 1);
    assert!(faint[0].probability.unwrap() < 0.75);
    let detector = Detector::new(DetectorConfig::default()).unwrap();
    let strict = detect_photo(
        &detector,
        &BySize,
        0.9,
        &photo(&[middle]),
        None,
        &mut NoClock,
    )
    .unwrap();
    assert_eq!(strict[0].rejection, Some(PhotoRejection::LowProbability));
    assert!(detect(&photo(&[]), None).is_empty());
}

#[test]
fn with_a_pinhole_model_the_ball_is_found_through_its_local_view() {
    let ball = ([150.0, 70.0], 15.0);
    let image = photo(&[ball]);
    let model = CameraModel::pinhole(220.0, 220.0, 119.5, 79.5, 240, 160);
    let found = detect(&image, Some(&model));
    let first = found.first().unwrap();
    assert!(first.published());
    let p = first.circle.center_px;
    assert!(
        (p[0] - 150.0).abs() < 1.0 && (p[1] - 70.0).abs() < 1.0,
        "{found:?}"
    );
    let alpha = first.angular_radius_rad.unwrap();
    assert!((alpha - (15.0f64 / 220.0).atan()).abs() < 0.01, "{alpha}");
}

#[test]
fn a_calibration_fits_a_photo_of_its_size_or_a_resized_one_when_asked() {
    let model = CameraModel::pinhole(500.0, 500.0, 319.5, 179.5, 640, 360);
    assert_eq!(fit_to_photo(&model, 640, 360, false).unwrap(), model);
    let err = fit_to_photo(&model, 1280, 720, false).unwrap_err();
    assert!(matches!(err, PhotoCameraError::SizeMismatch { .. }));
    let text = err.to_string();
    assert!(
        text.contains("640×360") && text.contains("1280×720"),
        "{text}"
    );
    let big = fit_to_photo(&model, 1280, 720, true).unwrap();
    assert_eq!(big.intrinsics.fx_px, 1000.0);
    assert_eq!(big.intrinsics.cx_px, 639.5);
    // A 4:3 photo is not a resized 16:9 frame.
    let err = fit_to_photo(&model, 640, 480, true).unwrap_err();
    assert!(
        matches!(err, PhotoCameraError::ShapeMismatch { .. }),
        "{err}"
    );
}

#[test]
fn the_overlay_draws_published_and_rejected_circles_in_their_colours() {
    let image = photo(&[]);
    let circle = |x: f64| Circle {
        center_px: [x, 80.0],
        radius_px: 20.0,
        score: 1.0,
    };
    let candidates = [
        PhotoCandidate {
            circle: circle(60.0),
            probability: Some(0.9),
            angular_radius_rad: None,
            rejection: None,
        },
        PhotoCandidate {
            circle: circle(170.0),
            probability: None,
            angular_radius_rad: None,
            rejection: Some(PhotoRejection::ColourCheck),
        },
    ];
    let out = overlay(&image, &candidates);
    assert_eq!(out.pixel(80, 80), Some(PUBLISHED_RGB), "the published rim");
    assert_eq!(out.pixel(60, 80), Some(PUBLISHED_RGB), "its centre");
    assert_eq!(out.pixel(190, 80), Some(REJECTED_RGB), "the rejected rim");
    assert_eq!(out.pixel(70, 80), image.pixel(70, 80), "inside stays");
    // Circles reaching off the photo are clipped.
    let edge = PhotoCandidate {
        circle: Circle {
            center_px: [-5.0, 200.0],
            radius_px: 30.0,
            score: 1.0,
        },
        ..candidates[0]
    };
    assert_eq!(overlay(&image, &[edge]).width(), image.width());
}
