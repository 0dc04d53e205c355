//! Tests of the two-colour ball mask: a patterned ball's pieces become one disc that the
//! Hough transform finds, white alone never selects anything, and a plain ball's mask is
//! left as it was.

#![allow(clippy::unwrap_used)]

use super::*;
use crate::circle::Circle;
use crate::colour::hough::{self, HoughConfig};

const SIDE: u32 = 80;
const CENTRE: [f64; 2] = [40.3, 39.6];
const RADIUS: f64 = 24.0;

/// Patch centres as (angle from the view's x axis, fraction of the radius): one in the
/// middle and five cutting deep into the outline.
fn patches() -> Vec<[f64; 2]> {
    let mut p = vec![[0.0, 0.0]];
    for k in 0..5 {
        p.push([f64::from(k) * 72.0_f64.to_radians(), 0.9]);
    }
    p
}

/// The ball colour's mask and the patches' colour mask of a patterned ball, with white
/// speckle in the background around it (a noisy floor).
fn patterned() -> (Mask, Mask) {
    let mut ball = Mask::zeros(SIDE, SIDE).unwrap();
    let mut white = Mask::zeros(SIDE, SIDE).unwrap();
    let patch_r = 0.3 * RADIUS;
    for y in 0..SIDE {
        for x in 0..SIDE {
            let (dx, dy) = (f64::from(x) - CENTRE[0], f64::from(y) - CENTRE[1]);
            if dx.hypot(dy) > RADIUS {
                white.set(x, y, (x * 7 + y * 13) % 11 == 0);
                continue;
            }
            let on_patch = patches().iter().any(|&[a, f]| {
                let (px, py) = (f * RADIUS * a.cos(), f * RADIUS * a.sin());
                (dx - px).hypot(dy - py) < patch_r
            });
            ball.set(x, y, !on_patch);
            white.set(x, y, on_patch);
        }
    }
    (ball, white)
}

fn disc(radius: f64) -> Mask {
    let mut m = Mask::zeros(SIDE, SIDE).unwrap();
    for y in 0..SIDE {
        for x in 0..SIDE {
            m.set(
                x,
                y,
                (f64::from(x) - CENTRE[0]).hypot(f64::from(y) - CENTRE[1]) <= radius,
            );
        }
    }
    m
}

/// The hull the detector gives the test ball's region.
fn hull() -> Hull {
    Hull {
        centre_px: CENTRE,
        radius_px: RADIUS * 1.05,
    }
}

fn circles(mask: &Mask) -> Vec<Circle> {
    hough::detect(
        mask.data(),
        SIDE as usize,
        SIDE as usize,
        &HoughConfig::default(),
    )
    .unwrap()
}

fn is_the_ball(c: &Circle) -> bool {
    (c.center_px[0] - CENTRE[0]).hypot(c.center_px[1] - CENTRE[1]) < 1.5
        && (c.radius_px - RADIUS).abs() < 1.5
}

#[test]
fn a_patterned_ball_becomes_one_disc_that_the_hough_transform_finds() {
    let (ball, white) = patterned();
    let cfg = PatternConfig::default();
    let region = region_mask(&ball, &white, &hull(), 2, &cfg);
    let found = circles(&region);
    assert!(found.first().is_some_and(is_the_ball), "{found:?}");
    // Nearly the whole disc, and nothing of the speckle outside the hull.
    let hull = disc(hull().radius_px + 0.5);
    let outside = (region.data().iter().zip(hull.data()))
        .filter(|&(&r, &h)| r > h)
        .count();
    assert_eq!(outside, 0);
    assert!(region.count() as f64 > 0.95 * disc(RADIUS).count() as f64);

    // The ball colour alone is not the ball.
    let found = circles(&crate::colour::morphology::close(&ball, 2));
    assert!(!found.iter().any(is_the_ball), "{found:?}");
}

#[test]
fn white_alone_selects_nothing() {
    let nothing = Mask::zeros(SIDE, SIDE).unwrap();
    let white = disc(RADIUS);
    let cfg = PatternConfig::default();
    assert_eq!(region_mask(&nothing, &white, &hull(), 2, &cfg).count(), 0);
    assert_eq!(join_white(&nothing, &white, &hull(), 12).count(), 0);
}

