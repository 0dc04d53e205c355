//! From a ball's pixel to a point on the floor with an honest covariance.
//!
//! The pixel is unprojected through the calibrated camera model to a ray, the ray is carried
//! into the field frame by the robot's kinematics ([`kinematics`]) and intersected with
//! the plane of ball centres, z = ball radius (the seed's ground-plane method, without its
//! fitted corrections: those only made up for a wrong camera model).
//!
//! The ball's apparent size is a second range cue: its angular radius gives the distance
//! from the camera, free of the head's elevation error that dominates the ground plane far
//! away (a low camera sees distant balls at grazing angles). The two ranges are combined
//! with the minimum-variance weight, their correlation included.
//!
//! The floor covariance is the first-order propagation of every input's uncertainty through
//! the whole map: the pixel centre (whose error grows with the ball's image radius, since
//! shading, partial occlusion and blur shift a big blob's centre more), the robot's pose
//! (its 3×3 covariance as the robot reports it), the three head joints and the angular
//! radius. The Jacobian is
//! taken by central differences of the exact map, so it stays right for any lens model. An
//! elevation error moves the point along the view ray by an amount growing with the square
//! of the range, an azimuth or heading error moves it across by an amount growing with the
//! range: the covariance comes out elongated along the ray and growing with distance.

pub mod kinematics;

use crate::calibration::camera::CameraModel;
use crate::projection::kinematics::{CameraPose, camera_pose};
use nalgebra::{Matrix2, SMatrix, SVector, Vector3};
use proto::{Camera, HeadJoints, Pose2};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Rays closer to the horizontal than this are refused: the floor point would be far away
/// and hopelessly uncertain.
pub const MIN_DEPRESSION_RAD: f64 = 0.01;

/// Why a pixel has no floor point.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ProjectionError {
    #[error("pixel ({u_px:.1}, {v_px:.1}) cannot be unprojected by the camera model")]
    Unprojectable { u_px: f64, v_px: f64 },
    #[error(
        "the view ray does not meet the floor ahead of the camera (it points {elevation_deg:.1}° from the horizontal)"
    )]
    AboveHorizon { elevation_deg: f64 },
    #[error("the floor point is {range_m:.2} m away, beyond the {max_m:.2} m limit")]
    TooFar { range_m: f64, max_m: f64 },
    #[error("the covariance is not finite or not positive definite")]
    BadCovariance,
}

/// The uncertainties fed into the projection, besides the robot's own pose covariance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProjectionNoise {
    /// Standard deviation of a small ball's centre, pixels.
    pub centre_sigma_px: f64,
    /// Extra standard deviation of the centre per pixel of image radius.
    pub centre_sigma_per_radius: f64,
    /// Standard deviations of the lift, yaw and pitch joint angles, radians.
    pub joint_sigma_rad: [f64; 3],
    /// Standard deviation of the ball's image radius, pixels, plus a part per pixel of
    /// radius; the apparent-size range cue is weighed by it.
    pub radius_sigma_px: f64,
    pub radius_sigma_per_radius: f64,
    /// Floor points farther than this from the camera are refused, metres.
    pub max_range_m: f64,
}

impl Default for ProjectionNoise {
    fn default() -> Self {
        ProjectionNoise {
            centre_sigma_px: 0.5,
            centre_sigma_per_radius: 0.04,
            joint_sigma_rad: [0.004, 0.004, 0.004],
            radius_sigma_px: 0.1,
            radius_sigma_per_radius: 0.01,
            max_range_m: 5.0,
        }
    }
}

/// A ball's floor position as seen by one camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloorPoint {
    /// Ball centre on the floor, field frame, metres.
    pub position_m: [f64; 2],
    /// Its covariance, row-major 2×2, square metres.
    pub covariance_m2: [f64; 4],
    /// Horizontal distance from the camera, metres.
    pub range_m: f64,
    /// The ground-plane cue's horizontal range alone, metres.
    pub ground_range_m: f64,
    /// Weight of the ground-plane range against the apparent-size range (1: ground only).
    pub ground_weight: f64,
}

