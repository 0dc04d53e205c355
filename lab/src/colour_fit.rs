//! Fitting the colour detector's window to labelled photos (`ball-lab calibrate-colour`).
//!
//! Ball pixels are the disc inside each labelled box (shrunk to 70 % of its radius, so that
//! the box's corners and the ball's rim, which mix with the floor, are left out); background
//! pixels are the ring from 1.5 to 3 radii around it, where the floor and what lies next to
//! the ball are. The hue window runs from the 10th to the 90th percentile of the hues of the
//! ball's coloured pixels (saturation at least 0.25) about their circular mean (so a red ball's window can wrap through 0°), widened by a
//! margin; the saturation and value floors are the 10th and 5th percentiles less a margin.
//! The fit reports how many ball pixels and how many background pixels the window lets in.

use thiserror::Error;
use vision::Circle;
use vision::image::RgbImage;
use vision::settings::HsvThresholds;
use vision::stages::colour::disc_hsv;

/// Why no window can be fitted.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ColourFitError {
    #[error(
        "only {0} (coloured) ball pixels in the labelled boxes: label more balls (at least 50 pixels)"
    )]
    TooFewPixels(usize),
}

/// Ball and background pixels (hue degrees, saturation, value) gathered from photos.
#[derive(Debug, Clone, Default)]
pub struct ColourSamples {
    pub ball: Vec<(f64, f64, f64)>,
    pub background: Vec<(f64, f64, f64)>,
}

impl ColourSamples {
    /// Adds one labelled ball of a photo: its centre and radius.
    pub fn add_ball(&mut self, image: &RgbImage, centre_px: [f64; 2], radius_px: f64) {
        let circle = Circle {
            center_px: centre_px,
            radius_px,
            score: 1.0,
        };
        self.ball.extend(disc_hsv(image, &circle, 0.7));
        // The ring, every `step`-th pixel, so a big ring does not outweigh the other
        // balls' rings (about 400 pixels each).
        let ring = std::f64::consts::PI * (9.0 - 2.25) * radius_px * radius_px;
        let step = ((ring / 400.0) as usize).max(1);
        let [cx, cy] = centre_px;
        let r15 = 1.5 * radius_px;
        let reach = 3.0 * radius_px;
        let (x0, x1) = (
            (cx - reach).floor().max(0.0) as u32,
            (cx + reach).ceil().max(0.0) as u32,
        );
        let (y0, y1) = (
            (cy - reach).floor().max(0.0) as u32,
            (cy + reach).ceil().max(0.0) as u32,
        );
        let mut k = 0;
        for y in y0..y1.min(image.height()) {
            let dy = f64::from(y) - cy;
            for x in x0..x1.min(image.width()) {
                let dx = f64::from(x) - cx;
                let d = dx.hypot(dy);
                if d > r15 && d <= 3.0 * radius_px {
                    k += 1;
                    if k % step == 0
                        && let Some([r, g, b]) = image.pixel(x, y)
                    {
                        self.background
                            .push(vision::stages::colour::rgb_to_hsv(r, g, b));
                    }
                }
            }
        }
    }
}

/// A fitted window and how well it separates the samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColourFit {
    pub thresholds: HsvThresholds,
    /// A wider window for lighting adaptation to move within.
    pub limits: HsvThresholds,
    pub ball_pixels: usize,
    pub background_pixels: usize,
    /// Share of ball pixels inside the window.
    pub ball_inside: f64,
    /// Share of background pixels inside the window.
    pub background_inside: f64,
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

fn wrap(a: f64) -> f64 {
    a.rem_euclid(360.0)
}

