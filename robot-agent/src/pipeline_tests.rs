//! Tests of detection + projection + validation on frames drawn through a known camera.

#![allow(clippy::unwrap_used)]

use super::*;
use crate::projection::kinematics::camera_pose;
use crate::test_fixtures::{head as head_yawed, miro_lens as lens};
use nalgebra::Vector3;
use vision::{DetectorConfig, HoughOnly, NoClock};

fn head() -> HeadJoints {
    head_yawed(0.0)
}

/// A grey frame with the orange silhouette of a ball of `radius_m` at floor point `p`: the
/// pixels whose ray passes within the ball's angular radius of its centre (times `scale`, to
/// fake a wrong-sized object).
fn frame(pose: &Pose2, p: [f64; 2], radius_m: f64, scale: f64) -> RgbImage {
    let lens = lens();
    let cam = camera_pose(pose, &head(), Camera::Left);
    let q = cam.point_in_camera(Vector3::new(p[0], p[1], radius_m));
    let alpha = (radius_m / q.norm()).asin() * scale;
    let centre = lens.project([q.x, q.y, q.z]).unwrap();
    // Rays are only tested near the centre's pixel, for speed.
    let reach = 3.0 * alpha * lens.intrinsics.fx_px + 4.0;
    let mut data = Vec::with_capacity(640 * 360 * 3);
    for y in 0..360 {
        for x in 0..640 {
            let (u, v) = (f64::from(x), f64::from(y));
            let inside = (u - centre[0]).hypot(v - centre[1]) <= reach
                && lens
                    .unproject([u, v])
                    .is_some_and(|ray| Vector3::from(ray).angle(&q) <= alpha);
            data.extend_from_slice(if inside {
                &[235, 120, 30]
            } else {
                &[120, 118, 112]
            });
        }
    }
    RgbImage::new(640, 360, data).unwrap()
}

fn run(pose: Pose2, image: &RgbImage, shared: Option<SharedBall>) -> FrameResult {
    let pitch = Pitch::default();
    let lens = lens();
    let ctx = FrameContext {
        camera: Camera::Left,
        model: &lens,
        pose,
        pose_covariance: [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4],
        head: head(),
        pitch: &pitch,
        shared,
    };
    let detector = Detector::new(DetectorConfig::default()).unwrap();
    process_frame(
        &detector,
        &HoughOnly,
        &ProjectionNoise::default(),
        &ValidationConfig::default(),
        image,
        &ctx,
        &mut NoClock,
    )
    .unwrap()
}

const POSE: Pose2 = Pose2 {
    x_m: -0.5,
    y_m: 0.2,
    theta_rad: 0.3,
};

#[test]
fn a_ball_on_the_pitch_is_found_where_it_lies() {
    for p in [[0.2, 0.8], [0.5, 0.6], [1.2, 1.1]] {
        let result = run(POSE, &frame(&POSE, p, 0.04, 1.0), None);
        let s = result
            .sighting
            .unwrap_or_else(|| panic!("{p:?}: {result:?}"));
        let e = (s.floor.position_m[0] - p[0]).hypot(s.floor.position_m[1] - p[1]);
        // Pixel quantisation of the drawn disc against the covariance's scale.
        let sigma = (s.floor.covariance_m2[0] + s.floor.covariance_m2[3]).sqrt();
        assert!(e < 0.02 + 0.01 * s.floor.range_m, "{p:?}: error {e} m");
        assert!(e < 3.0 * sigma, "{p:?}: error {e} m, σ {sigma} m");
    }
}

#[test]
fn a_ball_beyond_the_wall_is_refused() {
    let pose = Pose2 {
        x_m: 1.5,
        y_m: 0.0,
        theta_rad: 0.0,
    };
    let result = run(pose, &frame(&pose, [2.6, 0.5], 0.04, 1.0), None);
    assert!(result.sighting.is_none());
    assert!(
        matches!(result.rejected[0].1, Rejection::OffPitch { .. }),
        "{result:?}"
    );
}

#[test]
fn an_object_of_the_wrong_size_is_refused() {
    let result = run(POSE, &frame(&POSE, [0.5, 0.6], 0.04, 2.2), None);
    assert!(result.sighting.is_none(), "{result:?}");
    assert_eq!(result.rejected[0].1.reason(), "radius_mismatch");
}

