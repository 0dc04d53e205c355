//! Proposals by appearance: compact blobs that stand out from their surroundings, of any
//! colour.
//!
//! The colour path ([`crate::detect`]) only ever sees pixels inside one colour
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
//! classifier's work ([`crate::check::ballnet`]), which also refines the centre and the
//! radius: the filter's radius is only its size class.

use crate::circle::Circle;
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
    /// The weight of a brightness difference beside a colour difference (1: plain RGB
    /// distance; below 1 favours coloured balls over pale lines and shadows).
    pub luminance_weight: f64,
}

impl Default for AppearanceConfig {
    fn default() -> Self {
        AppearanceConfig {
            max_candidates: 48,
            min_contrast: 0.05,
            min_radius_px: 7.0,
            max_radius_px: 160.0,
            luminance_weight: 0.1,
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
    /// The integral images of the level's opponent channels, one plane after another,
    /// each with a zero first row and column: brightness `R + G + B`, red-green `R - G`,
    /// yellow-blue `R + G - 2 B`, all exact in integers.
    fn integral(&self) -> Vec<i32> {
        let (w, h) = (self.width, self.height);
        let iw = w + 1;
        let plane = iw * (h + 1);
        let mut sums = vec![0i32; 3 * plane];
        for y in 0..h {
            let mut row = [0i32; 3];
            let src = &self.data[3 * y * w..][..3 * w];
            for x in 0..w {
                let (r, g, b) = (
                    i32::from(src[3 * x]),
                    i32::from(src[3 * x + 1]),
                    i32::from(src[3 * x + 2]),
                );
                row[0] += r + g + b;
                row[1] += r - g;
                row[2] += r + g - 2 * b;
                for (k, v) in row.iter().enumerate() {
                    let at = k * plane + (y + 1) * iw + x + 1;
                    sums[at] = sums[at - iw] + v;
                }
            }
        }
        sums
    }
}

/// The level of half the size of an RGB image, each pixel the mean of a 2×2 block
/// (rounded); none when it would be under 8 pixels on a side.
fn halve(src: &[u8], width: usize, height: usize) -> Option<Level> {
    let (w, h) = (width / 2, height / 2);
    if w < 8 || h < 8 {
        return None;
    }
    let mut data = vec![0u8; 3 * w * h];
    let stride = 3 * width;
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

/// A proposal before the ranking: where, how big and how strong.
#[derive(Debug, Clone, Copy)]
struct Peak {
    x_px: f64,
    y_px: f64,
    radius_px: f64,
    contrast: f64,
}

/// The responses of one row's interior pixels (every box inside the level), written as
/// whole-row slice arithmetic so the compiler can vectorise it; the same values as the
/// per-pixel path of [`responses`]. `buf` holds the boxes' means between rows (resized
/// here once, then reused).
#[allow(clippy::too_many_arguments)]
fn interior_row(
    sums: &[i32],
    [iw, plane]: [usize; 2],
    y: usize,
    [a, b]: [usize; 2],
    xs: std::ops::Range<usize>,
    weights: [f32; 3],
    min2: f32,
    buf: &mut Vec<f32>,
    out: &mut [f32],
) {
    let n = xs.len();
    // The centre square, then the ring's four sides (above, below, left, right): columns
    // [x + x0, x + x1) and rows [y0, y1) for every x of `xs` (every box lies inside the
    // level).
    let (ai, bi) = (a as isize, b as isize);
    let boxes = [
        (-ai, ai + 1, y - a, y + a + 1),
        (-bi, bi + 1, y - b, y - a),
        (-bi, bi + 1, y + a + 1, y + b + 1),
        (-bi, -ai, y - a, y + a + 1),
        (ai + 1, bi + 1, y - a, y + a + 1),
    ];
    buf.resize(boxes.len() * 3 * n + n, 0.0);
    let (means, least) = buf.split_at_mut(boxes.len() * 3 * n);
    for (i, &(x0, x1, y0, y1)) in boxes.iter().enumerate() {
        let inv = 1.0 / ((x1 - x0) as usize * (y1 - y0)) as f32;
        let (c0, c1) = (
            xs.start.saturating_add_signed(x0),
            xs.start.saturating_add_signed(x1),
        );
        for k in 0..3 {
            let o = k * plane;
            let top = &sums[o + y0 * iw..][..iw];
            let bottom = &sums[o + y1 * iw..][..iw];
            let dst = &mut means[(3 * i + k) * n..][..n];
            for ((d, (&tl, &tr)), (&bl, &br)) in dst
                .iter_mut()
                .zip(top[c0..c0 + n].iter().zip(&top[c1..c1 + n]))
                .zip(bottom[c0..c0 + n].iter().zip(&bottom[c1..c1 + n]))
            {
                *d = (br - bl - tr + tl) as f32 * inv;
            }
        }
    }
    let (centre, sides) = means.split_at(3 * n);
    least.fill(f32::INFINITY);
    for side in sides.chunks_exact(3 * n) {
        let (s0, rest) = side.split_at(n);
        let (s1, s2) = rest.split_at(n);
        let (c0, rest) = centre.split_at(n);
        let (c1, c2) = rest.split_at(n);
        for i in 0..n {
            let d0 = c0[i] - s0[i];
            let d1 = c1[i] - s1[i];
            let d2 = c2[i] - s2[i];
            let d = weights[0] * d0 * d0 + weights[1] * d1 * d1 + weights[2] * d2 * d2;
            least[i] = least[i].min(d);
        }
    }
    for (o, l) in out[xs].iter_mut().zip(least.iter()) {
        *o = if *l >= min2 { l.sqrt() / 255.0 } else { 0.0 };
    }
}

/// The all-round centre-surround response of every pixel of a level for one filter size:
/// the mean colour of the square of half-side `a` against the mean of each of the four
/// sides of its ring out to half-side `b` (above, below, left, right), the smallest of the
/// four distances. A ball differs from its surroundings on every side; an edge or a line
/// through the square does not. The distance weighs the brightness difference by
/// `luminance_weight` beside the two colour-opponent differences (red-green,
/// yellow-blue), so a pale line or a shadow counts less than a coloured disc. Responses
/// below `min` are left at zero, which lets most floor pixels stop after one side.
#[allow(clippy::too_many_arguments)]
fn responses(
    sums: &[i32],
    w: usize,
    h: usize,
    a: usize,
    b: usize,
    luminance_weight: f32,
    min: f32,
    fast_interior: bool,
) -> Vec<f32> {
    let iw = w + 1;
    let plane = iw * (h + 1);
    let boxsum = |x0: usize, y0: usize, x1: usize, y1: usize| -> Option<[f32; 4]> {
        // Sums over [x0, x1) × [y0, y1), and the pixel count.
        if x1 <= x0 || y1 <= y0 {
            return None;
        }
        let (p, q, r, s) = (y0 * iw + x0, y0 * iw + x1, y1 * iw + x0, y1 * iw + x1);
        let sum = |k: usize| {
            let o = k * plane;
            (sums[o + s] + sums[o + p] - sums[o + q] - sums[o + r]) as f32
        };
        Some([sum(0), sum(1), sum(2), ((x1 - x0) * (y1 - y0)) as f32])
    };
    // In units of 255: brightness (R+G+B)/3 weighed, red-green, yellow-blue (R+G)/2 - B.
    let weights = [luminance_weight * luminance_weight / 3.0, 1.0, 0.25];
    let min2 = (min * 255.0) * (min * 255.0);
    let mut out = vec![0f32; w * h];
    let (interior_x, interior_y) = if fast_interior {
        (b..w.saturating_sub(b), b..h.saturating_sub(b))
    } else {
        (0..0, 0..0)
    };
    if !interior_x.is_empty() {
        let mut buf = Vec::new();
        for y in interior_y.clone() {
            interior_row(
                sums,
                [iw, plane],
                y,
                [a, b],
                interior_x.clone(),
                weights,
                min2,
                &mut buf,
                &mut out[y * w..][..w],
            );
        }
    }
    // The pixels left: the whole row, or only its ends when its interior was done.
    let rest = |y: usize| {
        if interior_y.contains(&y) && !interior_x.is_empty() {
            (0..interior_x.start).chain(interior_x.end..w)
        } else {
            (0..w).chain(w..w)
        }
    };
    for y in 0..h {
        let (cy0, cy1) = (y.saturating_sub(a), (y + a + 1).min(h));
        let (sy0, sy1) = (y.saturating_sub(b), (y + b + 1).min(h));
        for x in rest(y) {
            let (cx0, cx1) = (x.saturating_sub(a), (x + a + 1).min(w));
            let (sx0, sx1) = (x.saturating_sub(b), (x + b + 1).min(w));
            let Some(c) = boxsum(cx0, cy0, cx1, cy1) else {
                continue;
            };
            let c = [c[0] / c[3], c[1] / c[3], c[2] / c[3]];
            // Sides cut off by the frame's edge are left out: a ball half out of the
            // picture still differs from the floor on the sides that remain.
            let sides = [
                (sx0, sy0, sx1, cy0),
                (sx0, cy1, sx1, sy1),
                (sx0, cy0, cx0, cy1),
                (cx1, cy0, sx1, cy1),
            ];
            let mut least = f32::INFINITY;
            let mut seen = 0;
            for (x0, y0, x1, y1) in sides {
                let Some(side) = boxsum(x0, y0, x1, y1) else {
                    continue;
                };
                let mut d2 = 0.0;
                for k in 0..3 {
                    let d = c[k] - side[k] / side[3];
                    d2 += weights[k] * d * d;
                }
                least = least.min(d2);
                seen += 1;
                if least < min2 {
                    break;
                }
            }
            if seen >= 2 && least >= min2 {
                out[y * w + x] = least.sqrt() / 255.0;
            }
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
    halve(
        image.data(),
        image.width() as usize,
        image.height() as usize,
    )
    .map(|half| propose_on(half, config))
    .unwrap_or_default()
}

/// [`propose`] for a frame already halved by the caller: `half` is the frame of
/// `2 width`×`2 height` pixels (or one more in either) with each pixel the mean of a 2×2
/// block, as values 0..255 (rounded here as the halving here rounds), RGB rows.
pub fn propose_from_half(
    half: &[f32],
    width: usize,
    height: usize,
    config: &AppearanceConfig,
) -> Vec<Circle> {
    if width < 8 || height < 8 || half.len() != 3 * width * height {
        return Vec::new();
    }
    let data = half
        .iter()
        // Halves round up as the halving here does (a cast saturates, and costs far less
        // than a call to round).
        .map(|&v| (v + 0.5) as u8)
        .collect();
    propose_on(
        Level {
            data,
            width,
            height,
        },
        config,
    )
}

/// The proposals of every level from the frame's first halving on.
fn propose_on(half: Level, config: &AppearanceConfig) -> Vec<Circle> {
    let mut all: Vec<Peak> = Vec::new();
    let mut level = Some(half);
    let mut factor = 2.0f64;
    while let Some(l) = level {
        let smallest = RADIUS_OVER_SIDE * 3.0 * factor;
        if smallest > config.max_radius_px {
            break;
        }
        let sizes: Vec<(usize, f64)> = CENTRE_HALF_SIDES
            .iter()
            .map(|&a| (a, RADIUS_OVER_SIDE * (2 * a + 1) as f64 * factor))
            .filter(|&(_, r)| r >= config.min_radius_px && r <= config.max_radius_px)
            .collect();
        if !sizes.is_empty() {
            let sums = l.integral();
            for (a, radius_px) in sizes {
                let resp = responses(
                    &sums,
                    l.width,
                    l.height,
                    a,
                    2 * a + 1,
                    config.luminance_weight as f32,
                    config.min_contrast as f32,
                    true,
                );
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
        }
        level = halve(&l.data, l.width, l.height);
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
    fn the_row_path_gives_the_pixel_paths_responses() {
        let mut rng = proto::rng::Rng::new(4);
        let mut img = RgbImage::filled(61, 47, [0, 0, 0]).unwrap();
        for y in 0..47 {
            for x in 0..61 {
                img.set_pixel(x, y, [0; 3].map(|_| rng.index(256) as u8));
            }
        }
        let level = Level {
            data: img.data().to_vec(),
            width: 61,
            height: 47,
        };
        let sums = level.integral();
        for a in CENTRE_HALF_SIDES {
            let fast = responses(&sums, 61, 47, a, 2 * a + 1, 0.3, 0.02, true);
            let slow = responses(&sums, 61, 47, a, 2 * a + 1, 0.3, 0.02, false);
            assert!(slow.iter().filter(|&&v| v > 0.0).count() > 100);
            for (k, (f, s)) in fast.iter().zip(&slow).enumerate() {
                assert!((f - s).abs() < 1e-5, "pixel {k}: {f} vs {s}");
            }
        }
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
