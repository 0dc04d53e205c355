//! Calibrating the simulator's MiRo camera from its rendered chessboards: the agent never
//! sees the simulator's lens function, yet the fitted model must reproduce it over the
//! whole image.

#![allow(clippy::unwrap_used)]

use lab::{Board, LensModel, calibrate_with, detect_views};
use robot_agent::CameraModel;
use sim::{Chessboard, calibration_views, render_chessboard};
use vision::GrayImage;
use vision::RgbImage;

/// Largest and RMS distance, pixels, between where the simulator's lens and the model put
/// the same rays, over a grid covering the whole image.
fn lens_error_px(model: &CameraModel) -> (f64, f64) {
    let lens = sim::LensModel::miro();
    let (mut max, mut sum, mut n) = (0.0f64, 0.0, 0.0);
    for v in (0..360).step_by(8).chain([359]) {
        for u in (0..640).step_by(8).chain([639]) {
            let (u, v) = (f64::from(u), f64::from(v));
            // The simulator puts pixel centres at +0.5, the camera models at integers.
            let ray = lens.ray([u + 0.5, v + 0.5]).unwrap();
            let p = model.project(ray).unwrap();
            let e = (p[0] - u).hypot(p[1] - v);
            max = max.max(e);
            sum += e * e;
            n += 1.0;
        }
    }
    (max, (sum / n).sqrt())
}

#[test]
fn rendered_boards_calibrate_the_simulated_fisheye() {
    let lens = sim::LensModel::miro();
    let board = Chessboard::default();
    let images: Vec<(String, GrayImage)> = calibration_views(&lens, 24, 5)
        .iter()
        .enumerate()
        .map(|(k, pose)| {
            let (frame, _) = render_chessboard(&lens, &board, pose, 2.0, k as u64);
            let rgb = RgbImage::new(frame.width, frame.height, frame.rgb).unwrap();
            (format!("{k}"), GrayImage::from_rgb(&rgb))
        })
        .collect();
    let b = Board {
        cols: 9,
        rows: 6,
        square_m: 0.025,
    };
    let views = detect_views(&images, &b);
    // Two fisheye terms: the boards do not reach the image corners (see `calibrate_with`).
    let c = calibrate_with(&views, &b, 640, 360, LensModel::KannalaBrandt, 2).unwrap();
    assert_eq!(c.views_used, 24);
    assert!(c.rms_px < 0.3, "RMS {}", c.rms_px);
    let (max, rms) = lens_error_px(&c.model);
    assert!(max < 0.5, "largest lens error {max} px (RMS {rms})");
}

#[test]
fn the_shipped_calibration_matches_the_simulated_lens() {
    let c = robot_agent::builtin::sim_calibration().unwrap();
    let (max, rms) = lens_error_px(&c.model);
    assert!(max < 0.5, "largest lens error {max} px (RMS {rms})");
}
