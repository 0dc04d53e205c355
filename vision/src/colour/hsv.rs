//! First stage of the ball detector: colour segmentation in HSV space.
//!
//! A pixel belongs to the ball's colour when its hue lies in a hue window (which may wrap
//! through 0°, as red does) and its saturation and value lie in closed ranges; see
//! [`HsvThresholds`]. [`MaskLut`] answers that question for a whole frame with one table
//! lookup per pixel; [`mask_exact`] is the per-pixel reference. [`adapt`] follows slow
//! lighting changes by moving the thresholds towards the colours of accepted balls.
//!
//! The mask cleanup lives in [`crate::colour::morphology`] and the connected components
//! in [`crate::colour::components`].

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::circle::Circle;
use crate::image::{Mask, RgbImage};

/// Why thresholds, or an adaptation request, are unusable.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum HsvError {
    /// A field is NaN or infinite.
    #[error("{field} is not finite")]
    NonFinite {
        /// Name of the field.
        field: &'static str,
    },
    /// A hue bound lies outside [0°, 360°].
    #[error("{field} = {value}° is outside [0, 360]")]
    HueOutOfRange {
        /// Name of the field.
        field: &'static str,
        /// Its value, degrees.
        value: f64,
    },
    /// A saturation or value bound lies outside [0, 1].
    #[error("{field} = {value} is outside [0, 1]")]
    OutOfUnitRange {
        /// Name of the field.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// A lower bound exceeds its upper bound.
    #[error("{lower_field} = {lower} exceeds {upper_field} = {upper}")]
    EmptyRange {
        /// Name of the lower bound.
        lower_field: &'static str,
        /// Its value.
        lower: f64,
        /// Name of the upper bound.
        upper_field: &'static str,
        /// Its value.
        upper: f64,
    },
    /// The adaptation rate is not in [0, 1].
    #[error("adaptation rate {0} is outside [0, 1]")]
    BadRate(f64),
}

/// The colour window of the ball in HSV space.
///
/// Hue is in degrees in [0, 360]; when `hue_lo_deg <= hue_hi_deg` the window is
/// `[hue_lo_deg, hue_hi_deg]`, otherwise it wraps through 0°: hue ≥ `hue_lo_deg` or
/// hue ≤ `hue_hi_deg` (340..20 selects reds). 0..360 accepts every hue. Saturation and
/// value are in [0, 1] and their ranges are closed. Grey pixels have hue 0°.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HsvThresholds {
    /// Start of the hue window, degrees.
    pub hue_lo_deg: f64,
    /// End of the hue window, degrees.
    pub hue_hi_deg: f64,
    /// Smallest accepted saturation.
    pub sat_min: f64,
    /// Largest accepted saturation.
    pub sat_max: f64,
    /// Smallest accepted value (brightness).
    pub val_min: f64,
    /// Largest accepted value (brightness).
    pub val_max: f64,
}

impl HsvThresholds {
    /// Checks that every field is finite, hues lie in [0, 360], saturation and value bounds
    /// in [0, 1], and each minimum does not exceed its maximum.
    pub fn check(&self) -> Result<(), HsvError> {
        let fields = [
            ("hue_lo_deg", self.hue_lo_deg),
            ("hue_hi_deg", self.hue_hi_deg),
            ("sat_min", self.sat_min),
            ("sat_max", self.sat_max),
            ("val_min", self.val_min),
            ("val_max", self.val_max),
        ];
        for (field, value) in fields {
            if !value.is_finite() {
                return Err(HsvError::NonFinite { field });
            }
        }
        for (field, value) in &fields[..2] {
            if !(0.0..=360.0).contains(value) {
                return Err(HsvError::HueOutOfRange {
                    field,
                    value: *value,
                });
            }
        }
        for (field, value) in &fields[2..] {
            if !(0.0..=1.0).contains(value) {
                return Err(HsvError::OutOfUnitRange {
                    field,
                    value: *value,
                });
            }
        }
        for pair in [&fields[2..4], &fields[4..6]] {
            let ((lower_field, lower), (upper_field, upper)) = (pair[0], pair[1]);
            if lower > upper {
                return Err(HsvError::EmptyRange {
                    lower_field,
                    lower,
                    upper_field,
                    upper,
                });
            }
        }
        Ok(())
    }

