//! Camera models for a MiRo's cameras: pinhole intrinsics with either OpenCV's
//! Brown–Conrady (radial-tangential) distortion or OpenCV's fisheye (Kannala–Brandt)
//! distortion.
//!
//! The camera frame has z forward (along the optical axis), x right and y down, in metres;
//! pixel coordinates have u right and v down with the origin at the top-left corner of the
//! image, OpenCV's convention (the centre of the top-left pixel is (0, 0)).
//!
//! Every operation is a pure function that returns `None` instead of a meaningless or
//! non-finite answer: behind the camera, outside the region where the distortion is
//! invertible, or when the inverse distortion does not converge.

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Largest number of Newton iterations spent inverting the distortion.
const MAX_NEWTON_ITERATIONS: usize = 50;

/// Largest residual, in normalised image coordinates, accepted from the inverse distortion.
/// With focal lengths of a few hundred pixels it is well under a nanopixel.
const NEWTON_TOLERANCE: f64 = 1e-13;

/// Below this ratio of off-axis distance to depth a fisheye point is treated as on the
/// optical axis, where the general formulas divide by zero; the error so made is of the
/// order of the square of the ratio.
const ON_AXIS_RATIO: f64 = 1e-7;

/// The pinhole part of a camera: focal lengths and principal point in pixels, and the image
/// size.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Intrinsics {
    /// Horizontal focal length, pixels.
    pub fx_px: f64,
    /// Vertical focal length, pixels.
    pub fy_px: f64,
    /// Horizontal coordinate of the principal point, pixels.
    pub cx_px: f64,
    /// Vertical coordinate of the principal point, pixels.
    pub cy_px: f64,
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
}

impl Intrinsics {
    /// Whether a pixel lies on the image: within `[-0.5, width - 0.5] × [-0.5, height - 0.5]`,
    /// the area covered by the image's pixels when pixel centres are at integer coordinates.
    pub fn contains(&self, pixel: [f64; 2]) -> bool {
        let [u, v] = pixel;
        (-0.5..=f64::from(self.width_px) - 0.5).contains(&u)
            && (-0.5..=f64::from(self.height_px) - 0.5).contains(&v)
    }
}

/// A lens distortion model, acting on normalised image coordinates (pixel offsets from the
/// principal point divided by the focal lengths).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case")]
pub enum Distortion {
    /// OpenCV's pinhole distortion: for an undistorted normalised point (x, y) with
    /// r² = x² + y²,
    /// x_d = x (1 + k1 r² + k2 r⁴ + k3 r⁶) + 2 p1 x y + p2 (r² + 2 x²) and
    /// y_d = y (1 + k1 r² + k2 r⁴ + k3 r⁶) + p1 (r² + 2 y²) + 2 p2 x y.
    /// All zero is the plain pinhole camera.
    BrownConrady {
        /// Radial coefficient of r².
        k1: f64,
        /// Radial coefficient of r⁴.
        k2: f64,
        /// First tangential coefficient.
        p1: f64,
        /// Second tangential coefficient.
        p2: f64,
        /// Radial coefficient of r⁶.
        k3: f64,
    },
    /// OpenCV's fisheye distortion: a ray at angle θ from the optical axis lands at distance
    /// θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸) from the principal point in normalised
    /// coordinates, in the ray's own azimuth. All zero is the equidistant projection.
    KannalaBrandt {
        /// Coefficient of θ³.
        k1: f64,
        /// Coefficient of θ⁵.
        k2: f64,
        /// Coefficient of θ⁷.
        k3: f64,
        /// Coefficient of θ⁹.
        k4: f64,
    },
}

impl Distortion {
    /// No distortion: the plain pinhole camera.
    pub const NONE: Distortion = Distortion::BrownConrady {
        k1: 0.0,
        k2: 0.0,
        p1: 0.0,
        p2: 0.0,
        k3: 0.0,
    };
}

/// Why a camera model cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CameraModelError {
    /// A focal length is zero, negative or not a number.
    #[error("focal length {field} = {value} is not positive")]
    NonPositiveFocalLength {
        /// The offending field.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// A parameter is infinite or not a number.
    #[error("parameter {field} is not finite")]
    NonFinite {
        /// The offending field.
        field: &'static str,
    },
    /// The image has no pixels.
    #[error("image size {width_px}×{height_px} px is empty")]
    ZeroImageSize {
        /// Image width, pixels.
        width_px: u32,
        /// Image height, pixels.
        height_px: u32,
    },
}

