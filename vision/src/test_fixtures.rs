//! Test fixtures shared by the vision stages' tests (and, with the `test-support`
//! feature, by the agent's).

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

/// A 640×360 Kannala–Brandt fisheye with about 120° of horizontal field of view, close to
/// a MiRo camera's calibration.
pub fn miro_lens() -> crate::camera::CameraModel {
    use crate::camera::{CameraModel, Distortion, Intrinsics};
    CameraModel {
        intrinsics: Intrinsics {
            fx_px: 344.0,
            fy_px: 344.0,
            cx_px: 320.0,
            cy_px: 180.0,
            width_px: 640,
            height_px: 360,
        },
        distortion: Distortion::KannalaBrandt {
            k1: -0.1,
            k2: 0.005,
            k3: 0.0,
            k4: 0.0,
        },
    }
}

/// An orange ball's colour window.
pub fn orange() -> crate::colour::hsv::HsvThresholds {
    crate::colour::hsv::HsvThresholds {
        hue_lo_deg: 15.0,
        hue_hi_deg: 45.0,
        sat_min: 0.5,
        sat_max: 1.0,
        val_min: 0.4,
        val_max: 1.0,
    }
}
