//! The simulator's own camera lens: an equisolid-like fisheye the agent is never told.
//!
//! A ray at angle θ from the optical axis lands at radius `r = 2·f·sin(θ / 1.25)` pixels
//! from the principal point, the lens of MiRo's simulated camera. The agent must find
//! its intrinsics and distortion by calibrating from rendered chessboards, as it would on
//! a real robot; so the principal point sits slightly off-centre and the pixels are very
//! slightly non-square, as they are on a real sensor.
//!
//! Camera (optical) frame, as in `proto::miro`: z along the optical axis, x to the image's
//! right, y down the image. Pixel coordinates have (0, 0) at the top-left pixel's top-left
//! corner, so the centre of pixel (i, j) is (i + 0.5, j + 0.5).

use crate::vec3::V3;

/// The lens's divisor of θ: `r = 2·f·sin(θ / THETA_DIVISOR)`.
pub const THETA_DIVISOR: f64 = 1.25;
/// Directions further than this from the optical axis are not imaged (the mapping is
/// monotonic up to 1.25·90° = 112.5°; a margin keeps it well conditioned).
pub const MAX_THETA_RAD: f64 = 105.0 * std::f64::consts::PI / 180.0;

/// A fisheye lens and sensor. `f_px` is the horizontal focal length; the vertical one is
/// `aspect · f_px`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LensModel {
    pub width: u32,
    pub height: u32,
    pub f_px: f64,
    pub cx: f64,
    pub cy: f64,
    /// fy / fx.
    pub aspect: f64,
}

impl LensModel {
    /// MiRo's camera at its delivered 640×360: 120° horizontal field of view.
    pub fn miro() -> Self {
        let half_fov_rad = proto::miro::HORIZONTAL_FOV_RAD / 2.0;
        LensModel {
            width: 640,
            height: 360,
            // 320 px = 2·f·sin(60° / 1.25).
            f_px: 320.0 / (2.0 * (half_fov_rad / THETA_DIVISOR).sin()),
            cx: 322.7,
            cy: 178.4,
            aspect: 0.997,
        }
    }

    /// The same lens imaged at another resolution (same field of view, same relative
    /// principal point), e.g. 1280×720.
    pub fn scaled_to(&self, width: u32, height: u32) -> Self {
        let k = f64::from(width) / f64::from(self.width);
        let ky = f64::from(height) / f64::from(self.height);
        LensModel {
            width,
            height,
            f_px: self.f_px * k,
            cx: self.cx * k,
            cy: self.cy * ky,
            aspect: self.aspect * ky / k,
        }
    }

    /// Radius in pixels (horizontal units) of a ray at `theta_rad` from the axis.
    pub fn radius_px(&self, theta_rad: f64) -> f64 {
        2.0 * self.f_px * (theta_rad / THETA_DIVISOR).sin()
    }

    /// Angle from the axis of a ray landing `r_px` (horizontal units) from the principal
    /// point; `None` beyond the lens's range.
    pub fn theta_rad(&self, r_px: f64) -> Option<f64> {
        let s = r_px / (2.0 * self.f_px);
        let theta = THETA_DIVISOR * s.min(1.0).asin();
        (s <= 1.0 && theta <= MAX_THETA_RAD).then_some(theta)
    }

    /// Pixel where a direction in the camera frame is imaged (need not be a unit vector).
    /// The pixel may lie outside the image; `None` only when the direction is beyond
    /// [`MAX_THETA_RAD`] from the axis (or zero).
    pub fn project(&self, dir_cam: V3) -> Option<[f64; 2]> {
        let [x, y, z] = dir_cam;
        let rho = x.hypot(y);
        let theta = rho.atan2(z);
        if theta.is_nan() || theta > MAX_THETA_RAD || (rho == 0.0 && z <= 0.0) {
            return None;
        }
        let r = self.radius_px(theta);
        let (ux, uy) = if rho > 0.0 {
            (x / rho, y / rho)
        } else {
            (0.0, 0.0)
        };
        Some([self.cx + r * ux, self.cy + self.aspect * r * uy])
    }

