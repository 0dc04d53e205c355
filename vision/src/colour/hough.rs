//! Circular Hough transform for ball candidates in a binary mask (typically a region of
//! interest around a colour blob).
//!
//! The method has two stages:
//!
//! 1. **Centre accumulator.** Edge pixels are the mask's boundary pixels: set pixels with an
//!    unset 4-neighbour inside the mask (neighbours outside the mask do not count, so the
//!    border of a clipped region is not an edge). Each edge pixel's outward normal is the
//!    negated gradient of a 3×3 Sobel on the mask averaged over the pixel's 3×3
//!    neighbourhood (samples outside the mask repeat the nearest pixel). Because the mask
//!    is filled (the ball is the set region), each edge pixel votes **inward only**, along
//!    its normal, at distances `r_min_px..=r_max_px` from its sub-pixel edge location, for
//!    centres inside the mask.
//! 2. **Radius per centre peak.** Local maxima of the 3×3 box-summed accumulator, strongest
//!    first and at least `min_center_distance_px` apart, become candidate centres, placed
//!    at sub-pixel precision by the 3×3 weighted centroid of the accumulator around the
//!    peak. For each candidate a histogram of the distances to the edge pixels whose
//!    normal points at it gives the radius; centre and radius are then refined by a few
//!    Gauss–Newton steps of a geometric circle fit to those supporting edge pixels.
//!
//! A circle's score is the number of supporting edge pixels (within 1 px of the circle,
//! normal within 15° of the direction to its centre) divided by its circumference in
//! pixels: about 0.9 for a whole rasterised disc (0.8 at 4 px), proportionally less for a
//! partly hidden one and about 0.2 for a square. Circles scoring below
//! `min_votes_ratio` are dropped, the rest go through non-maximum suppression on their
//! centre distance and come out best first.
//!
//! Pixel coordinates have x right and y down with the centre of the top-left pixel at
//! (0, 0).

use crate::circle::Circle;
use thiserror::Error;

/// Cosine of the largest angle between an edge pixel's inward normal and the direction to a
/// candidate centre for that pixel to take part in the radius histogram and the circle fit
/// (30°, wide enough for the normal's direction errors on a rasterised rim and for a
/// candidate centre a pixel or two off).
const FIT_NORMAL_COSINE: f64 = 0.866;

/// Cosine of the largest angle between an edge pixel's inward normal and the direction to a
/// circle's centre for that pixel to count in the circle's score (15°). It keeps nearly all
/// of a rasterised disc's rim but only about a quarter of each side of a square, so straight
/// outlines score far below round ones.
const SCORE_NORMAL_COSINE: f64 = 0.966;

/// Largest distance, in pixels, between an edge location and a circle for the edge pixel to
/// support the circle's score.
const SCORE_BAND_PX: f64 = 1.0;

/// Largest distance, in pixels, between an edge location and the histogram's radius for the
/// edge pixel to take part in the circle fit.
const FIT_BAND_PX: f64 = 1.5;

/// Gauss–Newton iterations of the circle fit.
const FIT_ITERATIONS: usize = 6;

/// Largest distance, in pixels, the circle fit may move a centre from its accumulator peak
/// before the fit is rejected in favour of the peak; for big circles, this fraction of the
/// radius if more. The peak of a big ball whose rim is uneven (a flattened highlight, a
/// shadow's bulge) can lie 4–5 px from the centre the whole rim agrees on.
const MAX_FIT_SHIFT_PX: f64 = 3.0;
const MAX_FIT_SHIFT_FRACTION: f64 = 0.15;

/// Candidate centres examined per requested circle.
const CANDIDATES_PER_CIRCLE: usize = 4;

/// Fraction of the score threshold's support a radius histogram peak must hold for its
/// candidate to be fitted and scored.
const PRE_FIT_SUPPORT_FRACTION: f64 = 0.5;

/// Smoothing half of the separable 5×5 gradient kernel (a 3×3 Sobel's smoothing convolved
/// with a 3-pixel box).
const SMOOTH: [i32; 5] = [1, 3, 4, 3, 1];

/// Differencing half of the separable 5×5 gradient kernel (a 3×3 Sobel's central difference
/// convolved with a 3-pixel box).
const DIFFERENCE: [i32; 5] = [-1, -1, 0, 1, 1];

/// Largest radius the configuration accepts, pixels; it bounds the voting cost.
const MAX_RADIUS_PX: f64 = 1024.0;