/// Fits the window to the samples.
pub fn fit(samples: &ColourSamples) -> Result<ColourFit, ColourFitError> {
    let n = samples.ball.len();
    if n < 50 {
        return Err(ColourFitError::TooFewPixels(n));
    }
    // Hue about the circular mean, weighted by saturation (grey pixels have no hue).
    let (mut s, mut c) = (0.0, 0.0);
    for &(h, sat, _) in &samples.ball {
        s += sat * h.to_radians().sin();
        c += sat * h.to_radians().cos();
    }
    let mean = wrap(s.atan2(c).to_degrees());
    // Only coloured pixels say where the hue lies (a pale or dark pixel's hue is noise).
    let mut offsets: Vec<f64> = samples
        .ball
        .iter()
        .filter(|p| p.1 >= 0.25 && p.2 >= 0.15)
        .map(|&(h, _, _)| wrap(h - mean + 180.0) - 180.0)
        .collect();
    if offsets.len() < 50 {
        return Err(ColourFitError::TooFewPixels(offsets.len()));
    }
    offsets.sort_by(f64::total_cmp);
    let margin_deg = 3.0;
    let (lo_off, hi_off) = (
        percentile(&offsets, 0.10) - margin_deg,
        percentile(&offsets, 0.90) + margin_deg,
    );
    let mut sats: Vec<f64> = samples.ball.iter().map(|p| p.1).collect();
    let mut vals: Vec<f64> = samples.ball.iter().map(|p| p.2).collect();
    sats.sort_by(f64::total_cmp);
    vals.sort_by(f64::total_cmp);
    let sat_min = (percentile(&sats, 0.10) - 0.05).clamp(0.05, 0.95);
    let val_min = (percentile(&vals, 0.05) - 0.05).clamp(0.02, 0.95);
    let thresholds = HsvThresholds {
        hue_lo_deg: wrap(mean + lo_off),
        hue_hi_deg: wrap(mean + hi_off),
        sat_min,
        sat_max: 1.0,
        val_min,
        val_max: 1.0,
    };
    let limits = HsvThresholds {
        hue_lo_deg: wrap(mean + lo_off - 10.0),
        hue_hi_deg: wrap(mean + hi_off + 10.0),
        sat_min: (sat_min - 0.15).max(0.02),
        sat_max: 1.0,
        val_min: (val_min - 0.05).max(0.01),
        val_max: 1.0,
    };
    // Rounded as the settings file writes them, so the file is the window reported here.
    let round = |t: HsvThresholds| HsvThresholds {
        hue_lo_deg: wrap((t.hue_lo_deg * 10.0).round() / 10.0),
        hue_hi_deg: wrap((t.hue_hi_deg * 10.0).round() / 10.0),
        sat_min: (t.sat_min * 1000.0).round() / 1000.0,
        sat_max: t.sat_max,
        val_min: (t.val_min * 1000.0).round() / 1000.0,
        val_max: t.val_max,
    };
    let (thresholds, limits) = (round(thresholds), round(limits));
    let inside = |px: &[(f64, f64, f64)]| {
        if px.is_empty() {
            return 0.0;
        }
        px.iter()
            .filter(|&&(h, s, v)| thresholds.contains(h, s, v))
            .count() as f64
            / px.len() as f64
    };
    Ok(ColourFit {
        thresholds,
        limits,
        ball_pixels: n,
        background_pixels: samples.background.len(),
        ball_inside: inside(&samples.ball),
        background_inside: inside(&samples.background),
    })
}

impl ColourFit {
    /// The settings file's tables for this window.
    pub fn to_toml(self) -> String {
        let table = |name: &str, t: &HsvThresholds| {
            format!(
                "[detector.{name}]\nhue_lo_deg = {:.1}\nhue_hi_deg = {:.1}\nsat_min = {:.3}\nsat_max = {:.3}\nval_min = {:.3}\nval_max = {:.3}\n",
                t.hue_lo_deg, t.hue_hi_deg, t.sat_min, t.sat_max, t.val_min, t.val_max
            )
        };
        format!(
            "# Fitted by ball-lab calibrate-colour: {} ball pixels ({:.1} % inside the window), \
             {} background pixels ({:.2} % inside).\n# For the dissertation's colour pipeline: `--detector dissertation --config THIS_FILE`.\n{}\n{}",
            self.ball_pixels,
            100.0 * self.ball_inside,
            self.background_pixels,
            100.0 * self.background_inside,
            table("thresholds", &self.thresholds),
            table("limits", &self.limits)
        )
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// A yellow disc on green carpet.
    fn photo() -> RgbImage {
        let mut img = RgbImage::filled(120, 90, [40, 130, 50]).unwrap();
        for y in 0..90 {
            for x in 0..120 {
                if (f64::from(x) - 60.0).hypot(f64::from(y) - 45.0) < 12.0 {
                    let k = ((x + y) % 7) as u8;
                    img.set_pixel(x, y, [230 - 3 * k, 210 - 2 * k, 40 + k]);
                }
            }
        }
        img
    }

    #[test]
    fn a_yellow_ball_gets_a_yellow_window_that_keeps_the_carpet_out() {
        let mut s = ColourSamples::default();
        s.add_ball(&photo(), [60.0, 45.0], 12.0);
        let f = fit(&s).unwrap();
        assert!(f.ball_inside > 0.85, "{f:?}");
        assert!(f.background_inside < 0.01, "{f:?}");
        let t = f.thresholds;
        assert!(t.hue_lo_deg > 35.0 && t.hue_hi_deg < 75.0, "{t:?}");
        assert!(t.contains(55.0, 0.8, 0.9));
        let toml_text = f.to_toml();
        #[derive(serde::Deserialize)]
        struct Settings {
            detector: vision::DetectorConfig,
        }
        let parsed: Settings = toml::from_str(&toml_text).unwrap();
        assert_eq!(parsed.detector.thresholds, t);
        assert_eq!(parsed.detector.limits, f.limits);
    }

    #[test]
    fn too_few_pixels_is_an_error() {
        let mut s = ColourSamples::default();
        s.add_ball(&photo(), [60.0, 45.0], 2.0);
        assert!(matches!(fit(&s), Err(ColourFitError::TooFewPixels(_))));
    }
}
