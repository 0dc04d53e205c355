//! Tests of the camera renderer against its own ground truth.

#![allow(clippy::unwrap_used)]

use crate::head::{camera_pose, default_head};
use crate::lens::LensModel;
use crate::render::{CameraRig, render, render_robot_cameras};
use crate::render_scene::{BallTruth, Frame, Lighting, RobotBody, Scene};
use proto::{Camera, Pose2};
use std::sync::OnceLock;

fn rig() -> &'static CameraRig {
    static RIG: OnceLock<CameraRig> = OnceLock::new();
    RIG.get_or_init(|| CameraRig::new(LensModel::miro()))
}

fn observer() -> Pose2 {
    Pose2 {
        x_m: -0.8,
        y_m: 0.0,
        theta_rad: 0.0,
    }
}

fn scene_with_ball(ball_m: [f64; 3]) -> Scene {
    Scene {
        ball_m: Some(ball_m),
        noise_sigma: 0.0,
        ..Scene::default()
    }
}

fn left(scene: &Scene, seed: u64) -> (Frame, Option<BallTruth>) {
    let cam = camera_pose(observer(), default_head(), Camera::Left);
    render(rig(), scene, &cam, seed)
}

fn is_orange(p: [u8; 3]) -> bool {
    let [r, g, b] = p.map(f64::from);
    r > 30.0 && r > 1.5 * g && g > 1.5 * b
}