/// Where the ray through `pixel` meets the plane z = `ball_radius_m`, and the horizontal
/// distance from the camera to it.
pub fn floor_point(
    model: &CameraModel,
    camera: &CameraPose,
    pixel: [f64; 2],
    ball_radius_m: f64,
    max_range_m: f64,
) -> Result<([f64; 2], f64), ProjectionError> {
    let ray = model
        .unproject(pixel)
        .ok_or(ProjectionError::Unprojectable {
            u_px: pixel[0],
            v_px: pixel[1],
        })?;
    let d = camera.direction_in_field(ray);
    let horizontal = d.x.hypot(d.y);
    let elevation = d.z.atan2(horizontal);
    let drop_m = camera.centre_m.z - ball_radius_m;
    if elevation > -MIN_DEPRESSION_RAD || drop_m <= 0.0 {
        return Err(ProjectionError::AboveHorizon {
            elevation_deg: elevation.to_degrees(),
        });
    }
    let t = drop_m / -d.z;
    let range_m = t * horizontal;
    if range_m > max_range_m {
        return Err(ProjectionError::TooFar {
            range_m,
            max_m: max_range_m,
        });
    }
    let p = camera.centre_m + d * t;
    Ok(([p.x, p.y], range_m))
}

/// Everything the floor point depends on: pixel (u, v), pose (x, y, θ), joints (lift, yaw,
/// pitch) and the ball's angular radius (0 when there is none).
type Inputs = SVector<f64, 9>;

const ALPHA: usize = 8;

fn inputs(pixel: [f64; 2], pose: &Pose2, head: &HeadJoints, angular_radius_rad: f64) -> Inputs {
    Inputs::from([
        pixel[0],
        pixel[1],
        pose.x_m,
        pose.y_m,
        pose.theta_rad,
        head.lift_rad,
        head.yaw_rad,
        head.pitch_rad,
        angular_radius_rad,
    ])
}

/// The two range cues for one set of inputs: the ground-plane point's horizontal range and,
/// when the ball's angular radius is known, the horizontal range its apparent size implies,
/// both along the same horizontal direction from the camera.
#[derive(Debug, Clone, Copy)]
struct Cues {
    camera_xy_m: [f64; 2],
    direction: [f64; 2],
    ground_m: f64,
    size_m: f64,
}

impl Cues {
    /// The point at range `w`·ground + (1 − `w`)·size along the direction.
    fn point(&self, w: f64) -> [f64; 2] {
        let range = w * self.ground_m + (1.0 - w) * self.size_m;
        [
            self.camera_xy_m[0] + self.direction[0] * range,
            self.camera_xy_m[1] + self.direction[1] * range,
        ]
    }
}

fn cues_of(
    model: &CameraModel,
    camera: Camera,
    x: &Inputs,
    ball_radius_m: f64,
) -> Result<Cues, ProjectionError> {
    let pose = Pose2 {
        x_m: x[2],
        y_m: x[3],
        theta_rad: x[4],
    };
    let head = HeadJoints {
        lift_rad: x[5],
        yaw_rad: x[6],
        pitch_rad: x[7],
    };
    let cam = camera_pose(&pose, &head, camera);
    let (p, ground_m) = floor_point(model, &cam, [x[0], x[1]], ball_radius_m, f64::INFINITY)?;
    let camera_xy_m = [cam.centre_m.x, cam.centre_m.y];
    let direction = [
        (p[0] - camera_xy_m[0]) / ground_m,
        (p[1] - camera_xy_m[1]) / ground_m,
    ];
    let alpha = x[ALPHA];
    let size_m = if alpha > 0.0 {
        let distance_m = ball_radius_m / alpha.sin();
        let drop_m = cam.centre_m.z - ball_radius_m;
        (distance_m * distance_m - drop_m * drop_m).max(0.0).sqrt()
    } else {
        ground_m
    };
    Ok(Cues {
        camera_xy_m,
        direction,
        ground_m,
        size_m,
    })
}

/// Difference steps for the Jacobian: a quarter pixel, a tenth of a millimetre, 1e-5 rad,
/// 1e-6 rad of angular radius.
const STEPS: [f64; 9] = [0.25, 0.25, 1e-4, 1e-4, 1e-5, 1e-5, 1e-5, 1e-5, 1e-6];

