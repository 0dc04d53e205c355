//! One camera frame to ball candidates: the image half of the detector.
//!
//! Stages, each timed through the caller's [`StageClock`] (the pipeline never reads a
//! clock itself):
//!
//! 1. `mask`: the HSV colour mask of the whole frame through the lookup table.
//! 2. `cleanup`: an opening removes speckle.
//! 3. `blobs`: connected components, largest first; each one's box, grown by a margin, is a
//!    region of interest.
//! 4. `hough`: in each region, a closing fills the holes that a patterned ball's white
//!    patches leave, then the circular Hough transform finds circles.
//! 5. `classify`: each circle goes through the caller's [`CandidateClassifier`] (the HOG +
//!    SVM filter and the dominant-colour check in the agent), which gives the probability
//!    that it is the ball.
//!
//! World validation and the choice of at most one ball per frame happen after projection
//! (see [`crate::pipeline`]).

use crate::components::largest_components;
use crate::hough::{Circle, HoughConfig, HoughError};
use crate::hsv::{HsvError, HsvThresholds, MaskLut};
use crate::image::{ImageError, Mask, RgbImage};
use crate::morphology::{close, open};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// The detector's settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DetectorConfig {
    /// The ball's colour window.
    pub thresholds: HsvThresholds,
    /// The widest the colour window may become by lighting adaptation.
    pub limits: HsvThresholds,
    /// Fraction of the way the thresholds move towards an accepted ball's colours.
    pub adapt_rate: f64,
    /// Radius of the speckle-removing opening, pixels (0 to skip).
    pub open_radius_px: u32,
    /// Radius of the hole-filling closing inside each region, pixels (0 to skip).
    pub close_radius_px: u32,
    /// Blobs smaller than this are ignored, pixels.
    pub min_blob_area_px: usize,
    /// At most this many blobs are searched for circles, largest first.
    pub max_blobs: usize,
    /// Margin added around each blob's box, pixels.
    pub roi_margin_px: u32,
    /// The circular Hough transform's settings.
    pub hough: HoughConfig,
}

impl Default for DetectorConfig {
    /// An orange ball under ordinary indoor light.
    fn default() -> Self {
        DetectorConfig {
            thresholds: HsvThresholds {
                hue_lo_deg: 8.0,
                hue_hi_deg: 42.0,
                sat_min: 0.45,
                sat_max: 1.0,
                val_min: 0.2,
                val_max: 1.0,
            },
            limits: HsvThresholds {
                hue_lo_deg: 0.0,
                hue_hi_deg: 55.0,
                sat_min: 0.3,
                sat_max: 1.0,
                val_min: 0.1,
                val_max: 1.0,
            },
            adapt_rate: 0.1,
            open_radius_px: 1,
            close_radius_px: 2,
            min_blob_area_px: 12,
            max_blobs: 6,
            roi_margin_px: 4,
            hough: HoughConfig::default(),
        }
    }
}

