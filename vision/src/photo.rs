//! Ball candidates in one photo on its own: the image half of the detector and the
//! classifier, without the robot's pose and so without projection or world validation.
//!
//! This is what `ball-lab detect` runs on a folder of someone's own photos. Every circle
//! the detector proposed is reported with what became of it: the classifier's colour check
//! refused it, its probability was too low, a more probable candidate was published, or it
//! is the one published (at most one per photo, the most probable above the threshold, as
//! in the agent before world validation).
//!
//! The camera model is optional. With one (a calibration, or a plain pinhole), each blob is
//! searched in its local perspective view as in the agent; without one the photo is
//! searched as it is, which is right for an ordinary, nearly distortion-free camera.

use crate::camera::CameraModel;
use crate::circle::Circle;
use crate::detect::{CandidateClassifier, DetectError, Detector, StageClock, judge};
use crate::image::RgbImage;
use thiserror::Error;

/// Why a candidate was not published.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PhotoRejection {
    /// The classifier refused it outright (its dominant-colour check, or no patch could be
    /// cut around it), so it has no probability.
    ColourCheck,
    /// Its probability is below the validation's `min_probability`.
    LowProbability,
    /// Its ball is a more probable candidate's (the same ball proposed twice).
    Repeat,
    /// It passed, but a more probable candidate was published.
    RunnerUp,
}

impl PhotoRejection {
    /// A short name for reports.
    pub fn reason(&self) -> &'static str {
        match self {
            PhotoRejection::ColourCheck => "colour_check",
            PhotoRejection::LowProbability => "low_probability",
            PhotoRejection::Repeat => "repeat",
            PhotoRejection::RunnerUp => "runner_up",
        }
    }
}

/// A circle the detector considered in a photo.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhotoCandidate {
    /// Centre in the photo and radius, pixels.
    pub circle: Circle,
    /// The classifier's probability that it is the ball; `None` when refused outright.
    pub probability: Option<f64>,
    /// Half the angle the ball subtends at the camera, with a camera model.
    pub angular_radius_rad: Option<f64>,
    /// `None` for the published candidate.
    pub rejection: Option<PhotoRejection>,
}

impl PhotoCandidate {
    /// Whether this is the photo's ball.
    pub fn published(&self) -> bool {
        self.rejection.is_none()
    }
}

/// Every candidate of a photo: the scored ones most probable first (the first of them
/// published when its probability reaches `min_probability`), then repeats of their balls,
/// then those the classifier refused, largest first.
pub fn detect_photo(
    detector: &Detector,
    classifier: &dyn CandidateClassifier,
    min_probability: f64,
    image: &RgbImage,
    model: Option<&CameraModel>,
    clock: &mut dyn StageClock,
) -> Result<Vec<PhotoCandidate>, DetectError> {
    let proposals = detector.propose(image, model, clock)?;
    let mut scored = Vec::new();
    let mut refused = Vec::new();
    let mut repeats = Vec::new();
    for j in judge(&proposals, image, classifier) {
        let p = &proposals.items[j.index];
        match j.candidate {
            Some(c) if j.repeat => repeats.push(PhotoCandidate {
                circle: c.circle,
                probability: Some(c.probability),
                angular_radius_rad: c.angular_radius_rad,
                rejection: Some(PhotoRejection::Repeat),
            }),
            Some(c) => scored.push(PhotoCandidate {
                circle: c.circle,
                probability: Some(c.probability),
                angular_radius_rad: c.angular_radius_rad,
                rejection: Some(PhotoRejection::ColourCheck),
            }),
            None => refused.push(PhotoCandidate {
                circle: p.frame,
                probability: None,
                angular_radius_rad: p.angular_radius_rad,
                rejection: Some(PhotoRejection::ColourCheck),
            }),
        }
    }
    let key = |c: &PhotoCandidate| c.probability.unwrap_or(f64::NEG_INFINITY);
    scored.sort_by(|a, b| key(b).total_cmp(&key(a)));
    refused.sort_by(|a, b| b.circle.radius_px.total_cmp(&a.circle.radius_px));
    let mut published = false;
    for c in &mut scored {
        let passes = c.probability.is_some_and(|p| p >= min_probability);
        c.rejection = match (passes, published) {
            (false, _) => Some(PhotoRejection::LowProbability),
            (true, true) => Some(PhotoRejection::RunnerUp),
            (true, false) => None,
        };
        published |= passes;
    }
    clock.mark("classify");
    scored.extend(repeats);
    scored.extend(refused);
    Ok(scored)
}