/// Centroid and equivalent radius of orange pixels within `reach_px` of `near`.
fn orange_blob(frame: &Frame, near: [f64; 2], reach_px: f64) -> (f64, [f64; 2]) {
    let (mut n, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for y in 0..frame.height {
        for x in 0..frame.width {
            let (cx, cy) = (f64::from(x) + 0.5, f64::from(y) + 0.5);
            if (cx - near[0]).hypot(cy - near[1]) < reach_px && is_orange(frame.pixel(x, y)) {
                n += 1.0;
                sx += cx;
                sy += cy;
            }
        }
    }
    ((n / std::f64::consts::PI).sqrt(), [sx / n, sy / n])
}

#[test]
fn ball_truth_matches_the_rendered_ball() {
    for ball in [
        [-0.35, 0.12, 0.04],
        [-0.2, 0.3, 0.04],
        [0.2, 0.2, 0.04],
        [-0.5, 0.35, 0.04],
        [-0.3, 0.0, 0.15],
    ] {
        let (frame, truth) = left(&scene_with_ball(ball), 1);
        let t = truth.unwrap();
        assert!(t.in_frame && t.visible_fraction == 1.0 && !t.occluded_by_robot);
        let c = t.center_px.unwrap();
        let (r, centroid) = orange_blob(&frame, c, 2.0 * t.radius_px + 3.0);
        assert!(
            (centroid[0] - c[0]).abs() < 1.0 && (centroid[1] - c[1]).abs() < 1.0,
            "{ball:?}: centroid {centroid:?} truth {c:?}"
        );
        assert!(
            (r - t.radius_px).abs() < 1.0,
            "{ball:?}: radius {r} truth {}",
            t.radius_px
        );
        let equivalent = (t.silhouette_px as f64 / std::f64::consts::PI).sqrt();
        assert!(
            (equivalent - t.radius_px).abs() < 0.5,
            "{equivalent} {}",
            t.radius_px
        );
        let cam = camera_pose(observer(), default_head(), Camera::Left).origin_m;
        let range = crate::vec3::norm(crate::vec3::sub(ball, cam));
        assert!((t.range_m - range).abs() < 1e-12);
    }
}

#[test]
fn a_robot_in_front_hides_part_of_the_ball() {
    let ball = [0.4, 0.3, 0.04];
    let (_, clear) = left(&scene_with_ball(ball), 1);
    let clear = clear.unwrap();
    assert_eq!(clear.visible_fraction, 1.0);
    let mut scene = scene_with_ball(ball);
    let cam = camera_pose(observer(), default_head(), Camera::Left).origin_m;
    // A robot on the line of sight, a little off it so that part of the ball shows.
    let f = 0.55;
    scene.robots.push(RobotBody {
        pose: Pose2 {
            x_m: cam[0] + f * (ball[0] - cam[0]),
            y_m: cam[1] + f * (ball[1] - cam[1]) - 0.1,
            theta_rad: 1.0,
        },
        head: default_head(),
    });
    let (_, hidden) = left(&scene, 1);
    let hidden = hidden.unwrap();
    assert!(hidden.occluded_by_robot);
    assert!(hidden.visible_fraction < 0.9, "{}", hidden.visible_fraction);
    assert_eq!(hidden.silhouette_px, clear.silhouette_px);
    assert_eq!(hidden.center_px, clear.center_px);
}

#[test]
fn a_ball_behind_the_camera_is_not_in_frame() {
    let (_, t) = left(&scene_with_ball([-1.5, 0.0, 0.04]), 1);
    let t = t.unwrap();
    assert!(!t.in_frame);
    assert_eq!(
        (t.visible_px, t.silhouette_px, t.visible_fraction),
        (0, 0, 0.0)
    );
    let (_, none) = left(&Scene::default(), 1);
    assert!(none.is_none());
}

#[test]
fn same_seed_same_bytes_and_noise_follows_the_seed() {
    let mut scene = scene_with_ball([-0.3, 0.1, 0.04]);
    scene.noise_sigma = 3.0;
    let (a, _) = left(&scene, 7);
    let (b, _) = left(&scene, 7);
    let (c, _) = left(&scene, 8);
    assert_eq!(a, b);
    assert_ne!(a, c);
    scene.seed = 1;
    assert_ne!(left(&scene, 7).0, a);
    // Without noise the seed does not matter.
    scene.noise_sigma = 0.0;
    assert_eq!(left(&scene, 1).0, left(&scene, 2).0);
    // The noise has about the requested spread.
    let (clean, _) = left(&scene, 1);
    let diffs: Vec<f64> = a
        .rgb
        .iter()
        .zip(&clean.rgb)
        .filter(|(_, c)| (20..235).contains(*c))
        .map(|(&n, &c)| f64::from(n) - f64::from(c))
        .collect();
    let sd = (diffs.iter().map(|d| d * d).sum::<f64>() / diffs.len() as f64).sqrt();
    assert!((sd - 3.0).abs() < 0.2, "{sd}");
}

#[test]
fn exposure_scales_brightness_and_gain_tints() {
    let scene = scene_with_ball([-0.3, 0.1, 0.04]);
    let mean = |f: &Frame, c: usize| {
        f.rgb
            .iter()
            .skip(c)
            .step_by(3)
            .map(|&v| f64::from(v))
            .sum::<f64>()
            / (f.rgb.len() / 3) as f64
    };
    let (bright, _) = left(&scene, 1);
    let mut dim = scene.clone();
    dim.lighting.exposure = 0.5;
    let (dark, _) = left(&dim, 1);
    for c in 0..3 {
        let ratio = mean(&dark, c) / mean(&bright, c);
        assert!((ratio - 0.5).abs() < 0.02, "channel {c}: {ratio}");
    }
    let mut blue = scene.clone();
    blue.lighting = Lighting {
        gain_rgb: [0.8, 1.0, 1.25],
        ..Lighting::default()
    };
    let (tinted, _) = left(&blue, 1);
    assert!(mean(&tinted, 0) < 0.85 * mean(&bright, 0));
    assert!(mean(&tinted, 2) > 1.15 * mean(&bright, 2));
}

#[test]
fn each_camera_sees_its_own_side() {
    let scene = scene_with_ball([-0.3, 0.25, 0.04]);
    let [(l, lt), (r, rt)] = render_robot_cameras(rig(), &scene, observer(), default_head(), 3);
    assert_ne!(l, r);
    let (lt, rt) = (lt.unwrap(), rt.unwrap());
    assert!(lt.in_frame);
    // Ball to the robot's left: further right in the left image than in the right one,
    // and in the right camera's image it lies left of centre if at all.
    let lc = lt.center_px.unwrap();
    assert!(lc[0] > 320.0 || !rt.in_frame || rt.center_px.unwrap()[0] < lc[0]);
    assert_eq!((l.width, l.height, l.rgb.len()), (640, 360, 640 * 360 * 3));
}

#[test]
fn walls_floor_and_room_are_where_the_geometry_says() {
    // Looking along +x from the middle: floor at the bottom of the image, room above.
    let (f, _) = left(
        &Scene {
            noise_sigma: 0.0,
            ..Scene::default()
        },
        1,
    );
    let bottom = f.pixel(320, 350);
    assert!(bottom[1] > bottom[0] && bottom[1] > bottom[2], "{bottom:?}");
    let top = f.pixel(320, 5);
    assert!(top[0] >= top[2], "{top:?}");
}

/// `cargo test -p sim --release -- --ignored render_speed --nocapture`
#[test]
#[ignore]
fn render_speed() {
    let rig = CameraRig::new(LensModel::miro());
    let mut scene = Scene {
        ball_m: Some([-0.3, 0.1, 0.04]),
        ..Scene::default()
    };
    scene.robots.push(RobotBody {
        pose: Pose2 {
            x_m: 0.1,
            y_m: -0.15,
            theta_rad: 2.5,
        },
        head: default_head(),
    });
    let cam = camera_pose(observer(), default_head(), Camera::Left);
    let n = 300;
    let start = std::time::Instant::now();
    let mut checksum = 0u64;
    for i in 0..n {
        let (f, _) = render(&rig, &scene, &cam, i);
        checksum = checksum.wrapping_add(u64::from(f.rgb[i as usize * 97]));
    }
    let fps = f64::from(n as u32) / start.elapsed().as_secs_f64();
    println!(
        "render 640x360 with noise, ball and one robot: {fps:.1} frames/s (checksum {checksum})"
    );
    assert!(fps > 50.0, "{fps}");
}