    /// Unit direction in the camera frame of the ray through `pixel`; `None` beyond the
    /// lens's range. Exact inverse of [`LensModel::project`].
    pub fn ray(&self, pixel: [f64; 2]) -> Option<V3> {
        let dx = pixel[0] - self.cx;
        let dy = (pixel[1] - self.cy) / self.aspect;
        let r = dx.hypot(dy);
        let theta = self.theta_rad(r)?;
        if r == 0.0 {
            return Some([0.0, 0.0, 1.0]);
        }
        let (s, c) = theta.sin_cos();
        Some([s * dx / r, s * dy / r, c])
    }

    /// Whether a pixel position lies inside the image, at least `margin_px` from its edges.
    pub fn contains(&self, pixel: [f64; 2], margin_px: f64) -> bool {
        pixel[0] >= margin_px
            && pixel[1] >= margin_px
            && pixel[0] <= f64::from(self.width) - margin_px
            && pixel[1] <= f64::from(self.height) - margin_px
    }
}

impl Default for LensModel {
    fn default() -> Self {
        LensModel::miro()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::vec3::{norm, sub, unit};

    #[test]
    fn miro_lens_has_a_120_degree_horizontal_field_of_view() {
        let lens = LensModel::miro();
        assert!((lens.f_px - 215.3).abs() < 0.05, "{}", lens.f_px);
        let left = lens.ray([lens.cx - 320.0, lens.cy]).unwrap();
        let right = lens.ray([lens.cx + 320.0, lens.cy]).unwrap();
        let fov = left[2].acos() + right[2].acos();
        assert!(
            (fov.to_degrees() - 120.0).abs() < 1e-9,
            "{}",
            fov.to_degrees()
        );
        // The image's corners are imaged at under 90° from the axis.
        let corner = lens.ray([0.0, 0.0]).unwrap();
        assert!(corner[2] > 0.0);
    }

    #[test]
    fn project_and_ray_are_inverses() {
        for lens in [LensModel::miro(), LensModel::miro().scaled_to(1280, 720)] {
            for j in 0..=12 {
                for i in 0..=16 {
                    let px = [
                        f64::from(lens.width) * f64::from(i) / 16.0,
                        f64::from(lens.height) * f64::from(j) / 12.0,
                    ];
                    let d = lens.ray(px).unwrap();
                    assert!((norm(d) - 1.0).abs() < 1e-12);
                    let back = lens.project(d).unwrap();
                    assert!((back[0] - px[0]).abs() < 1e-9 && (back[1] - px[1]).abs() < 1e-9);
                    let d2 = lens
                        .ray(lens.project(unit([d[0], d[1], d[2]])).unwrap())
                        .unwrap();
                    assert!(norm(sub(d, d2)) < 1e-12);
                }
            }
        }
    }

    #[test]
    fn scaling_keeps_the_field_of_view() {
        let a = LensModel::miro();
        let b = a.scaled_to(1280, 720);
        let d = [0.3, -0.2, 0.9];
        let pa = a.project(d).unwrap();
        let pb = b.project(d).unwrap();
        assert!((pb[0] - 2.0 * pa[0]).abs() < 1e-9 && (pb[1] - 2.0 * pa[1]).abs() < 1e-9);
    }

    #[test]
    fn directions_behind_the_lens_are_not_imaged() {
        let lens = LensModel::miro();
        assert!(lens.project([0.0, 0.0, -1.0]).is_none());
        assert!(lens.project([1.0, 0.0, -1.0]).is_none());
        assert!(lens.project([1.0, 0.0, -0.1]).is_some());
        assert!(lens.ray([lens.cx + 1000.0, lens.cy]).is_none());
        assert_eq!(lens.project([0.0, 0.0, 2.0]), Some([lens.cx, lens.cy]));
    }
}
