//! The dominant-colour check of a ball candidate: k-means on the RGB pixels inside the
//! candidate circle.
//!
//! A round, ball-like shape that passed the HOG + SVM filter may still be the wrong
//! object (a white cup seen from above, a shadow). The HSV mask that produced it only says
//! that *some* pixels have the ball's colour; clustering the circle's pixels into k = 2 or
//! 3 colours (ball, background in the corners of a mis-centred circle, highlight or
//! shadow) and requiring that the largest cluster's mean colour is a ball colour, and that
//! it holds a configurable share of the pixels, rejects shapes where the ball colour is a
//! minority.
//!
//! A patterned ball (the ball's colour with white patches) is accepted too when the patches'
//! colour window is given: the clusters whose mean is a ball colour must then hold
//! `min_ball_share_with_patches` of the pixels, and together with the clusters whose mean
//! is the patches' colour `min_share`. White alone never passes.
//!
//! Only the inner part of the circle is sampled (`radius_fraction`, 0.8 by default) so that
//! a slightly too large circle does not pull in the background; large circles are
//! subsampled on a regular grid to at most `max_samples` pixels. Initialisation is
//! k-means++ with a seeded generator, so the result is a pure function of its inputs.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::colour::hsv::{HsvError, HsvThresholds, rgb_to_hsv};
use crate::image::RgbImage;
use proto::rng::SplitMix64;

/// Why a colour check could not be made.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ColourError {
    /// A configuration field is out of range.
    #[error("colour check parameter {name} = {value} is invalid: {why}")]
    BadParameter {
        /// The field.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The allowed range.
        why: &'static str,
    },
    /// The circle is not finite or its radius not positive.
    #[error("circle centre ({x_px}, {y_px}) px radius {radius_px} px is not a usable circle")]
    BadCircle {
        /// Centre x, pixels.
        x_px: f64,
        /// Centre y, pixels.
        y_px: f64,
        /// Radius, pixels.
        radius_px: f64,
    },
    /// The thresholds are invalid.
    #[error(transparent)]
    Thresholds(#[from] HsvError),
}

/// Parameters of the colour check.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ColourCheckConfig {
    /// Clusters, 1 to 8 (2 or 3 in practice).
    pub k: usize,
    /// Lloyd iterations after the k-means++ initialisation.
    pub iterations: usize,
    /// Smallest share of the sampled pixels the dominant cluster must hold, in [0, 1]; with
    /// patches, the ball's and the patches' clusters together.
    pub min_share: f64,
    /// With patches, the smallest share of the sampled pixels the ball-coloured clusters
    /// must hold, in [0, 1].
    pub min_ball_share_with_patches: f64,
    /// Sampled disc radius as a fraction of the circle's radius, in (0, 1].
    pub radius_fraction: f64,
    /// Largest number of pixels clustered; larger circles are subsampled on a grid.
    pub max_samples: usize,
    /// Seed of the k-means++ initialisation.
    pub seed: u64,
}

impl Default for ColourCheckConfig {
    fn default() -> Self {
        Self {
            k: 2,
            iterations: 6,
            min_share: 0.5,
            min_ball_share_with_patches: 0.35,
            radius_fraction: 0.8,
            max_samples: 256,
            seed: 0x5EED,
        }
    }
}

impl ColourCheckConfig {
    /// Checks the ranges documented on each field.
    pub fn check(&self) -> Result<(), ColourError> {
        let bad = |name, value, why| Err(ColourError::BadParameter { name, value, why });
        if !(1..=8).contains(&self.k) {
            return bad("k", self.k as f64, "must be in 1..=8");
        }
        if !(0.0..=1.0).contains(&self.min_share) {
            return bad("min_share", self.min_share, "must be in [0, 1]");
        }
        if !(0.0..=1.0).contains(&self.min_ball_share_with_patches) {
            return bad(
                "min_ball_share_with_patches",
                self.min_ball_share_with_patches,
                "must be in [0, 1]",
            );
        }
        if !(self.radius_fraction > 0.0 && self.radius_fraction <= 1.0) {
            return bad("radius_fraction", self.radius_fraction, "must be in (0, 1]");
        }
        if self.max_samples == 0 {
            return bad("max_samples", 0.0, "must be positive");
        }
        Ok(())
    }
}

