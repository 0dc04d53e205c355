//! Camera geometry and the measurement model of a MiRo's ball sightings.
//!
//! A ball seen by a camera at height h above the ball-centre plane is projected onto the
//! floor along the view ray. An error in the ray's elevation moves the point along the ray
//! by σ_elev·(d² + h²)/h; an error in its azimuth moves it across by σ_azim·√(d² + h²)
//! (B-Human's model). On top, the robot only knows its pose up to a slowly varying error,
//! which shifts the whole point and swings it by θ_err·d. The reported covariance adds
//! these honestly; the tests check that it matches the errors actually drawn.

use crate::rng::Rng;
use crate::vec2::{V2, add, angle, axpy, dist, norm, perp, rotate, sub, unit_or, wrap_angle};
use proto::{Camera, Pose2};

/// Cameras look this far outward of straight ahead (left camera at +27°).
pub const CAMERA_YAW_RAD: f64 = 27.0 * std::f64::consts::PI / 180.0;
/// Horizontal half field of view of each camera.
pub const HALF_FOV_RAD: f64 = 60.6 * std::f64::consts::PI / 180.0;
/// Camera height above the floor.
pub const CAMERA_HEIGHT_M: f64 = 0.29;
/// Camera optical centres relative to the body centre: forward (head) and sideways.
pub const CAMERA_FORWARD_M: f64 = 0.08;
pub const CAMERA_LATERAL_M: f64 = 0.043;
/// Below this floor distance the ball is under the camera's view.
pub const MIN_RANGE_M: f64 = 0.12;
/// Detection probability is `P_NEAR` up to `FULL_RANGE_M`, falling linearly to `P_FAR` at
/// `MAX_RANGE_M`, zero beyond (the ball gets too small for the detector).
pub const FULL_RANGE_M: f64 = 1.2;
pub const MAX_RANGE_M: f64 = 2.4;
pub const P_NEAR: f64 = 0.97;
pub const P_FAR: f64 = 0.5;
/// Angular noise of the view ray.
pub const SIGMA_ELEV_RAD: f64 = 0.008;
pub const SIGMA_AZIM_RAD: f64 = 0.006;
/// Self-localisation error: Ornstein–Uhlenbeck with this time constant and stationary σ.
pub const POSE_TAU_S: f64 = 3.0;
pub const POSE_SIGMA_XY_M: f64 = 0.01;
pub const POSE_SIGMA_THETA_RAD: f64 = 0.01;
/// A robot's white top, mistaken for the ball, sits this high above the floor.
pub const WHITE_TOP_HEIGHT_M: f64 = 0.15;
/// False positives project at most this far from the camera.
pub const FALSE_POSITIVE_CAP_M: f64 = 3.0;

/// One camera's floor-plane placement at a capture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraView {
    pub camera: Camera,
    pub pos: V2,
    pub axis_rad: f64,
}

/// Both cameras of a robot at `pose`.
pub fn cameras(pose: &Pose2) -> [CameraView; 2] {
    let centre = [pose.x_m, pose.y_m];
    let view = |camera, side: f64| CameraView {
        camera,
        pos: add(
            centre,
            rotate([CAMERA_FORWARD_M, side * CAMERA_LATERAL_M], pose.theta_rad),
        ),
        axis_rad: wrap_angle(pose.theta_rad + side * CAMERA_YAW_RAD),
    };
    [view(Camera::Left, 1.0), view(Camera::Right, -1.0)]
}

impl CameraView {
    /// Floor distance to `p` if it lies within the horizontal field of view (any range).
    pub fn sees(&self, p: V2) -> Option<f64> {
        let rel = sub(p, self.pos);
        let off = wrap_angle(angle(rel) - self.axis_rad);
        (off.abs() <= HALF_FOV_RAD).then(|| norm(rel))
    }
}

/// Height of the camera above the plane the agent projects onto (the ball centre).
pub fn projection_height_m(ball_radius_m: f64) -> f64 {
    CAMERA_HEIGHT_M - ball_radius_m
}

