//! Tests of the colour segmentation stage: known conversions, a synthetic scene, the lookup
//! table against the exact mask, red wrap-around, morphology, components, lighting
//! adaptation and garbage inputs.

#![allow(clippy::unwrap_used)]

use super::*;
use crate::colour::components::largest_components;
use crate::colour::morphology::{close, open};
use crate::image::ImageError;
use crate::test_fixtures::orange;
use approx::assert_abs_diff_eq;
use proptest::prelude::*;

/// Orange ball thresholds.
/// Limits wide enough for any orange ball.
fn orange_limits() -> HsvThresholds {
    HsvThresholds {
        hue_lo_deg: 5.0,
        hue_hi_deg: 55.0,
        sat_min: 0.3,
        sat_max: 1.0,
        val_min: 0.15,
        val_max: 1.0,
    }
}

/// A deterministic pseudo-random byte per pixel and seed.
fn noise(x: u32, y: u32, seed: u32) -> u8 {
    let mut h = x.wrapping_mul(0x9E37_79B1) ^ y.wrapping_mul(0x85EB_CA77) ^ seed;
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^= h >> 12;
    (h & 0xFF) as u8
}

const W: u32 = 160;
const H: u32 = 120;
const CENTRE: [f64; 2] = [70.3, 55.7];
const RADIUS: f64 = 20.0;
const ORANGE: [u8; 3] = [255, 128, 0];

/// A textured green floor with a white blob, and an orange disc whose edge pixels blend
/// the two colours by 4×4-supersampled coverage (`antialias`) or not.
fn scene(antialias: bool) -> RgbImage {
    let mut img = RgbImage::filled(W, H, [0, 0, 0]).unwrap();
    for y in 0..H {
        for x in 0..W {
            let n = |s| i32::from(noise(x, y, s) % 40) - 20;
            let mut floor = [(40 + n(1)) as u8, (130 + n(2)) as u8, (45 + n(3)) as u8];
            let (dx, dy) = (f64::from(x) - 125.0, f64::from(y) - 30.0);
            if dx * dx + dy * dy <= 100.0 {
                floor = [250, 250, 245];
            }
            let coverage = if antialias {
                let mut inside = 0;
                for i in 0..4 {
                    for j in 0..4 {
                        let u = f64::from(x) - 0.375 + 0.25 * f64::from(i);
                        let v = f64::from(y) - 0.375 + 0.25 * f64::from(j);
                        inside += i32::from((u - CENTRE[0]).hypot(v - CENTRE[1]) <= RADIUS);
                    }
                }
                f64::from(inside) / 16.0
            } else {
                f64::from(u8::from(in_disc(x, y)))
            };
            let mut rgb = [0u8; 3];
            for c in 0..3 {
                let mixed =
                    coverage * f64::from(ORANGE[c]) + (1.0 - coverage) * f64::from(floor[c]);
                rgb[c] = mixed.round() as u8;
            }
            img.set_pixel(x, y, rgb);
        }
    }
    img
}

fn dist(x: u32, y: u32) -> f64 {
    (f64::from(x) - CENTRE[0]).hypot(f64::from(y) - CENTRE[1])
}

fn in_disc(x: u32, y: u32) -> bool {
    dist(x, y) <= RADIUS
}

#[test]
fn known_colours() {
    let cases = [
        ((255, 0, 0), (0.0, 1.0, 1.0)),
        ((0, 255, 0), (120.0, 1.0, 1.0)),
        ((0, 0, 255), (240.0, 1.0, 1.0)),
        ((128, 128, 128), (0.0, 0.0, 128.0 / 255.0)),
        ((255, 128, 0), (128.0 * 60.0 / 255.0, 1.0, 1.0)),
        ((200, 100, 50), (20.0, 0.75, 200.0 / 255.0)),
        ((0, 0, 0), (0.0, 0.0, 0.0)),
        ((255, 255, 255), (0.0, 0.0, 1.0)),
        ((255, 0, 255), (300.0, 1.0, 1.0)),
    ];
    for ((r, g, b), (h, s, v)) in cases {
        let got = rgb_to_hsv(r, g, b);
        assert_abs_diff_eq!(got.0, h, epsilon = 1e-12);
        assert_abs_diff_eq!(got.1, s, epsilon = 1e-12);
        assert_abs_diff_eq!(got.2, v, epsilon = 1e-12);
    }
}

