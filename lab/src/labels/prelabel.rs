//! Labels made by the detector for a person to correct: its balls as YOLO or VOC label
//! files (what LabelImg, CVAT and Label Studio import), and how unsure it was of each photo,
//! so the least certain photos can be checked first.

use crate::labels::BallBox;
use crate::labels::voc::write_voc;
use crate::labels::yolo::yolo_line;
use vision::Circle;

/// The label formats the detector writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum LabelFormat {
    /// One `NAME.txt` per photo, lines `0 cx cy w h` normalised, and `classes.txt` naming
    /// class 0 `ball`.
    Yolo,
    /// One Pascal VOC `NAME.xml` per photo, objects named `ball`.
    Voc,
}

impl LabelFormat {
    /// The label file's extension.
    pub fn extension(self) -> &'static str {
        match self {
            LabelFormat::Yolo => "txt",
            LabelFormat::Voc => "xml",
        }
    }

    /// The label file of a photo `file_name` (`width_px`×`height_px`) with these balls; a
    /// photo without a ball gets an empty file (reviewed: no ball), not none.
    pub fn file(self, file_name: &str, width_px: u32, height_px: u32, balls: &[BallBox]) -> String {
        match self {
            LabelFormat::Yolo => balls
                .iter()
                .map(|b| yolo_line(0, b, width_px, height_px) + "\n")
                .collect(),
            LabelFormat::Voc => write_voc(file_name, width_px, height_px, balls),
        }
    }
}

/// The box of a detected circle, clipped to the image (pixel centres at integers, so the
/// image spans -0.5..width - 0.5); `None` when nothing of it is in the image.
pub fn circle_box(circle: &Circle, width_px: u32, height_px: u32) -> Option<BallBox> {
    let [x, y] = circle.center_px;
    let r = circle.radius_px;
    let (w, h) = (f64::from(width_px) - 0.5, f64::from(height_px) - 0.5);
    let b = BallBox {
        x_min_px: (x - r).max(-0.5),
        y_min_px: (y - r).max(-0.5),
        x_max_px: (x + r).min(w),
        y_max_px: (y + r).min(h),
    };
    (b.width_px() > 0.0 && b.height_px() > 0.0).then_some(b)
}

/// How unsure the detector was about a photo, 0 (every candidate far from the threshold)
/// to 1 (one exactly at it): the largest over the candidates' probabilities of one less
/// their distance from `threshold`, measured as a share of the way to 0 or to 1.
pub fn uncertainty(probabilities: &[f64], threshold: f64) -> f64 {
    let t = threshold.clamp(1e-6, 1.0 - 1e-6);
    probabilities
        .iter()
        .filter(|p| p.is_finite())
        .map(|&p| {
            let margin = if p < t {
                (t - p) / t
            } else {
                (p - t) / (1.0 - t)
            };
            1.0 - margin.clamp(0.0, 1.0)
        })
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::labels::voc::parse_voc;
    use crate::labels::yolo::{BallClassIds, parse_yolo};

    fn circle(x: f64, y: f64, r: f64) -> Circle {
        Circle {
            center_px: [x, y],
            radius_px: r,
            score: 1.0,
        }
    }

    #[test]
    fn written_labels_read_back_as_the_detected_ball() {
        let b = circle_box(&circle(100.0, 60.0, 12.0), 320, 240).unwrap();
        let yolo = LabelFormat::Yolo.file("a.jpg", 320, 240, &[b]);
        let ids = BallClassIds {
            ids: vec![0],
            known_classes: Some(1),
        };
        let read = parse_yolo(&yolo, "a.txt", 320, 240, &ids).unwrap();
        assert_eq!(read.balls.len(), 1);
        let [cx, cy] = read.balls[0].centre_px();
        assert!(
            (cx - 100.0).abs() < 0.01 && (cy - 60.0).abs() < 0.01,
            "{cx} {cy}"
        );
        assert!((read.balls[0].width_px() - 24.0).abs() < 0.01);
        let voc = LabelFormat::Voc.file("a.jpg", 320, 240, &[b]);
        let read = parse_voc(&voc, "a.xml", &Default::default()).unwrap();
        assert_eq!((read.width_px, read.height_px), (320, 240));
        let [cx, cy] = read.balls[0].centre_px();
        assert!(
            (cx - 100.0).abs() < 0.01 && (cy - 60.0).abs() < 0.01,
            "{cx} {cy}"
        );
        assert_eq!(LabelFormat::Yolo.file("b.jpg", 320, 240, &[]), "");
        assert!(
            !LabelFormat::Voc
                .file("b.jpg", 320, 240, &[])
                .contains("<object>")
        );
    }

    #[test]
    fn a_ball_at_the_edge_is_clipped_and_one_outside_has_no_box() {
        let b = circle_box(&circle(2.0, 100.0, 10.0), 320, 240).unwrap();
        assert_eq!(b.x_min_px, -0.5);
        assert_eq!(b.x_max_px, 12.0);
        assert!(circle_box(&circle(-30.0, 100.0, 10.0), 320, 240).is_none());
    }

    #[test]
    fn photos_near_the_threshold_are_the_least_certain() {
        assert_eq!(uncertainty(&[], 0.5), 0.0);
        assert!((uncertainty(&[0.5], 0.5) - 1.0).abs() < 1e-12);
        let sure = uncertainty(&[0.99, 0.01], 0.5);
        let unsure = uncertainty(&[0.99, 0.45], 0.5);
        assert!(sure < 0.05 && unsure > 0.85, "{sure} {unsure}");
        assert!(uncertainty(&[f64::NAN], 0.5) == 0.0);
    }
}