/// Probability that the detector finds the ball at floor distance `d`.
pub fn detection_probability(d: f64) -> f64 {
    if !(MIN_RANGE_M..=MAX_RANGE_M).contains(&d) {
        0.0
    } else if d <= FULL_RANGE_M {
        P_NEAR
    } else {
        P_NEAR + (P_FAR - P_NEAR) * (d - FULL_RANGE_M) / (MAX_RANGE_M - FULL_RANGE_M)
    }
}

/// Probability that `camera` of a robot at `pose` finds a ball at floor point `p` in one
/// image: the detector's at the ball's range when it is in the field of view, else zero
/// (before occlusion and dropouts).
pub fn detection_probability_at(pose: &Pose2, camera: Camera, p: V2) -> f64 {
    cameras(pose)
        .iter()
        .find(|v| v.camera == camera)
        .and_then(|v| v.sees(p))
        .map_or(0.0, detection_probability)
}

/// Along-ray and across-ray standard deviations of the view-ray angle error at distance `d`.
pub fn ray_sigmas(d: f64, h: f64) -> (f64, f64) {
    let r2 = d * d + h * h;
    (SIGMA_ELEV_RAD * r2 / h, SIGMA_AZIM_RAD * r2.sqrt())
}

/// `s1²·u uᵀ + s2²·v vᵀ` for orthonormal u, v = perp(u), row-major.
fn oriented_cov(u: V2, s1: f64, s2: f64) -> [f64; 4] {
    let v = perp(u);
    let (a, b) = (s1 * s1, s2 * s2);
    let xy = a * u[0] * u[1] + b * v[0] * v[1];
    [
        a * u[0] * u[0] + b * v[0] * v[0],
        xy,
        xy,
        a * u[1] * u[1] + b * v[1] * v[1],
    ]
}

/// The covariance an honest agent reports for a point at `target`, seen from a camera at
/// `cam`, by a robot centred at `robot` whose pose is uncertain by the stationary σ.
pub fn honest_covariance(cam: V2, robot: V2, target: V2, h: f64) -> [f64; 4] {
    let ray = unit_or(sub(target, cam), [1.0, 0.0]);
    let (sr, st) = ray_sigmas(dist(target, cam), h);
    let angle_part = oriented_cov(ray, sr, st);
    let lever = sub(target, robot);
    let lateral = perp(unit_or(lever, ray));
    let swing = POSE_SIGMA_THETA_RAD * norm(lever);
    let pose_part = oriented_cov(lateral, swing, 0.0);
    let xy = POSE_SIGMA_XY_M * POSE_SIGMA_XY_M;
    [
        angle_part[0] + pose_part[0] + xy,
        angle_part[1] + pose_part[1],
        angle_part[2] + pose_part[2],
        angle_part[3] + pose_part[3] + xy,
    ]
}

/// The robot's self-localisation error (what it believes minus the truth).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PoseError {
    pub dx: f64,
    pub dy: f64,
    pub dtheta: f64,
}

impl PoseError {
    /// A draw from the stationary distribution.
    pub fn stationary(rng: &mut Rng) -> Self {
        PoseError {
            dx: POSE_SIGMA_XY_M * rng.normal(),
            dy: POSE_SIGMA_XY_M * rng.normal(),
            dtheta: POSE_SIGMA_THETA_RAD * rng.normal(),
        }
    }

    /// Exact Ornstein–Uhlenbeck transition over `dt_s`: the stationary σ is preserved.
    pub fn evolve(&mut self, dt_s: f64, rng: &mut Rng) {
        let decay = (-dt_s / POSE_TAU_S).exp();
        let kick = (1.0 - decay * decay).max(0.0).sqrt();
        self.dx = decay * self.dx + kick * POSE_SIGMA_XY_M * rng.normal();
        self.dy = decay * self.dy + kick * POSE_SIGMA_XY_M * rng.normal();
        self.dtheta = decay * self.dtheta + kick * POSE_SIGMA_THETA_RAD * rng.normal();
    }

