//! Candidate patches: the square window around a Hough circle, resampled to a fixed
//! 32×32 size so that the HOG descriptor (and hence the classifier) sees every candidate at
//! the same scale whatever its radius in the frame.
//!
//! The window is `window_over_radius × r` pixels wide (2.4 by default: the ball fills about
//! 83 % of the patch and a ring of background shows its outline). Samples are bilinear;
//! windows larger than the patch are box-filtered by averaging several bilinear samples per
//! patch pixel, so that a 40 px ball does not alias. Samples outside the frame repeat the
//! nearest edge pixel, so a ball at the border still gives a full patch.
//!
//! Grey levels are luma (ITU-R BT.601 weights) in [0, 1]. Patch coordinates have x right
//! and y down with the centre of the top-left pixel at (0, 0), like the frame's.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::image::RgbImage;

/// Side of a patch, pixels.
pub const PATCH_SIDE_PX: usize = 32;

/// Pixels in a patch.
pub const PATCH_PIXELS: usize = PATCH_SIDE_PX * PATCH_SIDE_PX;

/// Why a patch could not be extracted or built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PatchError {
    /// The circle's centre or radius is not finite, or the radius is not positive.
    #[error("circle centre ({x_px}, {y_px}) px radius {radius_px} px is not a usable circle")]
    BadCircle {
        /// Centre x, pixels.
        x_px: f64,
        /// Centre y, pixels.
        y_px: f64,
        /// Radius, pixels.
        radius_px: f64,
    },
    /// The window-to-radius ratio is not finite and positive.
    #[error("window_over_radius = {0} is not finite and positive")]
    BadMargin(f64),
    /// The frame has no pixels.
    #[error("cannot extract a patch from an empty image")]
    EmptyImage,
    /// A grey buffer does not hold 32×32 values.
    #[error("a patch needs {PATCH_PIXELS} grey values, got {0}")]
    Length(usize),
    /// A grey value is NaN or infinite.
    #[error("grey value {0} of the patch is not finite")]
    NonFinite(usize),
}

/// How a candidate's window is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PatchConfig {
    /// Side of the square window divided by the circle's radius (2.4: a margin of 0.2 r
    /// around the ball on each side).
    pub window_over_radius: f64,
}

impl Default for PatchConfig {
    fn default() -> Self {
        Self {
            window_over_radius: 2.4,
        }
    }
}

/// A 32×32 greyscale patch, row-major, values nominally in [0, 1].
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    grey: Vec<f32>,
}

/// A 32×32 RGB patch, row-major, 3 bytes per pixel: the same window as [`Patch`] in colour,
/// for the colour check or for storing labelled samples.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RgbPatch {
    data: Vec<u8>,
}

impl RgbPatch {
    /// The row-major RGB8 bytes, `3 × 32 × 32` of them.
    pub fn data(&self) -> &[u8] {
        &self.data
    }

    /// A colour patch of `3 × 32 × 32` row-major RGB8 bytes; fails on a wrong length.
    pub fn from_bytes(data: Vec<u8>) -> Result<Self, PatchError> {
        if data.len() != 3 * PATCH_PIXELS {
            return Err(PatchError::Length(data.len() / 3));
        }
        Ok(RgbPatch { data })
    }

    /// A colour patch whose pixel at `(x, y)` is `f(x, y)`.
    pub fn from_fn_rgb(mut f: impl FnMut(usize, usize) -> [u8; 3]) -> Self {
        let mut data = Vec::with_capacity(3 * PATCH_PIXELS);
        for y in 0..PATCH_SIDE_PX {
            for x in 0..PATCH_SIDE_PX {
                data.extend_from_slice(&f(x, y));
            }
        }
        RgbPatch { data }
    }

    /// The greyscale patch of this colour patch.
    pub fn to_grey(&self) -> Patch {
        let grey = self
            .data
            .chunks_exact(3)
            .map(|p| luma([f32::from(p[0]), f32::from(p[1]), f32::from(p[2])]))
            .collect();
        Patch { grey }
    }
}

impl Patch {
    /// A patch from 32×32 row-major grey values; fails on a wrong length or a non-finite
    /// value.
    pub fn from_grey(grey: Vec<f32>) -> Result<Self, PatchError> {
        if grey.len() != PATCH_PIXELS {
            return Err(PatchError::Length(grey.len()));
        }
        if let Some(i) = grey.iter().position(|v| !v.is_finite()) {
            return Err(PatchError::NonFinite(i));
        }
        Ok(Self { grey })
    }

