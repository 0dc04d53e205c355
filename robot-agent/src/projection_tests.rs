//! Tests of the floor projection: exact round trips through the kinematics and the lens,
//! the covariance's shape, and its honesty against sampled errors.

#![allow(clippy::unwrap_used)]

use super::*;
use crate::test_fixtures::{head as head_yawed, miro_lens};
use approx::assert_relative_eq;

fn pose() -> Pose2 {
    Pose2 {
        x_m: -0.5,
        y_m: 0.3,
        theta_rad: 0.4,
    }
}

fn head() -> HeadJoints {
    head_yawed(0.1)
}

const R: f64 = 0.04;
const POSE_COV: [f64; 9] = [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4];

/// A ball at `pixel` with image radius `radius_px` and no measured size.
fn at(pixel: [f64; 2], radius_px: f64) -> ImageBall {
    ImageBall {
        center_px: pixel,
        radius_px,
        angular_radius_rad: None,
    }
}

/// The ball whose centre is at `p` as `camera` sees it, with its true angular radius.
fn seen(p: [f64; 2], camera: Camera, radius_px: f64) -> ImageBall {
    let cam = camera_pose(&pose(), &head(), camera);
    let q = cam.point_in_camera(Vector3::new(p[0], p[1], R));
    ImageBall {
        center_px: pixel_of(p, camera),
        radius_px,
        angular_radius_rad: Some((R / q.norm()).asin()),
    }
}

/// The pixel where a ball centre at `p` appears.
fn pixel_of(p: [f64; 2], camera: Camera) -> [f64; 2] {
    let cam = camera_pose(&pose(), &head(), camera);
    let q = cam.point_in_camera(Vector3::new(p[0], p[1], R));
    miro_lens().project([q.x, q.y, q.z]).unwrap()
}

#[test]
fn floor_points_round_trip_through_the_lens_and_kinematics() {
    for camera in [Camera::Left, Camera::Right] {
        let cam = camera_pose(&pose(), &head(), camera);
        for (fwd, side) in [(0.4, 0.0), (1.0, 0.3), (2.5, -0.8), (0.6, 0.5)] {
            let heading = pose().theta_rad;
            let p = [
                pose().x_m + fwd * heading.cos() - side * heading.sin(),
                pose().y_m + fwd * heading.sin() + side * heading.cos(),
            ];
            let q = cam.point_in_camera(Vector3::new(p[0], p[1], R));
            let Some(pixel) = miro_lens().project([q.x, q.y, q.z]) else {
                continue;
            };
            if !miro_lens().intrinsics.contains(pixel) {
                continue;
            }
            let (back, range) = floor_point(&miro_lens(), &cam, pixel, R, 10.0).unwrap();
            assert_relative_eq!(back[0], p[0], epsilon = 1e-9);
            assert_relative_eq!(back[1], p[1], epsilon = 1e-9);
            let expected = (p[0] - cam.centre_m.x).hypot(p[1] - cam.centre_m.y);
            assert_relative_eq!(range, expected, epsilon = 1e-9);
        }
    }
}

#[test]
fn rays_above_the_horizon_and_far_points_are_refused() {
    let cam = camera_pose(&pose(), &head(), Camera::Left);
    // The top row of the image looks above the horizon with the default head.
    let err = floor_point(&miro_lens(), &cam, [320.0, 0.0], R, 10.0).unwrap_err();
    assert!(matches!(err, ProjectionError::AboveHorizon { .. }), "{err}");
    let far = pixel_of(
        [
            pose().x_m + 3.0 * 0.4f64.cos(),
            pose().y_m + 3.0 * 0.4f64.sin(),
        ],
        Camera::Left,
    );
    let err = floor_point(&miro_lens(), &cam, far, R, 2.0).unwrap_err();
    assert!(matches!(err, ProjectionError::TooFar { .. }), "{err}");
    let err = floor_point(&miro_lens(), &cam, [f64::NAN, 3.0], R, 2.0).unwrap_err();
    assert!(
        matches!(err, ProjectionError::Unprojectable { .. }),
        "{err}"
    );
}

/// The covariance's principal axis and its standard deviations along and across.
fn shape(fp: &FloorPoint) -> (f64, f64, f64) {
    let [a, b, _, d] = fp.covariance_m2;
    let mean = 0.5 * (a + d);
    let diff = (0.25 * (a - d).powi(2) + b * b).sqrt();
    let angle = 0.5 * (2.0 * b).atan2(a - d);
    (angle, (mean + diff).sqrt(), (mean - diff).sqrt())
}

fn angle_between_lines(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(std::f64::consts::PI);
    d.min(std::f64::consts::PI - d)
}