/// A calibrated camera: intrinsics and lens distortion.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraModel {
    /// Focal lengths, principal point and image size.
    pub intrinsics: Intrinsics,
    /// Lens distortion.
    pub distortion: Distortion,
}

impl CameraModel {
    /// A plain pinhole camera (no distortion) with the given focal lengths and principal
    /// point, pixels, for an image of `width_px × height_px`.
    pub fn pinhole(
        fx_px: f64,
        fy_px: f64,
        cx_px: f64,
        cy_px: f64,
        width_px: u32,
        height_px: u32,
    ) -> CameraModel {
        CameraModel {
            intrinsics: Intrinsics {
                fx_px,
                fy_px,
                cx_px,
                cy_px,
                width_px,
                height_px,
            },
            distortion: Distortion::NONE,
        }
    }

    /// The same camera with its images resized to `width_px × height_px` (the whole sensor
    /// scaled, not cropped): the focal lengths and principal point scale with the image,
    /// the principal point about the top-left corner of the image (pixel centres are at
    /// integer coordinates, so the image spans −0.5 to width − 0.5). The distortion acts
    /// on normalised coordinates and stays as it is.
    pub fn scaled_to(&self, width_px: u32, height_px: u32) -> CameraModel {
        let i = &self.intrinsics;
        let sx = f64::from(width_px) / f64::from(i.width_px);
        let sy = f64::from(height_px) / f64::from(i.height_px);
        CameraModel {
            intrinsics: Intrinsics {
                fx_px: i.fx_px * sx,
                fy_px: i.fy_px * sy,
                cx_px: (i.cx_px + 0.5) * sx - 0.5,
                cy_px: (i.cy_px + 0.5) * sy - 0.5,
                width_px,
                height_px,
            },
            distortion: self.distortion,
        }
    }

