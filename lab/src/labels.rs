//! Labelled ball boxes of an image, as the two common annotation formats give them:
//! [`voc`] (Pascal VOC XML) and [`yolo`] (YOLO text). Both readers are pure
//! (text in, boxes out) and share the box checks here, so the same malformed box gives the
//! same error or warning whichever format it came in.
//!
//! A box that reaches a little past the image (labelling tools round outwards) is clipped
//! to the image and counted as a warning; a box wholly outside it, an empty box or one with
//! its corners swapped is an error.

pub mod eval;
pub mod prelabel;
pub mod teacher;
pub mod voc;
pub mod yolo;

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// A labelled ball's axis-aligned box in image pixels: x right, y down, with the centre of
/// the top-left pixel at (0, 0) as in the detector's frames, so the image spans
/// -0.5..width - 0.5. The edges are the box's outer edges: VOC's 1-based inclusive pixel
/// indices `xmin..=xmax` become `xmin - 1.5 ..= xmax - 0.5`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BallBox {
    pub x_min_px: f64,
    pub y_min_px: f64,
    pub x_max_px: f64,
    pub y_max_px: f64,
}

impl BallBox {
    pub fn width_px(&self) -> f64 {
        self.x_max_px - self.x_min_px
    }

    pub fn height_px(&self) -> f64 {
        self.y_max_px - self.y_min_px
    }

    pub fn centre_px(&self) -> [f64; 2] {
        [
            0.5 * (self.x_min_px + self.x_max_px),
            0.5 * (self.y_min_px + self.y_max_px),
        ]
    }

    /// Whether a point lies inside the box (edges included).
    pub fn contains(&self, p_px: [f64; 2]) -> bool {
        (self.x_min_px..=self.x_max_px).contains(&p_px[0])
            && (self.y_min_px..=self.y_max_px).contains(&p_px[1])
    }

    /// Intersection over union with another box (0 when either is empty).
    pub fn iou(&self, other: &BallBox) -> f64 {
        let w = (self.x_max_px.min(other.x_max_px) - self.x_min_px.max(other.x_min_px)).max(0.0);
        let h = (self.y_max_px.min(other.y_max_px) - self.y_min_px.max(other.y_min_px)).max(0.0);
        let inter = w * h;
        let union =
            self.width_px() * self.height_px() + other.width_px() * other.height_px() - inter;
        if union > 0.0 { inter / union } else { 0.0 }
    }
}

/// Something in a label file that was usable but not as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LabelWarning {
    /// 1-based line of the file.
    pub line: usize,
    pub what: String,
}

/// The ball boxes of one image.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ImageLabels {
    /// Image size the labels were made for (VOC's `<size>`, or the image's for YOLO).
    pub width_px: u32,
    pub height_px: u32,
    pub balls: Vec<BallBox>,
    /// Objects of other classes.
    pub others: usize,
    pub warnings: Vec<LabelWarning>,
}

/// Why a label file could not be read.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LabelError {
    #[error("{file}: not XML: {reason}")]
    Xml { file: String, reason: String },
    #[error("{file} line {line}: <{element}> has no <{missing}>")]
    Missing {
        file: String,
        line: usize,
        element: String,
        missing: String,
    },
    #[error("{file} line {line}: {what} {text:?} is not a number")]
    BadNumber {
        file: String,
        line: usize,
        what: String,
        text: String,
    },
    #[error("{file} line {line}: {reason}")]
    BadBox {
        file: String,
        line: usize,
        reason: String,
    },
    #[error("{file} line {line}: {reason}")]
    BadLine {
        file: String,
        line: usize,
        reason: String,
    },
}

/// The class names that mean "ball", compared case-insensitively with surrounding spaces
/// ignored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BallNames(Vec<String>);

impl Default for BallNames {
    fn default() -> Self {
        Self::new(["ball", "sports ball", "football", "soccer ball"])
    }
}

impl BallNames {
    pub fn new<S: AsRef<str>>(names: impl IntoIterator<Item = S>) -> Self {
        Self(
            names
                .into_iter()
                .map(|n| n.as_ref().trim().to_lowercase())
                .collect(),
        )
    }

    pub fn is_ball(&self, name: &str) -> bool {
        let name = name.trim().to_lowercase();
        self.0.contains(&name)
    }
}