    /// Whether a hue, degrees in [0, 360), lies in the hue window.
    pub fn hue_contains(&self, h_deg: f64) -> bool {
        if self.hue_lo_deg <= self.hue_hi_deg {
            self.hue_lo_deg <= h_deg && h_deg <= self.hue_hi_deg
        } else {
            h_deg >= self.hue_lo_deg || h_deg <= self.hue_hi_deg
        }
    }

    /// Whether an HSV colour (hue in degrees, saturation and value in [0, 1]) is accepted.
    pub fn contains(&self, h_deg: f64, s: f64, v: f64) -> bool {
        self.hue_contains(h_deg)
            && (self.sat_min..=self.sat_max).contains(&s)
            && (self.val_min..=self.val_max).contains(&v)
    }

    /// Width of the hue window, degrees in [0, 360].
    pub fn hue_width_deg(&self) -> f64 {
        if self.hue_lo_deg <= self.hue_hi_deg {
            self.hue_hi_deg - self.hue_lo_deg
        } else {
            self.hue_hi_deg + 360.0 - self.hue_lo_deg
        }
    }
}

/// A colour window in a settings file, each bound optional.
#[derive(Debug, Clone, Copy, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct PartialThresholds {
    hue_lo_deg: Option<f64>,
    hue_hi_deg: Option<f64>,
    sat_min: Option<f64>,
    sat_max: Option<f64>,
    val_min: Option<f64>,
    val_max: Option<f64>,
}

impl HsvThresholds {
    /// Reads a colour window whose bounds are each optional, the missing ones taken from
    /// `base`. The detector's settings hold several windows with different defaults (the
    /// ball's, its adaptation limits, a patterned ball's patches), so a window alone has no
    /// single `Default` a partial table could fall back on.
    pub fn deserialize_over<'de, D: serde::Deserializer<'de>>(
        deserializer: D,
        base: HsvThresholds,
    ) -> Result<HsvThresholds, D::Error> {
        let p = PartialThresholds::deserialize(deserializer)?;
        Ok(HsvThresholds {
            hue_lo_deg: p.hue_lo_deg.unwrap_or(base.hue_lo_deg),
            hue_hi_deg: p.hue_hi_deg.unwrap_or(base.hue_hi_deg),
            sat_min: p.sat_min.unwrap_or(base.sat_min),
            sat_max: p.sat_max.unwrap_or(base.sat_max),
            val_min: p.val_min.unwrap_or(base.val_min),
            val_max: p.val_max.unwrap_or(base.val_max),
        })
    }
}

/// Converts an 8-bit RGB colour to HSV: hue in degrees in [0, 360) (0 for greys), saturation
/// `(max − min) / max` (0 for black) and value `max / 255`, both in [0, 1].
pub fn rgb_to_hsv(r: u8, g: u8, b: u8) -> (f64, f64, f64) {
    let (rf, gf, bf) = (f64::from(r), f64::from(g), f64::from(b));
    let max = rf.max(gf).max(bf);
    let min = rf.min(gf).min(bf);
    let delta = max - min;
    let v = max / 255.0;
    if delta == 0.0 {
        return (0.0, 0.0, v);
    }
    let s = delta / max;
    let h = if max == rf {
        let h = 60.0 * (gf - bf) / delta;
        if h < 0.0 { h + 360.0 } else { h }
    } else if max == gf {
        60.0 * (2.0 + (bf - rf) / delta)
    } else {
        60.0 * (4.0 + (rf - gf) / delta)
    };
    (h, s, v)
}