#[test]
fn a_sighting_far_from_a_fresh_shared_ball_is_refused_but_not_from_a_stale_one() {
    let image = frame(&POSE, [0.5, 0.6], 0.04, 1.0);
    let mut shared = SharedBall {
        position_m: [-1.5, -1.0],
        covariance_m2: [0.01, 0.0, 0.0, 0.01],
        age_s: 0.1,
    };
    let result = run(POSE, &image, Some(shared));
    assert_eq!(
        result.rejected[0].1.reason(),
        "far_from_shared",
        "{result:?}"
    );
    shared.age_s = 5.0;
    assert!(run(POSE, &image, Some(shared)).sighting.is_some());
    shared.position_m = [0.45, 0.65];
    shared.age_s = 0.1;
    assert!(run(POSE, &image, Some(shared)).sighting.is_some());
}

#[test]
fn the_shared_ball_is_predicted_where_the_detector_finds_it() {
    let p = [0.3, 0.1];
    let image = frame(&POSE, p, 0.04, 1.0);
    let found = run(POSE, &image, None);
    let (seen, _) = found.scored[0];
    let pitch = Pitch::default();
    let lens = lens();
    let shared = SharedBall {
        position_m: p,
        covariance_m2: [1e-3, 0.0, 0.0, 1e-3],
        age_s: 0.1,
    };
    let mut ctx = FrameContext {
        camera: Camera::Left,
        model: &lens,
        pose: POSE,
        pose_covariance: [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4],
        head: head(),
        pitch: &pitch,
        shared: Some(shared),
    };
    let cfg = ValidationConfig::default();
    let predicted = predicted_circle(&ctx, &cfg).unwrap();
    let d = (predicted.center_px[0] - seen.center_px[0])
        .hypot(predicted.center_px[1] - seen.center_px[1]);
    assert!(d < 2.0, "{predicted:?} vs {seen:?}");
    let ratio = predicted.radius_px / seen.radius_px;
    assert!((0.7..1.4).contains(&ratio), "{predicted:?} vs {seen:?}");
    // A stale state, or one behind the camera, predicts nothing.
    ctx.shared = Some(SharedBall {
        age_s: 5.0,
        ..shared
    });
    assert!(predicted_circle(&ctx, &cfg).is_none());
    ctx.shared = Some(SharedBall {
        position_m: [POSE.x_m - 1.0, POSE.y_m],
        ..shared
    });
    assert!(predicted_circle(&ctx, &cfg).is_none());
}

#[test]
fn every_scored_candidate_has_its_stage_and_fate() {
    // Two balls on the pitch: the more probable is the ball, the other a runner-up.
    let near = frame(&POSE, [0.5, 0.6], 0.04, 1.0);
    let far = frame(&POSE, [1.2, 1.1], 0.04, 1.0);
    let background = [120, 118, 112];
    let data: Vec<u8> = near
        .data()
        .chunks(3)
        .zip(far.data().chunks(3))
        .flat_map(|(a, b)| if a == background { b } else { a }.to_vec())
        .collect();
    let both = RgbImage::new(640, 360, data).unwrap();
    let found = run(POSE, &both, None);
    assert_eq!(found.candidates.len(), found.scored.len());
    let outcomes: Vec<CandidateOutcome> = found.candidates.iter().map(|c| c.outcome).collect();
    assert_eq!(outcomes[0], CandidateOutcome::Ball, "{found:?}");
    assert!(outcomes.contains(&CandidateOutcome::RunnerUp), "{found:?}");
    let ball = &found.candidates[0];
    assert_eq!(ball.circle, found.sighting.unwrap().circle);
    assert_eq!((ball.stage, ball.reason), (CandidateStage::Colour, None));
    for (c, (circle, p)) in found.candidates.iter().zip(&found.scored) {
        assert_eq!((c.circle, c.probability), (*circle, *p));
    }
    // A ball beyond the wall: every candidate rejected, with the reasons of `rejected`.
    let pose = Pose2 {
        x_m: 1.5,
        y_m: 0.0,
        theta_rad: 0.0,
    };
    let beyond = run(pose, &frame(&pose, [2.6, 0.5], 0.04, 1.0), None);
    assert!(
        beyond
            .candidates
            .iter()
            .all(|c| c.outcome == CandidateOutcome::Rejected)
    );
    let reasons: Vec<&str> = beyond.candidates.iter().filter_map(|c| c.reason).collect();
    let expected: Vec<&str> = beyond.rejected.iter().map(|(_, r)| r.reason()).collect();
    assert_eq!(reasons, expected);
}