#[test]
fn covariance_is_elongated_along_the_ray_and_grows_with_range() {
    let noise = ProjectionNoise::default();
    let heading = pose().theta_rad;
    let mut last_major = 0.0;
    for fwd in [1.0, 1.5, 2.0, 2.5] {
        let p = [
            pose().x_m + fwd * heading.cos(),
            pose().y_m + fwd * heading.sin(),
        ];
        let pixel = pixel_of(p, Camera::Left);
        let fp = project_ball(
            &miro_lens(),
            Camera::Left,
            &at(pixel, 8.0),
            &pose(),
            &POSE_COV,
            &head(),
            R,
            &noise,
        )
        .unwrap();
        let (axis, major, minor) = shape(&fp);
        let cam = camera_pose(&pose(), &head(), Camera::Left);
        let ray = (p[1] - cam.centre_m.y).atan2(p[0] - cam.centre_m.x);
        assert!(
            angle_between_lines(axis, ray) < 0.35,
            "axis {axis} ray {ray} at {fwd} m"
        );
        assert!(major > 1.5 * minor, "{major} {minor} at {fwd} m");
        assert!(major > last_major, "{major} after {last_major} at {fwd} m");
        last_major = major;
    }
}

#[test]
fn bigger_image_radius_and_pose_uncertainty_widen_the_covariance() {
    let noise = ProjectionNoise::default();
    let pixel = pixel_of([0.3, 0.8], Camera::Right);
    let run = |radius: f64, cov: &[f64; 9]| {
        project_ball(
            &miro_lens(),
            Camera::Right,
            &at(pixel, radius),
            &pose(),
            cov,
            &head(),
            R,
            &noise,
        )
        .unwrap()
        .covariance_m2
    };
    let small = run(4.0, &POSE_COV);
    let big = run(30.0, &POSE_COV);
    assert!(big[0] + big[3] > small[0] + small[3]);
    let loose: [f64; 9] = POSE_COV.map(|v| v * 25.0);
    let wide = run(4.0, &loose);
    assert!(wide[0] + wide[3] > 4.0 * (small[0] + small[3]) * 0.5);
}

/// A small deterministic standard normal source (Box–Muller over a splitmix sequence).
fn gaussian_source() -> impl FnMut() -> f64 {
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut uniform = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    move || (-2.0 * (1.0 - uniform()).ln()).sqrt() * (2.0 * std::f64::consts::PI * uniform()).cos()
}

/// Samples the inputs from their stated distributions and checks that the floor points'
/// scatter matches the propagated covariance (normalised squared errors average about 2),
/// for the ground plane alone and for the two cues combined.
#[test]
fn covariance_matches_sampled_errors() {
    let noise = ProjectionNoise::default();
    let pose_cov = [4e-5, 0.0, 0.0, 0.0, 4e-5, 0.0, 0.0, 0.0, 1e-4];
    let radius = 10.0;
    for ball in [
        at(pixel_of([0.2, 1.0], Camera::Left), radius),
        seen([0.2, 1.0], Camera::Left, radius),
        seen([0.8, 1.9], Camera::Left, 6.0),
    ] {
        let fp = project_ball(
            &miro_lens(),
            Camera::Left,
            &ball,
            &pose(),
            &pose_cov,
            &head(),
            R,
            &noise,
        )
        .unwrap();
        let inv = Matrix2::from_row_slice(&fp.covariance_m2)
            .try_inverse()
            .unwrap();
        let cov = inputs_covariance(&ball, &pose_cov, &noise);
        let base = inputs(
            ball.center_px,
            &pose(),
            &head(),
            ball.angular_radius_rad.unwrap_or(0.0),
        );
        let mut gaussian = gaussian_source();
        let n = 4000;
        let mut nees = 0.0;
        for _ in 0..n {
            let mut x = base;
            for k in 0..9 {
                x[k] += cov[(k, k)].sqrt() * gaussian();
            }
            let cues = cues_of(&miro_lens(), Camera::Left, &x, R).unwrap();
            let p = cues.point(fp.ground_weight);
            let e = nalgebra::Vector2::new(p[0] - fp.position_m[0], p[1] - fp.position_m[1]);
            nees += (e.transpose() * inv * e)[(0, 0)];
        }
        let mean = nees / f64::from(n);
        assert!(
            (1.8..2.2).contains(&mean),
            "mean normalised squared error {mean} for {ball:?}"
        );
    }
}

/// The along-ray standard deviation of a floor point seen from the robot's camera.
fn sigma_along(fp: &FloorPoint, camera: Camera) -> f64 {
    let cam = camera_pose(&pose(), &head(), camera);
    let d = nalgebra::Vector2::new(
        fp.position_m[0] - cam.centre_m.x,
        fp.position_m[1] - cam.centre_m.y,
    )
    .normalize();
    (d.transpose() * Matrix2::from_row_slice(&fp.covariance_m2) * d)[(0, 0)].sqrt()
}