/// The exact mask: each pixel converted with [`rgb_to_hsv`] and tested against the
/// thresholds. The reference for [`MaskLut`], slower because it divides per pixel.
/// HSV colours of the pixels within `shrink` × the circle's radius of its centre (the rim
/// mixes in the background).
pub fn disc_hsv(image: &RgbImage, circle: &Circle, shrink: f64) -> Vec<(f64, f64, f64)> {
    let r = circle.radius_px * shrink;
    let [cx, cy] = circle.center_px;
    let x0 = (cx - r).floor().max(0.0) as u32;
    let y0 = (cy - r).floor().max(0.0) as u32;
    let x1 = ((cx + r).ceil().max(0.0) as u32).min(image.width().saturating_sub(1));
    let y1 = ((cy + r).ceil().max(0.0) as u32).min(image.height().saturating_sub(1));
    let mut out = Vec::new();
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (dx, dy) = (f64::from(x) - cx, f64::from(y) - cy);
            if dx * dx + dy * dy <= r * r
                && let Some([red, g, b]) = image.pixel(x, y)
            {
                out.push(rgb_to_hsv(red, g, b));
            }
        }
    }
    out
}

#[cfg(test)]
pub fn mask_exact(image: &RgbImage, thresholds: &HsvThresholds) -> Result<Mask, HsvError> {
    thresholds.check()?;
    let data = image
        .data()
        .chunks_exact(3)
        .map(|p| {
            let (h, s, v) = rgb_to_hsv(p[0], p[1], p[2]);
            u8::from(thresholds.contains(h, s, v))
        })
        .collect();
    Ok(Mask::from_parts_unchecked(
        image.width(),
        image.height(),
        data,
    ))
}

/// Bits kept per colour channel by [`MaskLut`].
pub const LUT_BITS: u32 = 5;

/// Levels per channel in one [`MaskLut`] cell (8).
pub const LUT_CELL_LEVELS: u8 = 1 << (8 - LUT_BITS);

/// The thresholds compiled into a 32×32×32 table over RGB for one-lookup-per-pixel masks.
///
/// Quantisation: each channel keeps its top 5 bits, so a cell holds 8×8×8 colours, and the
/// cell's answer is the exact answer for the colour at the cell's centre (each channel at
/// `8·k + 4`). The table therefore agrees with [`mask_exact`] except for colours within 4
/// levels per channel of a colour that [`mask_exact`] classifies differently, i.e. in a
/// band along the threshold boundaries (wide in hue for dark or unsaturated colours, where
/// hue is ill-defined anyway). Building costs 32 768 conversions; applying costs one
/// lookup per pixel.
#[derive(Clone, PartialEq, Eq)]
pub struct MaskLut {
    table: Vec<u8>,
}

impl std::fmt::Debug for MaskLut {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MaskLut")
            .field(
                "accepted_cells",
                &self.table.iter().filter(|&&b| b != 0).count(),
            )
            .finish()
    }
}

impl MaskLut {
    /// Compiles thresholds into a table; fails when they do not pass
    /// [`HsvThresholds::check`].
    pub fn new(thresholds: &HsvThresholds) -> Result<Self, HsvError> {
        thresholds.check()?;
        let cells = 1usize << LUT_BITS;
        let half = LUT_CELL_LEVELS / 2;
        let centre = |k: usize| (k as u8) * LUT_CELL_LEVELS + half;
        let mut table = Vec::with_capacity(cells * cells * cells);
        for r in 0..cells {
            for g in 0..cells {
                for b in 0..cells {
                    let (h, s, v) = rgb_to_hsv(centre(r), centre(g), centre(b));
                    table.push(u8::from(thresholds.contains(h, s, v)));
                }
            }
        }
        Ok(Self { table })
    }

    /// Whether the table accepts a colour.
    #[inline]
    pub fn accepts(&self, r: u8, g: u8, b: u8) -> bool {
        self.table[Self::index(r, g, b)] != 0
    }