    /// Checks that the model is usable: finite parameters, positive focal lengths and a
    /// non-empty image.
    pub fn check(&self) -> Result<(), CameraModelError> {
        let i = &self.intrinsics;
        for (field, value) in [("fx_px", i.fx_px), ("fy_px", i.fy_px)] {
            if value.is_nan() || value <= 0.0 {
                return Err(CameraModelError::NonPositiveFocalLength { field, value });
            }
        }
        let coefficients: &[(&'static str, f64)] = match self.distortion {
            Distortion::BrownConrady { k1, k2, p1, p2, k3 } => {
                &[("k1", k1), ("k2", k2), ("p1", p1), ("p2", p2), ("k3", k3)]
            }
            Distortion::KannalaBrandt { k1, k2, k3, k4 } => {
                &[("k1", k1), ("k2", k2), ("k3", k3), ("k4", k4)]
            }
        };
        let intrinsics = [
            ("fx_px", i.fx_px),
            ("fy_px", i.fy_px),
            ("cx_px", i.cx_px),
            ("cy_px", i.cy_px),
        ];
        if let Some((field, _)) = intrinsics
            .iter()
            .chain(coefficients)
            .find(|(_, value)| !value.is_finite())
        {
            return Err(CameraModelError::NonFinite { field });
        }
        if i.width_px == 0 || i.height_px == 0 {
            return Err(CameraModelError::ZeroImageSize {
                width_px: i.width_px,
                height_px: i.height_px,
            });
        }
        Ok(())
    }

    /// Projects a point in the camera frame (metres) to pixel coordinates.
    ///
    /// `None` when the model fails [`CameraModel::check`], when the point is not in front of
    /// the camera (z ≤ 0, for both models: the fisheye model accepts any angle strictly
    /// under 90° off the axis), when it lies where the distortion folds over and so cannot be
    /// inverted, or when anything is not finite. The fold test is local, at the point: for
    /// Brown–Conrady the radial factor, the radial derivative d(r_d)/dr and the Jacobian
    /// determinant of the map must be positive; for the fisheye dθ_d/dθ must be. The pixel
    /// may fall outside the image; see [`Intrinsics::contains`].
    pub fn project(&self, p_cam: [f64; 3]) -> Option<[f64; 2]> {
        let (m, _) = self.distort_point(p_cam)?;
        self.pixel_of_normalised(m)
    }

    /// The Jacobian of [`CameraModel::project`] with respect to the point in the camera
    /// frame, in pixels per metre: row 0 is ∂u/∂(x, y, z), row 1 is ∂v/∂(x, y, z).
    ///
    /// Computed analytically by the chain rule (focal lengths × distortion × perspective
    /// division); `None` exactly where `project` is.
    pub fn project_jacobian(&self, p_cam: [f64; 3]) -> Option<[[f64; 3]; 2]> {
        let (m, j) = self.distort_point(p_cam)?;
        self.pixel_of_normalised(m)?;
        let i = &self.intrinsics;
        let jacobian = [
            [i.fx_px * j[0][0], i.fx_px * j[0][1], i.fx_px * j[0][2]],
            [i.fy_px * j[1][0], i.fy_px * j[1][1], i.fy_px * j[1][2]],
        ];
        jacobian
            .iter()
            .flatten()
            .all(|v| v.is_finite())
            .then_some(jacobian)
    }

    /// The unit ray, in the camera frame, of the points that project to a pixel.
    ///
    /// The distortion is inverted by Newton's method, and the solution accepted only if it
    /// re-distorts to within 1e-13 (normalised, relative) of the pixel's normalised
    /// coordinates and passes the same fold test as [`CameraModel::project`].
    ///
    /// `None` when the model fails [`CameraModel::check`], when the pixel is not finite, when
    /// the inverse distortion does not converge, or when the pixel lies beyond what the lens
    /// can image (the fisheye angle would reach 90°, or the solution lies where the
    /// distortion folds over). Pixels outside the image are unprojected like any other.
    pub fn unproject(&self, pixel: [f64; 2]) -> Option<[f64; 3]> {
        let m = self.normalised_of_pixel(pixel)?;
        let ray = match self.distortion {
            Distortion::BrownConrady { .. } => {
                let [x, y] = self.undistort_normalised(m)?;
                let norm = (x * x + y * y + 1.0).sqrt();
                [x / norm, y / norm, 1.0 / norm]
            }
            Distortion::KannalaBrandt { k1, k2, k3, k4 } => {
                let theta_d = m[0].hypot(m[1]);
                if theta_d == 0.0 {
                    [0.0, 0.0, 1.0]
                } else {
                    let theta = fisheye_inverse(theta_d, [k1, k2, k3, k4])?;
                    let s = theta.sin() / theta_d;
                    [s * m[0], s * m[1], theta.cos()]
                }
            }
        };
        ray.iter().all(|v| v.is_finite()).then_some(ray)
    }

    /// The normalised undistorted coordinates (x/z, y/z) of the points that project to a
    /// pixel: where an ideal pinhole camera with unit focal length would see them.
    ///
    /// `None` where [`CameraModel::unproject`] is.
    pub fn undistort_point(&self, pixel: [f64; 2]) -> Option<[f64; 2]> {
        match self.distortion {
            Distortion::BrownConrady { .. } => {
                self.undistort_normalised(self.normalised_of_pixel(pixel)?)
            }
            Distortion::KannalaBrandt { .. } => {
                let [x, y, z] = self.unproject(pixel)?;
                let point = [x / z, y / z];
                (z > 0.0 && point.iter().all(|v| v.is_finite())).then_some(point)
            }
        }
    }

    /// Normalised distorted coordinates of a point in the camera frame and their Jacobian
    /// with respect to the point.
    fn distort_point(&self, p_cam: [f64; 3]) -> Option<([f64; 2], [[f64; 3]; 2])> {
        self.check().ok()?;
        let [x, y, z] = p_cam;
        if !(x.is_finite() && y.is_finite() && z.is_finite()) || z <= 0.0 {
            return None;
        }
        let (m, j) = match self.distortion {
            Distortion::BrownConrady { k1, k2, p1, p2, k3 } => {
                let (xn, yn) = (x / z, y / z);
                let coefficients = [k1, k2, p1, p2, k3];
                let (m, d) = brown_conrady([xn, yn], coefficients);
                if !brown_conrady_unfolded([xn, yn], coefficients, &d) {
                    return None;
                }
                // ∂(x/z, y/z)/∂(x, y, z).
                let n = [[1.0 / z, 0.0, -xn / z], [0.0, 1.0 / z, -yn / z]];
                let mut j = [[0.0; 3]; 2];
                for (row, d_row) in j.iter_mut().zip(&d) {
                    for (col, out) in row.iter_mut().enumerate() {
                        *out = d_row[0] * n[0][col] + d_row[1] * n[1][col];
                    }
                }
                (m, j)
            }
            Distortion::KannalaBrandt { k1, k2, k3, k4 } => {
                kannala_brandt([x, y, z], [k1, k2, k3, k4])?
            }
        };
        (m.iter().chain(j.iter().flatten()).all(|v| v.is_finite())).then_some((m, j))
    }

    /// Pixel coordinates of normalised distorted coordinates.
    fn pixel_of_normalised(&self, m: [f64; 2]) -> Option<[f64; 2]> {
        let i = &self.intrinsics;
        let pixel = [i.fx_px * m[0] + i.cx_px, i.fy_px * m[1] + i.cy_px];
        pixel.iter().all(|v| v.is_finite()).then_some(pixel)
    }

    /// Normalised distorted coordinates of a pixel.
    fn normalised_of_pixel(&self, pixel: [f64; 2]) -> Option<[f64; 2]> {
        self.check().ok()?;
        let i = &self.intrinsics;
        let m = [
            (pixel[0] - i.cx_px) / i.fx_px,
            (pixel[1] - i.cy_px) / i.fy_px,
        ];
        m.iter().all(|v| v.is_finite()).then_some(m)
    }

    /// Inverts the Brown–Conrady distortion by Newton's method, starting from the distorted
    /// point. `None` for the fisheye model.
    fn undistort_normalised(&self, target: [f64; 2]) -> Option<[f64; 2]> {
        let Distortion::BrownConrady { k1, k2, p1, p2, k3 } = self.distortion else {
            return None;
        };
        let coefficients = [k1, k2, p1, p2, k3];
        let tolerance = NEWTON_TOLERANCE * (1.0 + target[0].hypot(target[1]));
        let mut p = target;
        for _ in 0..MAX_NEWTON_ITERATIONS {
            let (m, d) = brown_conrady(p, coefficients);
            let r = [m[0] - target[0], m[1] - target[1]];
            let det = d[0][0] * d[1][1] - d[0][1] * d[1][0];
            if det == 0.0 || det.is_nan() || !r[0].is_finite() || !r[1].is_finite() {
                return None;
            }
            if r[0].hypot(r[1]) <= tolerance * 1e-3 {
                break;
            }
            let step = [
                (d[1][1] * r[0] - d[0][1] * r[1]) / det,
                (d[0][0] * r[1] - d[1][0] * r[0]) / det,
            ];
            p = [p[0] - step[0], p[1] - step[1]];
            if step[0].hypot(step[1]) <= f64::EPSILON * (1.0 + p[0].hypot(p[1])) {
                break;
            }
        }
        let (m, d) = brown_conrady(p, coefficients);
        let residual = (m[0] - target[0]).hypot(m[1] - target[1]);
        (residual <= tolerance
            && p.iter().all(|v| v.is_finite())
            && brown_conrady_unfolded(p, coefficients, &d))
        .then_some(p)
    }
}

/// The Brown–Conrady map of a normalised undistorted point, and its 2×2 Jacobian.
fn brown_conrady(p: [f64; 2], [k1, k2, p1, p2, k3]: [f64; 5]) -> ([f64; 2], [[f64; 2]; 2]) {
    let [x, y] = p;
    let r2 = x * x + y * y;
    let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    // d(radial)/d(r²).
    let radial_slope = k1 + r2 * (2.0 * k2 + r2 * 3.0 * k3);
    let m = [
        x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
        y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
    ];
    let cross = 2.0 * x * y * radial_slope + 2.0 * p1 * x + 2.0 * p2 * y;
    let d = [
        [
            radial + 2.0 * x * x * radial_slope + 2.0 * p1 * y + 6.0 * p2 * x,
            cross,
        ],
        [
            cross,
            radial + 2.0 * y * y * radial_slope + 6.0 * p1 * y + 2.0 * p2 * x,
        ],
    ];
    (m, d)
}

/// Whether the Brown–Conrady map is locally invertible without folding at a point, given
/// its Jacobian there: the radial factor 1 + k1 r² + k2 r⁴ + k3 r⁶ and the radial
/// derivative d(r·factor)/dr are positive, and so is the Jacobian determinant.
fn brown_conrady_unfolded(p: [f64; 2], [k1, k2, _, _, k3]: [f64; 5], d: &[[f64; 2]; 2]) -> bool {
    let r2 = p[0] * p[0] + p[1] * p[1];
    let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    let radial_derivative = 1.0 + r2 * (3.0 * k1 + r2 * (5.0 * k2 + r2 * 7.0 * k3));
    radial > 0.0 && radial_derivative > 0.0 && d[0][0] * d[1][1] - d[0][1] * d[1][0] > 0.0
}

/// θ_d(θ) and dθ_d/dθ of the Kannala–Brandt polynomial.
fn fisheye_polynomial(theta: f64, [k1, k2, k3, k4]: [f64; 4]) -> (f64, f64) {
    let t2 = theta * theta;
    let theta_d = theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))));
    let slope = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
    (theta_d, slope)
}

