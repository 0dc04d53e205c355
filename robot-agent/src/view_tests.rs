//! Tests of the camera view: size, bytes, the decoded JPEG, the annotations' places.

#![allow(clippy::unwrap_used)]

use super::*;
use proto::{CandidateStage, MAX_VIEW_JPEG_BYTES, MAX_VIEW_PAYLOAD_BYTES};
use vision::Circle;

/// A carpet-like frame with a soft gradient, a texture and an orange ball at `ball` (frame
/// pixels) of `radius` px.
fn frame(width: u32, height: u32, ball: [f64; 2], radius: f64) -> RgbImage {
    let mut data = Vec::with_capacity(width as usize * height as usize * 3);
    for y in 0..height {
        for x in 0..width {
            let d = (f64::from(x) - ball[0]).hypot(f64::from(y) - ball[1]);
            if d <= radius {
                data.extend_from_slice(&[235, 120, 30]);
            } else {
                let t = ((x * 7 + y * 13) % 23) as u8;
                let g = (90 + (y * 60 / height) as u8).saturating_add(t);
                data.extend_from_slice(&[g, g.saturating_add(8), g]);
            }
        }
    }
    RgbImage::new(width, height, data).unwrap()
}

/// Every pixel uniformly random: the JPEG's worst case.
fn noise(width: u32, height: u32) -> RgbImage {
    let mut rng = proto::rng::Rng::new(7);
    let data = (0..width as usize * height as usize * 3)
        .map(|_| rng.index(256) as u8)
        .collect();
    RgbImage::new(width, height, data).unwrap()
}

fn candidate(
    x: f64,
    y: f64,
    r: f64,
    p: f64,
    outcome: CandidateOutcome,
    reason: Option<&'static str>,
) -> ScoredCandidate {
    ScoredCandidate {
        circle: Circle {
            center_px: [x, y],
            radius_px: r,
            score: 0.0,
        },
        probability: p,
        stage: CandidateStage::Colour,
        outcome,
        reason,
    }
}

fn result(candidates: Vec<ScoredCandidate>) -> FrameResult {
    FrameResult {
        candidates,
        ..FrameResult::default()
    }
}

const STAMP: Stamp = Stamp(1_700_000_000_000_000_000);

fn view_of(image: &RgbImage, r: &FrameResult) -> CameraView {
    camera_view("miro1", 3, Camera::Left, STAMP, image, r, 4.5).unwrap()
}

/// The JPEG's decoded size, checked against the view's.
fn decoded_size(view: &CameraView) -> (u32, u32) {
    let bytes = view.jpeg().unwrap();
    assert!(
        bytes.len() <= VIEW_JPEG_TARGET_BYTES,
        "{} bytes",
        bytes.len()
    );
    let mut decoder = jpeg_decoder::Decoder::new(std::io::Cursor::new(&bytes));
    let pixels = decoder.decode().unwrap();
    let info = decoder.info().unwrap();
    let (w, h) = (u32::from(info.width), u32::from(info.height));
    assert_eq!(pixels.len(), w as usize * h as usize * 3);
    (w, h)
}

#[test]
fn frames_become_small_jpegs_of_the_stated_size() {
    for (w, h) in [(640, 360), (1280, 720)] {
        let image = frame(w, h, [0.47 * f64::from(w), 0.7 * f64::from(h)], 26.0);
        let view = view_of(&image, &FrameResult::default());
        assert_eq!((view.width_px, view.height_px), (320, 180), "{w}×{h}");
        assert_eq!((view.source_width_px, view.source_height_px), (w, h));
        assert_eq!(decoded_size(&view), (320, 180));
        let ctx = ValidationContext::new(Pitch::default(), STAMP);
        view.validate(&ctx).unwrap();
        assert_eq!((view.seq, view.robot_id.as_str()), (3, "miro1"));
    }
}