    /// The table's cell of a colour.
    #[inline]
    pub(crate) fn index(r: u8, g: u8, b: u8) -> usize {
        let shift = 8 - LUT_BITS;
        (usize::from(r >> shift) << (2 * LUT_BITS))
            | (usize::from(g >> shift) << LUT_BITS)
            | usize::from(b >> shift)
    }

    /// The table, one byte (0 or 1) per colour cell, indexed by [`MaskLut::index`].
    pub(crate) fn cells(&self) -> &[u8] {
        &self.table
    }

    /// The mask of a frame.
    pub fn apply(&self, image: &RgbImage) -> Mask {
        let data = image
            .data()
            .chunks_exact(3)
            .map(|p| self.table[Self::index(p[0], p[1], p[2])])
            .collect();
        Mask::from_parts_unchecked(image.width(), image.height(), data)
    }
}

/// The mask of a frame through a freshly built [`MaskLut`]; callers masking a stream of
/// frames with the same thresholds should keep the [`MaskLut`] instead.
#[cfg(test)]
pub fn mask(image: &RgbImage, thresholds: &HsvThresholds) -> Result<Mask, HsvError> {
    Ok(MaskLut::new(thresholds)?.apply(image))
}

/// Fewest valid samples for [`adapt`] to move the thresholds.
pub const ADAPT_MIN_SAMPLES: usize = 32;

/// Lower percentile of the accepted pixels' saturation and value that [`adapt`] aims the
/// minimum bounds at (the upper bounds aim at `100 − ADAPT_PERCENTILE`).
pub const ADAPT_PERCENTILE: f64 = 5.0;

/// Margin kept between the percentiles and the bounds [`adapt`] aims at.
pub const ADAPT_MARGIN: f64 = 0.05;

/// Largest hue-window shift of one [`adapt`] call, degrees.
pub const ADAPT_MAX_HUE_STEP_DEG: f64 = 2.0;

/// Nearest-rank percentile `p` (in percent) of sorted samples (a bound that is one of
/// them); at least one sample.
fn percentile(sorted: &[f64], p: f64) -> f64 {
    proto::stats::nearest_rank(sorted, p).unwrap_or(f64::NAN)
}

/// Wraps an angle in degrees to [0, 360).
fn wrap_deg(a: f64) -> f64 {
    let w = a.rem_euclid(360.0);
    if w >= 360.0 { 0.0 } else { w }
}

