//! Tests of the candidate stage on drawn photos unlike the MiRo's frames: a close ball
//! bigger than the Hough range, a far ball a few pixels wide, a ball whose shaded side
//! is paler than the colour window, and a highlight on a red toy.

#![allow(clippy::unwrap_used)]

use super::*;

/// A green carpet with a faint texture.
fn carpet(w: u32, h: u32) -> RgbImage {
    let mut data = Vec::with_capacity((w * h * 3) as usize);
    for y in 0..h {
        for x in 0..w {
            let t = ((x * 7 + y * 13) % 11) as u8;
            data.extend_from_slice(&[40 + t, 110 + t, 50 + t]);
        }
    }
    RgbImage::new(w, h, data).unwrap()
}

/// Paints a disc: `colour(dy / radius)` gives the RGB from the top (−1) to the bottom (1).
fn disc(image: &mut RgbImage, c: [f64; 2], r: f64, colour: impl Fn(f64) -> [u8; 3]) {
    for y in 0..image.height() {
        for x in 0..image.width() {
            let (dx, dy) = (f64::from(x) - c[0], f64::from(y) - c[1]);
            if dx.hypot(dy) <= r {
                image.set_pixel(x, y, colour(dy / r));
            }
        }
    }
}

fn orange(t: f64) -> [u8; 3] {
    let k = 0.95 - 0.25 * t;
    [(235.0 * k) as u8, (120.0 * k) as u8, (25.0 * k) as u8]
}

fn pinhole(w: u32, h: u32, f: f64) -> CameraModel {
    CameraModel::pinhole(f, f, f64::from(w - 1) / 2.0, f64::from(h - 1) / 2.0, w, h)
}

/// The proposal nearest `centre`, as (centre distance, radius).
fn nearest(image: &RgbImage, model: Option<&CameraModel>, centre: [f64; 2]) -> Option<(f64, f64)> {
    let detector = Detector::new(DetectorConfig::default()).unwrap();
    let proposals = detector.propose(image, model, &mut NoClock).unwrap();
    proposals
        .items
        .iter()
        .map(|p| {
            let c = p.frame.center_px;
            (
                (c[0] - centre[0]).hypot(c[1] - centre[1]),
                p.frame.radius_px,
            )
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

#[test]
fn a_close_ball_bigger_than_the_hough_range_is_proposed_with_and_without_a_camera() {
    let mut image = carpet(224, 224);
    let (c, r) = ([120.0, 105.0], 70.0);
    disc(&mut image, c, r, orange);
    let model = pinhole(224, 224, 200.0);
    for m in [None, Some(&model)] {
        let (d, radius) = nearest(&image, m, c).expect("a proposal");
        assert!(d < 6.0, "centre {d} px off (model {})", m.is_some());
        assert!(
            (radius - r).abs() < 0.15 * r,
            "radius {radius} (model {})",
            m.is_some()
        );
    }
}

#[test]
fn a_far_ball_a_few_pixels_wide_is_proposed() {
    for r in [2.0, 3.0, 4.5] {
        let mut image = carpet(320, 240);
        let c = [200.0, 60.0];
        disc(&mut image, c, r, orange);
        let (d, radius) = nearest(&image, None, c).expect("a proposal");
        assert!(d < 1.5, "r {r}: centre {d} px off");
        assert!((radius - r).abs() < 1.5, "r {r}: radius {radius}");
    }
}

#[test]
fn a_shaded_side_paler_than_the_window_grows_from_the_lit_side() {
    let mut image = carpet(320, 240);
    let (c, r) = ([150.0, 120.0], 16.0);
    // The lower half is a dull orange (saturation about 0.35), inside the limits only.
    disc(&mut image, c, r, |t| {
        if t < 0.0 { orange(t) } else { [150, 120, 97] }
    });
    let seeded = nearest(&image, None, c).expect("a proposal");
    assert!((seeded.1 - r).abs() < 0.2 * r, "radius {}", seeded.1);
    // The strict window alone sees a half disc.
    let strict = Detector::new(DetectorConfig {
        seeded: false,
        ..DetectorConfig::default()
    })
    .unwrap();
    let proposals = strict.propose(&image, None, &mut NoClock).unwrap();
    let best = proposals.items.iter().map(|p| {
        let q = p.frame.center_px;
        (q[0] - c[0]).hypot(q[1] - c[1])
    });
    let strict_centre_error = best.fold(f64::INFINITY, f64::min);
    assert!(
        seeded.0 < strict_centre_error,
        "grown {} px, strict {} px",
        seeded.0,
        strict_centre_error
    );
}

#[test]
fn a_highlight_on_a_red_toy_is_not_a_ball() {
    let mut image = carpet(320, 240);
    let c = [160.0, 120.0];
    disc(&mut image, c, 40.0, |_| [225, 20, 15]);
    // A pale orange highlight, round and small, in the middle of the red.
    disc(&mut image, [150.0, 110.0], 6.0, |_| [240, 190, 140]);
    let detector = Detector::new(DetectorConfig::default()).unwrap();
    let proposals = detector.propose(&image, None, &mut NoClock).unwrap();
    for p in &proposals.items {
        let q = p.frame.center_px;
        assert!(
            (q[0] - 150.0).hypot(q[1] - 110.0) > 4.0 || p.frame.radius_px > 20.0,
            "the highlight was proposed: {:?}",
            p.frame
        );
    }
}