/// Settings of the circular Hough transform.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HoughConfig {
    /// Smallest radius searched, pixels.
    pub r_min_px: f64,
    /// Largest radius searched, pixels.
    pub r_max_px: f64,
    /// Smallest score kept: supporting edge pixels divided by the circumference in pixels.
    pub min_votes_ratio: f64,
    /// Largest number of circles returned.
    pub max_circles: usize,
    /// Smallest distance between the centres of two returned circles, pixels.
    pub min_center_distance_px: f64,
}

impl Default for HoughConfig {
    /// Balls of radius 4 to 40 px, at least 40 % of the rim visible, up to 4 circles at
    /// least 8 px apart.
    fn default() -> Self {
        Self {
            r_min_px: 4.0,
            r_max_px: 40.0,
            min_votes_ratio: 0.4,
            max_circles: 4,
            min_center_distance_px: 8.0,
        }
    }
}

impl HoughConfig {
    /// Checks that the settings make sense: finite radii with
    /// `1 ≤ r_min_px ≤ r_max_px ≤ 1024`, a ratio in `(0, 2]`, at least one circle and a
    /// finite non-negative centre distance.
    pub fn check(&self) -> Result<(), HoughError> {
        let bad = |field: &'static str, value: f64| HoughError::InvalidConfig { field, value };
        if !(self.r_min_px.is_finite() && self.r_min_px >= 1.0) {
            return Err(bad("r_min_px", self.r_min_px));
        }
        if !(self.r_max_px.is_finite()
            && self.r_max_px >= self.r_min_px
            && self.r_max_px <= MAX_RADIUS_PX)
        {
            return Err(bad("r_max_px", self.r_max_px));
        }
        if !(self.min_votes_ratio > 0.0 && self.min_votes_ratio <= 2.0) {
            return Err(bad("min_votes_ratio", self.min_votes_ratio));
        }
        if self.max_circles == 0 {
            return Err(bad("max_circles", 0.0));
        }
        if !(self.min_center_distance_px.is_finite() && self.min_center_distance_px >= 0.0) {
            return Err(bad("min_center_distance_px", self.min_center_distance_px));
        }
        Ok(())
    }
}

/// Why the Hough transform could not run.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum HoughError {
    /// A setting is out of range or not finite.
    #[error("invalid Hough setting {field} = {value}")]
    InvalidConfig {
        /// Name of the setting.
        field: &'static str,
        /// Its value (0 for a zero count).
        value: f64,
    },
    /// The mask's data does not hold `width × height` bytes.
    #[error("mask data holds {actual} bytes, expected {width} × {height}")]
    DataLength {
        /// Mask width, pixels.
        width: usize,
        /// Mask height, pixels.
        height: usize,
        /// Bytes given.
        actual: usize,
    },
}

/// An edge pixel: its sub-pixel edge location and its unit inward normal.
#[derive(Debug, Clone, Copy)]
struct Edge {
    /// Edge location: the pixel centre moved half a pixel step outward along the normal.
    at: [f64; 2],
    /// Unit normal pointing into the set region.
    inward: [f64; 2],
}

/// Finds circles in a binary mask of `width × height` pixels stored row by row in `mask`
/// (0 unset, anything else set), best score first.
///
/// An empty mask gives no circles; a mask whose data length is not `width × height`, or a
/// configuration failing [`HoughConfig::check`], is an error. Centres are sought inside the
/// mask; the circle fit may move one by up to 3 px, so a disc cut by the mask's border is
/// found as long as its centre is inside.
///
/// The cost grows with the mask's area and with the number of edge pixels times the radius
/// range: about 0.1 ms for a 120×120 region holding a 40 px ball on one core.
pub fn detect(
    mask: &[u8],
    width: usize,
    height: usize,
    config: &HoughConfig,
) -> Result<Vec<Circle>, HoughError> {
    config.check()?;
    if width.checked_mul(height) != Some(mask.len()) {
        return Err(HoughError::DataLength {
            width,
            height,
            actual: mask.len(),
        });
    }
    if mask.is_empty() {
        return Ok(Vec::new());
    }
    let edges = edges(mask, width, height);
    if edges.is_empty() {
        return Ok(Vec::new());
    }
    let accumulator = vote(&edges, width, height, config);
    let peaks = peaks(&accumulator, width, height, config);
    let mut circles: Vec<Circle> = peaks
        .iter()
        .filter_map(|&centre| fit_circle(&edges, centre, config))
        .filter(|circle| circle.score >= config.min_votes_ratio)
        .collect();
    circles.sort_by(|a, b| b.score.total_cmp(&a.score));
    Ok(suppress(circles, config))
}

