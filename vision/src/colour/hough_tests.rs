//! Tests of the circular Hough transform: synthetic discs at sub-pixel centres, several and
//! clipped discs, shapes that are not circles, noise, and garbage inputs.

#![allow(clippy::unwrap_used)]

use super::*;
use proptest::prelude::*;

/// A `width × height` mask with the given discs (centre x, centre y, radius) set: a pixel is
/// set when its centre lies inside a disc.
fn discs(width: usize, height: usize, list: &[(f64, f64, f64)]) -> Vec<u8> {
    let mut mask = vec![0u8; width * height];
    for y in 0..height {
        for x in 0..width {
            let inside = list
                .iter()
                .any(|&(cx, cy, r)| (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2) <= r * r);
            mask[y * width + x] = u8::from(inside);
        }
    }
    mask
}

fn assert_circle(circle: &Circle, cx: f64, cy: f64, r: f64) {
    let centre_error = (circle.center_px[0] - cx).hypot(circle.center_px[1] - cy);
    assert!(
        centre_error <= 0.5 && (circle.radius_px - r).abs() <= 0.5,
        "expected ({cx}, {cy}) r {r}, got {circle:?}"
    );
}

#[test]
fn single_discs_at_sub_pixel_centres_are_found_accurately() {
    for &r in &[4.0, 10.0, 25.0, 40.0] {
        for &(fx, fy) in &[(0.0, 0.0), (0.3, 0.7), (0.5, 0.25), (0.81, 0.44)] {
            let size = (2.0 * r) as usize + 20;
            let (cx, cy) = (size as f64 / 2.0 + fx, size as f64 / 2.0 - 1.0 + fy);
            let mask = discs(size, size, &[(cx, cy, r)]);
            let circles = detect(&mask, size, size, &HoughConfig::default()).unwrap();
            assert!(
                !circles.is_empty(),
                "radius {r} offset ({fx}, {fy}) not found"
            );
            assert_circle(&circles[0], cx, cy, r);
            assert!(circles[0].score > 0.6, "{circles:?}");
        }
    }
}

#[test]
fn two_separated_discs_are_both_found() {
    let list = [(30.3, 40.6, 12.0), (95.7, 45.2, 20.0)];
    let mask = discs(130, 80, &list);
    let circles = detect(&mask, 130, 80, &HoughConfig::default()).unwrap();
    assert!(circles.len() >= 2, "{circles:?}");
    for &(cx, cy, r) in &list {
        let found = circles[..2]
            .iter()
            .find(|c| (c.center_px[0] - cx).hypot(c.center_px[1] - cy) < 2.0)
            .unwrap_or_else(|| panic!("({cx}, {cy}) missing from {circles:?}"));
        assert_circle(found, cx, cy, r);
    }
}

#[test]
fn disc_clipped_by_the_border_is_found() {
    // A third of the disc lies left of the image.
    let (cx, cy, r) = (5.4, 30.2, 15.0);
    let mask = discs(60, 60, &[(cx, cy, r)]);
    let circles = detect(&mask, 60, 60, &HoughConfig::default()).unwrap();
    assert!(!circles.is_empty());
    let c = &circles[0];
    assert!(
        (c.center_px[0] - cx).hypot(c.center_px[1] - cy) <= 1.0,
        "{c:?}"
    );
    assert!((c.radius_px - r).abs() <= 1.0, "{c:?}");
}

#[test]
fn square_scores_far_below_a_disc() {
    let (w, h) = (60, 60);
    let mut mask = vec![0u8; w * h];
    for y in 15..45 {
        for x in 15..45 {
            mask[y * w + x] = 1;
        }
    }
    let config = HoughConfig {
        min_votes_ratio: 0.05,
        ..HoughConfig::default()
    };
    let square = detect(&mask, w, h, &config).unwrap();
    let disc = detect(&discs(w, h, &[(30.0, 30.0, 15.0)]), w, h, &config).unwrap();
    let best_square = square.first().map_or(0.0, |c| c.score);
    assert!(best_square < 0.5 * disc[0].score, "{square:?} vs {disc:?}");
    assert!(
        detect(&mask, w, h, &HoughConfig::default())
            .unwrap()
            .is_empty(),
        "{square:?}"
    );
}

#[test]
fn thin_line_gives_no_circle() {
    let (w, h) = (80, 40);
    let mut mask = vec![0u8; w * h];
    for x in 5..75 {
        mask[20 * w + x] = 1;
        mask[(10 + x / 4) * w + x] = 1;
    }
    let circles = detect(&mask, w, h, &HoughConfig::default()).unwrap();
    assert!(circles.is_empty(), "{circles:?}");
}

#[test]
fn noise_specks_give_no_circle() {
    let (w, h) = (100, 100);
    let mut mask = vec![0u8; w * h];
    // A deterministic scatter of single pixels and 2×2 specks.
    let mut state = 12345u64;
    for i in 0..300 {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let x = (state >> 33) as usize % (w - 1);
        let y = (state >> 17) as usize % (h - 1);
        mask[y * w + x] = 1;
        if i % 3 == 0 {
            mask[y * w + x + 1] = 1;
            mask[(y + 1) * w + x] = 1;
            mask[(y + 1) * w + x + 1] = 1;
        }
    }
    let circles = detect(&mask, w, h, &HoughConfig::default()).unwrap();
    assert!(circles.is_empty(), "{circles:?}");
}