#[test]
fn apparent_size_narrows_the_range_far_away_and_resists_an_elevation_bias() {
    let noise = ProjectionNoise::default();
    let heading = pose().theta_rad;
    let project = |ball: &ImageBall, head: &HeadJoints| {
        project_ball(
            &miro_lens(),
            Camera::Left,
            ball,
            &pose(),
            &POSE_COV,
            head,
            R,
            &noise,
        )
        .unwrap()
    };
    for fwd in [1.5, 2.0, 2.5] {
        let p = [
            pose().x_m + fwd * heading.cos(),
            pose().y_m + fwd * heading.sin(),
        ];
        let sized = seen(p, Camera::Left, 7.0);
        let ground_only = at(sized.center_px, 7.0);
        let (a, b) = (project(&sized, &head()), project(&ground_only, &head()));
        assert!(
            sigma_along(&a, Camera::Left) < 0.8 * sigma_along(&b, Camera::Left),
            "at {fwd} m: {} vs {}",
            sigma_along(&a, Camera::Left),
            sigma_along(&b, Camera::Left)
        );
        assert!(a.ground_weight > 0.0 && a.ground_weight < 1.0, "{a:?}");
        assert_eq!(b.ground_weight, 1.0);
        // Both unbiased with exact inputs.
        assert_relative_eq!(a.position_m[0], p[0], epsilon = 1e-6);
        assert_relative_eq!(a.position_m[1], p[1], epsilon = 1e-6);
        // The head reads 0.01 rad lower than it is: the ground plane moves the ball away,
        // the apparent size holds it.
        let mut biased = head();
        biased.pitch_rad -= 0.01;
        let err = |fp: &FloorPoint| (fp.position_m[0] - p[0]).hypot(fp.position_m[1] - p[1]);
        let (a, b) = (project(&sized, &biased), project(&ground_only, &biased));
        assert!(
            err(&a) < 0.7 * err(&b),
            "at {fwd} m: {} vs {}",
            err(&a),
            err(&b)
        );
    }
}

#[test]
fn ground_weight_is_the_minimum_variance_weight() {
    // Independent cues of equal variance: half each; a cue with no variance takes all.
    assert_relative_eq!(ground_weight(1.0, 0.0, 1.0), 0.5);
    assert_relative_eq!(ground_weight(1.0, 0.0, 3.0), 0.75);
    assert_relative_eq!(ground_weight(0.0, 0.0, 1.0), 1.0);
    assert_relative_eq!(ground_weight(1.0, 0.0, 0.0), 0.0);
    // Degenerate: identical cues.
    assert_relative_eq!(ground_weight(1.0, 1.0, 1.0), 1.0);
    assert_relative_eq!(ground_weight(f64::NAN, 0.0, 1.0), 1.0);
}

#[test]
fn image_radius_gives_the_distance() {
    let cam = camera_pose(&pose(), &head(), Camera::Left);
    let p = Vector3::new(0.3, 0.9, R);
    let q = cam.point_in_camera(p);
    let lens = miro_lens();
    let pixel = lens.project([q.x, q.y, q.z]).unwrap();
    // The image radius of a ball: the centre's projection moved by the ball's angular radius.
    let alpha = (R / q.norm()).asin();
    let side = nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), alpha) * q;
    let edge = lens.project([side.x, side.y, side.z]).unwrap();
    let radius_px = (edge[0] - pixel[0]).hypot(edge[1] - pixel[1]);
    let d = distance_from_image_radius(&lens, pixel, radius_px, R).unwrap();
    assert_relative_eq!(d, q.norm(), max_relative = 0.05);
}

#[test]
fn footprint_lies_ahead_of_the_camera_within_range() {
    let cam = camera_pose(&pose(), &head(), Camera::Left);
    let poly = footprint(&miro_lens(), &cam, 3.0, 8);
    assert_eq!(poly.len(), 32);
    let heading = pose().theta_rad + proto::miro::CAMERA_DIVERGENCE_RAD + 0.1;
    for p in &poly {
        let dx = p[0] - cam.centre_m.x;
        let dy = p[1] - cam.centre_m.y;
        assert!(dx.hypot(dy) <= 3.0 + 1e-9);
        assert!(
            dx * heading.cos() + dy * heading.sin() > 0.0,
            "{p:?} behind the camera"
        );
    }
    // The near edge (bottom of the image) is much closer than the far edge.
    let near = poly[16];
    assert!((near[0] - cam.centre_m.x).hypot(near[1] - cam.centre_m.y) < 1.0);
}