/// The mask's boundary pixels with their Sobel normals; pixels with a zero gradient (an
/// isolated pixel, for one) are left out.
fn edges(mask: &[u8], width: usize, height: usize) -> Vec<Edge> {
    let set = |x: usize, y: usize| mask[y * width + x] != 0;
    // Value at a clamped position, as 0 or 1.
    let at = |x: isize, y: isize| -> i32 {
        let xc = x.clamp(0, width as isize - 1) as usize;
        let yc = y.clamp(0, height as isize - 1) as usize;
        i32::from(set(xc, yc))
    };
    let mut edges = Vec::new();
    for y in 0..height {
        for x in 0..width {
            if !set(x, y) {
                continue;
            }
            let boundary = (x > 0 && !set(x - 1, y))
                || (x + 1 < width && !set(x + 1, y))
                || (y > 0 && !set(x, y - 1))
                || (y + 1 < height && !set(x, y + 1));
            if !boundary {
                continue;
            }
            // The 3×3 Sobel summed over the pixel's 3×3 neighbourhood: a separable 5×5
            // kernel, smoothing (1, 3, 4, 3, 1) across and differencing (-1, -1, 0, 1, 1)
            // along each axis. It halves the plain Sobel's direction error on a rasterised
            // rim (to about 4° typical, 12° worst).
            let (xi, yi) = (x as isize, y as isize);
            let (mut gx, mut gy) = (0, 0);
            for (dy, (&smooth_y, &diff_y)) in SMOOTH.iter().zip(&DIFFERENCE).enumerate() {
                for (dx, (&smooth_x, &diff_x)) in SMOOTH.iter().zip(&DIFFERENCE).enumerate() {
                    let value = at(xi + dx as isize - 2, yi + dy as isize - 2);
                    gx += value * smooth_y * diff_x;
                    gy += value * diff_y * smooth_x;
                }
            }
            if gx == 0 && gy == 0 {
                continue;
            }
            let norm = f64::from(gx * gx + gy * gy).sqrt();
            // The gradient points from unset to set: inward.
            let inward = [f64::from(gx) / norm, f64::from(gy) / norm];
            // The set/unset transition lies, on average, half a pixel step beyond the pixel
            // centre along the outward normal, a step measured along the dominant axis.
            let step = 0.5 * inward[0].abs().max(inward[1].abs());
            edges.push(Edge {
                at: [x as f64 - step * inward[0], y as f64 - step * inward[1]],
                inward,
            });
        }
    }
    edges
}

/// The centre accumulator: each edge pixel votes for the pixels along its inward normal at
/// distances `r_min_px..=r_max_px`, one vote per pixel step.
fn vote(edges: &[Edge], width: usize, height: usize, config: &HoughConfig) -> Vec<u32> {
    let mut accumulator = vec![0u32; width * height];
    let steps = (config.r_max_px - config.r_min_px).floor() as usize;
    let (w, h) = (width as f64, height as f64);
    for edge in edges {
        let mut last = usize::MAX;
        // Shifted by half a pixel so that truncation rounds to the nearest pixel.
        let mut x = edge.at[0] + 0.5 + config.r_min_px * edge.inward[0];
        let mut y = edge.at[1] + 0.5 + config.r_min_px * edge.inward[1];
        for _ in 0..=steps {
            if x >= 0.0 && y >= 0.0 && x < w && y < h {
                let index = y as usize * width + x as usize;
                if index != last {
                    accumulator[index] += 1;
                    last = index;
                }
            }
            x += edge.inward[0];
            y += edge.inward[1];
        }
    }
    accumulator
}