/// Follows lighting changes: moves thresholds a fraction `rate` (in [0, 1]) of the way
/// towards targets derived from the HSV colours `(hue_deg, s, v)` of pixels on accepted
/// balls, without leaving `limits`.
///
/// - Saturation and value: the minimum aims at the 5th percentile of the samples minus
///   [`ADAPT_MARGIN`], the maximum at the 95th plus the margin; each new bound is
///   `old + rate · (target − old)` clamped to `limits`' range for that channel, so a
///   minimum never exceeds its maximum.
/// - Hue: the window keeps its width and its centre moves `rate` of the way towards the
///   samples' circular mean hue, at most [`ADAPT_MAX_HUE_STEP_DEG`] per call; the moved
///   window is then slid to lie inside `limits`' hue window (or replaced by it when it is
///   wider). A full 0..360 window is left alone.
///
/// Samples that are not finite or out of range are ignored; with fewer than
/// [`ADAPT_MIN_SAMPLES`] valid samples the thresholds come back unchanged. The result
/// depends only on the arguments (the samples' order does not matter).
pub fn adapt(
    current: &HsvThresholds,
    accepted_pixels_hsv: &[(f64, f64, f64)],
    rate: f64,
    limits: &HsvThresholds,
) -> Result<HsvThresholds, HsvError> {
    current.check()?;
    limits.check()?;
    if !(0.0..=1.0).contains(&rate) {
        return Err(HsvError::BadRate(rate));
    }
    let valid: Vec<(f64, f64, f64)> = accepted_pixels_hsv
        .iter()
        .copied()
        .filter(|&(h, s, v)| {
            (0.0..=360.0).contains(&h) && (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&v)
        })
        .collect();
    if valid.len() < ADAPT_MIN_SAMPLES {
        return Ok(*current);
    }
    let mut sats: Vec<f64> = valid.iter().map(|p| p.1).collect();
    let mut vals: Vec<f64> = valid.iter().map(|p| p.2).collect();
    sats.sort_by(f64::total_cmp);
    vals.sort_by(f64::total_cmp);
    let step =
        |old: f64, target: f64, lo: f64, hi: f64| (old + rate * (target - old)).clamp(lo, hi);
    let lo_p = ADAPT_PERCENTILE;
    let hi_p = 100.0 - ADAPT_PERCENTILE;
    let (sl, sh) = (limits.sat_min, limits.sat_max);
    let (vl, vh) = (limits.val_min, limits.val_max);
    let mut out = HsvThresholds {
        sat_min: step(
            current.sat_min,
            percentile(&sats, lo_p) - ADAPT_MARGIN,
            sl,
            sh,
        ),
        sat_max: step(
            current.sat_max,
            percentile(&sats, hi_p) + ADAPT_MARGIN,
            sl,
            sh,
        ),
        val_min: step(
            current.val_min,
            percentile(&vals, lo_p) - ADAPT_MARGIN,
            vl,
            vh,
        ),
        val_max: step(
            current.val_max,
            percentile(&vals, hi_p) + ADAPT_MARGIN,
            vl,
            vh,
        ),
        ..*current
    };

    let width = current.hue_width_deg();
    if width < 360.0 {
        // Circular mean of the hues; the sums are order-independent up to rounding, so sort
        // first to make the result exactly independent of the samples' order.
        let mut hues: Vec<f64> = valid.iter().map(|p| p.0).collect();
        hues.sort_by(f64::total_cmp);
        let (sin, cos) = hues.iter().fold((0.0, 0.0), |(s, c), h| {
            let (hs, hc) = h.to_radians().sin_cos();
            (s + hs, c + hc)
        });
        let shift = if sin.hypot(cos) > 1e-9 * hues.len() as f64 {
            let mean = wrap_deg(sin.atan2(cos).to_degrees());
            let centre = current.hue_lo_deg + width / 2.0;
            let d = wrap_deg(mean - centre + 180.0) - 180.0;
            (rate * d).clamp(-ADAPT_MAX_HUE_STEP_DEG, ADAPT_MAX_HUE_STEP_DEG)
        } else {
            0.0
        };
        let limit_width = limits.hue_width_deg();
        let (lo, hi) = if width > limit_width {
            (limits.hue_lo_deg, limits.hue_hi_deg)
        } else {
            // Offset of the window's start from the limits' start, kept in range so that
            // the whole window lies inside the limits.
            let offset = wrap_deg(current.hue_lo_deg - limits.hue_lo_deg);
            let offset = if offset > limit_width && limit_width < 360.0 {
                // The window starts outside the limits: take the nearer end.
                let past_end = offset - limit_width;
                let before_start = 360.0 - offset;
                if past_end < before_start {
                    limit_width
                } else {
                    0.0
                }
            } else {
                offset
            };
            let offset = if limit_width >= 360.0 {
                offset + shift
            } else {
                (offset + shift).clamp(0.0, limit_width - width)
            };
            let lo = wrap_deg(limits.hue_lo_deg + offset);
            let hi = lo + width;
            (lo, if hi > 360.0 { hi - 360.0 } else { hi })
        };
        out.hue_lo_deg = lo;
        out.hue_hi_deg = hi;
    }
    Ok(out)
}

#[cfg(test)]
#[path = "hsv_tests.rs"]
mod tests;