/// The outcome of the colour check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColourCheck {
    /// Mean colour of the largest cluster (black when no pixel was sampled).
    pub dominant_rgb: [u8; 3],
    /// Share of the sampled pixels in the largest cluster, in [0, 1].
    pub share: f64,
    /// Share of the sampled pixels in clusters whose mean is a ball colour, in [0, 1].
    pub ball_share: f64,
    /// Whether the dominant colour is a ball colour and its share is large enough, or
    /// (with patches) the ball's and the patches' colours are.
    pub passes: bool,
}

/// Clusters of a k-means run, largest first.
#[derive(Debug, Clone, PartialEq)]
pub struct Clusters {
    /// Mean colour of each cluster (RGB, 0..=255).
    pub centres: Vec<[f32; 3]>,
    /// Pixels assigned to each cluster.
    pub counts: Vec<usize>,
}

fn dist2(a: [f32; 3], b: [f32; 3]) -> f32 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)
}

/// Index of the nearest centre.
fn nearest(p: [f32; 3], centres: &[[f32; 3]]) -> usize {
    let mut best = (f32::INFINITY, 0);
    for (c, &centre) in centres.iter().enumerate() {
        let d = dist2(p, centre);
        if d < best.0 {
            best = (d, c);
        }
    }
    best.1
}

/// k-means with k-means++ seeding (`k` ≥ 1; fewer clusters come out when there are fewer
/// distinct pixels), then `iterations` Lloyd steps. Empty clusters are dropped.
pub fn kmeans(pixels: &[[f32; 3]], k: usize, iterations: usize, seed: u64) -> Clusters {
    let mut rng = SplitMix64::new(seed);
    let mut centres: Vec<[f32; 3]> = Vec::new();
    if let Some(&first) = pixels.get(rng.below(pixels.len())) {
        centres.push(first);
    }
    let mut d2: Vec<f32> = pixels
        .iter()
        .map(|&p| centres.first().map_or(0.0, |&c| dist2(p, c)))
        .collect();
    while centres.len() < k {
        let total: f64 = d2.iter().map(|&d| f64::from(d)).sum();
        if total <= 0.0 {
            break;
        }
        // Draw a pixel with probability proportional to its squared distance.
        let mut target = rng.next_f64() * total;
        let mut pick = pixels.len() - 1;
        for (i, &d) in d2.iter().enumerate() {
            target -= f64::from(d);
            if target < 0.0 {
                pick = i;
                break;
            }
        }
        let c = pixels[pick];
        centres.push(c);
        for (d, &p) in d2.iter_mut().zip(pixels) {
            *d = d.min(dist2(p, c));
        }
    }
    let mut counts = vec![0usize; centres.len()];
    for _ in 0..=iterations {
        let mut sums = vec![[0.0f64; 3]; centres.len()];
        counts.iter_mut().for_each(|c| *c = 0);
        for &p in pixels {
            let c = nearest(p, &centres);
            counts[c] += 1;
            for k in 0..3 {
                sums[c][k] += f64::from(p[k]);
            }
        }
        for ((centre, sum), &n) in centres.iter_mut().zip(&sums).zip(&counts) {
            if n > 0 {
                *centre = sum.map(|s| (s / n as f64) as f32);
            }
        }
    }
    let mut order: Vec<usize> = (0..centres.len()).filter(|&c| counts[c] > 0).collect();
    order.sort_by(|&a, &b| counts[b].cmp(&counts[a]).then(a.cmp(&b)));
    Clusters {
        centres: order.iter().map(|&c| centres[c]).collect(),
        counts: order.iter().map(|&c| counts[c]).collect(),
    }
}