#[test]
fn scene_mask_is_the_disc_up_to_its_edge_ring() {
    let img = scene(true);
    for m in [
        mask_exact(&img, &orange()).unwrap(),
        mask(&img, &orange()).unwrap(),
    ] {
        for y in 0..H {
            for x in 0..W {
                if (dist(x, y) - RADIUS).abs() > 1.0 {
                    assert_eq!(m.get(x, y), in_disc(x, y), "pixel ({x}, {y})");
                }
            }
        }
    }
}

#[test]
fn lut_agrees_with_exact_mask_outside_the_quantisation_band() {
    let th = orange();
    let lut = MaskLut::new(&th).unwrap();
    let exact = |r: u8, g: u8, b: u8| {
        let (h, s, v) = rgb_to_hsv(r, g, b);
        th.contains(h, s, v)
    };
    let centre = |c: u8| (c & !(LUT_CELL_LEVELS - 1)) + LUT_CELL_LEVELS / 2;
    let mut disagreements = 0u32;
    for r in 0..=255u8 {
        for g in 0..=255u8 {
            for b in 0..=255u8 {
                let answer = lut.accepts(r, g, b);
                if answer != exact(r, g, b) {
                    disagreements += 1;
                    // The table gives the exact answer for a colour at most 4 levels away
                    // per channel: the pixel lies in the band along the boundary.
                    let (cr, cg, cb) = (centre(r), centre(g), centre(b));
                    assert!(cr.abs_diff(r) <= 4 && cg.abs_diff(g) <= 4 && cb.abs_diff(b) <= 4);
                    assert_eq!(answer, exact(cr, cg, cb));
                }
            }
        }
    }
    // The band is a thin shell: a few per cent of the colour cube at most.
    let fraction = f64::from(disagreements) / f64::from(1u32 << 24);
    assert!(fraction < 0.02, "{fraction}");
    // Away from the disc's edge ring the scene's two masks agree exactly.
    let img = scene(true);
    let (a, b) = (mask_exact(&img, &th).unwrap(), lut.apply(&img));
    for y in 0..H {
        for x in 0..W {
            if (dist(x, y) - RADIUS).abs() > 1.0 {
                assert_eq!(a.get(x, y), b.get(x, y));
            }
        }
    }
}

#[test]
fn red_window_wraps_through_zero() {
    let red = HsvThresholds {
        hue_lo_deg: 340.0,
        hue_hi_deg: 20.0,
        sat_min: 0.5,
        sat_max: 1.0,
        val_min: 0.3,
        val_max: 1.0,
    };
    red.check().unwrap();
    assert_abs_diff_eq!(red.hue_width_deg(), 40.0);
    let lut = MaskLut::new(&red).unwrap();
    let cases = [
        ([255, 0, 0], true),
        ([255, 0, 40], true),   // 350.6°
        ([255, 60, 0], true),   // 14.1°
        ([255, 128, 0], false), // 30.1°
        ([255, 0, 200], false), // 312.9°
        ([0, 255, 0], false),
    ];
    for (rgb, expected) in cases {
        let img = RgbImage::filled(2, 2, rgb).unwrap();
        assert_eq!(
            mask_exact(&img, &red).unwrap().count(),
            4 * usize::from(expected),
            "{rgb:?}"
        );
        assert_eq!(
            lut.apply(&img).count(),
            4 * usize::from(expected),
            "{rgb:?}"
        );
    }
}