/// Why a calibration cannot be used for a photo.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PhotoCameraError {
    #[error(
        "the calibration is for {calibration_w}×{calibration_h} px images but the photo is \
         {photo_w}×{photo_h} px (rescale the calibration to the photo's size, or calibrate at it)"
    )]
    SizeMismatch {
        calibration_w: u32,
        calibration_h: u32,
        photo_w: u32,
        photo_h: u32,
    },
    #[error(
        "the calibration's {calibration_w}×{calibration_h} px images and the photo's \
         {photo_w}×{photo_h} px differ in shape, so the photo is not a resized frame (a crop \
         needs its own calibration)"
    )]
    ShapeMismatch {
        calibration_w: u32,
        calibration_h: u32,
        photo_w: u32,
        photo_h: u32,
    },
}

/// Width-to-height ratios closer than this are taken as the same image shape (a resize
/// rounds each side to whole pixels).
const SHAPE_TOLERANCE: f64 = 0.01;

/// A calibration made for a photo's size: as it is when the sizes agree; scaled to the
/// photo with `rescale` when the photo is the same shape resized; an error otherwise.
pub fn fit_to_photo(
    model: &CameraModel,
    photo_w: u32,
    photo_h: u32,
    rescale: bool,
) -> Result<CameraModel, PhotoCameraError> {
    let (calibration_w, calibration_h) = (model.intrinsics.width_px, model.intrinsics.height_px);
    if (calibration_w, calibration_h) == (photo_w, photo_h) {
        return Ok(*model);
    }
    if !rescale {
        return Err(PhotoCameraError::SizeMismatch {
            calibration_w,
            calibration_h,
            photo_w,
            photo_h,
        });
    }
    let shape = |w: u32, h: u32| f64::from(w) / f64::from(h.max(1));
    let ratio = shape(photo_w, photo_h) / shape(calibration_w, calibration_h);
    if (ratio - 1.0).abs() > SHAPE_TOLERANCE {
        return Err(PhotoCameraError::ShapeMismatch {
            calibration_w,
            calibration_h,
            photo_w,
            photo_h,
        });
    }
    Ok(model.scaled_to(photo_w, photo_h))
}

/// Colour of the published candidate's circle in an overlay.
pub const PUBLISHED_RGB: [u8; 3] = [40, 230, 40];
/// Colour of the other candidates' circles.
pub const REJECTED_RGB: [u8; 3] = [230, 40, 230];

/// The photo with each candidate's circle and centre drawn: the published one thick in
/// [`PUBLISHED_RGB`], the others thin in [`REJECTED_RGB`]; the published one last, on top.
pub fn overlay(image: &RgbImage, candidates: &[PhotoCandidate]) -> RgbImage {
    let mut out = image.clone();
    let (published, rejected): (Vec<&PhotoCandidate>, Vec<&PhotoCandidate>) =
        candidates.iter().partition(|c| c.published());
    for c in rejected {
        draw_ring(&mut out, &c.circle, 1.0, REJECTED_RGB);
    }
    for c in published {
        draw_ring(&mut out, &c.circle, 2.0, PUBLISHED_RGB);
    }
    out
}

/// A ring of `width_px` on the circle's rim and a small cross at its centre.
fn draw_ring(image: &mut RgbImage, circle: &Circle, width_px: f64, rgb: [u8; 3]) {
    let [cx, cy] = circle.center_px;
    let r = circle.radius_px;
    let reach = r + width_px;
    let x0 = (cx - reach).floor().max(0.0) as u32;
    let y0 = (cy - reach).floor().max(0.0) as u32;
    let x1 = (cx + reach).ceil().max(0.0) as u32;
    let y1 = (cy + reach).ceil().max(0.0) as u32;
    let arm_px = (0.25 * r).clamp(2.0, 6.0);
    for y in y0..=y1.min(image.height().saturating_sub(1)) {
        for x in x0..=x1.min(image.width().saturating_sub(1)) {
            let (dx, dy) = (f64::from(x) - cx, f64::from(y) - cy);
            let on_rim = (dx.hypot(dy) - r).abs() <= 0.5 * width_px;
            let on_cross =
                (dx.abs() <= 0.5 && dy.abs() <= arm_px) || (dy.abs() <= 0.5 && dx.abs() <= arm_px);
            if on_rim || on_cross {
                image.set_pixel(x, y, rgb);
            }
        }
    }
}

#[cfg(test)]
#[path = "photo_tests.rs"]
mod tests;