/// The Kannala–Brandt map of a point in front of the camera (z > 0) to normalised distorted
/// coordinates, and its Jacobian with respect to the point. `None` where dθ_d/dθ ≤ 0.
fn kannala_brandt(
    [x, y, z]: [f64; 3],
    coefficients: [f64; 4],
) -> Option<([f64; 2], [[f64; 3]; 2])> {
    let rho = x.hypot(y);
    let theta = rho.atan2(z);
    let (theta_d, slope) = fisheye_polynomial(theta, coefficients);
    if slope.is_nan() || slope <= 0.0 {
        return None;
    }
    if rho <= ON_AXIS_RATIO * z {
        // Near the axis θ_d ≈ θ ≈ ρ/z: the map is the pinhole's to second order.
        let m = [x / z, y / z];
        let j = [[1.0 / z, 0.0, -x / (z * z)], [0.0, 1.0 / z, -y / (z * z)]];
        return Some((m, j));
    }
    let u = [x / rho, y / rho];
    let m = [theta_d * u[0], theta_d * u[1]];
    // ∇θ with respect to (x, y, z), θ = atan2(ρ, z).
    let range2 = rho * rho + z * z;
    let grad_theta = [z * u[0] / range2, z * u[1] / range2, -rho / range2];
    // m = θ_d(θ) u: ∂m = u (θ_d' ∇θ) + θ_d ∂u, with ∂u/∂(x, y) = (I − u uᵀ)/ρ, ∂u/∂z = 0.
    let mut j = [[0.0; 3]; 2];
    for (a, row) in j.iter_mut().enumerate() {
        for (b, out) in row.iter_mut().enumerate() {
            let du = if b < 2 {
                (f64::from(u8::from(a == b)) - u[a] * u[b]) / rho
            } else {
                0.0
            };
            *out = u[a] * slope * grad_theta[b] + theta_d * du;
        }
    }
    Some((m, j))
}