#[test]
fn a_noisy_frame_still_fits() {
    // At 320×180 nothing averages the noise away: the size has to give.
    for (sw, sh) in [(640, 360), (320, 180)] {
        let view = view_of(&noise(sw, sh), &FrameResult::default());
        let (w, h) = decoded_size(&view);
        assert_eq!((w, h), (view.width_px, view.height_px));
        assert!(w <= 320 && h <= 320);
        // The aspect survives the halving.
        assert!(
            (f64::from(w) / f64::from(h) - 640.0 / 360.0).abs() < 0.1,
            "{w}×{h}"
        );
        assert!(view.jpeg().unwrap().len() <= MAX_VIEW_JPEG_BYTES);
        view.validate(&ValidationContext::new(Pitch::default(), STAMP))
            .unwrap();
    }
}

#[test]
fn sizes_keep_the_aspect_and_never_grow() {
    assert_eq!(view_size_px(640, 360), (320, 180));
    assert_eq!(view_size_px(360, 640), (180, 320));
    assert_eq!(view_size_px(1920, 1080), (320, 180));
    assert_eq!(view_size_px(200, 100), (200, 100));
    assert_eq!(view_size_px(100_000, 1), (320, 1));
    let small = frame(200, 100, [50.0, 50.0], 10.0);
    let view = view_of(&small, &FrameResult::default());
    assert_eq!(decoded_size(&view), (200, 100));
}

#[test]
fn downscaling_averages_the_covered_area() {
    // Two columns of 2×2 blocks: 0 and 200 on top, 100 and 40 below.
    let mut image = RgbImage::filled(4, 4, [0, 0, 0]).unwrap();
    for y in 0..4 {
        for x in 0..4 {
            let v = match (x < 2, y < 2) {
                (true, true) => 0,
                (false, true) => 200,
                (true, false) => 100,
                (false, false) => 40,
            };
            image.set_pixel(x, y, [v, v, 255 - v]);
        }
    }
    let small = downscale(&image, 2, 2).unwrap();
    assert_eq!(small.pixel(0, 0), Some([0, 0, 255]));
    assert_eq!(small.pixel(1, 0), Some([200, 200, 55]));
    assert_eq!(small.pixel(0, 1), Some([100, 100, 155]));
    assert_eq!(small.pixel(1, 1), Some([40, 40, 215]));
    // A ratio that is not whole: 3 → 2 takes one and a half pixels each.
    let row = RgbImage::new(3, 1, vec![0, 0, 0, 90, 90, 90, 180, 180, 180]).unwrap();
    let two = downscale(&row, 2, 1).unwrap();
    assert_eq!(two.pixel(0, 0), Some([30, 30, 30]));
    assert_eq!(two.pixel(1, 0), Some([150, 150, 150]));
    // A flat image stays flat, by whole factors or not.
    for (w, h) in [(3, 2), (7, 5), (1, 1)] {
        let flat = downscale(&RgbImage::filled(7, 5, [9, 99, 199]).unwrap(), w, h).unwrap();
        assert_eq!((flat.width(), flat.height()), (w, h));
        assert!(flat.data().chunks(3).all(|p| p == [9, 99, 199]));
    }
    // Whole factors and the general path agree.
    let image = frame(64, 36, [20.0, 20.0], 9.0);
    let whole = downscale(&image, 32, 18).unwrap();
    let (cols, rows) = (spans(64, 32), spans(36, 18));
    for (y, row) in rows.iter().enumerate() {
        for (x, col) in cols.iter().enumerate() {
            let mut mean = [0.0f64; 3];
            for &(j, wy) in row {
                for &(i, wx) in col {
                    let p = image.pixel(i as u32, j as u32).unwrap();
                    for c in 0..3 {
                        mean[c] += f64::from(wx * wy) * f64::from(p[c]);
                    }
                }
            }
            let got = whole.pixel(x as u32, y as u32).unwrap();
            for c in 0..3 {
                assert!((f64::from(got[c]) - mean[c]).abs() <= 0.5 + 1e-4);
            }
        }
    }
}