#[test]
fn a_ball_next_to_white_grows_no_further_than_its_hull() {
    // A plain ball touching a white robot on its right.
    let ball = disc(RADIUS);
    let mut white = Mask::zeros(SIDE, SIDE).unwrap();
    for y in 0..SIDE {
        for x in 0..SIDE {
            white.set(x, y, !ball.get(x, y) && f64::from(x) > CENTRE[0]);
        }
    }
    let cfg = PatternConfig::default();
    let region = region_mask(&ball, &white, &hull(), 2, &cfg);
    // The white robot joins only within the hull, just past the ball's outline.
    for y in 0..SIDE {
        for x in 0..SIDE {
            let d = (f64::from(x) - CENTRE[0]).hypot(f64::from(y) - CENTRE[1]);
            assert!(!region.get(x, y) || d <= hull().radius_px, "({x}, {y})");
        }
    }
    assert!(region.count() >= ball.count());
}

#[test]
fn white_joins_only_within_reach_and_the_hull() {
    // A small ball-coloured square in a white field.
    let mut ball = Mask::zeros(SIDE, SIDE).unwrap();
    for y in 30..40 {
        for x in 30..40 {
            ball.set(x, y, true);
        }
    }
    let white = Mask::new(SIDE, SIDE, vec![1; (SIDE * SIDE) as usize]).unwrap();
    let hull = Hull {
        centre_px: [34.5, 34.5],
        radius_px: 8.0,
    };
    let grown = join_white(&ball, &white, &hull, 12);
    for y in 0..SIDE {
        for x in 0..SIDE {
            if grown.get(x, y) {
                assert!((f64::from(x) - 34.5).hypot(f64::from(y) - 34.5) <= 8.0);
            }
        }
    }
    assert!(
        grown.count() > 180 && grown.count() < 210,
        "{}",
        grown.count()
    );
    // One step of reach adds at most a one-pixel ring.
    let one = join_white(&ball, &white, &hull, 1);
    assert!(one.count() <= 12 * 12 && one.get(29, 34) && !one.get(28, 34));
    // No reach, no white.
    assert_eq!(join_white(&ball, &white, &hull, 0), ball);
}

#[test]
fn only_sparse_blobs_are_searched_as_patterned_balls() {
    use crate::colour::components::joined_components;
    let cfg = PatternConfig::default();
    let blob = |m: &Mask| joined_components(m, 3, 1, 1)[0];
    // A disc, half a disc and a rectangle (a wall marking) cover most of their boxes.
    assert!(cfg.patterned_hull(&blob(&disc(RADIUS))).is_none());
    let mut half = disc(RADIUS);
    let mut bar = Mask::zeros(SIDE, SIDE).unwrap();
    for y in 0..SIDE {
        for x in 0..SIDE {
            half.set(x, y, half.get(x, y) && f64::from(x) < CENTRE[0]);
            bar.set(x, y, (10..50).contains(&x) && (20..30).contains(&y));
        }
    }
    assert!(cfg.patterned_hull(&blob(&half)).is_none());
    assert!(cfg.patterned_hull(&blob(&bar)).is_none());
    // A patterned ball's ball colour does not; its hull is about the ball.
    let (ball, _) = patterned();
    let hull = cfg.patterned_hull(&blob(&ball)).unwrap();
    assert!((hull.radius_px - RADIUS).abs() < 0.1 * RADIUS, "{hull:?}");
    assert!((hull.centre_px[0] - CENTRE[0]).hypot(hull.centre_px[1] - CENTRE[1]) < 2.0);
    let off = PatternConfig {
        enabled: false,
        ..cfg
    };
    assert!(off.patterned_hull(&blob(&ball)).is_none());
}

#[test]
fn settings_are_checked_and_parse_with_defaults() {
    assert!(PatternConfig::default().check().is_ok());
    let bad = PatternConfig {
        join_reach_px: 0,
        ..PatternConfig::default()
    };
    assert!(matches!(bad.check(), Err(PatternError::BadReach { .. })));
    let bad = PatternConfig {
        view_growth: 2.0,
        ..PatternConfig::default()
    };
    assert!(matches!(bad.check(), Err(PatternError::BadFraction { .. })));
    let mut bad = PatternConfig::default();
    bad.white.sat_max = 1.5;
    assert!(matches!(bad.check(), Err(PatternError::White(_))));
    let parsed: PatternConfig = toml::from_str("white_reach_px = 6\nfill_holes = false").unwrap();
    assert_eq!(parsed.white_reach_px, 6);
    assert!(!parsed.fill_holes);
    assert_eq!(parsed.white, PatternConfig::default().white);
    assert!(toml::from_str::<PatternConfig>("reach = 1").is_err());
}