    /// The pose the robot believes it has.
    pub fn believed(&self, truth: &Pose2) -> Pose2 {
        Pose2 {
            x_m: truth.x_m + self.dx,
            y_m: truth.y_m + self.dy,
            theta_rad: wrap_angle(truth.theta_rad + self.dtheta),
        }
    }
}

/// Where the agent puts a point truly at `target`: view-ray angle noise around the truth,
/// then mapped through the believed rather than the true pose. Errors are drawn from `rng`.
pub fn measure(cam: V2, robot: V2, target: V2, h: f64, pose_err: &PoseError, rng: &mut Rng) -> V2 {
    let ray = unit_or(sub(target, cam), [1.0, 0.0]);
    let (sr, st) = ray_sigmas(dist(target, cam), h);
    let seen = axpy(
        axpy(target, sr * rng.normal(), ray),
        st * rng.normal(),
        perp(ray),
    );
    // The agent measures relative to its body, then places that with its believed pose.
    let rel = rotate(sub(seen, robot), pose_err.dtheta);
    add(add(robot, rel), [pose_err.dx, pose_err.dy])
}

/// Where a robot body's white top, seen along the ray to its centre at floor distance
/// `d_body`, lands when projected as if it were a ball: further along the same ray.
pub fn false_positive_point(cam: V2, body: V2, h: f64) -> V2 {
    let d_body = dist(cam, body);
    let below = CAMERA_HEIGHT_M - WHITE_TOP_HEIGHT_M;
    let d_fp = (d_body * h / below.max(1e-3)).min(FALSE_POSITIVE_CAP_M);
    axpy(cam, d_fp, unit_or(sub(body, cam), [1.0, 0.0]))
}

/// Scales a covariance (misreporting agents).
pub fn scaled(c: [f64; 4], k: f64) -> [f64; 4] {
    [c[0] * k, c[1] * k, c[2] * k, c[3] * k]
}

/// A 2×2 row-major inverse (None when singular).
#[cfg(test)]
pub fn inverse2(c: [f64; 4]) -> Option<[f64; 4]> {
    let det = c[0] * c[3] - c[1] * c[2];
    (det.abs() > 1e-300).then(|| scaled([c[3], -c[1], -c[2], c[0]], 1.0 / det))
}

