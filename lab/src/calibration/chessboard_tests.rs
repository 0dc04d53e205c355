#![allow(clippy::unwrap_used)]

use super::*;
use crate::calibration::fixtures::{Scene, barrel_scene, fisheye_scene, photo, photo_names};

#[test]
fn finds_the_board_in_the_photographs() {
    let mut found = 0;
    for name in photo_names() {
        if let Ok(corners) = find_chessboard(&photo(name), 9, 6) {
            assert_eq!(corners.len(), 54);
            found += 1;
        }
    }
    assert!(found >= 12, "found the board in {found} photographs");
}

/// Root-mean-square distance of detected corners from the truth over a scene.
fn corner_rms_px(scene: &Scene) -> f64 {
    let mut squared = 0.0;
    let mut count = 0;
    for (name, image, truth) in &scene.views {
        let corners = find_chessboard(image, scene.board.cols, scene.board.rows)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        // The board is symmetric under a half turn: compare with the truth either way.
        let error = |reversed: bool| {
            corners
                .iter()
                .enumerate()
                .map(|(k, c)| {
                    let t = truth[if reversed { truth.len() - 1 - k } else { k }];
                    (c[0] - t[0]).powi(2) + (c[1] - t[1]).powi(2)
                })
                .sum::<f64>()
        };
        let (straight, turned) = (error(false), error(true));
        assert!(
            straight.min(turned) < 0.5 * straight.max(turned),
            "{name}: mirrored"
        );
        squared += straight.min(turned);
        count += corners.len();
    }
    (squared / count as f64).sqrt()
}

#[test]
fn corners_of_a_barrel_distorted_render_are_accurate() {
    let rms = corner_rms_px(barrel_scene());
    assert!(rms < 0.15, "corner RMS {rms} px");
}

#[test]
fn corners_of_a_fisheye_render_are_accurate() {
    let rms = corner_rms_px(fisheye_scene());
    assert!(rms < 0.15, "corner RMS {rms} px");
}

#[test]
fn orientation_is_canonical() {
    for (_, image, _) in &barrel_scene().views {
        let c = find_chessboard(image, 9, 6).unwrap();
        let along = sub(c[8], c[0]);
        let across = sub(c[45], c[0]);
        assert!(along[0] * across[1] - along[1] * across[0] > 0.0);
        // Refinement moves corners by well under a pixel.
        assert!(along[0] >= -1.0);
    }
}

#[test]
fn blank_noise_and_wrong_sizes_are_clear_errors() {
    let blank = GrayImage::filled(640, 480, 128.0);
    assert!(matches!(
        find_chessboard(&blank, 9, 6),
        Err(ChessboardError::TooFewCorners { found: 0, .. })
    ));
    let mut state = 1u32;
    let noise: Vec<f32> = (0..640 * 480)
        .map(|_| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 24) as f32
        })
        .collect();
    let noise = GrayImage::new(640, 480, noise).unwrap();
    assert!(find_chessboard(&noise, 9, 6).is_err());
    let (_, image, _) = &barrel_scene().views[0];
    // Larger than the board: no complete grid. Smaller: fits in several places.
    assert!(matches!(
        find_chessboard(image, 10, 6),
        Err(ChessboardError::GridIncomplete { .. } | ChessboardError::TooFewCorners { .. })
    ));
    assert!(matches!(
        find_chessboard(image, 8, 5),
        Err(ChessboardError::Ambiguous { .. })
    ));
    assert!(matches!(
        find_chessboard(image, 1, 6),
        Err(ChessboardError::InvalidBoardSize { .. })
    ));
    assert!(matches!(
        find_chessboard(&GrayImage::filled(10, 10, 0.0), 9, 6),
        Err(ChessboardError::ImageTooSmall { .. })
    ));
}