/// A ball as the detector found it in one image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageBall {
    pub center_px: [f64; 2],
    /// Image radius, pixels (the centre's uncertainty grows with it).
    pub radius_px: f64,
    /// The ball's angular radius seen from the camera, if the detector measured it.
    pub angular_radius_rad: Option<f64>,
}

/// The inputs' covariance: pixel, pose (row-major 3×3), joints and angular radius.
fn inputs_covariance(
    ball: &ImageBall,
    pose_covariance: &[f64; 9],
    noise: &ProjectionNoise,
) -> SMatrix<f64, 9, 9> {
    let radius_px = ball.radius_px.max(0.0);
    let mut cov = SMatrix::<f64, 9, 9>::zeros();
    let sigma_px = noise.centre_sigma_px + noise.centre_sigma_per_radius * radius_px;
    cov[(0, 0)] = sigma_px * sigma_px;
    cov[(1, 1)] = sigma_px * sigma_px;
    for r in 0..3 {
        for c in 0..3 {
            cov[(2 + r, 2 + c)] = pose_covariance[3 * r + c];
        }
        cov[(5 + r, 5 + r)] = noise.joint_sigma_rad[r].powi(2);
    }
    if let Some(alpha) = ball
        .angular_radius_rad
        .filter(|a| *a > 0.0 && radius_px > 0.0)
    {
        // The angular radius is proportional to the image radius: same relative error.
        let sigma_r = noise.radius_sigma_px + noise.radius_sigma_per_radius * radius_px;
        cov[(ALPHA, ALPHA)] = (alpha * sigma_r / radius_px).powi(2);
    }
    cov
}

/// The weight of the ground-plane range in the minimum-variance combination of two
/// correlated estimates with covariance [[gg, gs], [gs, ss]], in [0, 1].
fn ground_weight(gg: f64, gs: f64, ss: f64) -> f64 {
    let denominator = gg + ss - 2.0 * gs;
    if !(denominator > 0.0 && denominator.is_finite()) {
        return 1.0;
    }
    ((ss - gs) / denominator).clamp(0.0, 1.0)
}

/// Projects a ball onto the floor, with the covariance propagated from the pixel, pose,
/// joint and size uncertainties.
///
/// Two cues give the range from the camera along the centre ray's horizontal direction: the
/// ground plane (the ray meets z = ball radius) and the ball's apparent size (its angular
/// radius gives the distance). The first is sensitive to the head's elevation, the second
/// is not; they are combined with the weight that minimises the range's variance, their
/// correlation through the shared inputs included, and the covariance is that of the
/// combined point. Without an angular radius the ground plane alone is used.
///
/// `pose_covariance` is the robot's row-major 3×3 covariance of (x, y, θ).
#[allow(clippy::too_many_arguments)]
pub fn project_ball(
    model: &CameraModel,
    camera: Camera,
    ball: &ImageBall,
    pose: &Pose2,
    pose_covariance: &[f64; 9],
    head: &HeadJoints,
    ball_radius_m: f64,
    noise: &ProjectionNoise,
) -> Result<FloorPoint, ProjectionError> {
    let alpha = ball.angular_radius_rad.filter(|a| *a > 0.0).unwrap_or(0.0);
    let x = inputs(ball.center_px, pose, head, alpha);
    let centre = cues_of(model, camera, &x, ball_radius_m)?;
    // Central differences of both cues for every input.
    let mut sides = [[centre; 2]; 9];
    let mut jacobian = SMatrix::<f64, 2, 9>::zeros();
    for (k, step) in STEPS.iter().enumerate() {
        let (mut hi, mut lo) = (x, x);
        hi[k] += step;
        lo[k] -= step;
        let (a, b) = (
            cues_of(model, camera, &hi, ball_radius_m)?,
            cues_of(model, camera, &lo, ball_radius_m)?,
        );
        jacobian[(0, k)] = (a.ground_m - b.ground_m) / (2.0 * step);
        jacobian[(1, k)] = (a.size_m - b.size_m) / (2.0 * step);
        sides[k] = [a, b];
    }
    let inputs_cov = inputs_covariance(ball, pose_covariance, noise);
    let w = if alpha > 0.0 {
        let ranges = jacobian * inputs_cov * jacobian.transpose();
        ground_weight(ranges[(0, 0)], ranges[(0, 1)], ranges[(1, 1)])
    } else {
        1.0
    };
    let position_m = centre.point(w);
    let range_m = w * centre.ground_m + (1.0 - w) * centre.size_m;
    if range_m > noise.max_range_m {
        return Err(ProjectionError::TooFar {
            range_m,
            max_m: noise.max_range_m,
        });
    }
    let mut point_jacobian = SMatrix::<f64, 2, 9>::zeros();
    for (k, [a, b]) in sides.iter().enumerate() {
        let (pa, pb) = (a.point(w), b.point(w));
        point_jacobian[(0, k)] = (pa[0] - pb[0]) / (2.0 * STEPS[k]);
        point_jacobian[(1, k)] = (pa[1] - pb[1]) / (2.0 * STEPS[k]);
    }
    let cov: Matrix2<f64> = point_jacobian * inputs_cov * point_jacobian.transpose();
    let cov = (cov + cov.transpose()) * 0.5;
    let ok = cov.iter().all(|v| v.is_finite()) && cov[(0, 0)] > 0.0 && cov.determinant() > 0.0;
    if !ok {
        return Err(ProjectionError::BadCovariance);
    }
    Ok(FloorPoint {
        position_m,
        covariance_m2: [cov[(0, 0)], cov[(0, 1)], cov[(1, 0)], cov[(1, 1)]],
        range_m,
        ground_range_m: centre.ground_m,
        ground_weight: w,
    })
}

