//! Tests of the morphology: specks and holes on a disc, and the running-count passes
//! against brute force on random masks.

#![allow(clippy::unwrap_used)]

use super::*;
use proptest::prelude::*;

use crate::test_fixtures::disc_mask;

#[test]
fn opening_removes_specks_and_closing_fills_holes() {
    let disc = disc_mask();
    let mut specked = disc.clone();
    for (x, y) in [
        (5, 5),
        (150, 100),
        (100, 10),
        (101, 11),
        (130, 60),
        (131, 60),
        (130, 61),
    ] {
        specked.set(x, y, true);
    }
    let opened = open(&specked, 2);
    for (x, y) in [(5, 5), (150, 100), (100, 10), (101, 11), (130, 60)] {
        assert!(!opened.get(x, y));
    }
    // Opening never adds pixels and keeps the disc's bulk.
    for (o, s) in opened.data().iter().zip(specked.data()) {
        assert!(o <= s);
    }
    assert!(opened.count() as f64 > 0.97 * disc.count() as f64);

    let mut holed = disc.clone();
    let holes = [(70, 55), (71, 55), (60, 50), (80, 62), (81, 63)];
    for &(x, y) in &holes {
        holed.set(x, y, false);
    }
    let closed = close(&holed, 1);
    for &(x, y) in &holes {
        assert!(closed.get(x, y));
    }
    for (c, s) in closed.data().iter().zip(holed.data()) {
        assert!(c >= s);
    }
    assert_eq!(open(&disc, 0), disc);
    assert_eq!(close(&disc, 0), disc);
}

/// Brute-force erosion or dilation with the clipped square window.
fn brute(m: &Mask, r: u32, erode: bool) -> Mask {
    let (w, h) = (m.width() as i64, m.height() as i64);
    let mut out = Mask::zeros(m.width(), m.height()).unwrap();
    let r = i64::from(r);
    for y in 0..h {
        for x in 0..w {
            let mut all = true;
            let mut any = false;
            for yy in (y - r).max(0)..=(y + r).min(h - 1) {
                for xx in (x - r).max(0)..=(x + r).min(w - 1) {
                    let on = m.get(xx as u32, yy as u32);
                    all &= on;
                    any |= on;
                }
            }
            out.set(x as u32, y as u32, if erode { all } else { any });
        }
    }
    out
}

proptest! {
    #[test]
    fn morphology_matches_brute_force(
        w in 1u32..14,
        h in 1u32..14,
        bits in proptest::collection::vec(0u8..2, 196),
        radius in 0u32..6,
    ) {
        let m = Mask::new(w, h, bits[..(w * h) as usize].to_vec()).unwrap();
        prop_assert_eq!(erode(&m, radius), brute(&m, radius, true));
        prop_assert_eq!(dilate(&m, radius), brute(&m, radius, false));
    }
}

#[test]
fn fill_holes_fills_enclosed_background_only() {
    // A ring with a hole, and a ring cut open to the border.
    let mut m = Mask::zeros(40, 20).unwrap();
    for y in 2..12 {
        for x in 2..12 {
            m.set(x, y, !(4..10).contains(&x) || !(4..10).contains(&y));
        }
    }
    for y in 0..10 {
        for x in 20..30 {
            m.set(x, y, !(22..28).contains(&x) || !(2..8).contains(&y));
        }
    }
    for y in 0..2 {
        for x in 24..26 {
            m.set(x, y, false);
        }
    }
    let filled = fill_holes(&m);
    assert!(
        filled.get(6, 6) && filled.get(9, 9),
        "the closed ring's hole is filled"
    );
    assert!(
        !filled.get(24, 4),
        "the open ring's inside is reached from the border"
    );
    assert!(!filled.get(0, 0) && !filled.get(15, 15));
    // Nothing selected is cleared, and the only additions are the hole.
    assert_eq!(filled.count(), m.count() + 36);
    assert_eq!(fill_holes(&Mask::zeros(0, 0).unwrap()).count(), 0);
}
