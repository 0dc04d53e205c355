//! Tests of patch extraction: scale, edge clamping, mirroring, rotation, bad inputs.

#![allow(clippy::unwrap_used)]

use super::*;
use approx::assert_abs_diff_eq;

/// A 100×80 grey background with a white disc of radius 10 px at (40, 30).
fn disc_image() -> RgbImage {
    let mut img = RgbImage::filled(100, 80, [50, 50, 50]).unwrap();
    for y in 0..80 {
        for x in 0..100 {
            if (f64::from(x) - 40.0).hypot(f64::from(y) - 30.0) <= 10.0 {
                img.set_pixel(x, y, [255, 255, 255]);
            }
        }
    }
    img
}

#[test]
fn disc_fills_the_middle_and_background_the_corners() {
    let p = extract(&disc_image(), [40.0, 30.0], 10.0, &PatchConfig::default()).unwrap();
    assert_abs_diff_eq!(p.at(16, 16), 1.0, epsilon = 1e-3);
    assert_abs_diff_eq!(p.at(0, 0), 50.0 / 255.0, epsilon = 1e-3);
    // The window is 24 px wide for 32 patch pixels: the rim (10 px from the centre) lies
    // 10 / 24 × 32 ≈ 13.3 patch pixels from the patch centre.
    assert!(p.at(16, 16 + 12) > 0.9);
    assert!(p.at(16, 16 + 15) < 0.3);
}

#[test]
fn large_windows_are_box_filtered() {
    // Alternating columns average to mid grey instead of aliasing.
    let mut img = RgbImage::filled(200, 200, [0, 0, 0]).unwrap();
    for y in 0..200 {
        for x in (0..200).step_by(2) {
            img.set_pixel(x, y, [255, 255, 255]);
        }
    }
    // A 64 px window: two frame pixels per patch pixel.
    let cfg = PatchConfig {
        window_over_radius: 2.0,
    };
    let p = extract(&img, [100.0, 100.0], 32.0, &cfg).unwrap();
    for &v in p.grey() {
        assert_abs_diff_eq!(v, 0.5, epsilon = 0.08);
    }
}

#[test]
fn windows_past_the_border_repeat_the_edge() {
    let mut img = RgbImage::filled(20, 20, [0, 0, 0]).unwrap();
    img.set_pixel(0, 0, [255, 255, 255]);
    let p = extract(&img, [0.0, 0.0], 8.0, &PatchConfig::default()).unwrap();
    assert!(p.grey().iter().all(|v| v.is_finite()));
    assert_abs_diff_eq!(p.at(0, 0), 1.0, epsilon = 1e-4);
    assert_abs_diff_eq!(p.at(31, 31), 0.0, epsilon = 1e-4);
}

#[test]
fn colour_patch_matches_the_grey_patch() {
    let img = disc_image();
    let cfg = PatchConfig::default();
    let grey = extract(&img, [41.3, 29.2], 11.0, &cfg).unwrap();
    let colour = extract_rgb(&img, [41.3, 29.2], 11.0, &cfg).unwrap();
    assert_eq!(colour.data().len(), 3 * PATCH_PIXELS);
    for (a, b) in grey.grey().iter().zip(colour.to_grey().grey()) {
        assert_abs_diff_eq!(*a, *b, epsilon = 0.5 / 255.0 + 1e-5);
    }
}

#[test]
fn mirroring_twice_is_identity_and_rotation_turns_clockwise() {
    let p = Patch::from_fn(|x, y| (x * 3 + y * 7) as f32 / 400.0).unwrap();
    assert_eq!(p.mirrored().mirrored(), p);
    assert_abs_diff_eq!(p.mirrored().at(0, 5), p.at(31, 5));
    let zero = p.rotated(0.0);
    for (a, b) in zero.grey().iter().zip(p.grey()) {
        assert_abs_diff_eq!(*a, *b, epsilon = 1e-6);
    }
    // Right half bright; a quarter turn (x towards y) makes the bottom half bright.
    let right = Patch::from_fn(|x, _| if x >= 16 { 1.0 } else { 0.0 }).unwrap();
    let turned = right.rotated(std::f64::consts::FRAC_PI_2);
    assert_abs_diff_eq!(turned.at(16, 28), 1.0, epsilon = 1e-5);
    assert_abs_diff_eq!(turned.at(16, 3), 0.0, epsilon = 1e-5);
}

#[test]
fn bad_inputs_are_errors() {
    let img = disc_image();
    let cfg = PatchConfig::default();
    assert!(matches!(
        extract(&img, [f64::NAN, 1.0], 5.0, &cfg),
        Err(PatchError::BadCircle { .. })
    ));
    assert!(matches!(
        extract(&img, [1.0, 1.0], 0.0, &cfg),
        Err(PatchError::BadCircle { .. })
    ));
    let zero = PatchConfig {
        window_over_radius: 0.0,
    };
    assert_eq!(
        extract(&img, [1.0, 1.0], 5.0, &zero),
        Err(PatchError::BadMargin(0.0))
    );
    let empty = RgbImage::new(0, 0, Vec::new()).unwrap();
    assert_eq!(
        extract(&empty, [0.0, 0.0], 5.0, &cfg),
        Err(PatchError::EmptyImage)
    );
    assert_eq!(Patch::from_grey(vec![0.0; 5]), Err(PatchError::Length(5)));
    let mut nan = vec![0.0; PATCH_PIXELS];
    nan[7] = f32::NAN;
    assert_eq!(Patch::from_grey(nan), Err(PatchError::NonFinite(7)));
}