/// Why the detector could not be built or run.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DetectError {
    #[error(transparent)]
    Hsv(#[from] HsvError),
    #[error(transparent)]
    Hough(#[from] HoughError),
    #[error(transparent)]
    Image(#[from] ImageError),
    #[error("adapt_rate {0} is outside [0, 1]")]
    BadRate(f64),
}

/// Marks the end of each stage; the agent's shell measures the time between marks.
pub trait StageClock {
    fn mark(&mut self, stage: &'static str);
}

/// A clock that measures nothing, for tests and offline runs.
#[derive(Debug)]
pub struct NoClock;

impl StageClock for NoClock {
    fn mark(&mut self, _stage: &'static str) {}
}

/// Judges a circle: the probability that it is the ball, or `None` to reject it outright.
pub trait CandidateClassifier {
    fn probability(&self, image: &RgbImage, circle: &Circle) -> Option<f64>;
}

/// Accepts every circle with its Hough score as the probability (no learned filter).
#[derive(Debug)]
pub struct HoughOnly;

impl CandidateClassifier for HoughOnly {
    fn probability(&self, _image: &RgbImage, circle: &Circle) -> Option<f64> {
        Some(circle.score.clamp(0.0, 1.0))
    }
}

/// A circle that passed the classifier.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    pub circle: Circle,
    /// The classifier's probability that this is the ball.
    pub probability: f64,
}

/// The image half of the ball detector, with its lighting-adapted colour window.
#[derive(Debug, Clone)]
pub struct Detector {
    config: DetectorConfig,
    thresholds: HsvThresholds,
    lut: MaskLut,
}

impl Detector {
    pub fn new(config: DetectorConfig) -> Result<Self, DetectError> {
        config.thresholds.check()?;
        config.limits.check()?;
        config.hough.check()?;
        if !(0.0..=1.0).contains(&config.adapt_rate) {
            return Err(DetectError::BadRate(config.adapt_rate));
        }
        Ok(Detector {
            config,
            thresholds: config.thresholds,
            lut: MaskLut::new(&config.thresholds)?,
        })
    }

    pub fn config(&self) -> &DetectorConfig {
        &self.config
    }

    /// The colour window in use, after lighting adaptation.
    pub fn thresholds(&self) -> &HsvThresholds {
        &self.thresholds
    }

    /// The candidates in a frame, most probable first.
    pub fn detect(
        &self,
        image: &RgbImage,
        classifier: &dyn CandidateClassifier,
        clock: &mut dyn StageClock,
    ) -> Result<Vec<Candidate>, DetectError> {
        let cfg = &self.config;
        let mask = self.lut.apply(image);
        clock.mark("mask");
        let mask = if cfg.open_radius_px > 0 {
            open(&mask, cfg.open_radius_px)
        } else {
            mask
        };
        clock.mark("cleanup");
        let blobs = largest_components(&mask, cfg.min_blob_area_px, cfg.max_blobs);
        clock.mark("blobs");
        let mut circles = Vec::new();
        for blob in &blobs {
            let m = cfg.roi_margin_px + cfg.close_radius_px;
            let x0 = blob.bbox.x_min.saturating_sub(m);
            let y0 = blob.bbox.y_min.saturating_sub(m);
            let x1 = (blob.bbox.x_max + m).min(mask.width() - 1);
            let y1 = (blob.bbox.y_max + m).min(mask.height() - 1);
            let roi = crop(&mask, x0, y0, x1 - x0 + 1, y1 - y0 + 1)?;
            let roi = if cfg.close_radius_px > 0 {
                close(&roi, cfg.close_radius_px)
            } else {
                roi
            };
            let found = crate::hough::detect(
                roi.data(),
                roi.width() as usize,
                roi.height() as usize,
                &cfg.hough,
            )?;
            circles.extend(found.into_iter().map(|c| Circle {
                center_px: [
                    c.center_px[0] + f64::from(x0),
                    c.center_px[1] + f64::from(y0),
                ],
                ..c
            }));
        }
        clock.mark("hough");
        let mut candidates: Vec<Candidate> = circles
            .into_iter()
            .filter_map(|circle| {
                let probability = classifier.probability(image, &circle)?;
                Some(Candidate {
                    circle,
                    probability,
                })
            })
            .collect();
        candidates.sort_by(|a, b| b.probability.total_cmp(&a.probability));
        clock.mark("classify");
        Ok(candidates)
    }

    /// Moves the colour window towards the colours inside an accepted ball's circle.
    pub fn adapt(&mut self, image: &RgbImage, ball: &Circle) -> Result<(), DetectError> {
        let samples = disc_hsv(image, ball, 0.7);
        let next = crate::hsv::adapt(
            &self.thresholds,
            &samples,
            self.config.adapt_rate,
            &self.config.limits,
        )?;
        if next != self.thresholds {
            self.lut = MaskLut::new(&next)?;
            self.thresholds = next;
        }
        Ok(())
    }
}

/// A window of a mask.
fn crop(mask: &Mask, x0: u32, y0: u32, w: u32, h: u32) -> Result<Mask, ImageError> {
    let stride = mask.width() as usize;
    let mut data = Vec::with_capacity(w as usize * h as usize);
    for y in y0..y0 + h {
        let start = y as usize * stride + x0 as usize;
        data.extend_from_slice(&mask.data()[start..start + w as usize]);
    }
    Mask::new(w, h, data)
}

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
                out.push(crate::hsv::rgb_to_hsv(red, g, b));
            }
        }
    }
    out
}

#[cfg(test)]
#[path = "detect_tests.rs"]
mod tests;
