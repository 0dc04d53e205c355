//! What a robot's camera saw: a small JPEG of one frame with what the detector made of it
//! (every candidate, the published ball, the rejected ones and why), and each camera's
//! perception counters carried in the robot's status.
//!
//! A view is published on `{prefix}/robots/{robot_id}/view/{camera}` at a low rate; the
//! JPEG travels inside the JSON as base64, so a view is one self-describing message like
//! every other on the wire. Annotations are in the JPEG's own pixels.

use crate::validate::{ValidationContext, ValidationError};
use crate::{Camera, Stamp};
use base64::Engine as _;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Widest and tallest view image, pixels.
pub const MAX_VIEW_SIDE_PX: u32 = 320;
/// Largest view JPEG, bytes (an agent aims at 30 kB and lowers the quality to fit).
pub const MAX_VIEW_JPEG_BYTES: usize = 32 * 1024;
/// Largest view message on the wire, bytes: the base64 JPEG and the annotations. A receiver
/// refuses a larger payload before it decodes it.
pub const MAX_VIEW_PAYLOAD_BYTES: usize = 64 * 1024;
/// Most candidates one view may carry.
pub const MAX_VIEW_CANDIDATES: usize = 64;
/// Longest rejection reason, bytes.
pub const MAX_REASON_BYTES: usize = 32;
/// Most rejection reasons a camera's counters may carry.
pub const MAX_REJECTION_REASONS: usize = 16;

/// The stage of the detector that proposed a candidate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CandidateStage {
    /// The colour stage (a blob of the ball's colours).
    Colour,
    /// The candidate network's heatmap.
    Network,
    /// The appearance (centre-surround contrast) stage.
    Appearance,
    /// Where the team's ball was predicted to appear.
    Predicted,
}

/// What became of a candidate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CandidateOutcome {
    /// Published as the frame's ball.
    Ball,
    /// Valid, but a more probable candidate was published.
    RunnerUp,
    /// Refused; `reason` says why.
    Rejected,
}

/// One candidate of a view, in the view image's pixels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ViewCandidate {
    pub u_px: f64,
    pub v_px: f64,
    pub radius_px: f64,
    /// The classifier's probability that it is the ball, 0..1.
    pub score: f64,
    pub stage: CandidateStage,
    pub outcome: CandidateOutcome,
    /// Why it was rejected (`low_probability`, `projection`, `off_pitch`,
    /// `radius_mismatch`, `far_from_shared`), with `outcome` `rejected`.
    pub reason: Option<String>,
}

/// A camera frame as the robot saw it, downscaled, with the detector's candidates.
/// Published on `{prefix}/robots/{robot_id}/view/{camera}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraView {
    pub version: u32,
    pub robot_id: String,
    /// Per-robot sequence number of its views.
    pub seq: u64,
    pub camera: Camera,
    /// Capture time of the frame.
    pub stamp: Stamp,
    /// Size of the JPEG, pixels (at most 320 each way).
    pub width_px: u32,
    pub height_px: u32,
    /// Size of the camera frame it was made from, pixels.
    pub source_width_px: u32,
    pub source_height_px: u32,
    /// The perception pipeline's time on this frame, milliseconds.
    pub detector_ms: f64,
    /// Every candidate the classifier scored, most probable first.
    pub candidates: Vec<ViewCandidate>,
    /// The image: a baseline or progressive JPEG, base64 (standard alphabet, padded).
    pub jpeg_base64: String,
}

/// One camera's perception since the agent started, and over the last status interval.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraPerception {
    pub camera: Camera,
    /// Frames processed since the agent started.
    pub frames: u64,
    /// Candidates the classifier scored, since the start.
    pub candidates: u64,
    /// Balls published, since the start.
    pub balls: u64,
    /// Candidates rejected since the start, by reason.
    pub rejections: BTreeMap<String, u64>,
    /// Over the last status interval: frames a second, candidates per frame, balls a
    /// second and the pipeline's median time per frame (milliseconds).
    pub frames_per_s: f64,
    pub candidates_per_frame: f64,
    pub balls_per_s: f64,
    pub detector_ms: f64,
}

