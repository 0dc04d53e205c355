//! Proposals by appearance: compact blobs that stand out from their surroundings, of any
//! colour.
//!
//! The colour path ([`crate::detection::detect`]) only ever sees pixels inside one colour
//! window; a ball of another colour, or the right ball under another light, never becomes a
//! candidate. This stage asks a question that holds for every ball on every floor: is there
//! a disc here whose mean colour differs from the ring around it?
//!
//! The frame is halved, then halved again into a pyramid of levels. On every level two
//! centre-surround filters run at every pixel: the mean colour of a square of side 3 (or 5)
//! level pixels against the mean of the ring out to side 7 (or 11), by integral images, so
//! each costs the same whatever its size. The response is the Euclidean distance of the two
//! means in RGB (0..1 per channel). A pixel whose response is the largest of its 3×3
//! neighbours and above `min_contrast` is a proposal; the proposals of all levels and sizes
//! are ranked by response, ones that repeat a stronger proposal's place and size are
//! dropped, and at most `max_candidates` survive. Deciding which of them is the ball is the
//! classifier's work ([`crate::detection::ballnet`]), which also refines the centre and the
//! radius: the filter's radius is only its size class.

use crate::detection::hough::Circle;
use crate::image::RgbImage;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// The appearance proposal's settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AppearanceConfig {
    /// At most this many proposals per frame, strongest first.
    pub max_candidates: usize,
    /// The smallest centre-surround response proposed (RGB distance, 0..√3).
    pub min_contrast: f64,
    /// Proposals with a radius below this are not made, frame pixels.
    pub min_radius_px: f64,
    /// Nor above this.
    pub max_radius_px: f64,
}

impl Default for AppearanceConfig {
    fn default() -> Self {
        AppearanceConfig {
            max_candidates: 24,
            min_contrast: 0.05,
            min_radius_px: 2.0,
            max_radius_px: 160.0,
        }
    }
}

/// Why the appearance settings cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum AppearanceError {
    #[error("appearance.max_candidates must be at least 1")]
    NoCandidates,
    #[error("appearance.min_contrast {0} is not finite and non-negative")]
    BadContrast(f64),
    #[error("appearance radii {0}..{1} px are not a finite positive range")]
    BadRadii(f64, f64),
}

impl AppearanceConfig {
    pub fn check(&self) -> Result<(), AppearanceError> {
        if self.max_candidates == 0 {
            return Err(AppearanceError::NoCandidates);
        }
        if !(self.min_contrast.is_finite() && self.min_contrast >= 0.0) {
            return Err(AppearanceError::BadContrast(self.min_contrast));
        }
        let (lo, hi) = (self.min_radius_px, self.max_radius_px);
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi >= lo) {
            return Err(AppearanceError::BadRadii(lo, hi));
        }
        Ok(())
    }
}

/// The centre squares' half-sides on every level, level pixels; the ring's half-side is
/// `2 a + 1`.
const CENTRE_HALF_SIDES: [usize; 2] = [1, 2];

/// A ball whose diameter is the centre square's side gives the strongest response; its
/// radius is this share of the side.
const RADIUS_OVER_SIDE: f64 = 0.6;

/// One pyramid level: RGB, 3 bytes a pixel, and its size.
struct Level {
    data: Vec<u8>,
    width: usize,
    height: usize,
}

impl Level {
    /// The level of half the size, each pixel the mean of a 2×2 block.
    fn halved(&self) -> Option<Level> {
        let (w, h) = (self.width / 2, self.height / 2);
        if w < 8 || h < 8 {
            return None;
        }
        let mut data = vec![0u8; 3 * w * h];
        let src = &self.data;
        let stride = 3 * self.width;
        for y in 0..h {
            let (r0, r1) = (
                &src[2 * y * stride..][..stride],
                &src[(2 * y + 1) * stride..][..stride],
            );
            let out = &mut data[3 * y * w..][..3 * w];
            for x in 0..w {
                for k in 0..3 {
                    let i = 6 * x + k;
                    let s = u16::from(r0[i])
                        + u16::from(r0[i + 3])
                        + u16::from(r1[i])
                        + u16::from(r1[i + 3]);
                    out[3 * x + k] = ((s + 2) / 4) as u8;
                }
            }
        }
        Some(Level {
            data,
            width: w,
            height: h,
        })
    }