#[test]
fn adaptation_follows_dim_light_within_limits() {
    // A ball under dim light: value 0.25..0.45, hue around 33°.
    let samples: Vec<(f64, f64, f64)> = (0..200)
        .map(|i| {
            let t = f64::from(i) / 199.0;
            (31.0 + 4.0 * t, 0.7 + 0.2 * t, 0.25 + 0.2 * (1.0 - t))
        })
        .collect();
    let th = orange();
    let limits = orange_limits();
    let once = adapt(&th, &samples, 0.5, &limits).unwrap();
    assert!(once.val_min < th.val_min);
    once.check().unwrap();
    // Repeated adaptation converges on the targets, clamped by the limits.
    let mut t = th;
    for _ in 0..100 {
        t = adapt(&t, &samples, 0.5, &limits).unwrap();
    }
    assert_abs_diff_eq!(t.val_min, 0.26 - ADAPT_MARGIN, epsilon = 0.011);
    assert_abs_diff_eq!(t.sat_max, 0.89 + ADAPT_MARGIN, epsilon = 0.011);
    assert_abs_diff_eq!(t.hue_width_deg(), 30.0, epsilon = 1e-9);
    assert_abs_diff_eq!(t.hue_lo_deg + 15.0, 33.0, epsilon = 0.1);
    // Tighter limits hold the bounds.
    let tight = HsvThresholds {
        val_min: 0.3,
        hue_lo_deg: 14.0,
        hue_hi_deg: 46.0,
        ..limits
    };
    let mut t = th;
    for _ in 0..100 {
        t = adapt(&t, &samples, 1.0, &tight).unwrap();
        assert!(t.val_min >= 0.3 && t.hue_lo_deg >= 14.0 && t.hue_hi_deg <= 46.0 + 1e-9);
    }
    assert_abs_diff_eq!(t.val_min, 0.3);
    assert_abs_diff_eq!(t.hue_hi_deg, 46.0, epsilon = 1e-9);
    // One call moves the hue window by at most the step.
    assert!((once.hue_lo_deg - th.hue_lo_deg).abs() <= ADAPT_MAX_HUE_STEP_DEG + 1e-12);
    // Order does not matter; too few samples change nothing; rate 0 changes nothing.
    let mut reversed = samples.clone();
    reversed.reverse();
    assert_eq!(adapt(&th, &reversed, 0.5, &limits).unwrap(), once);
    assert_eq!(adapt(&th, &samples[..10], 0.5, &limits).unwrap(), th);
    assert_eq!(adapt(&th, &samples, 0.0, &limits).unwrap(), th);
}

#[test]
fn adaptation_keeps_a_red_window_inside_wrapping_limits() {
    let red = HsvThresholds {
        hue_lo_deg: 345.0,
        hue_hi_deg: 15.0,
        ..orange()
    };
    let limits = HsvThresholds {
        hue_lo_deg: 340.0,
        hue_hi_deg: 25.0,
        ..orange_limits()
    };
    let samples: Vec<(f64, f64, f64)> = (0..100).map(|_| (30.0, 0.8, 0.8)).collect();
    let mut t = red;
    for _ in 0..50 {
        t = adapt(&t, &samples, 1.0, &limits).unwrap();
        t.check().unwrap();
    }
    assert_abs_diff_eq!(t.hue_lo_deg, 355.0, epsilon = 1e-9);
    assert_abs_diff_eq!(t.hue_hi_deg, 25.0, epsilon = 1e-9);
}

#[test]
fn bad_sizes_and_thresholds_are_errors() {
    assert!(matches!(
        RgbImage::new(4, 3, vec![0; 35]),
        Err(ImageError::DataLength {
            expected: 36,
            actual: 35,
            ..
        })
    ));
    assert!(RgbImage::new(u32::MAX, u32::MAX, vec![]).is_err());
    assert!(RgbImage::filled(u32::MAX, u32::MAX, [0; 3]).is_err());
    assert!(Mask::new(2, 2, vec![0, 1, 2, 0]).is_err());
    assert!(Mask::new(2, 2, vec![0, 1, 1]).is_err());
    assert!(Mask::zeros(u32::MAX, u32::MAX).is_err());
    let bad = [
        HsvThresholds {
            hue_lo_deg: f64::NAN,
            ..orange()
        },
        HsvThresholds {
            hue_hi_deg: 361.0,
            ..orange()
        },
        HsvThresholds {
            sat_min: -0.1,
            ..orange()
        },
        HsvThresholds {
            val_max: f64::INFINITY,
            ..orange()
        },
        HsvThresholds {
            sat_min: 0.9,
            sat_max: 0.8,
            ..orange()
        },
        HsvThresholds {
            val_min: 0.9,
            val_max: 0.8,
            ..orange()
        },
    ];
    let img = RgbImage::filled(3, 3, ORANGE).unwrap();
    for th in bad {
        assert!(th.check().is_err(), "{th:?}");
        assert!(MaskLut::new(&th).is_err());
        assert!(mask(&img, &th).is_err());
        assert!(mask_exact(&img, &th).is_err());
        assert!(adapt(&th, &[], 0.5, &orange_limits()).is_err());
        assert!(adapt(&orange(), &[], 0.5, &th).is_err());
    }
    for rate in [-0.1, 1.5, f64::NAN] {
        assert!(matches!(
            adapt(&orange(), &[], rate, &orange_limits()),
            Err(HsvError::BadRate(_))
        ));
    }
}