#[test]
fn empty_and_tiny_inputs_give_no_circle() {
    let config = HoughConfig::default();
    assert!(detect(&[], 0, 0, &config).unwrap().is_empty());
    assert!(detect(&[], 0, 7, &config).unwrap().is_empty());
    assert!(detect(&[1], 1, 1, &config).unwrap().is_empty());
    assert!(detect(&[1, 0, 1, 1], 2, 2, &config).unwrap().is_empty());
    assert!(detect(&[0; 100], 10, 10, &config).unwrap().is_empty());
    assert!(detect(&[1; 100], 10, 10, &config).unwrap().is_empty());
}

#[test]
fn wrong_data_length_is_an_error() {
    let config = HoughConfig::default();
    assert!(matches!(
        detect(&[0; 10], 4, 3, &config),
        Err(HoughError::DataLength { .. })
    ));
    assert!(matches!(
        detect(&[0; 10], usize::MAX, 3, &config),
        Err(HoughError::DataLength { .. })
    ));
}

#[test]
fn bad_configurations_are_errors() {
    let good = HoughConfig::default();
    assert!(good.check().is_ok());
    let bad = [
        HoughConfig {
            r_min_px: 0.5,
            ..good
        },
        HoughConfig {
            r_min_px: f64::NAN,
            ..good
        },
        HoughConfig {
            r_max_px: 3.0,
            ..good
        },
        HoughConfig {
            r_max_px: f64::INFINITY,
            ..good
        },
        HoughConfig {
            min_votes_ratio: 0.0,
            ..good
        },
        HoughConfig {
            min_votes_ratio: f64::NAN,
            ..good
        },
        HoughConfig {
            max_circles: 0,
            ..good
        },
        HoughConfig {
            min_center_distance_px: -1.0,
            ..good
        },
    ];
    for config in bad {
        assert!(config.check().is_err(), "{config:?}");
        assert!(detect(&[0; 4], 2, 2, &config).is_err(), "{config:?}");
    }
}

#[test]
fn circles_are_sorted_and_separated() {
    let mask = discs(
        120,
        60,
        &[(20.0, 30.0, 10.0), (60.0, 30.0, 15.0), (100.0, 28.0, 6.0)],
    );
    let config = HoughConfig::default();
    let circles = detect(&mask, 120, 60, &config).unwrap();
    assert_eq!(circles.len(), 3, "{circles:?}");
    for pair in circles.windows(2) {
        assert!(pair[0].score >= pair[1].score);
    }
    for (i, a) in circles.iter().enumerate() {
        for b in &circles[i + 1..] {
            let d = (a.center_px[0] - b.center_px[0]).hypot(a.center_px[1] - b.center_px[1]);
            assert!(d >= config.min_center_distance_px);
        }
    }
}

proptest! {
    #[test]
    fn random_masks_never_panic(
        width in 0usize..40,
        height in 0usize..40,
        bytes in proptest::collection::vec(0u8..3, 0..1600),
        r_min in 1.0f64..10.0,
        r_span in 0.0f64..30.0,
    ) {
        let config = HoughConfig { r_min_px: r_min, r_max_px: r_min + r_span, ..HoughConfig::default() };
        let mut data = bytes;
        data.truncate(width * height);
        let length_ok = data.len() == width * height;
        let result = detect(&data, width, height, &config);
        prop_assert_eq!(result.is_ok(), length_ok);
        for circle in result.unwrap_or_default() {
            prop_assert!(circle.score.is_finite() && circle.radius_px.is_finite());
            let margin = MAX_FIT_SHIFT_PX + 1.0;
            prop_assert!(circle.center_px[0] >= -margin && circle.center_px[1] >= -margin);
            prop_assert!(circle.center_px[0] <= width as f64 + margin);
            prop_assert!(circle.center_px[1] <= height as f64 + margin);
        }
    }
}

/// A close ball's mask as the detector saw it in a rendered frame (its local view, 83×83,
/// `#` set): a flattened highlight on top, a shadow's bulge below. The accumulator's peak
/// lies a few pixels from the centre the rim agrees on; the fit must still be taken.
#[test]
fn a_close_ball_with_an_uneven_rim_is_found() {
    let text = include_str!("../../tests/data/close-ball-mask.txt");
    let rows: Vec<&str> = text.lines().collect();
    let (width, height) = (rows[0].len(), rows.len());
    let mask: Vec<u8> = rows
        .iter()
        .flat_map(|row| row.bytes().map(|b| u8::from(b == b'#')))
        .collect();
    let circles = detect(&mask, width, height, &HoughConfig::default()).unwrap();
    let c = circles.first().expect("no circle");
    assert!(c.score > 0.75, "{c:?}");
    assert!((c.radius_px - 30.0).abs() < 1.5, "{c:?}");
    assert!(
        (c.center_px[0] - 40.7).hypot(c.center_px[1] - 41.8) < 1.5,
        "{c:?}"
    );
}