    /// A patch where pixel (x, y) has the grey value `f(x, y)`.
    pub fn from_fn(mut f: impl FnMut(usize, usize) -> f32) -> Result<Self, PatchError> {
        let mut grey = Vec::with_capacity(PATCH_PIXELS);
        for y in 0..PATCH_SIDE_PX {
            for x in 0..PATCH_SIDE_PX {
                grey.push(f(x, y));
            }
        }
        Self::from_grey(grey)
    }

    /// The row-major grey values.
    pub fn grey(&self) -> &[f32] {
        &self.grey
    }

    /// Grey value of pixel (x, y); coordinates are clamped into the patch.
    pub fn at(&self, x: usize, y: usize) -> f32 {
        let x = x.min(PATCH_SIDE_PX - 1);
        let y = y.min(PATCH_SIDE_PX - 1);
        self.grey[y * PATCH_SIDE_PX + x]
    }

    /// The patch mirrored left–right (a ball seen in a mirror is still a ball: a free
    /// training sample).
    pub fn mirrored(&self) -> Patch {
        let mut grey = self.grey.clone();
        for row in grey.chunks_exact_mut(PATCH_SIDE_PX) {
            row.reverse();
        }
        Patch { grey }
    }

    /// The patch rotated by `angle_rad` (positive turns x towards y, i.e. clockwise on
    /// screen) about its centre, bilinear, corners filled by clamping to the edge. Used to
    /// augment positives, whose content of interest (the disc) stays inside the patch.
    pub fn rotated(&self, angle_rad: f64) -> Patch {
        let c = (PATCH_SIDE_PX as f64 - 1.0) / 2.0;
        let (sin, cos) = angle_rad.sin_cos();
        let mut grey = Vec::with_capacity(PATCH_PIXELS);
        for y in 0..PATCH_SIDE_PX {
            for x in 0..PATCH_SIDE_PX {
                // Inverse map: the output pixel takes the source at the rotated-back position.
                let (dx, dy) = (x as f64 - c, y as f64 - c);
                let sx = c + cos * dx + sin * dy;
                let sy = c - sin * dx + cos * dy;
                grey.push(
                    bilinear(sx, sy, PATCH_SIDE_PX, PATCH_SIDE_PX, |xi, yi| {
                        [self.grey[yi * PATCH_SIDE_PX + xi], 0.0, 0.0]
                    })[0],
                );
            }
        }
        Patch { grey }
    }
}

/// BT.601 luma of an RGB colour given in 0..=255, scaled to [0, 1].
fn luma(rgb: [f32; 3]) -> f32 {
    (0.299 * rgb[0] + 0.587 * rgb[1] + 0.114 * rgb[2]) / 255.0
}

/// Bilinear sample at (x, y) of a `width × height` grid read through `at`, clamping to
/// the edge. Three channels so that grey and colour share it.
fn bilinear(
    x: f64,
    y: f64,
    width: usize,
    height: usize,
    at: impl Fn(usize, usize) -> [f32; 3],
) -> [f32; 3] {
    let max_x = (width - 1) as f64;
    let max_y = (height - 1) as f64;
    let x = x.clamp(0.0, max_x);
    let y = y.clamp(0.0, max_y);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
    let (x0, y0) = (x0 as usize, y0 as usize);
    let (x1, y1) = ((x0 + 1).min(width - 1), (y0 + 1).min(height - 1));
    let (a, b, c, d) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
    let mut out = [0.0; 3];
    for k in 0..3 {
        let top = a[k] + (b[k] - a[k]) * fx;
        let bottom = c[k] + (d[k] - c[k]) * fx;
        out[k] = top + (bottom - top) * fy;
    }
    out
}

/// Checks the inputs of an extraction.
fn check(
    image: &RgbImage,
    center_px: [f64; 2],
    radius_px: f64,
    config: &PatchConfig,
) -> Result<(), PatchError> {
    let usable =
        center_px.iter().all(|v| v.is_finite()) && radius_px.is_finite() && radius_px > 0.0;
    if !usable {
        return Err(PatchError::BadCircle {
            x_px: center_px[0],
            y_px: center_px[1],
            radius_px,
        });
    }
    let m = config.window_over_radius;
    if !(m.is_finite() && m > 0.0) {
        return Err(PatchError::BadMargin(m));
    }
    if image.width() == 0 || image.height() == 0 {
        return Err(PatchError::EmptyImage);
    }
    Ok(())
}