/// The angular radius of a ball that appears with image radius `radius_px` around `pixel`:
/// the angle between the rays through the centre and through points `radius_px` away on
/// either side, averaged. `None` where the model cannot unproject or the angle is zero.
pub fn angular_radius_from_image_radius(
    model: &CameraModel,
    pixel: [f64; 2],
    radius_px: f64,
) -> Option<f64> {
    let centre = Vector3::from(model.unproject(pixel)?);
    let mut sum = 0.0;
    for (du, dv) in [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)] {
        let edge =
            Vector3::from(model.unproject([pixel[0] + du * radius_px, pixel[1] + dv * radius_px])?);
        sum += centre.angle(&edge);
    }
    let alpha = sum / 4.0;
    (alpha > 0.0).then_some(alpha)
}

/// The distance from the camera's optical centre to a ball of radius `ball_radius_m` that
/// appears with image radius `radius_px` around `pixel` (see
/// [`angular_radius_from_image_radius`]).
#[cfg(test)]
pub fn distance_from_image_radius(
    model: &CameraModel,
    pixel: [f64; 2],
    radius_px: f64,
    ball_radius_m: f64,
) -> Option<f64> {
    angular_radius_from_image_radius(model, pixel, radius_px).map(|a| ball_radius_m / a.sin())
}

/// The part of the floor a camera sees, as a polygon in the field frame: the image border
/// unprojected onto the floor, cut off at `max_range_m` where the border looks above the
/// horizon or farther away. Points that cannot be unprojected are skipped.
pub fn footprint(
    model: &CameraModel,
    camera: &CameraPose,
    max_range_m: f64,
    points_per_side: usize,
) -> Vec<[f64; 2]> {
    let w = f64::from(model.intrinsics.width_px) - 1.0;
    let h = f64::from(model.intrinsics.height_px) - 1.0;
    let n = points_per_side.max(1);
    let corners = [[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]];
    let mut polygon = Vec::with_capacity(4 * n);
    for side in 0..4 {
        let a = corners[side];
        let b = corners[(side + 1) % 4];
        for k in 0..n {
            let s = k as f64 / n as f64;
            let pixel = [a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])];
            let Some(ray) = model.unproject(pixel) else {
                continue;
            };
            let d = camera.direction_in_field(ray);
            let horizontal = d.x.hypot(d.y);
            if horizontal <= 0.0 {
                continue;
            }
            let reach = if d.z < 0.0 {
                (camera.centre_m.z / -d.z * horizontal).min(max_range_m)
            } else {
                max_range_m
            };
            let scale = reach / horizontal;
            polygon.push([
                camera.centre_m.x + d.x * scale,
                camera.centre_m.y + d.y * scale,
            ]);
        }
    }
    polygon
}

#[cfg(test)]
#[path = "projection_tests.rs"]
mod tests;