/// Checks a box against an image of `width_px` × `height_px`: swapped or empty boxes and
/// boxes wholly outside are errors, a box reaching past the image is clipped with a warning.
pub(crate) fn checked_box(
    b: BallBox,
    width_px: u32,
    height_px: u32,
    file: &str,
    line: usize,
    warnings: &mut Vec<LabelWarning>,
) -> Result<BallBox, LabelError> {
    let bad = |reason: String| LabelError::BadBox {
        file: file.to_owned(),
        line,
        reason,
    };
    if b.x_max_px < b.x_min_px || b.y_max_px < b.y_min_px {
        return Err(bad(format!(
            "box ({}, {})–({}, {}) has its maximum below its minimum",
            b.x_min_px, b.y_min_px, b.x_max_px, b.y_max_px
        )));
    }
    if b.width_px() <= 0.0 || b.height_px() <= 0.0 {
        return Err(bad(format!(
            "box ({}, {})–({}, {}) is empty",
            b.x_min_px, b.y_min_px, b.x_max_px, b.y_max_px
        )));
    }
    let (w, h) = (f64::from(width_px) - 0.5, f64::from(height_px) - 0.5);
    let clipped = BallBox {
        x_min_px: b.x_min_px.max(-0.5),
        y_min_px: b.y_min_px.max(-0.5),
        x_max_px: b.x_max_px.min(w),
        y_max_px: b.y_max_px.min(h),
    };
    if clipped.width_px() <= 0.0 || clipped.height_px() <= 0.0 {
        return Err(bad(format!(
            "box ({}, {})–({}, {}) lies outside the {width_px}×{height_px} image",
            b.x_min_px, b.y_min_px, b.x_max_px, b.y_max_px
        )));
    }
    if clipped != b {
        warnings.push(LabelWarning {
            line,
            what: format!(
                "box ({}, {})–({}, {}) reaches past the {width_px}×{height_px} image: clipped",
                b.x_min_px, b.y_min_px, b.x_max_px, b.y_max_px
            ),
        });
    }
    Ok(clipped)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn bx(x0: f64, y0: f64, x1: f64, y1: f64) -> BallBox {
        BallBox {
            x_min_px: x0,
            y_min_px: y0,
            x_max_px: x1,
            y_max_px: y1,
        }
    }

    #[test]
    fn iou_and_containment() {
        let a = bx(0.0, 0.0, 10.0, 10.0);
        assert_eq!(a.iou(&a), 1.0);
        assert!((a.iou(&bx(5.0, 0.0, 15.0, 10.0)) - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(a.iou(&bx(20.0, 20.0, 30.0, 30.0)), 0.0);
        assert!(a.contains([10.0, 0.0]) && !a.contains([10.1, 5.0]));
        assert_eq!(a.centre_px(), [5.0, 5.0]);
    }

    #[test]
    fn ball_names_ignore_case_and_spaces() {
        let n = BallNames::default();
        assert!(n.is_ball("Sports Ball") && n.is_ball(" football ") && n.is_ball("BALL"));
        assert!(!n.is_ball("person") && !n.is_ball("balls"));
    }

    #[test]
    fn boxes_are_clipped_or_refused() {
        let mut w = Vec::new();
        let ok = checked_box(bx(-2.0, 5.0, 12.0, 20.0), 10, 30, "f", 3, &mut w).unwrap();
        assert_eq!(ok, bx(-0.5, 5.0, 9.5, 20.0));
        assert_eq!(w.len(), 1);
        assert_eq!(w[0].line, 3);
        let swapped = checked_box(bx(8.0, 5.0, 2.0, 20.0), 10, 30, "f", 4, &mut w).unwrap_err();
        assert!(swapped.to_string().contains("f line 4"), "{swapped}");
        assert!(swapped.to_string().contains("maximum below"), "{swapped}");
        let outside = checked_box(bx(20.0, 5.0, 25.0, 9.0), 10, 30, "f", 5, &mut w).unwrap_err();
        assert!(outside.to_string().contains("outside"), "{outside}");
        let empty = checked_box(bx(2.0, 5.0, 2.0, 9.0), 10, 30, "f", 6, &mut w).unwrap_err();
        assert!(empty.to_string().contains("empty"), "{empty}");
    }
}