impl CameraView {
    /// The JPEG's bytes, or why they are not a JPEG of the stated size.
    pub fn jpeg(&self) -> Result<Vec<u8>, ValidationError> {
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(self.jpeg_base64.as_bytes())
            .map_err(|_| ValidationError::NotAnImage("jpeg_base64 is not base64"))?;
        if bytes.len() > MAX_VIEW_JPEG_BYTES {
            return Err(ValidationError::TooLong {
                field: "jpeg_base64",
                bytes: bytes.len(),
                limit: MAX_VIEW_JPEG_BYTES,
            });
        }
        match jpeg_size_px(&bytes) {
            None => Err(ValidationError::NotAnImage("jpeg_base64 is not a JPEG")),
            Some(size) if size != (self.width_px, self.height_px) => Err(
                ValidationError::NotAnImage("the JPEG's size is not width_px × height_px"),
            ),
            Some(_) => Ok(bytes),
        }
    }

    /// Checks everything but the image (see [`CameraView::jpeg`]): the cheap checks a
    /// receiver makes first.
    pub fn validate_fields(&self, ctx: &ValidationContext) -> Result<(), ValidationError> {
        crate::validate::check_version(self.version)?;
        crate::validate::check_robot_id(&self.robot_id)?;
        crate::validate::check_count("candidates", self.candidates.len(), MAX_VIEW_CANDIDATES)?;
        let max_b64 = MAX_VIEW_JPEG_BYTES.div_ceil(3) * 4;
        if self.jpeg_base64.len() > max_b64 {
            return Err(ValidationError::TooLong {
                field: "jpeg_base64",
                bytes: self.jpeg_base64.len(),
                limit: max_b64,
            });
        }
        let side = f64::from(MAX_VIEW_SIDE_PX);
        for (field, v) in [("width_px", self.width_px), ("height_px", self.height_px)] {
            crate::validate::check_range(field, f64::from(v), 1.0, side)?;
        }
        for (field, v) in [
            ("source_width_px", self.source_width_px),
            ("source_height_px", self.source_height_px),
        ] {
            crate::validate::check_range(field, f64::from(v), 1.0, 100_000.0)?;
        }
        crate::validate::check_finite("detector_ms", &[self.detector_ms])?;
        crate::validate::check_range("detector_ms", self.detector_ms, 0.0, 1e6)?;
        let (w, h) = (f64::from(self.width_px), f64::from(self.height_px));
        for c in &self.candidates {
            crate::validate::check_finite("candidates", &[c.u_px, c.v_px, c.radius_px, c.score])?;
            crate::validate::check_range("candidates.u_px", c.u_px, 0.0, w)?;
            crate::validate::check_range("candidates.v_px", c.v_px, 0.0, h)?;
            crate::validate::check_range("candidates.radius_px", c.radius_px, 0.0, w.max(h))?;
            crate::validate::check_range("candidates.score", c.score, 0.0, 1.0)?;
            if let Some(r) = &c.reason {
                check_reason("candidates.reason", r)?;
            }
        }
        ctx.check_stamp(self.stamp)
    }
}

impl crate::Validate for CameraView {
    /// Every check, the image's too.
    fn validate(&self, ctx: &ValidationContext) -> Result<(), ValidationError> {
        self.validate_fields(ctx)?;
        self.jpeg().map(|_| ())
    }
}

/// A reason: 1..=[`MAX_REASON_BYTES`] of `a-z 0-9 _`.
fn check_reason(field: &'static str, r: &str) -> Result<(), ValidationError> {
    let ok = (1..=MAX_REASON_BYTES).contains(&r.len())
        && r.bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_');
    if ok {
        Ok(())
    } else {
        Err(ValidationError::TooLong {
            field,
            bytes: r.len(),
            limit: MAX_REASON_BYTES,
        })
    }
}