/// Candidate centres: strict local maxima (ties broken by position) of the 3×3 box-summed
/// accumulator holding enough votes for the smallest circle, strongest first, each at least
/// `min_center_distance_px` from every stronger one, at sub-pixel precision by the 3×3
/// weighted centroid of the accumulator around the peak.
fn peaks(accumulator: &[u32], width: usize, height: usize, config: &HoughConfig) -> Vec<[f64; 2]> {
    let summed = box_sum_3x3(accumulator, width, height);
    let threshold = (config.min_votes_ratio * std::f64::consts::TAU * config.r_min_px)
        .ceil()
        .max(1.0) as u32;
    let mut found: Vec<(u32, usize, usize)> = Vec::new();
    for (y, row) in summed.chunks_exact(width).enumerate() {
        for (x, &value) in row.iter().enumerate() {
            if value < threshold {
                continue;
            }
            let mut is_max = true;
            'neighbours: for yy in y.saturating_sub(1)..=(y + 1).min(height - 1) {
                for xx in x.saturating_sub(1)..=(x + 1).min(width - 1) {
                    let other = summed[yy * width + xx];
                    if other > value || (other == value && (yy, xx) < (y, x)) {
                        is_max = false;
                        break 'neighbours;
                    }
                }
            }
            if is_max {
                found.push((value, x, y));
            }
        }
    }
    found.sort_by_key(|peak| std::cmp::Reverse(peak.0));
    let limit = config.max_circles.saturating_mul(CANDIDATES_PER_CIRCLE);
    let min_distance_sq = config.min_center_distance_px * config.min_center_distance_px;
    let mut kept: Vec<(usize, usize)> = Vec::new();
    for &(_, x, y) in &found {
        if kept.len() == limit {
            break;
        }
        let far = kept.iter().all(|&(kx, ky)| {
            let (dx, dy) = (kx.abs_diff(x) as f64, ky.abs_diff(y) as f64);
            dx * dx + dy * dy >= min_distance_sq
        });
        if far {
            kept.push((x, y));
        }
    }
    kept.into_iter()
        .map(|(x, y)| {
            let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
            for yy in y.saturating_sub(1)..=(y + 1).min(height - 1) {
                for xx in x.saturating_sub(1)..=(x + 1).min(width - 1) {
                    let weight = f64::from(accumulator[yy * width + xx]);
                    sx += weight * xx as f64;
                    sy += weight * yy as f64;
                    sw += weight;
                }
            }
            if sw > 0.0 {
                [sx / sw, sy / sw]
            } else {
                [x as f64, y as f64]
            }
        })
        .collect()
}

/// Sum of each pixel's 3×3 neighbourhood (the part inside the image), by separable passes.
fn box_sum_3x3(values: &[u32], width: usize, height: usize) -> Vec<u32> {
    debug_assert_eq!(values.len(), width * height);
    let mut rows = values.to_vec();
    for (out, row) in rows.chunks_exact_mut(width).zip(values.chunks_exact(width)) {
        for x in 1..width {
            out[x] += row[x - 1];
            out[x - 1] += row[x];
        }
    }
    let mut summed = rows.clone();
    for i in width..rows.len() {
        summed[i] += rows[i - width];
        summed[i - width] += rows[i];
    }
    summed
}

/// Distance from an edge location to a centre, if the edge's inward normal points at the
/// centre.
fn supporting_distance(edge: &Edge, centre: [f64; 2], min_cosine: f64) -> Option<f64> {
    let dx = centre[0] - edge.at[0];
    let dy = centre[1] - edge.at[1];
    let d = (dx * dx + dy * dy).sqrt();
    (d > 0.0 && (dx * edge.inward[0] + dy * edge.inward[1]) >= min_cosine * d).then_some(d)
}