/// Bilinear taps along one axis: lower index, upper index and the upper weight, for
/// `count` samples starting at `first_px` spaced `step_px`, clamped to `0..len`.
fn taps(first_px: f64, step_px: f64, count: usize, len: usize) -> Vec<(usize, usize, f32)> {
    let max = (len - 1) as f64;
    (0..count)
        .map(|i| {
            let p = (first_px + i as f64 * step_px).clamp(0.0, max);
            let lo = p.floor();
            let i0 = lo as usize;
            (i0, (i0 + 1).min(len - 1), (p - lo) as f32)
        })
        .collect()
}

/// The window of the circle resampled to 32×32 colour samples (0..=255 as f32), box
/// filtered when the window is larger than the patch. The sample grid is separable, so
/// the bilinear taps are computed once per column and per row.
fn resample(
    image: &RgbImage,
    center_px: [f64; 2],
    radius_px: f64,
    config: &PatchConfig,
) -> Vec<[f32; 3]> {
    let side_px = config.window_over_radius * radius_px;
    let step_px = side_px / PATCH_SIDE_PX as f64;
    // Sub-samples per patch pixel and axis: enough that their spacing is at most a pixel,
    // up to 4 (each a bilinear tap of four pixels, so a window up to 8 pixels a patch pixel
    // is still read whole; beyond, more samples cost more than they change).
    let sub = step_px.ceil().clamp(1.0, 4.0) as usize;
    let sub_step_px = step_px / sub as f64;
    let weight = 1.0 / (sub * sub) as f32;
    let (w, h) = (image.width() as usize, image.height() as usize);
    let data = image.data();
    // Pixel centres sit at integers, so pixel i covers [i − 0.5, i + 0.5]; the first
    // sample sits half a sub-step inside the window's edge.
    let first = |c: f64| c - side_px / 2.0 + sub_step_px / 2.0 - 0.5;
    let n = PATCH_SIDE_PX * sub;
    let xs = taps(first(center_px[0]), sub_step_px, n, w);
    let ys = taps(first(center_px[1]), sub_step_px, n, h);
    let mut out = vec![[0.0f32; 3]; PATCH_PIXELS];
    for (j, &(y0, y1, fy)) in ys.iter().enumerate() {
        let (row0, row1) = (&data[3 * y0 * w..][..3 * w], &data[3 * y1 * w..][..3 * w]);
        let out_row = &mut out[(j / sub) * PATCH_SIDE_PX..][..PATCH_SIDE_PX];
        for (i, &(x0, x1, fx)) in xs.iter().enumerate() {
            let acc = &mut out_row[i / sub];
            for k in 0..3 {
                let a = f32::from(row0[3 * x0 + k]);
                let b = f32::from(row0[3 * x1 + k]);
                let c = f32::from(row1[3 * x0 + k]);
                let d = f32::from(row1[3 * x1 + k]);
                let top = a + (b - a) * fx;
                let bottom = c + (d - c) * fx;
                acc[k] += (top + (bottom - top) * fy) * weight;
            }
        }
    }
    out
}

/// The greyscale patch of the circle centred at `center_px` with radius `radius_px` in
/// `image`.
pub fn extract(
    image: &RgbImage,
    center_px: [f64; 2],
    radius_px: f64,
    config: &PatchConfig,
) -> Result<Patch, PatchError> {
    check(image, center_px, radius_px, config)?;
    let grey = resample(image, center_px, radius_px, config)
        .into_iter()
        .map(luma)
        .collect();
    Ok(Patch { grey })
}

/// The colour patch of the same window as [`extract`].
pub fn extract_rgb(
    image: &RgbImage,
    center_px: [f64; 2],
    radius_px: f64,
    config: &PatchConfig,
) -> Result<RgbPatch, PatchError> {
    check(image, center_px, radius_px, config)?;
    let data = resample(image, center_px, radius_px, config)
        .into_iter()
        .flat_map(|p| p.map(|v| v.round().clamp(0.0, 255.0) as u8))
        .collect();
    Ok(RgbPatch { data })
}

#[cfg(test)]
#[path = "patch_tests.rs"]
mod tests;