/// Squared Mahalanobis length of `e` under covariance `c`.
#[cfg(test)]
pub fn mahalanobis2(e: V2, c: [f64; 4]) -> f64 {
    match inverse2(c) {
        Some(i) => e[0] * (i[0] * e[0] + i[1] * e[1]) + e[1] * (i[2] * e[0] + i[3] * e[1]),
        None => f64::INFINITY,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const H: f64 = 0.25;

    /// Empirical covariance of measure − truth, with fresh stationary pose errors per draw.
    fn empirical(cam: V2, robot: V2, target: V2, n: usize, seed: u64) -> [f64; 4] {
        let mut rng = Rng::new(seed);
        let mut s = [0.0; 4];
        for _ in 0..n {
            let pe = PoseError::stationary(&mut rng);
            let e = sub(measure(cam, robot, target, H, &pe, &mut rng), target);
            s[0] += e[0] * e[0];
            s[1] += e[0] * e[1];
            s[3] += e[1] * e[1];
        }
        s[2] = s[1];
        scaled(s, 1.0 / n as f64)
    }

    #[test]
    fn honest_covariance_matches_drawn_errors() {
        let robot = [0.0, 0.0];
        for (k, target) in [[1.0, 0.3], [0.4, -0.2], [1.8, 1.0], [0.2, 2.0]]
            .into_iter()
            .enumerate()
        {
            let cam = [0.08, 0.0];
            let reported = honest_covariance(cam, robot, target, H);
            let emp = empirical(cam, robot, target, 40_000, k as u64);
            let scale_ref = reported[0].max(reported[3]);
            for i in 0..4 {
                assert!(
                    (emp[i] - reported[i]).abs() < 0.04 * scale_ref,
                    "target {target:?} elem {i}: empirical {} reported {}",
                    emp[i],
                    reported[i]
                );
            }
            // Whitened errors: mean squared Mahalanobis length is 2 for a 2D Gaussian.
            let mut rng = Rng::new(100 + k as u64);
            let n = 20_000;
            let nees: f64 = (0..n)
                .map(|_| {
                    let pe = PoseError::stationary(&mut rng);
                    mahalanobis2(
                        sub(measure(cam, robot, target, H, &pe, &mut rng), target),
                        reported,
                    )
                })
                .sum::<f64>()
                / n as f64;
            assert!((nees - 2.0).abs() < 0.08, "{nees}");
            // A misreporting agent's covariance is off by its factor.
            let under = mahalanobis_mean(&emp, scaled(reported, 0.25));
            assert!((under / 2.0 - 4.0).abs() < 0.3, "{under}");
        }
    }

    fn mahalanobis_mean(emp: &[f64; 4], c: [f64; 4]) -> f64 {
        // E[eᵀ C⁻¹ e] = tr(C⁻¹ Σ).
        let i = inverse2(c).unwrap_or([0.0; 4]);
        i[0] * emp[0] + i[1] * emp[2] + i[2] * emp[1] + i[3] * emp[3]
    }

    #[test]
    fn radial_error_dominates_lateral() {
        for d in [0.3, 0.8, 1.5, 2.4] {
            let (sr, st) = ray_sigmas(d, H);
            assert!(sr > st, "{d}");
            // Reported along the ray versus across it.
            let c = honest_covariance([0.0, 0.0], [-0.08, 0.0], [d, 0.0], H);
            assert!(c[0] > c[3], "{d}: {c:?}");
        }
        let (sr, st) = ray_sigmas(1.0, H);
        assert!((sr - 0.008 * 1.0625 / 0.25).abs() < 1e-12);
        assert!((st - 0.006 * 1.0625_f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn pose_error_process_keeps_its_stationary_spread() {
        let mut rng = Rng::new(4);
        let mut pe = PoseError::stationary(&mut rng);
        let (mut sx, mut st) = (0.0, 0.0);
        let n = 200_000;
        for _ in 0..n {
            pe.evolve(1.0, &mut rng);
            sx += pe.dx * pe.dx;
            st += pe.dtheta * pe.dtheta;
        }
        assert!(((sx / n as f64).sqrt() / POSE_SIGMA_XY_M - 1.0).abs() < 0.03);
        assert!(((st / n as f64).sqrt() / POSE_SIGMA_THETA_RAD - 1.0).abs() < 0.03);
    }

    #[test]
    fn geometry_of_cameras_detection_and_false_positives() {
        let pose = Pose2::default();
        let [l, r] = cameras(&pose);
        assert_eq!(l.camera, Camera::Left);
        assert!(l.axis_rad > 0.0 && r.axis_rad < 0.0 && l.pos[1] > 0.0);
        assert!(l.sees([1.0, 0.0]).is_some() && r.sees([1.0, 0.0]).is_some());
        assert!(r.sees([0.5, 1.5]).is_none() && l.sees([0.5, 1.5]).is_some());
        assert!(l.sees([-1.0, 0.0]).is_none());
        assert_eq!(detection_probability(0.1), 0.0);
        assert_eq!(detection_probability(1.0), P_NEAR);
        assert!((detection_probability(1.8) - 0.735).abs() < 1e-12);
        assert_eq!(detection_probability(2.5), 0.0);
        let fp = false_positive_point([0.0, 0.0], [1.0, 0.0], H);
        assert!((fp[0] - 0.25 / 0.14).abs() < 1e-12 && fp[1] == 0.0);
        let far = false_positive_point([0.0, 0.0], [0.0, 2.0], H);
        assert!((far[1] - FALSE_POSITIVE_CAP_M).abs() < 1e-12);
    }
}