#[test]
fn annotations_land_at_the_scaled_place() {
    let image = frame(640, 360, [300.0, 250.0], 26.0);
    let r = result(vec![
        candidate(300.0, 250.0, 26.0, 0.9, CandidateOutcome::Ball, None),
        candidate(
            610.0,
            20.0,
            8.0,
            0.7,
            CandidateOutcome::Rejected,
            Some("off_pitch"),
        ),
        // Out of the frame and too big: clamped into the view.
        candidate(
            -20.0,
            400.0,
            5000.0,
            1.5,
            CandidateOutcome::Rejected,
            Some("projection"),
        ),
        candidate(100.0, 100.0, 10.0, 0.6, CandidateOutcome::RunnerUp, None),
    ]);
    let view = view_of(&image, &r);
    view.validate(&ValidationContext::new(Pitch::default(), STAMP))
        .unwrap();
    let c = &view.candidates;
    assert_eq!(c.len(), 4);
    // Most probable first.
    assert!(c.windows(2).all(|w| w[0].score >= w[1].score));
    let clamped = &c[0];
    assert_eq!(
        (clamped.u_px, clamped.v_px, clamped.radius_px, clamped.score),
        (0.0, 180.0, 320.0, 1.0)
    );
    let ball = c
        .iter()
        .find(|c| c.outcome == CandidateOutcome::Ball)
        .unwrap();
    assert!((ball.u_px - 150.0).abs() < 1e-9 && (ball.v_px - 125.0).abs() < 1e-9);
    assert!((ball.radius_px - 13.0).abs() < 1e-9);
    assert_eq!(ball.reason, None);
    let off = c
        .iter()
        .find(|c| c.reason.as_deref() == Some("off_pitch"))
        .unwrap();
    assert!((off.u_px - 305.0).abs() < 1e-9 && (off.v_px - 10.0).abs() < 1e-9);
    assert_eq!(off.stage, CandidateStage::Colour);
}

#[test]
fn many_candidates_are_cut_to_the_limit_keeping_the_ball() {
    let mut candidates: Vec<ScoredCandidate> = (0..100)
        .map(|k| {
            candidate(
                f64::from(k) * 6.123_456_789,
                f64::from(k) * 3.456_789_123,
                7.891_234_567,
                0.999 - f64::from(k) * 0.001,
                CandidateOutcome::Rejected,
                Some("radius_mismatch"),
            )
        })
        .collect();
    candidates.push(candidate(
        320.0,
        180.0,
        20.0,
        0.5,
        CandidateOutcome::Ball,
        None,
    ));
    let view = view_of(&noise(640, 360), &result(candidates));
    assert_eq!(view.candidates.len(), MAX_VIEW_CANDIDATES);
    assert_eq!(
        view.candidates.last().map(|c| c.outcome),
        Some(CandidateOutcome::Ball)
    );
    assert!(view.candidates.windows(2).all(|w| w[0].score >= w[1].score));
    // The worst case (a noisy frame, every candidate) is within the wire's payload limit.
    let payload = proto::encode(&view);
    assert!(payload.len() <= MAX_VIEW_PAYLOAD_BYTES, "{}", payload.len());
    let back: CameraView = proto::decode(&payload).unwrap();
    assert_eq!(back, view);
}

#[test]
fn bad_inputs_are_errors_not_invalid_views() {
    let empty = RgbImage::new(0, 0, Vec::new()).unwrap();
    assert!(matches!(
        camera_view(
            "miro1",
            0,
            Camera::Left,
            STAMP,
            &empty,
            &FrameResult::default(),
            1.0
        ),
        Err(ViewError::EmptyFrame { .. })
    ));
    let image = frame(64, 36, [10.0, 10.0], 4.0);
    let bad_id = camera_view(
        "not an id",
        0,
        Camera::Left,
        STAMP,
        &image,
        &FrameResult::default(),
        1.0,
    );
    assert!(matches!(bad_id, Err(ViewError::Invalid(_))), "{bad_id:?}");
    let nan = camera_view(
        "miro1",
        0,
        Camera::Right,
        STAMP,
        &image,
        &FrameResult::default(),
        f64::NAN,
    );
    assert!(matches!(nan, Err(ViewError::Invalid(_))), "{nan:?}");
}