    /// The integral image, 3 channels interleaved, with a zero first row and column.
    fn integral(&self) -> Vec<u32> {
        let (w, h) = (self.width, self.height);
        let iw = w + 1;
        let mut sums = vec![0u32; 3 * iw * (h + 1)];
        for y in 0..h {
            let mut row = [0u32; 3];
            let src = &self.data[3 * y * w..][..3 * w];
            let (above, here) = sums.split_at_mut(3 * (y + 1) * iw);
            let above = &above[3 * y * iw..];
            for x in 0..w {
                for k in 0..3 {
                    row[k] += u32::from(src[3 * x + k]);
                    here[3 * (x + 1) + k] = above[3 * (x + 1) + k] + row[k];
                }
            }
        }
        sums
    }
}

/// A proposal before the ranking: where, how big and how strong.
#[derive(Debug, Clone, Copy)]
struct Peak {
    x_px: f64,
    y_px: f64,
    radius_px: f64,
    contrast: f64,
}

/// The centre-surround response of every pixel of a level for one filter size: the
/// distance between the mean colour of the square of half-side `a` and that of its ring out
/// to half-side `b`, both clipped to the level.
fn responses(sums: &[u32], w: usize, h: usize, a: usize, b: usize) -> Vec<f32> {
    let iw = w + 1;
    let boxsum = |x0: usize, y0: usize, x1: usize, y1: usize| -> [u32; 3] {
        // Sum over [x0, x1) × [y0, y1).
        let (p, q, r, s) = (
            3 * (y0 * iw + x0),
            3 * (y0 * iw + x1),
            3 * (y1 * iw + x0),
            3 * (y1 * iw + x1),
        );
        [
            sums[s] + sums[p] - sums[q] - sums[r],
            sums[s + 1] + sums[p + 1] - sums[q + 1] - sums[r + 1],
            sums[s + 2] + sums[p + 2] - sums[q + 2] - sums[r + 2],
        ]
    };
    let mut out = vec![0f32; w * h];
    for y in 0..h {
        let (cy0, cy1) = (y.saturating_sub(a), (y + a + 1).min(h));
        let (sy0, sy1) = (y.saturating_sub(b), (y + b + 1).min(h));
        for x in 0..w {
            let (cx0, cx1) = (x.saturating_sub(a), (x + a + 1).min(w));
            let (sx0, sx1) = (x.saturating_sub(b), (x + b + 1).min(w));
            let c = boxsum(cx0, cy0, cx1, cy1);
            let s = boxsum(sx0, sy0, sx1, sy1);
            let nc = ((cx1 - cx0) * (cy1 - cy0)) as f32;
            let ns = ((sx1 - sx0) * (sy1 - sy0)) as f32 - nc;
            if ns < 1.0 {
                continue;
            }
            let mut d2 = 0.0f32;
            for k in 0..3 {
                let mc = c[k] as f32 / nc;
                let ms = (s[k] - c[k]) as f32 / ns;
                let d = (mc - ms) / 255.0;
                d2 += d * d;
            }
            out[y * w + x] = d2.sqrt();
        }
    }
    out
}

/// The local maxima of a response map at or above `min`.
fn peaks(resp: &[f32], w: usize, h: usize, min: f32, mut found: impl FnMut(usize, usize, f32)) {
    for y in 0..h {
        for x in 0..w {
            let v = resp[y * w + x];
            if v < min {
                continue;
            }
            let mut top = true;
            'n: for ny in y.saturating_sub(1)..(y + 2).min(h) {
                for nx in x.saturating_sub(1)..(x + 2).min(w) {
                    let u = resp[ny * w + nx];
                    // Ties go to the first in scan order, so a plateau gives one peak.
                    if u > v || (u == v && (ny, nx) < (y, x)) {
                        top = false;
                        break 'n;
                    }
                }
            }
            if top {
                found(x, y, v);
            }
        }
    }
}

/// Whether `p` repeats the stronger `q`: nearly the same place and size.
fn repeats(p: &Peak, q: &Peak) -> bool {
    let d = (p.x_px - q.x_px).hypot(p.y_px - q.y_px);
    let ratio = p.radius_px.max(q.radius_px) / p.radius_px.min(q.radius_px);
    d < 0.5 * p.radius_px.max(q.radius_px) && ratio < 1.9
}