/// The angle θ ∈ [0, π/2) off the optical axis whose distorted angle is `theta_d` > 0,
/// by Newton's method started at θ = θ_d (clamped to 0.9 · π/2); a step that would leave
/// [0, π/2) goes halfway to the violated bound instead. `None` if it does not converge or
/// meets a point where dθ_d/dθ ≤ 0.
fn fisheye_inverse(theta_d: f64, coefficients: [f64; 4]) -> Option<f64> {
    const LIMIT_RAD: f64 = std::f64::consts::FRAC_PI_2;
    let tolerance = NEWTON_TOLERANCE * (1.0 + theta_d);
    let mut theta = theta_d.min(0.9 * LIMIT_RAD);
    for _ in 0..MAX_NEWTON_ITERATIONS {
        let (value, slope) = fisheye_polynomial(theta, coefficients);
        if slope.is_nan() || slope <= 0.0 || !value.is_finite() {
            return None;
        }
        let residual = value - theta_d;
        if residual.abs() <= tolerance * 1e-3 {
            break;
        }
        let step = residual / slope;
        // Damped: stay inside [0, π/2).
        let mut next = theta - step;
        if next < 0.0 {
            next = 0.5 * theta;
        } else if next >= LIMIT_RAD {
            next = 0.5 * (theta + LIMIT_RAD);
        }
        let moved = (next - theta).abs();
        theta = next;
        if moved <= f64::EPSILON * (1.0 + theta) {
            break;
        }
    }
    let (value, slope) = fisheye_polynomial(theta, coefficients);
    ((value - theta_d).abs() <= tolerance && slope > 0.0 && (0.0..LIMIT_RAD).contains(&theta))
        .then_some(theta)
}

#[cfg(test)]
#[path = "camera_tests.rs"]
mod tests;
