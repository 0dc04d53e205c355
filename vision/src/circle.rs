//! A ball candidate's circle in image pixels: what every proposal stage finds and the
//! check judges.

/// A circle in an image's pixel coordinates (a proposal's, a refined candidate's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    /// Centre (x right, y down), pixels.
    pub center_px: [f64; 2],
    /// Radius, pixels.
    pub radius_px: f64,
    /// The proposing stage's score (the Hough transform's: supporting edge pixels divided
    /// by the circumference in pixels).
    pub score: f64,
}