/// The circle around a candidate centre: radius from the distance histogram, centre and
/// radius refined by a geometric fit, and the score. `None` if no radius in range has
/// support.
fn fit_circle(edges: &[Edge], centre: [f64; 2], config: &HoughConfig) -> Option<Circle> {
    // 1 px bins from r_min - 1 to r_max + 1.
    let base = config.r_min_px - 1.0;
    let bins = (config.r_max_px - config.r_min_px).floor() as usize + 3;
    let mut histogram = vec![0u32; bins];
    for edge in edges {
        if let Some(d) = supporting_distance(edge, centre, FIT_NORMAL_COSINE) {
            let bin = (d - base).round();
            if bin >= 0.0 && (bin as usize) < bins {
                histogram[bin as usize] += 1;
            }
        }
    }
    // The bin with the most support in a 3-bin window (the smallest such bin on a tie).
    let (best_bin, best_support) = (1..bins - 1)
        .map(|b| (b, histogram[b - 1] + histogram[b] + histogram[b + 1]))
        .max_by_key(|&(b, support)| (support, std::cmp::Reverse(b)))?;
    let radius = base + best_bin as f64;
    // A candidate with well under the support the threshold asks for is not worth fitting:
    // the fit moves the circle by at most a few pixels.
    let needed = PRE_FIT_SUPPORT_FRACTION * config.min_votes_ratio * std::f64::consts::TAU * radius;
    if best_support < 3 || f64::from(best_support) < needed {
        return None;
    }
    let (fitted_centre, fitted_radius) = refine(edges, centre, radius)
        .filter(|(c, _)| {
            (c[0] - centre[0]).hypot(c[1] - centre[1])
                <= MAX_FIT_SHIFT_PX.max(MAX_FIT_SHIFT_FRACTION * radius)
        })
        .unwrap_or((centre, radius));
    if !(fitted_radius >= config.r_min_px - 0.5 && fitted_radius <= config.r_max_px + 0.5) {
        return None;
    }
    let support = edges
        .iter()
        .filter_map(|edge| supporting_distance(edge, fitted_centre, SCORE_NORMAL_COSINE))
        .filter(|d| (d - fitted_radius).abs() <= SCORE_BAND_PX)
        .count();
    Some(Circle {
        center_px: fitted_centre,
        radius_px: fitted_radius,
        score: support as f64 / (std::f64::consts::TAU * fitted_radius),
    })
}

/// Gauss–Newton refinement of a circle (minimising the squared distances of the supporting
/// edge locations to it). `None` if the fit degenerates.
fn refine(edges: &[Edge], centre: [f64; 2], radius: f64) -> Option<([f64; 2], f64)> {
    let inliers: Vec<[f64; 2]> = edges
        .iter()
        .filter(|edge| {
            supporting_distance(edge, centre, FIT_NORMAL_COSINE)
                .is_some_and(|d| (d - radius).abs() <= FIT_BAND_PX)
        })
        .map(|edge| edge.at)
        .collect();
    if inliers.len() < 5 {
        return None;
    }
    let (mut c, mut r) = (centre, radius);
    for _ in 0..FIT_ITERATIONS {
        // Normal equations JᵀJ δ = -Jᵀf for residuals f = |p - c| - r.
        let mut jtj = [[0.0f64; 3]; 3];
        let mut jtf = [0.0f64; 3];
        for p in &inliers {
            let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
            let d = (dx * dx + dy * dy).sqrt();
            if d <= 0.0 {
                continue;
            }
            let j = [-dx / d, -dy / d, -1.0];
            let f = d - r;
            for (row, jr) in jtj.iter_mut().zip(j) {
                for (cell, jc) in row.iter_mut().zip(j) {
                    *cell += jr * jc;
                }
            }
            for (cell, jr) in jtf.iter_mut().zip(j) {
                *cell += jr * f;
            }
        }
        let delta = solve3(jtj, [-jtf[0], -jtf[1], -jtf[2]])?;
        c = [c[0] + delta[0], c[1] + delta[1]];
        r += delta[2];
        if !(c[0].is_finite() && c[1].is_finite() && r.is_finite() && r > 0.0) {
            return None;
        }
        if delta.iter().all(|d| d.abs() < 1e-4) {
            break;
        }
    }
    Some((c, r))
}

/// Solves a 3×3 linear system by Cramer's rule; `None` if it is (nearly) singular.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    let scale = a.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
    if !d.is_finite() || d.abs() <= 1e-9 * scale.powi(3) {
        return None;
    }
    let mut x = [0.0; 3];
    for (column, xi) in x.iter_mut().enumerate() {
        let mut m = a;
        for (row, bi) in m.iter_mut().zip(b) {
            row[column] = bi;
        }
        *xi = det(m) / d;
    }
    Some(x)
}

/// Greedy non-maximum suppression on circles sorted best first: a circle is kept if its
/// centre is at least `min_center_distance_px` from every kept one, up to `max_circles`.
fn suppress(circles: Vec<Circle>, config: &HoughConfig) -> Vec<Circle> {
    let mut kept: Vec<Circle> = Vec::with_capacity(config.max_circles);
    for circle in circles {
        if kept.len() == config.max_circles {
            break;
        }
        let far = kept.iter().all(|k| {
            let d =
                (k.center_px[0] - circle.center_px[0]).hypot(k.center_px[1] - circle.center_px[1]);
            d >= config.min_center_distance_px
        });
        if far {
            kept.push(circle);
        }
    }
    kept
}

#[cfg(test)]
#[path = "hough_tests.rs"]
mod tests;