/// The frame's proposals, strongest first; each circle's `score` is its response.
pub fn propose(image: &RgbImage, config: &AppearanceConfig) -> Vec<Circle> {
    let full = Level {
        data: image.data().to_vec(),
        width: image.width() as usize,
        height: image.height() as usize,
    };
    let mut all: Vec<Peak> = Vec::new();
    let mut level = full.halved();
    let mut factor = 2.0f64;
    while let Some(l) = level {
        let smallest = RADIUS_OVER_SIDE * 3.0 * factor;
        if smallest > config.max_radius_px {
            break;
        }
        let sums = l.integral();
        for a in CENTRE_HALF_SIDES {
            let radius_px = RADIUS_OVER_SIDE * (2 * a + 1) as f64 * factor;
            if radius_px < config.min_radius_px || radius_px > config.max_radius_px {
                continue;
            }
            let resp = responses(&sums, l.width, l.height, a, 2 * a + 1);
            peaks(
                &resp,
                l.width,
                l.height,
                config.min_contrast as f32,
                |x, y, v| {
                    all.push(Peak {
                        x_px: (x as f64 + 0.5) * factor - 0.5,
                        y_px: (y as f64 + 0.5) * factor - 0.5,
                        radius_px,
                        contrast: f64::from(v),
                    })
                },
            );
        }
        level = l.halved();
        factor *= 2.0;
    }
    all.sort_by(|p, q| q.contrast.total_cmp(&p.contrast));
    let mut kept: Vec<Peak> = Vec::new();
    for p in all {
        if kept.len() >= config.max_candidates {
            break;
        }
        if !kept.iter().any(|q| repeats(&p, q)) {
            kept.push(p);
        }
    }
    kept.into_iter()
        .map(|p| Circle {
            center_px: [p.x_px, p.y_px],
            radius_px: p.radius_px,
            score: p.contrast,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn disc(w: u32, h: u32, bg: [u8; 3], fg: [u8; 3], c: [f64; 2], r: f64) -> RgbImage {
        let mut img = RgbImage::filled(w, h, bg).unwrap();
        for y in 0..h {
            for x in 0..w {
                if (f64::from(x) - c[0]).hypot(f64::from(y) - c[1]) <= r {
                    img.set_pixel(x, y, fg);
                }
            }
        }
        img
    }

    #[test]
    fn a_disc_of_any_colour_is_the_strongest_proposal() {
        for (fg, r) in [
            ([230u8, 120, 20], 4.0),
            ([240, 230, 60], 9.0),
            ([250, 250, 250], 20.0),
            ([20, 20, 20], 40.0),
        ] {
            let img = disc(320, 240, [40, 120, 50], fg, [171.0, 93.0], r);
            let p = propose(&img, &AppearanceConfig::default());
            let best = p.first().unwrap();
            let d = (best.center_px[0] - 171.0).hypot(best.center_px[1] - 93.0);
            assert!(d < 0.5 * r + 2.0, "{fg:?} r {r}: {best:?}");
            assert!(
                best.radius_px > 0.4 * r && best.radius_px < 2.5 * r,
                "{fg:?} r {r}: {best:?}"
            );
        }
    }

    #[test]
    fn a_flat_frame_proposes_nothing_and_the_count_is_bounded() {
        let flat = RgbImage::filled(200, 100, [90, 90, 90]).unwrap();
        assert!(propose(&flat, &AppearanceConfig::default()).is_empty());
        let mut noisy = RgbImage::filled(200, 100, [0, 0, 0]).unwrap();
        let mut s = 7u32;
        for y in 0..100 {
            for x in 0..200 {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let v = (s >> 24) as u8;
                noisy.set_pixel(x, y, [v, v / 2, 255 - v]);
            }
        }
        let cfg = AppearanceConfig {
            max_candidates: 10,
            ..AppearanceConfig::default()
        };
        assert_eq!(propose(&noisy, &cfg).len(), 10);
    }

    #[test]
    fn tiny_frames_and_bad_settings() {
        let tiny = RgbImage::filled(5, 5, [1, 2, 3]).unwrap();
        assert!(propose(&tiny, &AppearanceConfig::default()).is_empty());
        assert!(
            AppearanceConfig {
                max_candidates: 0,
                ..Default::default()
            }
            .check()
            .is_err()
        );
        assert!(
            AppearanceConfig {
                min_contrast: f64::NAN,
                ..Default::default()
            }
            .check()
            .is_err()
        );
        assert!(
            AppearanceConfig {
                min_radius_px: 9.0,
                max_radius_px: 3.0,
                ..Default::default()
            }
            .check()
            .is_err()
        );
    }
}
