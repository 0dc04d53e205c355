//! Test fixtures shared by the detection stages' tests.

#![allow(clippy::unwrap_used)]

use crate::image::Mask;

const W: u32 = 160;
const H: u32 = 120;
pub const CENTRE: [f64; 2] = [70.3, 55.7];
pub const RADIUS: f64 = 20.0;

fn in_disc(x: u32, y: u32) -> bool {
    (f64::from(x) - CENTRE[0]).hypot(f64::from(y) - CENTRE[1]) <= RADIUS
}

/// The mask of a disc of radius 20 px centred at (70.3, 55.7) on a 160×120 mask.
pub fn disc_mask() -> Mask {
    let mut m = Mask::zeros(W, H).unwrap();
    for y in 0..H {
        for x in 0..W {
            m.set(x, y, in_disc(x, y));
        }
    }
    m
}
