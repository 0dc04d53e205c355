//! Tests of the colour check: clustering two colours, passing and failing circles,
//! determinism and bad inputs.

#![allow(clippy::unwrap_used)]

use super::*;
use crate::test_fixtures::orange;

/// A green frame with a disc of `rgb` of radius 12 px at (30, 30); the disc's left
/// columns left of x = 18 + `left_cols` is painted `left_rgb` instead.
fn frame(rgb: [u8; 3], left_rgb: [u8; 3], left_cols: u32) -> RgbImage {
    let mut img = RgbImage::filled(60, 60, [40, 140, 50]).unwrap();
    for y in 0..60 {
        for x in 0..60 {
            if (f64::from(x) - 30.0).hypot(f64::from(y) - 30.0) <= 12.0 {
                let c = if x < 18 + left_cols { left_rgb } else { rgb };
                img.set_pixel(x, y, c);
            }
        }
    }
    img
}

/// The colour check of the frame's disc against the orange window.
fn check_disc(
    img: &RgbImage,
    patches: Option<&HsvThresholds>,
    cfg: &ColourCheckConfig,
) -> ColourCheck {
    colour_check(img, [30.0, 30.0], 12.0, &orange(), patches, cfg).unwrap()
}

#[test]
fn kmeans_separates_two_colours() {
    let mut pixels = vec![[230.0, 120.0, 30.0]; 70];
    pixels.extend(vec![[20.0, 40.0, 200.0]; 30]);
    // A little spread around each colour.
    for (i, p) in pixels.iter_mut().enumerate() {
        p[0] += (i % 5) as f32;
    }
    let c = kmeans(&pixels, 2, 5, 1);
    assert_eq!(c.counts, vec![70, 30]);
    assert!((c.centres[0][0] - 232.0).abs() < 1.0 && (c.centres[0][2] - 30.0).abs() < 1e-3);
    assert!((c.centres[1][2] - 200.0).abs() < 1e-3);
    // k larger than the distinct colours: empty clusters are dropped.
    let one = kmeans(&[[1.0, 2.0, 3.0]; 10], 3, 3, 1);
    assert_eq!(one.counts, vec![10]);
    assert!(kmeans(&[], 2, 3, 1).counts.is_empty());
}

#[test]
fn an_orange_disc_passes_and_a_blue_one_fails() {
    let cfg = ColourCheckConfig::default();
    let ok = check_disc(&frame([230, 120, 30], [230, 120, 30], 0), None, &cfg);
    assert!(ok.passes, "{ok:?}");
    assert_eq!(ok.dominant_rgb, [230, 120, 30]);
    assert_eq!(ok.share, 1.0);
    let blue = check_disc(&frame([30, 60, 220], [30, 60, 220], 0), None, &cfg);
    assert!(!blue.passes, "{blue:?}");
    assert_eq!(blue.dominant_rgb, [30, 60, 220]);
}

#[test]
fn a_small_ball_coloured_share_fails() {
    // About 40 % orange, 60 % white: the dominant colour is white.
    let img = frame([240, 240, 240], [230, 120, 30], 8);
    let cfg = ColourCheckConfig::default();
    let c = check_disc(&img, None, &cfg);
    assert!(!c.passes, "{c:?}");
    assert!(c.share > 0.5 && c.share < 0.8, "{c:?}");
    // Mostly orange with a white part: passes with the default share, fails a strict one.
    let img = frame([230, 120, 30], [240, 240, 240], 8);
    let c = check_disc(&img, None, &cfg);
    assert!(c.passes && c.share < 0.85, "{c:?}");
    let strict = ColourCheckConfig {
        min_share: 0.9,
        ..cfg
    };
    assert!(!check_disc(&img, None, &strict).passes);
}

#[test]
fn large_circles_are_subsampled_and_results_are_deterministic() {
    let mut img = RgbImage::filled(400, 400, [230, 120, 30]).unwrap();
    img.set_pixel(200, 200, [0, 0, 255]);
    let cfg = ColourCheckConfig {
        k: 3,
        ..ColourCheckConfig::default()
    };
    let a = colour_check(&img, [200.0, 200.0], 150.0, &orange(), None, &cfg).unwrap();
    let b = colour_check(&img, [200.0, 200.0], 150.0, &orange(), None, &cfg).unwrap();
    assert_eq!(a, b);
    assert!(a.passes);
    // Off the image entirely: nothing sampled, fails.
    let off = colour_check(&img, [-500.0, -500.0], 10.0, &orange(), None, &cfg).unwrap();
    assert!(!off.passes && off.share == 0.0);
}

#[test]
fn bad_inputs_are_errors() {
    let img = frame([230, 120, 30], [230, 120, 30], 0);
    let cfg = ColourCheckConfig::default();
    let bad_k = ColourCheckConfig { k: 0, ..cfg };
    assert!(matches!(
        colour_check(&img, [30.0, 30.0], 12.0, &orange(), None, &bad_k),
        Err(ColourError::BadParameter { name: "k", .. })
    ));
    assert!(matches!(
        colour_check(&img, [30.0, f64::NAN], 12.0, &orange(), None, &cfg),
        Err(ColourError::BadCircle { .. })
    ));
    let mut t = orange();
    t.sat_min = 2.0;
    assert!(matches!(
        colour_check(&img, [30.0, 30.0], 12.0, &t, None, &cfg),
        Err(ColourError::Thresholds(_))
    ));
}

#[test]
fn ball_colour_with_white_patches_passes_and_white_alone_fails() {
    let white = crate::colour::two_colour::PatternConfig::default().white;
    let cfg = ColourCheckConfig::default();
    // About 40 % orange, 60 % white: a patterned ball's colours.
    let img = frame([240, 240, 240], [230, 120, 30], 11);
    let c = check_disc(&img, Some(&white), &cfg);
    assert!(c.passes && c.ball_share < 0.5, "{c:?}");
    // Less orange than the configured share: not a ball.
    let strict = ColourCheckConfig {
        min_ball_share_with_patches: 0.6,
        ..cfg
    };
    let c = check_disc(&img, Some(&white), &strict);
    assert!(!c.passes, "{c:?}");
    // White alone, or white with a little orange, never passes.
    let img = frame([240, 240, 240], [240, 240, 240], 0);
    let c = check_disc(&img, Some(&white), &cfg);
    assert!(!c.passes && c.ball_share == 0.0, "{c:?}");
    let img = frame([240, 240, 240], [230, 120, 30], 3);
    let c = check_disc(&img, Some(&white), &cfg);
    assert!(!c.passes, "{c:?}");
    // Orange with blue is not a patterned ball either.
    let img = frame([30, 60, 220], [230, 120, 30], 8);
    let c = check_disc(&img, Some(&white), &cfg);
    assert!(!c.passes, "{c:?}");
}