/// The pixels inside `radius_fraction × radius_px` of the centre, subsampled on a regular
/// grid to at most `max_samples`.
fn sample_disc(
    image: &RgbImage,
    center_px: [f64; 2],
    radius_px: f64,
    config: &ColourCheckConfig,
) -> Vec<[f32; 3]> {
    let r = radius_px * config.radius_fraction;
    let area_px = std::f64::consts::PI * r * r;
    let stride = (area_px / config.max_samples as f64).sqrt().ceil().max(1.0) as usize;
    let x_lo = (center_px[0] - r).ceil().max(0.0) as u32;
    let y_lo = (center_px[1] - r).ceil().max(0.0) as u32;
    let x_hi = (center_px[0] + r)
        .floor()
        .min(f64::from(image.width()) - 1.0);
    let y_hi = (center_px[1] + r)
        .floor()
        .min(f64::from(image.height()) - 1.0);
    let mut out = Vec::new();
    if x_hi < 0.0 || y_hi < 0.0 {
        return out;
    }
    for y in (y_lo..=y_hi as u32).step_by(stride) {
        for x in (x_lo..=x_hi as u32).step_by(stride) {
            let (dx, dy) = (f64::from(x) - center_px[0], f64::from(y) - center_px[1]);
            if dx * dx + dy * dy <= r * r
                && let Some(p) = image.pixel(x, y)
            {
                out.push(p.map(f32::from));
            }
        }
    }
    out
}

/// Checks the dominant colour inside the circle centred at `center_px` with radius
/// `radius_px` against the ball's thresholds, and with `patches` (the colour window of a
/// patterned ball's patches) accepts the ball's and the patches' colours together. A circle
/// with no pixel on the image fails.
pub fn colour_check(
    image: &RgbImage,
    center_px: [f64; 2],
    radius_px: f64,
    thresholds: &HsvThresholds,
    patches: Option<&HsvThresholds>,
    config: &ColourCheckConfig,
) -> Result<ColourCheck, ColourError> {
    config.check()?;
    thresholds.check()?;
    if let Some(p) = patches {
        p.check()?;
    }
    let usable =
        center_px.iter().all(|v| v.is_finite()) && radius_px.is_finite() && radius_px > 0.0;
    if !usable {
        return Err(ColourError::BadCircle {
            x_px: center_px[0],
            y_px: center_px[1],
            radius_px,
        });
    }
    let pixels = sample_disc(image, center_px, radius_px, config);
    let clusters = kmeans(&pixels, config.k, config.iterations, config.seed);
    let (Some(&centre), Some(&count)) = (clusters.centres.first(), clusters.counts.first()) else {
        return Ok(ColourCheck {
            dominant_rgb: [0; 3],
            share: 0.0,
            ball_share: 0.0,
            passes: false,
        });
    };
    let to_rgb = |c: [f32; 3]| c.map(|v| v.round().clamp(0.0, 255.0) as u8);
    let inside = |window: &HsvThresholds, c: [f32; 3]| {
        let [r, g, b] = to_rgb(c);
        let (h, s, v) = rgb_to_hsv(r, g, b);
        window.contains(h, s, v)
    };
    let total = pixels.len() as f64;
    let share = count as f64 / total;
    let share_of = |window: &HsvThresholds| {
        let n: usize = (clusters.centres.iter().zip(&clusters.counts))
            .filter(|&(&c, _)| inside(window, c))
            .map(|(_, &n)| n)
            .sum();
        n as f64 / total
    };
    let ball_share = share_of(thresholds);
    let plain = share >= config.min_share && inside(thresholds, centre);
    let patterned = patches.is_some_and(|p| {
        // A cluster in both windows counts once, as the ball's.
        let either = (clusters.centres.iter().zip(&clusters.counts))
            .filter(|&(&c, _)| inside(thresholds, c) || inside(p, c))
            .map(|(_, &n)| n)
            .sum::<usize>() as f64
            / total;
        ball_share >= config.min_ball_share_with_patches && either >= config.min_share
    });
    Ok(ColourCheck {
        dominant_rgb: to_rgb(centre),
        share,
        ball_share,
        passes: plain || patterned,
    })
}

#[cfg(test)]
#[path = "kmeans_tests.rs"]
mod tests;