#[test]
fn thresholds_round_trip_through_toml() {
    let text = toml::to_string(&orange()).unwrap();
    let back: HsvThresholds = toml::from_str(&text).unwrap();
    assert_eq!(back, orange());
    assert!(toml::from_str::<HsvThresholds>("hue_lo_deg = 1.0").is_err());
}

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        -10.0..370.0f64,
        -0.5..1.5f64,
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(0.0),
        Just(1.0),
        Just(360.0),
    ]
}

fn any_thresholds() -> impl Strategy<Value = HsvThresholds> {
    (
        any_f64(),
        any_f64(),
        any_f64(),
        any_f64(),
        any_f64(),
        any_f64(),
    )
        .prop_map(|(a, b, c, d, e, f)| HsvThresholds {
            hue_lo_deg: a,
            hue_hi_deg: b,
            sat_min: c,
            sat_max: d,
            val_min: e,
            val_max: f,
        })
}

proptest! {
    #[test]
    fn random_inputs_never_panic(
        w in 0u32..12,
        h in 0u32..12,
        extra in 0usize..2,
        bytes in proptest::collection::vec(any::<u8>(), 0..500),
        th in any_thresholds(),
        limits in any_thresholds(),
        samples in proptest::collection::vec((any_f64(), any_f64(), any_f64()), 0..60),
        rate in any_f64(),
        radius in 0u32..20,
    ) {
        let need = (w * h * 3) as usize + extra;
        let data: Vec<u8> = bytes.iter().copied().cycle().take(if bytes.is_empty() { 0 } else { need }).collect();
        let masks = RgbImage::new(w, h, data).map(|img| (mask_exact(&img, &th), mask(&img, &th)));
        if let Ok((Ok(a), Ok(b))) = masks {
            prop_assert_eq!(a.data().len(), b.data().len());
            let _ = largest_components(&open(&b, radius), 0, 3);
            let _ = close(&a, radius);
        }
        if let Ok(t) = adapt(&th, &samples, rate, &limits) {
            prop_assert!(t.check().is_ok());
        }
    }

    #[test]
    fn adaptation_stays_within_limits(
        samples in proptest::collection::vec((0.0..360.0f64, 0.0..=1.0f64, 0.0..=1.0f64), 32..80),
        rate in 0.0..=1.0f64,
        shift in 0.0..360.0f64,
    ) {
        let limits = HsvThresholds {
            hue_lo_deg: shift,
            hue_hi_deg: (shift + 60.0) % 360.0,
            ..orange_limits()
        };
        let current = HsvThresholds {
            hue_lo_deg: (shift + 10.0) % 360.0,
            hue_hi_deg: (shift + 40.0) % 360.0,
            ..orange()
        };
        let t = adapt(&current, &samples, rate, &limits).unwrap();
        prop_assert!(t.check().is_ok());
        prop_assert!(t.sat_min >= limits.sat_min && t.sat_max <= limits.sat_max);
        prop_assert!(t.val_min >= limits.val_min && t.val_max <= limits.val_max);
        let offset = (t.hue_lo_deg - limits.hue_lo_deg).rem_euclid(360.0);
        prop_assert!(offset.min(360.0 - offset) < 1e-9 || offset <= 30.0 + 1e-9, "{offset}");
        prop_assert!((t.hue_width_deg() - 30.0).abs() < 1e-9);
    }

}