impl CameraPerception {
    pub(crate) fn validate(&self) -> Result<(), ValidationError> {
        crate::validate::check_count(
            "cameras.rejections",
            self.rejections.len(),
            MAX_REJECTION_REASONS,
        )?;
        for r in self.rejections.keys() {
            check_reason("cameras.rejections", r)?;
        }
        let rates = [
            self.frames_per_s,
            self.candidates_per_frame,
            self.balls_per_s,
            self.detector_ms,
        ];
        crate::validate::check_finite("cameras", &rates)?;
        for v in rates {
            crate::validate::check_range("cameras", v, 0.0, 1e6)?;
        }
        Ok(())
    }
}

/// Width and height of a JPEG from its frame header, or `None` when `bytes` is not a JPEG
/// (no start-of-image marker, or no frame header before the scan or the end).
pub fn jpeg_size_px(bytes: &[u8]) -> Option<(u32, u32)> {
    if bytes.len() < 4 || bytes[..3] != [0xFF, 0xD8, 0xFF] {
        return None;
    }
    let mut i = 2;
    while i + 4 <= bytes.len() {
        if bytes[i] != 0xFF {
            return None;
        }
        let marker = bytes[i + 1];
        match marker {
            // Fill bytes before a marker.
            0xFF => {
                i += 1;
                continue;
            }
            // Markers without a length.
            0x01 | 0xD0..=0xD7 => {
                i += 2;
                continue;
            }
            0xD9 | 0xDA => return None,
            _ => {}
        }
        let len = usize::from(u16::from_be_bytes([bytes[i + 2], bytes[i + 3]]));
        if len < 2 {
            return None;
        }
        let is_frame = matches!(marker, 0xC0..=0xCF) && !matches!(marker, 0xC4 | 0xC8 | 0xCC);
        if is_frame {
            let h = bytes.get(i + 5..i + 7)?;
            let w = bytes.get(i + 7..i + 9)?;
            let (h, w) = (
                u32::from(u16::from_be_bytes([h[0], h[1]])),
                u32::from(u16::from_be_bytes([w[0], w[1]])),
            );
            return (w > 0 && h > 0).then_some((w, h));
        }
        i += 2 + len;
    }
    None
}

/// The base64 text of a JPEG, for [`CameraView::jpeg_base64`].
pub fn jpeg_base64(jpeg: &[u8]) -> String {
    base64::engine::general_purpose::STANDARD.encode(jpeg)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The smallest header a decoder would read: SOI, an APP0 segment, SOF0 of 7×5.
    fn header(w: u16, h: u16) -> Vec<u8> {
        let mut b = vec![0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x04, 0x00, 0x00];
        b.extend([0xFF, 0xC0, 0x00, 0x0B, 0x08]);
        b.extend(h.to_be_bytes());
        b.extend(w.to_be_bytes());
        b.extend([0x01, 0x01, 0x11, 0x00, 0xFF, 0xD9]);
        b
    }

    #[test]
    fn the_frame_header_gives_the_size() {
        assert_eq!(jpeg_size_px(&header(7, 5)), Some((7, 5)));
        assert_eq!(jpeg_size_px(b"\x89PNG\r\n\x1a\n"), None);
        assert_eq!(jpeg_size_px(&[0xFF, 0xD8, 0xFF, 0xD9]), None);
        // A header cut short is not a size.
        assert_eq!(jpeg_size_px(&header(7, 5)[..12]), None);
    }

    #[test]
    fn a_truncated_or_lying_length_never_panics() {
        for cut in 0..header(7, 5).len() {
            let _ = jpeg_size_px(&header(7, 5)[..cut]);
        }
        let mut b = header(7, 5);
        b[4] = 0xFF;
        b[5] = 0xFF;
        assert_eq!(jpeg_size_px(&b), None);
    }

    #[test]
    fn reasons_are_short_snake_case() {
        assert!(check_reason("r", "low_probability").is_ok());
        assert!(check_reason("r", "").is_err());
        assert!(check_reason("r", "Low Probability").is_err());
        assert!(check_reason("r", &"a".repeat(MAX_REASON_BYTES + 1)).is_err());
    }
}
